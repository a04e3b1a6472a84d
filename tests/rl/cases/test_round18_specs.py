"""Round 18 of held-out tries (issue 48), the findings read where a spec or a setting is read: each
test fails without its fix (docs/errors.md, "An eighteenth round of tries")."""

from __future__ import annotations

import tomllib
import warnings

import pytest
from elastica_magnetic_rl.cases.case import SPECS_DIR, load_case
from elastica_magnetic_rl.cases.variations import VariationError
from elastica_magnetic_rl.td3.config import MAX_YARDSTICK_WARMUP, TD3Config
from spec_texts import CATHETER_MAGNET_REACH

from elastica_magnetic.specfile import SpecError


def _quiet(data):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_case(data)


def _goto() -> dict:
    data = tomllib.loads((SPECS_DIR / "m1-4mT-goto.toml").read_text())
    data["name"] = "goto"
    return data


def _catheter() -> dict:
    data = tomllib.loads(CATHETER_MAGNET_REACH)
    data["name"] = "catheter"
    return data


@pytest.mark.parametrize(("make", "why"), [
    (_goto, "a goto case's yardstick is its steering field"),
    (_catheter, 'a case steered by \\[actuation\\] kind = "magnet-pose" has no rotating-field yardstick'),
])
@pytest.mark.parametrize("key", ["period", "clockwise"])
def test_a_rotating_fields_keys_on_a_case_that_cannot_play_one_are_refused(make, why, key):
    """S6, S7: ``[yardstick] period``/``clockwise`` on a goto or a steered case were accepted and
    recorded as if used (a goto's warm-up plays its steering field; a catheter has no controller)."""
    data = make()
    data.setdefault("yardstick", {}).update({"period": 1.0} if key == "period" else
                                            {"period": 1.0, "clockwise": True})
    with pytest.raises(SpecError, match=rf"\[yardstick\] period: {why}.*remove period and clockwise"):
        _quiet(data)


def test_a_warm_up_on_a_steered_case_is_played_by_its_steering_law():
    """V8 then: the refusal told a catheter's spec to give ``[yardstick] period``; now a steered
    case has a warm-up controller (its steering law reading the observation), so the setting is
    accepted and the controller it needs exists."""
    from elastica_magnetic_rl.envs.steering_yardstick import SteeringYardstick
    from elastica_magnetic_rl.envs.yardsticks import yardstick_controller

    data = _catheter()
    data["training"] = {**data.get("training", {}), "td3": {"yardstick_warmup": 100}}
    case = _quiet(data)
    assert case.training.td3["yardstick_warmup"] == 100
    assert isinstance(yardstick_controller(case)(), SteeringYardstick)


def test_a_warm_up_of_a_run_s_length_is_refused():
    """S57: ``yardstick_warmup = 1e8`` (cloning steps) was accepted: days of updates."""
    TD3Config(yardstick_warmup=MAX_YARDSTICK_WARMUP, learning_starts=256)
    with pytest.raises(ValueError, match="yardstick_warmup must be at most 1000000 cloning steps"):
        TD3Config(yardstick_warmup=100_000_000, learning_starts=256)


def test_a_fit_of_a_key_at_0_does_not_offer_an_absolute_range():
    """V28: ``--fit robot.gravity`` (0 in the spec) was told to give ``abs:LOW:HIGH``, which
    ``--fit`` does not take."""
    from elastica_magnetic_rl.sim2real.identify import load_spec, parse_fit

    spec = load_spec("m1-4mT")
    spec["robot"]["gravity"] = 0.0
    with pytest.raises(VariationError, match="0 in this spec") as info:
        parse_fit("robot.gravity", spec)
    assert "abs:" not in str(info.value) and "give the key a non-zero value" in str(info.value)


def test_noise_beyond_the_action_range_is_refused_naming_a_percent():
    """S111: ``[training.td3] exploration_noise = 10`` was accepted: every noisy action clipped."""
    data = tomllib.loads((SPECS_DIR / "m1-4mT.toml").read_text())
    data["name"] = "noisy"
    data["training"] = {**data.get("training", {}), "td3": {"exploration_noise": 10.0}}
    with pytest.raises(SpecError, match=r"exploration_noise must be at most 1 .*a percent\? 10 % is 0.1"):
        _quiet(data)


def test_an_integer_setting_written_with_an_exponent_says_how_to_write_it():
    """V113: ``learning_starts = 5e3`` was 'expected a value like 2500, got 5000.0'."""
    data = tomllib.loads((SPECS_DIR / "m1-4mT.toml").read_text())
    data["name"] = "exp"
    data["training"] = {**data.get("training", {}), "td3": {"learning_starts": 5e3}}
    with pytest.raises(SpecError, match=r"an integer; TOML reads 5000.0 as a decimal number, write 5000"):
        _quiet(data)


def test_a_period_faster_than_the_rate_limit_turns_is_warned():
    """S5: ``[yardstick] period = 0.05`` passed, though 0.3 mT per step at 4 mT turns once per
    0.84 s at the fastest (``msr field baseline`` warns about the same period)."""
    data = tomllib.loads((SPECS_DIR / "m1-4mT.toml").read_text())
    data["name"] = "fast-turn"
    data["yardstick"] = {**data.get("yardstick", {}), "period": 0.05}
    with pytest.warns(UserWarning, match=r"\[yardstick\] period: 0.05 s is shorter than the case's rate "
                                         r"limit allows.*takes 0.8\d+ s"):
        load_case(data)
    data["yardstick"]["period"] = 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_case(data)
