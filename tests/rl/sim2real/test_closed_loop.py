"""The goto loop closed around a simulated tracker (issue 51): a perfect tracker is the
environment's own loop, a noisy and late one still brings the steering yardstick to the target,
and impossible tracker settings are refused with their unit."""

from __future__ import annotations

import numpy as np
import pytest
from elastica_magnetic_rl.envs.yardsticks import SteeringFieldPolicy
from elastica_magnetic_rl.shipping.goto import evaluate_ring
from elastica_magnetic_rl.sim2real.closed_loop import SimulatedTracker, run_closed_loop


def test_a_perfect_tracker_is_the_environments_own_loop():
    policy = SteeringFieldPolicy("m1-4mT-goto")
    target = (0.005, 0.012)
    loop = run_closed_loop(policy, target, 1.0, "training", SimulatedTracker(0.0, 0.0))
    (direct,) = evaluate_ring(policy, 1.0, "training", targets=[target])
    assert loop["final_distance_to_target_m"] == direct["final_distance_to_target_m"]
    assert loop["tracking_error_m"] == 0.0 and loop["target_z_m"] == direct["target_z_m"]


def test_a_noisy_late_tracker_still_brings_the_yardstick_to_a_target_abeam():
    policy = SteeringFieldPolicy("m1-4mT-goto")  # the case's 2 s a turn: there in 2.7 s, settled by 4 s
    late = run_closed_loop(policy, (0.0, -0.015), 4.0, "training", SimulatedTracker(1e-4, 0.02))
    assert late["success"] and late["time_to_target_s"] < 3.0
    assert late["tracker_latency_s"] == pytest.approx(0.02) and late["tracking_error_m"] > 1e-4
    blind = run_closed_loop(policy, (0.0, -0.015), 4.0, "training", SimulatedTracker(1e-4, 0.5))
    assert blind["tracking_error_m"] > late["tracking_error_m"]  # half a second late: it overshoots
    assert blind["closest_distance_m"] < 0.002 and not np.isclose(
        blind["final_distance_to_target_m"], late["final_distance_to_target_m"])


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"noise_m": 0.1}, "noise_m must be a standard deviation in m within [0, 0.01]"),
    ({"noise_m": -1e-4}, "noise_m must be"),
    ({"latency_s": 20.0}, "latency_s must be a time in s within [0, 1]"),
    ({"latency_s": float("nan")}, "latency_s must be"),
])
def test_impossible_trackers_are_refused_with_their_unit(kwargs, message):
    with pytest.raises(ValueError) as err:
        SimulatedTracker(**kwargs)
    assert message in str(err.value)


def test_the_closed_loop_is_for_a_goto_case():
    from elastica_magnetic_rl.envs.yardsticks import RotatingFieldPolicy

    with pytest.raises(ValueError, match="case 'm1-4mT' has the crawl task"):
        run_closed_loop(RotatingFieldPolicy("m1-4mT"), (0.01, 0.0), 0.1, "training")


def test_a_closed_loop_follows_a_path_by_the_tracked_pose():
    """Out 4 mm to the left and back, the next waypoint taken when the *tracked* middle is within
    the tolerance: a perfect tracker switches as the open loop does; a noisy late one still ends
    the path."""
    from elastica_magnetic_rl.shipping.policy_runs import run_policy

    policy = SteeringFieldPolicy("m1-4mT-goto")
    path = [(0.0, 0.004), (0.0, 0.0)]
    perfect = run_closed_loop(policy, None, 3.0, "training", SimulatedTracker(0.0, 0.0), waypoints=path)
    direct = run_policy(policy, 3.0, "training", "zero", False, waypoints=path)
    reached = [w["reached_s"] for w in perfect["waypoints"]]
    assert reached == [w["reached_s"] for w in direct.meta["waypoints"]]
    assert perfect["target_left_m"] == 0.0 and all(w["reached_s"] for w in perfect["waypoints"])
    late = run_closed_loop(policy, None, 3.0, "training", SimulatedTracker(1e-4, 0.02), waypoints=path)
    assert all(w["reached_s"] is not None for w in late["waypoints"]) and late["tracking_error_m"] > 1e-4
    with pytest.raises(ValueError, match="give a target or waypoints, not both"):
        run_closed_loop(policy, (0.01, 0.0), 0.1, "training", waypoints=path)
    with pytest.raises(ValueError, match="give a target"):
        run_closed_loop(policy, None, 0.1, "training")


def test_a_closed_loop_crawls_along_a_heading_by_the_tracked_pose():
    """80 degrees to the left (within the law's walking band: it walks at once): a perfect tracker
    crawls as the open loop does (the same course, to round-off); a noisy late one still goes
    along the line (13 mm in 2 s), measured on the true path."""
    from elastica_magnetic_rl.shipping.policy_runs import run_policy

    policy = SteeringFieldPolicy("m1-4mT-goto")
    perfect = run_closed_loop(policy, None, 2.0, "training", SimulatedTracker(0.0, 0.0), heading=1.4)
    direct = run_policy(policy, 2.0, "training", "zero", False, heading=1.4).meta["heading"]
    assert perfect["heading"] == pytest.approx(direct, rel=1e-12, abs=1e-15)
    assert "target_x_m" not in perfect and "success" not in perfect  # its target moves with it
    late = run_closed_loop(policy, None, 2.0, "training", SimulatedTracker(1e-4, 0.02), heading=1.4)
    assert late["heading"]["distance_along_m"] > 0.5 * direct["distance_along_m"] > 0.0
    assert abs(late["heading"]["cross_track_m"]) < 0.003 and late["tracking_error_m"] > 1e-4
    with pytest.raises(ValueError, match="give waypoints or a heading, not both"):
        run_closed_loop(policy, None, 0.1, "training", waypoints=[(0.0, 0.01)], heading=0.5)
