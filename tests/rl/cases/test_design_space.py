"""The ``[design]`` table and the map from a search vector to a robot (issue 52), on the shipped
robot and on robots of every form the spec format allows (the spec matrix)."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import case_from_dict, load_case
from elastica_magnetic_rl.cases.design_space import LENGTH_WEIGHT_LOW, design_space
from elastica_magnetic_rl.design.folder import DesignError
from elastica_magnetic_rl.design.run import load_design
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from spec_matrix import ACTUATIONS, user_specs

from elastica_magnetic.specfile import SpecError, dumps


def _space(spec: dict, table: dict | None):
    case = case_from_dict(spec, "my.toml")
    return case, design_space(table, case.to_dict()["robot"], case.actuation.axes, "my.toml",
                              case.robot_spec("accurate").magnetization)


def test_the_papers_robot_by_default_six_equal_segments_in_the_plane():
    design = load_design("m1-4mT")
    space = design.space
    assert (space.segments, space.lengths) == (6, "equal")
    assert (space.directions, space.magnitude) == ("plane", "fixed")
    assert space.remanence == pytest.approx(61300.0)
    assert space.dim == 7  # six angles and the period


def test_the_start_vector_gives_back_the_robots_own_magnetization():
    # pattern 1 (halves along -x, +x) is six equal segments: three back, three front
    design = load_design("m1-4mT")
    magnetization = design.case.robot_spec("accurate").magnetization
    x0 = design.space.start_vector(magnetization, 2.0)
    assert np.allclose(np.abs(x0[:6]), [1, 1, 1, 0, 0, 0])
    assert design.space.period(x0) == pytest.approx(2.0)
    again = design.case_of(x0).robot_spec("accurate").magnetization
    np.testing.assert_allclose(again, magnetization, atol=1e-9 * 61300)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(spec=user_specs(task="crawl"), segments=st.integers(2, 12), data=st.data())
def test_every_vector_is_a_robot_the_parser_accepts(spec, segments, data):
    """Free lengths, free magnitudes (3d where the actuation has three axes), on drawn robots:
    element counts sum to the rod's, each segment at least the minimum length, magnitudes within
    the remanence, and the spec written parses back to the same magnetization."""
    n = spec["robot"]["n_elements"]
    segments = min(segments, n // 2)
    table = {"segments": segments, "lengths": "free", "magnitude": "free",
             "min_length": 2 * spec["robot"]["length"] / n}
    case, space = _space(spec, table)
    x = np.array(data.draw(st.lists(st.floats(-3.0, 3.0), min_size=space.dim, max_size=space.dim)))
    low, high = space.bounds()
    x = np.clip(x, low, high)
    counts = space.element_counts(x)
    assert sum(counts) == n and min(counts) >= 2
    segment_list = space.segment_list(x)
    assume(any(s["magnitude"] > 0 for s in segment_list))  # else no robot: the search scores it -1 m
    assert all(0.0 <= s["magnitude"] <= space.remanence * (1 + 1e-12) for s in segment_list)
    assert all(abs(np.linalg.norm(s["direction"]) - 1.0) < 1e-9 for s in segment_list)
    designed = case_from_dict(space.spec_of(case.to_dict(), x), "my.toml")
    m = designed.robot_spec("accurate").magnetization
    start = 0
    for seg, count in zip(segment_list, counts, strict=True):
        np.testing.assert_allclose(m[:, start:start + count],
                                   np.outer(np.array(seg["direction"]) * seg["magnitude"], np.ones(count)),
                                   atol=1e-6)
        start += count
    if case.actuation.axes == "xyz":
        assert space.directions == "3d"


@pytest.mark.parametrize("table, message", [
    ({"segments": 1}, "segments: must be >= 2"),
    ({"segments": 13}, "segments: must be <= 12"),
    ({"segments": 4, "lengths": "free", "min_length": 6.0}, "mm for m?"),
    ({"segments": 4, "lengths": "free", "min_length": 1e-5}, "shorter than one element"),
    ({"segments": 4, "min_length": 0.002}, "applies to free lengths only"),
    ({"directions": "3d"}, "needs the third coil pair"),
    ({"period_low": 3.0, "period_high": 2.0}, "must be larger than period_low"),
    ({"remanence": -61.3}, "must be > 0"),
    # round 12, S3: a remanence the robot as written exceeds (its start could not be made)
    ({"remanence": 30000.0}, "remanence: 30000 A/m is below the robot's own largest magnetization, "
                             "61300 A/m"),
    ({"segment": 6}, "unknown key"),
    ({"lengths": "random"}, "expected one of equal, free"),
    # round 10, S2/V2: the key and the value written, at spec check, not at run time
    ({"period_low": 0.001, "period_high": 0.002}, "period_low: 0.001 s is at or under 2 x the 0.01 s"),
    ({"period_low": 0.02, "period_high": 2.0}, "period_low: 0.02 s is at or under"),
    # round 10, S3: a band thicker than wide was simulated
    ({"thickness": [0.0005, 0.02]}, "thickness: the thickest band searched (0.02 m) is thicker"),
    ({"width": [0.0007, 0.012]}, "width: the thickest band searched (0.0008 m)"),
    ({"width": [0.004, 0.012], "thickness": [0.0005, 0.005]}, "thicker than the narrowest (0.004 m"),
])
def test_bad_design_tables_are_refused_by_name(tmp_path, table, message):
    spec = load_case("m1-4mT").to_dict()
    spec["design"] = table
    path = tmp_path / "my.toml"
    path.write_text(dumps(spec))
    with pytest.raises(SpecError) as info:
        load_design(path)
    assert f"{path}: [design]" in str(info.value) and message in str(info.value)


def test_a_remanence_in_ka_per_m_is_named(tmp_path):
    from elastica_magnetic.plausibility import ImplausibleValueWarning

    spec = load_case("m1-4mT").to_dict()
    spec["design"] = {"remanence": 61.3}
    path = tmp_path / "my.toml"
    path.write_text(dumps(spec))
    with pytest.warns(ImplausibleValueWarning, match=r"\[design\] remanence = 61.3 A/m.*kA/m"), \
            pytest.raises(SpecError, match=r"below the robot's own largest magnetization, 61300 A/m"
                                           r".*\(kA/m for A/m\?\)"):
        load_design(path)


def test_periods_in_ms_are_named_and_accepted_keys_are_silent(tmp_path):
    """Round 10, S2: periods of 500-6000 (ms written for s) passed without a word; S7: a
    ``[checks] accept`` naming a [design] key, the fix the warning proposes, was ignored."""
    import warnings

    from elastica_magnetic.plausibility import ImplausibleValueWarning

    spec = load_case("m1-4mT").to_dict()
    spec["design"] = {"period_low": 500, "period_high": 6000}
    path = tmp_path / "ms.toml"
    path.write_text(dumps(spec))
    with pytest.warns(ImplausibleValueWarning, match=r"period_low = 500 s .*500 ms is 0.5 s"):
        load_design(path)
    spec["design"] = {"remanence": 1.5e6}  # above solid NdFeB: warned, unless accepted
    spec["checks"] = {"accept": ["design.remanence"]}
    path.write_text(dumps(spec))
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImplausibleValueWarning)
        assert load_design(path).space.remanence == 1.5e6


def test_an_unknown_key_lists_the_size_keys_too(tmp_path):
    """Round 10, V1: the list of keys the table takes left out length, width, thickness, radius."""
    spec = load_case("m1-4mT").to_dict()
    spec["design"] = {"segmnts": 4}
    path = tmp_path / "typo.toml"
    path.write_text(dumps(spec))
    with pytest.raises(SpecError, match=r"segmnts: unknown key; did you mean segments\? \(this table "
                                        r"takes: .*length, lengths.*radius, remanence, segments, thickness, "
                                        r"width\)"):
        load_design(path)


def test_a_design_of_a_task_that_is_not_a_crawl_is_refused():
    with pytest.raises(DesignError, match="crawl"):
        load_design("m1-4mT-goto")


def test_a_segments_robot_keeps_its_own_segment_count(tmp_path):
    spec = {"robot": {"length": 0.02, "n_elements": 24, "width": 0.008, "thickness": 0.0008,
                      "density": 1860.0, "youngs_modulus": 84500.0, "poisson_ratio": 0.45,
                      "magnetization": {"kind": "segments", "magnitude": 50000.0, "segments": [
                          {"elements": 6, "direction": d} for d in
                          ([0, 1, 0], [1, 0, 0], [0, -1, 0], [-1, 0, 0])]},
                      "ground": {"static_mu": 0.8, "kinetic_mu": 0.6}},
            "actuation": {"field_limit": 0.004}, "task": {"kind": "crawl"}}
    path = tmp_path / "four.toml"
    path.write_text(dumps(spec))
    design = load_design(path)
    assert design.space.segments == 4 and design.space.remanence == pytest.approx(50000.0)
    x0 = design.space.start_vector(design.case.robot_spec("accurate").magnetization, 1.0)
    np.testing.assert_allclose(x0[:4], [0.5, 0.0, -0.5, 1.0], atol=1e-12)


def test_free_lengths_start_equal_and_respect_the_weights_bounds():
    spec = load_case("m1-4mT").to_dict()
    _, space = _space(spec, {"segments": 4, "lengths": "free"})
    low, high = space.bounds()
    assert low[4:8] == [LENGTH_WEIGHT_LOW] * 4 and high[4:8] == [1.0] * 4 and space.dim == 9
    assert space.element_counts(np.ones(space.dim)) == [16, 16, 16, 16]
    assert math.isinf(low[0]) and math.isinf(high[0])  # angles are not bounded


def test_actuations_of_every_form_give_a_space():
    for actuation in ACTUATIONS:
        spec = load_case("m1-4mT").to_dict()
        spec["actuation"] = {**spec["actuation"], **actuation}
        spec["actuation"].pop("max_increment", None) if "max_increment" not in actuation else None
        case, space = _space(spec, None)
        assert space.dim == (13 if case.actuation.axes == "xyz" else 7)


def test_a_design_table_round_trips_through_the_spec_and_other_commands_read_it(tmp_path):
    from elastica_magnetic_rl.cases.case import load_case as load

    spec = load_case("m1-4mT").to_dict()
    spec["design"] = {"segments": 4, "lengths": "free", "magnitude": "free"}
    path = tmp_path / "my.toml"
    path.write_text(dumps(spec))
    case = load(path)
    assert case.design.segments == 4 and case.design.min_length == pytest.approx(0.02 / 64)
    again = case_from_dict(case.to_dict(), "again.toml")
    assert again.design == case.design and again.to_dict() == case.to_dict()
    assert "[design]" in case.toml()


def test_sizes_in_a_design_table(tmp_path):
    spec = load_case("m1-4mT").to_dict()
    spec["design"] = {"segments": 4, "width": [0.006, 0.010], "length": [0.015, 0.025]}
    path = tmp_path / "my.toml"
    path.write_text(dumps(spec))
    design = load_design(path)
    space = design.space
    assert space.dim == 4 + 2 + 1
    x0 = design.start_vector(2.0)
    assert space.size_values(x0) == pytest.approx({"width": 0.008, "length": 0.02})
    x = x0.copy()
    x[4:6] = [0.0, 1.0]  # in the order length, width, thickness: the shortest, the widest
    designed = design.case_of(x).robot_spec("accurate")
    assert designed.length == pytest.approx(0.015)
    assert design.case_of(x).robot.tables["robot"]["width"] == pytest.approx(0.010)
    assert designed.radius == pytest.approx(0.0008 / math.sqrt(3))  # the band's r = h / sqrt(3)
    assert case_from_dict(design.case.to_dict(), "again.toml").design == space


@pytest.mark.parametrize("table, message", [
    ({"width": [0.01, 0.02]}, "does not hold the robot's own width = 0.008 m"),
    ({"width": [6, 10]}, "width high"),
    ({"radius": [0.0001, 0.001]}, "the robot has a band section"),
    ({"length": [0.02, 0.01]}, "0 < low < high"),
    ({"segments": 6, "lengths": "free", "min_length": 0.003, "length": [0.015, 0.025]},
     "do not fit in the shortest length"),
])
def test_bad_size_ranges_are_refused_by_name(tmp_path, table, message):
    spec = load_case("m1-4mT").to_dict()
    spec["design"] = table
    path = tmp_path / "my.toml"
    path.write_text(dumps(spec))
    with pytest.raises(SpecError, match=re.escape(message)):
        load_design(path)
