"""The rotating-field baseline: it turns the field as stated through the agent's action channel,
rolls the robot (forward clockwise, backward counter-clockwise) and ``msr field baseline`` writes what
``msr policy generate`` writes."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from elastica_magnetic_rl.envs.env import MagneticCrawlerEnv
from elastica_magnetic_rl.envs.yardsticks import RotatingFieldPolicy

from elastica_magnetic import read_field_csv
from elastica_magnetic.cli import main as msr


def roll(case: str, period: float, clockwise: bool, steps: int):
    """Fields (steps, 2) in T and the middle node's x displacement (m) in the training physics."""
    policy = RotatingFieldPolicy(case, period, clockwise=clockwise)
    env = MagneticCrawlerEnv(pattern=int(case[1]), field_limit=policy.field_limit,
                             physics="training", initial_field="zero", duration=steps / 100)
    obs, info = env.reset(seed=0)
    x0, fields = info["mid_x_m"], []
    for _ in range(steps):
        obs, _, terminated, _, info = env.step(policy.act(obs))
        assert not terminated
        fields.append(info["field_T"][:2])
    return np.asarray(fields), info["mid_x_m"] - x0


def test_field_ramps_up_then_turns_at_the_stated_rate():
    fields, _ = roll("m1-10mT", period=4.0, clockwise=True, steps=120)
    # From zero, at most 0.3 mT per axis per step (0.42 mT in amplitude): the 10 mT limit takes
    # at least 24 steps.
    assert np.all(np.abs(np.diff(fields, axis=0)) <= 0.3e-3 + 1e-12)
    amplitude = np.hypot(fields[:, 0], fields[:, 1])
    assert np.all(amplitude[:23] < 10e-3 - 1e-4)
    assert np.allclose(amplitude[60:], 10e-3, rtol=1e-6)
    angle = np.unwrap(np.arctan2(fields[60:, 1], fields[60:, 0]))
    rate = np.diff(angle) / 0.01  # rad/s, clockwise negative
    assert np.allclose(rate, -2 * math.pi / 4.0, rtol=1e-3)


def test_clockwise_rolls_forward_and_counterclockwise_backward():
    _, forward = roll("m1-10mT", period=2.0, clockwise=True, steps=300)
    _, backward = roll("m1-10mT", period=2.0, clockwise=False, steps=300)
    # 3 s of rolling at 10 mT: more than a body length (20 mm) each way.
    assert forward > 20e-3
    assert backward < -20e-3


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="period"):
        RotatingFieldPolicy("m1-4mT", period=0.0)
    with pytest.raises(ValueError, match="unknown case"):
        RotatingFieldPolicy("m3-4mT")


def test_msr_baseline_writes_the_generate_files(tmp_path, capsys):
    out = tmp_path / "baseline"
    capsys.readouterr()
    status = msr(["field", "baseline", "--case", "m2-4mT", "--period", "1.5", "--duration", "1.5",
                  "--physics", "training", "--out", str(out), "--no-gif", "--no-progress",
                  "--json"])
    result = json.loads(capsys.readouterr().out)
    assert status == 0
    assert result["policy_kind"] == "baseline" and result["case"] == "m2-4mT"
    assert "period 1.5 s" in result["policy"]
    fields = read_field_csv(result["fields_csv"])
    assert fields.shape == (150, 3)  # no shorter than the period: the field turns once
    assert np.all(np.abs(np.diff(fields[:, :2], axis=0)) <= 0.3e-3 + 1e-12)
    assert (out / "generate.json").is_file() and (out / "field_waveforms.png").is_file()
    assert "q_values" not in result["figures"]  # no critic to draw


@pytest.mark.parametrize("period", [0.001, 0.01, 0.02])
def test_a_period_that_aliases_under_the_control_rate_is_refused(period, capsys):
    with pytest.raises(ValueError, match="Nyquist limit of the 100 Hz field updates"):
        RotatingFieldPolicy("m1-4mT", period=period)
    assert msr(["field", "baseline", "--case", "m1-4mT", "--period", str(period), "--no-progress"]) == 2
    assert "--period: period" in capsys.readouterr().err
    assert RotatingFieldPolicy("m1-4mT", period=0.05).period == 0.05


