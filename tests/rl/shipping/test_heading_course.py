"""A commanded heading for a goto case (issue 51's ``heading``): ``run_policy(heading=)``, ``msr field
baseline`` / ``msr policy generate --heading``, the target kept the task's distance ahead on the line
from the start; the course's distances along and off the line; bad headings refused by name."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from elastica_magnetic_rl.cases.tasks import GotoTask
from elastica_magnetic_rl.envs.waypoints import HeadingCourse
from elastica_magnetic_rl.envs.yardsticks import SteeringFieldPolicy
from elastica_magnetic_rl.shipping.policy_runs import run_policy

from elastica_magnetic.cli import main


def run(argv: list[str]) -> int:
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code)


class _Env:
    """What a course reads of a goto environment: its task, start pose and retarget."""

    def __init__(self, start_pose) -> None:
        self.task = GotoTask(distance=0.015)
        self.start_pose = np.asarray(start_pose, dtype=np.float64)
        self.targets: list[tuple[float, float]] = []

    def retarget(self, target):
        self.targets.append(tuple(target))
        return np.zeros(3)


@pytest.mark.parametrize("start_heading", [0.0, 0.6, -2.5])
def test_the_course_measures_along_and_off_its_line_in_the_start_frame(start_heading):
    """A robot started at (x0, z0) facing ``start_heading``, commanded 90 degrees to its left: a point
    12 mm to its left and 3 mm ahead is 12 mm along the line and 3 mm to the line's right; the
    target moves to 15 mm beyond it along the line."""
    x0, z0 = 0.01, -0.02
    env = _Env([x0, z0, start_heading])
    course = HeadingCourse.for_env(env, math.pi / 2)
    assert course.first_target == pytest.approx((0.0, 0.015), abs=1e-15)
    course.begin(env)
    c, s = math.cos(start_heading), math.sin(start_heading)
    forward, left = 0.003, 0.012
    # the start frame's forward is (cos h, -sin h) in (x, z), its left (-sin h, -cos h)
    pose = [x0 + forward * c - left * s, z0 - forward * s - left * c, 0.0]
    course.advance(env, None, pose=pose)
    record = course.record()
    assert record["distance_along_m"] == pytest.approx(0.012)
    assert record["cross_track_m"] == pytest.approx(-0.003)  # + is the line's left: here its right
    assert record["max_cross_track_m"] == pytest.approx(0.003)
    assert record["travel_heading_rad"] == pytest.approx(math.atan2(left, forward))
    assert env.targets[-1] == pytest.approx((0.0, 0.012 + 0.015), abs=1e-15)


def test_a_course_refuses_what_is_not_a_heading():
    env = _Env([0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="give a target or a heading, not both"):
        HeadingCourse.for_env(env, 0.5, target=(0.01, 0.0))
    with pytest.raises(ValueError, match="an angle in rad within one turn"):
        HeadingCourse(90.0, 0.015)
    with pytest.raises(ValueError, match="give waypoints or a heading, not both"):
        run_policy(SteeringFieldPolicy("m1-4mT-goto"), 0.1, "training", "zero", False,
                   waypoints=[(0.0, 0.01)], heading=0.5)


def test_the_steering_yardstick_crawls_along_a_heading_to_its_left(tmp_path, capsys):
    """The band walks across its body: commanded to its left it goes there at once, on the line."""
    out = tmp_path / "left"
    assert run(["field", "baseline", "--case", "m1-4mT-goto", "--heading", "1.5708", "--duration", "3",
                "--physics", "training", "--no-progress", "--no-gif", "--json", "--out", str(out)]) == 0
    result = json.loads(capsys.readouterr().out)
    course = result["heading"]
    assert course["heading_rad"] == 1.5708
    assert course["distance_along_m"] > 0.01 and abs(course["cross_track_m"]) < 0.002
    assert course["travel_heading_rad"] == pytest.approx(math.pi / 2, abs=0.2)
    assert "goto" not in result and "final_distance_to_target_m" not in result  # its target moves with it
    assert result["target"] == "along the heading 1.571 rad (90 degrees to the left) for 3 s"
    assert result["duration_s"] == 3.0
    # the middle node went to the start's left (-z), as far as the course says
    rollout = np.load(out / "rollout.npz")
    mid = rollout["positions"].shape[2] // 2
    dz = rollout["positions"][-1, 2, mid] - rollout["positions"][0, 2, mid]
    assert -dz == pytest.approx(course["distance_along_m"], rel=0.05)
    assert (out / "top_view.png").stat().st_size > 0


@pytest.mark.parametrize(("argv", "message"), [
    (["field", "baseline", "--case", "m1-4mT", "--heading", "1.0"],
     "--heading is for a goto case; case 'm1-4mT' has the crawl task"),
    (["policy", "generate", "m1-4mT", "--heading", "1.0"],
     "--heading is for a goto case; case 'm1-4mT' has the crawl task"),
    (["field", "baseline", "--case", "m1-4mT-goto", "--heading", "90"],
     "degrees? give rad (90 degrees = 1.5708 rad)"),
    (["field", "baseline", "--case", "m1-4mT-goto", "--heading", "1.0", "--target", "0.01,0"],
     "not allowed with argument"),
    (["policy", "generate", "catheter-magnet-reach", "--heading", "1.0"],
     "--heading does not apply to case 'catheter-magnet-reach'"),
])
def test_bad_headings_are_refused_by_name(argv, message, tmp_path, capsys):
    assert run([*argv, "--out", str(tmp_path / "x"), "--no-progress"]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_a_shipped_goto_policy_plays_a_heading(tmp_path, capsys):
    assert run(["policy", "generate", "m1-4mT-goto", "--heading", "-1.5708", "--duration", "0.5", "--physics",
                "training", "--no-progress", "--no-figures", "--json", "--out", str(tmp_path / "g")]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["heading"]["heading_rad"] == -1.5708 and result["duration_s"] == 0.5
    assert result["target"] == "along the heading -1.571 rad (90 degrees to the right) for 0.5 s"
    assert result["policy_kind"] == "shipped" and "goto" not in result


@pytest.mark.parametrize(("angle", "words"), [
    (0.0, "straight ahead"), (math.pi, "straight behind"), (-math.pi, "straight behind"),
    (-0.5, "28.65 degrees to the right"), (5.5, "44.87 degrees to the right")])
def test_a_heading_is_said_in_words(angle, words):
    from elastica_magnetic_rl.shipping.generate import _bearing_words

    assert _bearing_words(angle) == words
