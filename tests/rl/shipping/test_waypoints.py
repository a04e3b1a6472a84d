"""A path of waypoints for a goto case (issue 51's ``path``): ``run_policy(waypoints=)``, ``msr field
baseline`` / ``msr policy generate --waypoints``, each waypoint the target until the middle node is
within the task's tolerance of it, and the top view; bad waypoints refused by name."""

from __future__ import annotations

import json

import numpy as np
import pytest
from elastica_magnetic_rl.envs.yardsticks import SteeringFieldPolicy
from elastica_magnetic_rl.shipping.policy_runs import run_policy

from elastica_magnetic.cli import main


def run(argv: list[str]) -> int:
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code)


def test_the_steering_yardstick_walks_a_path_out_and_back(tmp_path, capsys):
    """4 mm to the left (abeam: the band walks there), then back to the start: the first waypoint
    is reached, the target then moves to the second, which is reached too."""
    out = tmp_path / "path"
    assert run(["field", "baseline", "--case", "m1-4mT-goto", "--waypoints", "0,0.004:0,0",
                "--duration", "3", "--physics", "training", "--no-progress", "--no-gif", "--json",
                "--out", str(out)]) == 0
    result = json.loads(capsys.readouterr().out)
    first, second = result["waypoints"]
    assert (first["forward_m"], first["left_m"]) == (0.0, 0.004)
    assert first["reached_s"] is not None and second["reached_s"] is not None
    assert first["reached_s"] < second["reached_s"] <= 3.0
    assert result["waypoints_reached"] == 2 and result["goto"]["target_left_m"] == 0.0
    assert result["goto"]["success"] == (result["final_distance_to_target_m"] <= 0.002)
    assert result["target"].startswith("2 waypoints in order, then within 2.0 mm of the target (+0.0, +0.0)")
    assert (out / "top_view.png").stat().st_size > 0
    # the path's middle node went left (-z) and came back: its farthest point is past the tolerance
    rollout = np.load(out / "rollout.npz")
    mid = rollout["positions"].shape[2] // 2
    z = rollout["positions"][:, 2, mid] - rollout["positions"][0, 2, mid]
    assert z.min() < -0.002 and z[-1] > z.min() + 0.002


def test_an_unreached_waypoint_keeps_the_target_and_says_never():
    policy = SteeringFieldPolicy("m1-4mT-goto")
    rollout = run_policy(policy, 0.2, "training", "zero", False, waypoints=[(0.0, 0.01), (0.01, 0.0)])
    first, second = rollout.meta["waypoints"]
    assert first["reached_s"] is None and second["reached_s"] is None
    assert rollout.meta["target_xz_m"] == pytest.approx([first["x_m"], first["z_m"]])  # still the first
    with pytest.raises(ValueError, match="give a target or waypoints, not both"):
        run_policy(policy, 0.2, "training", "zero", False, target=(0.01, 0.0), waypoints=[(0.0, 0.01)])


@pytest.mark.parametrize(("argv", "message"), [
    (["field", "baseline", "--case", "m1-4mT", "--waypoints", "0,0.01:0.01,0"],
     "--waypoints is for a goto case; case 'm1-4mT' has the crawl task"),
    (["field", "baseline", "--case", "m1-4mT-goto", "--waypoints", "0,0.01"],
     "expected two or more FORWARD,LEFT pairs in m joined by ':'"),
    (["field", "baseline", "--case", "m1-4mT-goto", "--waypoints", "0,0.01:0.01,0,0"],
     "waypoint 2 of '0,0.01:0.01,0,0' is '0.01,0,0': a waypoint is FORWARD,LEFT in m (two numbers)"),
    (["field", "baseline", "--case", "m1-4mT-goto", "--waypoints", "0,0.01:15,0"],
     "waypoint 2 of '0,0.01:15,0': 15,0 is 15 m from the start: metres, not mm"),
    (["field", "baseline", "--case", "m1-4mT-goto", "--waypoints", "0,0.01:0.01,0", "--target", "0.01,0"],
     "not allowed with argument"),
    (["policy", "generate", "catheter-magnet-reach", "--waypoints", "0,0.01:0.01,0"],
     "--waypoints does not apply to case 'catheter-magnet-reach'"),
])
def test_bad_waypoints_are_refused_by_name(argv, message, tmp_path, capsys):
    assert run([*argv, "--out", str(tmp_path / "x"), "--no-progress"]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_a_far_waypoint_is_named_as_a_unit_slip(tmp_path, capsys):
    assert run(["field", "baseline", "--case", "m1-4mT-goto", "--waypoints", "0,0.004:1.5,0", "--duration",
                "0.05", "--physics", "training", "--no-progress", "--no-figures", "--json", "--out",
                str(tmp_path / "x")]) == 0
    err = capsys.readouterr().err
    assert "waypoint 2 1.5,0 is 1.5 m from the start" in err
    assert "(cm written for m? waypoint 2 0.015,0 is 1.5 cm)" in err