def test_the_steering_yardstick_resumes_from_its_state_as_if_never_stopped():
    """A warm-up it plays may be checkpointed inside an episode (``yardstick_warmup``): from its
    :meth:`state` a new controller acts as the first goes on, manoeuvre and turn phase included."""
    from elastica_magnetic_rl.cases.case import load_case
    from elastica_magnetic_rl.envs.yardsticks import SteeringFieldPolicy, yardstick_controller

    case = load_case("m1-4mT-goto")
    warm_up = yardstick_controller(case)()  # the memoryless law, which has no phase to lose
    assert isinstance(warm_up, SteeringFieldPolicy) and warm_up.markov

    def make():  # the default law: its manoeuvre and turn phase (one turn a second: the turn's
        return SteeringFieldPolicy(case, period=1.0)  # sense reverses after 100 of the 170 steps)

    first = make()
    assert (first.obs_dim, first.act_dim) == (case.obs_dim, 3)
    rng = np.random.default_rng(0)
    layout = first.layout
    observations = []
    for k in range(300):  # the target ahead (a turn in place) then abeam (a walk), the field turning
        obs = np.zeros(case.obs_dim, dtype=np.float32)
        obs[layout["heading"]] = (1.0, 0.0)
        obs[layout["target_offset"]] = (1.2, 0.1) if k < 150 else (0.1, 1.2)
        obs[layout["field_amplitude"]] = 200 * 4e-3 * rng.uniform(0.5, 1.0)
        obs[layout["field_angle"]] = rng.uniform(-math.pi, math.pi)
        observations.append(obs)
    actions = [first.act(o) for o in observations[:170]]
    state = first.state()
    json.dumps(state)  # plain numbers (a checkpoint loads with weights_only)
    second = make()
    second.set_state(state)
    for obs in observations[170:]:
        np.testing.assert_array_equal(first.act(obs), second.act(obs))
    third = make()  # without the state: another manoeuvre's phase
    assert any(not np.array_equal(first_action, third.act(obs))
               for first_action, obs in zip(actions[100:], observations[100:170], strict=True))
    assert yardstick_controller(load_case("m1-4mT")) is None


def test_a_warm_up_from_a_case_without_a_controller_is_refused_before_any_work(tmp_path, capsys):
    assert msr(["train", "--case", "m1-4mT", "--steps", "300", "--set", "yardstick_warmup=100",
                "--out", str(tmp_path / "runs")]) == 2
    err = capsys.readouterr().err
    assert "--set yardstick_warmup=100" in err and "case(s) m1-4mT have none" in err
    assert not (tmp_path / "runs").exists()


def test_the_memoryless_steering_law_labels_any_state_by_the_observed_clock():
    """DAgger on a goto case: the warm-up's law (``markov``) is a function of the observation
    alone (its walk by the bearing, its turn reversed by the ``clock`` block), so a label does not
    depend on what the controller did before; the default law, which remembers its manoeuvre,
    gives no label."""
    from elastica_magnetic_rl.cases.case import load_case
    from elastica_magnetic_rl.cases.tasks import GOTO_CLOCK_PERIOD
    from elastica_magnetic_rl.envs.env import MagneticCrawlerEnv
    from elastica_magnetic_rl.envs.yardsticks import SteeringFieldPolicy, yardstick_controller

    case = load_case("m1-4mT-goto")
    env = MagneticCrawlerEnv(case=case, physics="training", initial_field="zero", duration=1.0)
    obs, _ = env.reset(seed=3, options={"target": (0.015, 0.0)})  # straight ahead: a turn in place
    fresh, used = yardstick_controller(case)(), yardstick_controller(case)()
    assert fresh.markov
    rng = np.random.default_rng(1)
    turned, layout = set(), env.layout
    for k in range(1, 151):
        obs, *_ = env.step(rng.uniform(-1, 1, 3).astype(np.float32))  # another controller drives
        t = k * 0.01
        np.testing.assert_allclose(obs[layout["clock"]], [math.cos(2 * math.pi * t / GOTO_CLOCK_PERIOD),
                                                          math.sin(2 * math.pi * t / GOTO_CLOCK_PERIOD)],
                                   atol=1e-6)
        used.act(rng.uniform(-1, 1, case.obs_dim).astype(np.float32))  # a history of its own
        label = used.label(obs)
        np.testing.assert_array_equal(label, fresh.label(obs))
        np.testing.assert_array_equal(label, SteeringFieldPolicy(case, markov=True).act(obs))
        turned.add(bool(obs[layout["clock"]][1] < 0.0))
    assert turned == {True, False}  # both halves of the clock's cycle were labelled
    with pytest.raises(ValueError, match="labels a state only as its memoryless law"):
        SteeringFieldPolicy(case).label(obs)
    with pytest.raises(ValueError, match="its period must be that"):
        SteeringFieldPolicy(case, period=1.5, markov=True)


