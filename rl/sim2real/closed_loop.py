"""The goto task closed around a tracker: what a lab runs to send the robot to a point.

A goto policy needs to know where the robot is. In a lab a camera tracks markers on the robot
(back, middle, front) and the loop at 100 Hz is: tracked markers -> observation -> policy ->
field increment -> coils (``msr real stream``). :func:`run_closed_loop` is that loop with a
simulated tracker (:class:`SimulatedTracker`: Gaussian noise on every tracked coordinate and a
latency of whole 0.01 s steps), so that it is tested before a coil is switched on.

What the policy sees: the field is known (it is what the loop commanded); the robot's heading
and the target in its own frame come from the *tracked* markers, noisy and late; the rest of a
learned policy's observation (the body's angular velocities, orientation, heights and contacts,
which no camera gives) comes from a simulation of the robot run alongside, driven by the same
field (a digital twin; here the simulation itself). The hand-designed steering yardstick reads
only the field and the tracked pose, so its closed loop needs nothing but the tracker.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from elastica_magnetic.robot_spec import ACTION_PERIOD

from ..cases.tasks import GotoTask, goto_metrics
from ..envs.env import make_env
from ..envs.waypoints import HeadingCourse, course_for_env

__all__ = ["SimulatedTracker", "run_closed_loop"]

#: The longest latency :class:`SimulatedTracker` takes, s (a tracker slower than this cannot
#: close a 100 Hz loop on a robot that walks a body width per second).
MAX_LATENCY_S = 1.0


@dataclass(frozen=True)
class SimulatedTracker:
    """A camera tracking the back, middle and front of the robot on the floor.

    Args:
        noise_m: standard deviation of each tracked coordinate (x and z of each marker), m.
        latency_s: age of the markers the loop acts on, s, rounded to whole 0.01 s steps.
        seed: the noise's random seed.
    """

    noise_m: float = 1e-4
    latency_s: float = 0.02
    seed: int = 0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.noise_m) and 0.0 <= self.noise_m <= 0.01):
            raise ValueError(f"noise_m must be a standard deviation in m within [0, 0.01] (10 mm), "
                             f"got {self.noise_m!r}: 0.1 mm is 1e-4")
        if not (math.isfinite(self.latency_s) and 0.0 <= self.latency_s <= MAX_LATENCY_S):
            raise ValueError(f"latency_s must be a time in s within [0, {MAX_LATENCY_S:g}], got "
                             f"{self.latency_s!r}: 20 ms is 0.02")

    @property
    def latency_steps(self) -> int:
        """The latency in 0.01 s control steps."""
        return int(round(self.latency_s / ACTION_PERIOD))


def _markers(rod, middle: int) -> np.ndarray:
    """The back, middle and front nodes' floor positions ``(3, 2)`` (x, z), m."""
    return rod.position_collection[[0, 2]][:, [0, middle, -1]].T.copy()


def _pose(markers: np.ndarray) -> np.ndarray:
    """``(x, z, heading)`` of the middle from markers ``(3, 2)``, as
    :func:`~elastica_magnetic_rl.cases.tasks.floor_pose` reads the rod."""
    along = markers[2] - markers[0]
    return np.array([markers[1, 0], markers[1, 1], math.atan2(-along[1], along[0])])


