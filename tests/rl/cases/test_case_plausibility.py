"""Values that cannot be right are refused when a spec is read, naming the file, the table and
the key (rl/cases/case.py; issue 35)."""

from __future__ import annotations

import pytest
from elastica_magnetic_rl.cases.case import case_from_dict, load_case

from elastica_magnetic.specfile import SpecError


def _reach(**task):
    data = load_case("m1-4mT-reach").to_dict()
    data["task"].update(task)
    return data


@pytest.mark.parametrize(("target", "tolerance"), [(0.01, 0.01), (0.01, 0.02), (-0.005, 0.006)])
def test_a_reach_tolerance_not_under_the_target_distance_is_refused(target, tolerance):
    with pytest.raises(SpecError) as err:
        case_from_dict(_reach(target=target, tolerance=tolerance), "my.toml")
    text = str(err.value)
    assert text.startswith("my.toml") and "[task] tolerance" in text
    assert "must be smaller than the target distance" in text


def test_a_reach_tolerance_under_the_target_is_accepted():
    assert case_from_dict(_reach(target=-0.01, tolerance=0.002), "my.toml").task.tolerance == 0.002


@pytest.mark.parametrize(("td3", "message"), [
    ({"batch_size": 0}, "[training.td3] batch_size: batch_size must be >= 1, got 0"),
    ({"hidden_sizes": []}, "[training.td3] hidden_sizes: hidden_sizes must be one or more layers"),
    ({"hidden_sizes": [64, 0]}, "[training.td3] hidden_sizes: hidden_sizes must be one or more"),
    ({"buffer_size": 16, "batch_size": 64}, "[training.td3] buffer_size: buffer_size (16) must be "
                                            ">= batch_size (64)"),
    ({"tau": 2.0}, "[training.td3] tau: tau must be in (0, 1]"),
])
def test_training_td3_values_are_checked_when_the_spec_is_read(td3, message):
    data = load_case("m1-4mT").to_dict()
    data["training"]["td3"] = td3
    with pytest.raises(SpecError) as err:
        case_from_dict(data, "my.toml")
    assert str(err.value).startswith("my.toml") and message in str(err.value), str(err.value)


def test_a_yardstick_in_mm_is_refused_naming_the_mistake():
    """Issue 48: a yardstick beyond 100 body lengths in 10 s is no crawler's (mm written as m)."""
    import pytest
    from elastica_magnetic_rl.cases.case import case_from_dict, load_case

    from elastica_magnetic.specfile import SpecError

    spec = load_case("m1-4mT").to_dict()
    spec["yardstick"]["distance_10s"] = 20.5  # the authors' 20.5 mm, written as m
    with pytest.raises(SpecError, match=r"distance_10s: 20.5 m in 10 s is 1025 body lengths .* "
                                         r"it looks like mm written where m is expected"):
        case_from_dict(spec, "my.toml")
    spec["yardstick"]["distance_10s"] = 0.198  # the rolling gait's 10 body lengths: fine
    assert case_from_dict(spec, "my.toml").yardstick.distance_10s == 0.198


# -- round 5 of tries: values a spec took without a word --------------------------------------------


def test_a_reach_target_in_millimetres_is_refused_naming_the_mistake():
    with pytest.raises(SpecError, match=r"\[task\] target: 10 m is 500 body lengths of this 0.02 m "
                                        r"robot, more than the 200 .* \(10 mm is 0.01 m\)"):
        case_from_dict(_reach(target=10.0, tolerance=1.0), "my.toml")
    assert case_from_dict(_reach(target=0.03, tolerance=0.002), "my.toml").task.target == 0.03


@pytest.mark.parametrize(("key", "text", "expected"), [
    ("robot.youngs_modulus", "abs:70:100", "youngs_modulus = 70 Pa is below 100 Pa"),
    ("robot.density", "abs:1.5:2.0", "density = 1.5 kg/m^3 is below 50 kg/m^3"),
    ("robot.ground.kinetic_mu", "abs:40:70", "kinetic_mu = 40 is above 10"),
])
def test_randomized_ranges_are_checked_at_their_ends_when_the_spec_is_read(key, text, expected):
    """A `[training.randomize]` range in another unit (kPa, g/cm^3, %, percent factors) passed
    `msr case check` and failed in the first training episode that drew from it, without the file
    or the range; its ends are now checked as the spec's own values are."""
    data = load_case("m1-4mT").to_dict()
    data["training"]["randomize"] = {key: text}
    with pytest.raises(SpecError) as refused:
        case_from_dict(data, "my.toml")
    message = str(refused.value)
    assert message.startswith("my.toml: [training] randomize: the range's end") and expected in message
    data["training"]["randomize"] = {"magnetization": "0.85:1.15"}
    assert case_from_dict(data, "my.toml").training.randomize


def test_randomized_factors_written_as_percent_are_named_when_the_spec_is_read():
    data = load_case("m1-4mT").to_dict()
    data["training"]["randomize"] = {"magnetization": "85:115"}
    with pytest.raises(SpecError, match=r"my.toml: \[training\] randomize: 'magnetization=85:115'.*"
                                        r"85:115 looks like percent: 0.85:1.15"):
        case_from_dict(data, "my.toml")


def test_a_training_mass_scale_a_thousand_times_the_papers_is_refused():
    data = load_case("m1-4mT").to_dict()
    data["physics"]["training"]["mass_scale"] = 10526.3
    with pytest.raises(SpecError, match=r"\[physics.training\] mass_scale = 10526.3 is above 10000"):
        case_from_dict(data, "my.toml")
    data["physics"]["training"]["mass_scale"] = 1052.6
    with pytest.warns(UserWarning, match="mass_scale = 1052.6 is above 100"):
        case_from_dict(data, "my.toml")


def test_a_magnetization_phase_in_degrees_is_warned():
    data = load_case("m1-4mT").to_dict()
    data["robot"]["magnetization"] = {"kind": "sinusoid", "magnitude": 61300.0, "phase": 90.0}
    with pytest.warns(UserWarning, match=r"phase = 90 rad is above 6.28319 rad, a full turn.*"
                                         r"\(90 deg is 1.5708 rad\)"):
        case_from_dict(data, "my.toml")


def test_td3_settings_in_a_spec_take_the_set_spelling_and_name_the_expected_form():
    """Round 5, U19/U20: `hidden_sizes = "256,256"` was shown split into characters, `noise_color
    = "pink"` as "expected a value like 0.0"."""
    data = load_case("m1-4mT").to_dict()
    data["training"]["td3"] = {"hidden_sizes": "64,64", "buffer_size": "1e5"}
    assert dict(case_from_dict(data, "my.toml").training.td3) == {"hidden_sizes": (64, 64),
                                                                  "buffer_size": 100000}
    data["training"]["td3"] = {"noise_color": "pink"}
    with pytest.raises(SpecError, match=r"noise_color=pink: expected a number: the exponent of the "
                                        r"noise's spectrum 1/f\^beta \(0 white, 1 pink, 2 red\)"):
        case_from_dict(data, "my.toml")
    data["training"]["td3"] = {"hidden_sizes": "64x64"}
    with pytest.raises(SpecError, match="hidden_sizes=64x64: expected comma-separated layer widths"):
        case_from_dict(data, "my.toml")