def test_a_steering_yardstick_told_not_to_turn_in_place_walks_toward_every_target():
    """``[yardstick] turn_in_place = false`` (a goto case whose robot goes where the field's plane
    points): both laws put the plane toward the target at every bearing; the default turns in place
    toward bringing the target abeam first. The key is a goto case's, kept in the case's plain data
    only where given (a shipped policy's recorded case is unchanged by it)."""
    from elastica_magnetic_rl.cases.case import case_from_dict, load_case
    from elastica_magnetic_rl.envs.yardsticks import SteeringFieldPolicy

    walking_case, turning_case = load_case("m1-10mT-goto"), load_case("m1-4mT-goto")
    assert walking_case.yardstick.turn_in_place is False and turning_case.yardstick.turn_in_place is None
    assert "turn_in_place" not in turning_case.to_dict()["yardstick"]
    again = case_from_dict(walking_case.to_dict(), "again.toml", "again")
    assert again.yardstick.turn_in_place is False

    walker, turner = SteeringFieldPolicy(walking_case), SteeringFieldPolicy(turning_case)
    assert (walker.turn_in_place, turner.turn_in_place) == (False, True)
    assert SteeringFieldPolicy(walking_case, turn_in_place=True).turn_in_place  # an argument wins
    assert walker.meta["turn_in_place"] is False and "never turning in place" in walker.source
    for bearing in np.linspace(-math.pi, math.pi, 13)[:-1]:
        forward, left = math.cos(bearing), math.sin(bearing)
        assert walker.plane_bearing(forward, left) == pytest.approx(bearing)
        for clock_sin in (-0.5, 0.5):  # the memoryless law too, in both halves of its clock
            assert walker._markov_bearing(forward, left, clock_sin) == pytest.approx(bearing)
    turner.reset()  # straight ahead: the default turns, its plane near the body's axis
    assert abs(turner.plane_bearing(1.0, 0.0)) == pytest.approx(turner.turn_bearing)

    # the law plays the plane: from a field along +x, straight ahead, its step keeps B_z at zero
    # (the plane along the body); the turning law's plane is turn_bearing off the axis
    obs = np.zeros(walking_case.obs_dim, dtype=np.float32)
    layout = walker.layout
    obs[layout["heading"]] = (1.0, 0.0)
    obs[layout["target_offset"]] = (10.0, 0.0)
    obs[layout["field_amplitude"]] = 200 * 5e-3
    assert walker.act(obs)[2] == 0.0
    assert SteeringFieldPolicy(walking_case, turn_in_place=True).act(obs)[2] != 0.0


def test_a_goto_case_gives_its_steering_yardstick_the_turn_it_asks_of_the_field():
    """``[yardstick] steering_period`` (s): the steering yardstick's turn, the 1 s default where not
    given; an argument wins; the memoryless law keeps its clock's half cycle; kept in the case's
    plain data only where given; at or under two control periods refused by name. The turn is
    what the law plays: from a field along +x, one step asks for the phase ``2 pi 0.01 / period``
    further clockwise."""
    from elastica_magnetic_rl.cases.case import DEFAULT_STEERING_PERIOD, case_from_dict, load_case
    from elastica_magnetic_rl.envs.yardsticks import SteeringFieldPolicy

    from elastica_magnetic.specfile import SpecError

    data = load_case("m1-4mT-goto").to_dict()
    data["yardstick"].pop("steering_period", None)
    plain = case_from_dict(data, "plain.toml", "plain")
    assert plain.yardstick.steering_period is None and "steering_period" not in plain.to_dict()["yardstick"]
    assert SteeringFieldPolicy(plain).period == DEFAULT_STEERING_PERIOD == 1.0
    data["yardstick"]["steering_period"] = 0.15
    quick = case_from_dict(data, "quick.toml", "quick")
    assert quick.yardstick.steering_turn == 0.15
    assert case_from_dict(quick.to_dict(), "again.toml", "again").yardstick.steering_period == 0.15
    assert SteeringFieldPolicy(quick).period == 0.15 and "period 0.15 s" in SteeringFieldPolicy(quick).source
    assert SteeringFieldPolicy(quick, period=2.0).period == 2.0  # an argument wins
    assert SteeringFieldPolicy(quick, markov=True).period == 1.0  # the clock's half cycle
    data["yardstick"]["steering_period"] = 0.02
    with pytest.raises(SpecError, match=r"quick.toml: \[yardstick\] steering_period: 0.02 s is at or under"):
        case_from_dict(data, "quick.toml", "quick")

    fields = []
    for case in (plain, quick):
        policy = SteeringFieldPolicy(case, turn_in_place=False)
        obs = np.zeros(case.obs_dim, dtype=np.float32)
        obs[policy.layout["heading"]] = (1.0, 0.0)
        obs[policy.layout["target_offset"]] = (10.0, 0.0)
        obs[policy.layout["field_amplitude"]] = 200 * 1e-3  # 1 mT along +x: far from every limit
        fields.append(policy.act(obs))
    # clockwise seen from +z: the field along +x turns toward -y, by the asked phase within the limit
    assert fields[0][1] < 0.0 and fields[1][1] < fields[0][1]