def run_closed_loop(policy, target: tuple[float, float] | None = None, duration: float | None = None,
                    physics: str = "accurate", tracker: SimulatedTracker | None = None,
                    seed: int = 0, waypoints: Any = None, heading: float | None = None) -> dict[str, Any]:
    """Send the robot of a goto ``policy`` (a loaded policy or the steering yardstick) to
    ``target`` (forward, left; m from the start, in its start frame), the loop closed around
    ``tracker`` (default :class:`SimulatedTracker`: 0.1 mm, 20 ms), from a zero field; or along
    ``waypoints`` ``(k, 2)`` (the same frame) instead: each the target until the *tracked* middle
    is within the task's tolerance of it (what a lab's loop knows), the last one to the end; or
    along a ``heading`` (rad, counter-clockwise seen from above, 0 ahead) instead, the target kept
    the task's distance ahead of the *tracked* middle's place on the line
    (:class:`~elastica_magnetic_rl.envs.waypoints.HeadingCourse`).

    Returns the true path's :func:`~elastica_magnetic_rl.cases.tasks.goto_metrics`
    (``final_distance_to_target_m``, ``success``, ``time_to_target_s``...; of the last waypoint
    for a path), the target, the tracker's settings and ``tracking_error_m``: the largest distance
    between the tracked (late, noisy) and the true middle the policy acted on; for a path,
    ``waypoints`` (each one's place and the time it was reached, s, ``None``: never). Along a
    heading: ``heading`` (the course's record of the *true* path: ``distance_along_m``,
    ``cross_track_m``...) and no target or goto metrics (the target moves with the robot).
    """
    case = policy.case
    if not isinstance(case.task, GotoTask):
        raise ValueError(f"a closed loop to a target is for a goto case; case {case.name!r} has the "
                         f"{case.task.kind} task")
    tracker = SimulatedTracker() if tracker is None else tracker
    duration = case.task.episode_duration if duration is None else float(duration)
    env = make_env(case, physics, "zero", duration)
    route, target = course_for_env(env, target, waypoints, heading)
    if route is None and target is None:
        raise ValueError("give a target (forward, left; m), waypoints or a heading")
    obs, _ = env.reset(seed=seed, options={"target": tuple(route.first_target if route else target)})
    if route is not None:
        route.begin(env)
    if hasattr(policy, "reset"):
        policy.reset()
    rng = np.random.default_rng(tracker.seed)
    layout = env.layout
    rod, middle = env.simulation.rod, env.middle_node
    seen = deque([_markers(rod, middle)] * (tracker.latency_steps + 1),
                 maxlen=tracker.latency_steps + 1)
    times, path, worst = [0.0], [_markers(rod, middle)[1]], 0.0
    for _ in range(env.max_episode_steps):
        tracked = seen[0] + rng.normal(0.0, tracker.noise_m, size=(3, 2))
        worst = max(worst, float(np.hypot(*(tracked[1] - _markers(env.simulation.rod, middle)[1]))))
        if route is not None:  # the next waypoint once the tracked middle is within the tolerance
            route.advance(env, obs, _pose(tracked))  # (or the heading's target ahead of it)
        extra = env.task.observe(_pose(tracked), env.task_state)
        obs = obs.copy()  # the pose blocks from the tracker; the clock is the loop's own
        obs[layout["heading"]] = extra[:2]
        obs[layout["target_offset"]] = extra[2:4]
        obs, _, terminated, truncated, _ = env.step(policy.act(obs))
        rod = env.simulation.rod
        seen.append(_markers(rod, middle))
        times.append(env.simulation.time)
        path.append(_markers(rod, middle)[1])
        if terminated or truncated:
            break
    target_xz = [float(v) for v in env.task.target(env.task_state)]
    pose = np.column_stack([np.asarray(path), np.zeros(len(path))])
    loop = {"physics": physics, "duration_s": float(times[-1]), "diverged": bool(terminated),
            "tracker_noise_m": tracker.noise_m, "tracker_latency_s": tracker.latency_steps * ACTION_PERIOD,
            "tracking_error_m": worst}
    if heading is not None:  # the course measured on the true path, not the tracked one it followed
        true_course = HeadingCourse.for_env(env, heading)
        true_course.begin(env)
        for place in pose[1:]:
            true_course.measure(env, place)
        env.close()
        return {**loop, "heading": true_course.record()}
    env.close()
    return {"target_forward_m": float(target[0]), "target_left_m": float(target[1]),
            "target_x_m": target_xz[0], "target_z_m": target_xz[1],
            "tolerance_m": case.task.tolerance, **loop,
            **({} if route is None else {"waypoints": route.record()}),
            **goto_metrics(np.asarray(times), pose, target_xz, case.task.tolerance)}
