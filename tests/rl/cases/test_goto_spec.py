"""The goto task as a spec's ``[task]`` kind (issue 51): the shipped ``m1-4mT-goto`` case, its
keys with units, and refusals that name the key (a planar actuation, a tolerance that makes staying
put a success, bearings out of order, a ring in mm written for m)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import case_from_dict, case_names, load_case
from elastica_magnetic_rl.cases.tasks import GotoTask, goto_metrics, ring_targets

from elastica_magnetic.cli import main
from elastica_magnetic.specfile import SpecError


def _goto_spec(**task):
    data = load_case("m1-4mT-goto").to_dict()
    data["task"].update(task)
    return data


def test_the_shipped_goto_case_is_listed_and_round_trips(tmp_path, capsys):
    assert "m1-4mT-goto" in case_names()
    case = load_case("m1-4mT-goto")
    assert isinstance(case.task, GotoTask) and case.actuation.axes == "xyz"
    assert case.task.distance == 0.015 and case.task.tolerance == 0.002
    assert case.task.episode_duration == 30.0
    assert case.robot_spec("training").ground.sideways == "sliding"
    assert case.obs_dim == 4 * 64 + 4 + 1 + 6  # the field's z, the heading, the target and the clock
    assert case.target_label == "within 2.0 mm of a target 15.0 mm away in 30 s"
    assert not case.has_yardstick  # judged on a ring, not by one run's distance
    assert main(["case", "show", "m1-4mT-goto", "--toml"]) == 0
    text = capsys.readouterr().out
    assert 'kind = "goto"' in text and "distance = 0.015  # m from the start" in text
    mine = tmp_path / "mine.toml"
    mine.write_text(text)
    assert {**load_case(mine).to_dict(), "name": "m1-4mT-goto"} == case.to_dict()


def test_a_goto_spec_takes_its_keys():
    case = case_from_dict(_goto_spec(distance=0.01, angle_low=-1.0, angle_high=0.5,
                                     tolerance=0.001), "my.toml", "my")
    assert case.task == GotoTask(distance=0.01, angle_low=-1.0, angle_high=0.5, tolerance=0.001,
                                 episode_duration=30.0)


@pytest.mark.parametrize(("task", "message"), [
    ({"tolerance": 0.02}, "[task] tolerance: 0.02 m must be smaller than the target distance 0.015 m"),
    ({"angle_low": 1.0, "angle_high": 0.5}, "[task] angle_high: 0.5 rad is below angle_low = 1 rad"),
    ({"distance": 15.0}, "it looks like mm written where m is expected"),
    ({"distance": -0.015}, "[task] distance: must be > 0 (m from the start)"),
    ({"angle_high": 90.0}, "[task] angle_high: must be within [-6.28319, 6.28319] rad"),
    ({"target": 0.01}, "[task] target: unknown key"),
    ({"time_penalty": -0.001}, "[task] time_penalty: must be >= 0 (m/s)"),
])
def test_bad_goto_keys_are_refused_by_name(task, message):
    with pytest.raises(SpecError) as err:
        case_from_dict(_goto_spec(**task), "my.toml", "my")
    assert message in str(err.value)


def test_goto_on_two_axes_is_refused_naming_the_axes():
    data = _goto_spec()
    data["actuation"]["axes"] = "xy"
    data["actuation"]["field_limit"] = 0.004
    with pytest.raises(SpecError, match=r'my.toml: \[task\] kind = "goto" needs the third coil '
                                        r'pair.*axes = \'xy\'.*set \[actuation\] axes = "xyz"'):
        case_from_dict(data, "my.toml", "my")


def test_the_ring_is_evenly_spaced_from_straight_ahead_counter_clockwise():
    ring = ring_targets(0.015, 12)
    assert ring.shape == (12, 2)
    assert np.allclose(np.hypot(ring[:, 0], ring[:, 1]), 0.015)
    assert ring[0] == pytest.approx([0.015, 0.0])
    assert ring[3] == pytest.approx([0.0, 0.015], abs=1e-15)  # a quarter turn: the left
    bearings = np.unwrap(np.arctan2(ring[:, 1], ring[:, 0]))
    assert np.allclose(np.diff(bearings), 2 * math.pi / 12)
    with pytest.raises(ValueError, match="at least one target"):
        ring_targets(0.015, 0)


def test_goto_metrics_time_to_target_settling_and_final_distance():
    times = np.arange(6) * 0.5
    x = np.array([0.0, 0.004, 0.0092, 0.0095, 0.0075, 0.0099])  # passes, leaves, comes back
    pose = np.column_stack([x, np.zeros(6), np.zeros(6)])
    m = goto_metrics(times, pose, (0.01, 0.0), 0.001)
    assert m["success"] and m["time_to_target_s"] == 1.0 and m["settle_time_s"] == 2.5
    assert m["final_distance_to_target_m"] == pytest.approx(1e-4)
    assert m["closest_distance_m"] == pytest.approx(1e-4)
    never = goto_metrics(times, pose, (0.0, 0.02), 0.001)
    assert not never["success"] and never["time_to_target_s"] is None
    assert never["settle_time_s"] is None


def test_a_time_penalty_is_read_and_written_only_where_set(tmp_path):
    case = case_from_dict(_goto_spec(time_penalty=0.002), "my.toml", "my")
    assert case.task.time_penalty == 0.002 and case.to_dict()["task"]["time_penalty"] == 0.002
    assert "time_penalty = 0.002  # m/s" in case.toml()
    mine = tmp_path / "mine.toml"
    mine.write_text(case.toml())
    assert load_case(mine).task == case.task
    assert "time_penalty" not in load_case("m1-4mT-goto").to_dict()["task"]  # the shipped tables as they were


def test_a_time_penalty_in_mm_per_s_is_warned_naming_the_key():
    from elastica_magnetic.plausibility import ImplausibleValueWarning

    expected = r"\[task\] time_penalty: 5 m/s is more than 10 body lengths .*mm/s written for m/s\?"
    with pytest.warns(ImplausibleValueWarning, match=expected + r" \(5 mm/s is 0.005 m/s\)"):
        case_from_dict(_goto_spec(time_penalty=5.0), "my.toml", "my")
