"""Courses for a goto episode, followed by any goto controller through the target it is given:

- :class:`WaypointPath`: each waypoint the target until the robot's middle node comes within the
  task's tolerance of it, the last one to the end of the episode (the path a lab walks a robot
  along, around an obstacle);
- :class:`HeadingCourse`: a commanded heading, crawled along: the target a point on the line from
  the start at that heading, the task's ``distance`` ahead of the middle node's place along the line
  (a carrot), so the robot turns to the line, goes along it and keeps going.

Both keep the goto task's frame: (forward, left) in m from the start, headings in rad
counter-clockwise seen from above, 0 straight ahead."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..cases.tasks import GotoTask

__all__ = ["Heading", "HeadingCourse", "WaypointPath", "Waypoints", "course_for_env"]


@dataclass(frozen=True)
class Waypoints:
    """A path given where a single target is taken (e.g.
    :func:`~elastica_magnetic_rl.shipping.generate.generate`'s ``target``): ``points``, the
    waypoints in the order they are visited, each (forward, left) in m in the start frame."""

    points: tuple[tuple[float, float], ...]


@dataclass(frozen=True)
class Heading:
    """A heading given where a single target is taken: crawl along the line from the start at
    ``angle`` rad (counter-clockwise seen from above, 0 straight ahead) and keep going."""

    angle: float


class WaypointPath:
    """Which waypoint of a path is a goto episode's target, and when each was reached.

    ``points``: ``(k, 2)`` (forward, left; m in the episode's start frame, as a target given to
    ``reset``); ``tolerance``: m, the task's. Use: :meth:`for_env` before the reset (the first
    point is the reset's target), :meth:`begin` after it, :meth:`advance` after every step.
    """

    def __init__(self, points: Any, tolerance: float) -> None:
        array = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        self.points = [(float(forward), float(left)) for forward, left in array]
        if not self.points:
            raise ValueError("a path needs at least one waypoint")
        self.tolerance = float(tolerance)
        self.current = 0
        self.floor: list[list[float]] = []
        self.reached: list[float | None] = [None] * len(self.points)

    @classmethod
    def for_env(cls, env: Any, points: Any, target: Any = None) -> WaypointPath:
        """The path of ``points`` for ``env`` (a goto environment); ``target`` must be ``None``
        (a path's first point is the target)."""
        _check_course(env, target, "waypoints are", "waypoints")
        return cls(points, env.task.tolerance)

    @property
    def first_target(self) -> tuple[float, float]:
        """The reset's target: the first waypoint (forward, left; m)."""
        return self.points[0]

    def begin(self, env: Any) -> None:
        """After the reset: the waypoints' places on the floor (x, z; m) from the start frame."""
        self.floor = [[float(v) for v in env.task.start(env.start_pose, target=p)] for p in self.points]

    def advance(self, env: Any, obs: Any, pose: Any = None) -> Any:
        """After a step: the observation to act on, the next waypoint's (``env.retarget``) once the
        middle node is within the tolerance of this one. ``pose``: the floor pose ``(x, z,
        heading)`` judged (default the simulation's; a closed loop's: the tracked one)."""
        if pose is None:
            pose = env.task.position(env.simulation.rod, env.middle_node)
        if float(env.task.error(pose, np.asarray(self.floor[self.current]))) <= self.tolerance:
            if self.reached[self.current] is None:
                self.reached[self.current] = float(env.time)
            if self.current + 1 < len(self.points):
                self.current += 1
                return env.retarget(self.points[self.current])
        return obs

    def record(self) -> list[dict[str, Any]]:
        """Each waypoint: (forward, left) from the start, (x, z) on the floor (m) and the time it
        was reached (s; ``None``: never)."""
        return [{"forward_m": p[0], "left_m": p[1], "x_m": xz[0], "z_m": xz[1], "reached_s": t}
                for p, xz, t in zip(self.points, self.floor, self.reached, strict=True)]


def _check_course(env: Any, target: Any, subject: str, course: str) -> None:
    """Refuse a course (``subject``: "waypoints are", ...) for an environment without the goto
    task, or given beside a ``target`` (the course sets the target)."""
    if not isinstance(env.task, GotoTask):
        raise ValueError(f"{subject} for a goto case; this environment's task is {env.task.kind}")
    if target is not None:
        raise ValueError(f"give a target or {course}, not both")


def _start_frame(env: Any, pose: Any) -> tuple[float, float]:
    """The middle node's place ``pose`` (x, z, ...; m) in the episode's start frame: (forward,
    left), m."""
    x0, z0, h0 = (float(v) for v in env.start_pose)
    dx, dz = float(pose[0]) - x0, float(pose[1]) - z0
    c, s = math.cos(h0), math.sin(h0)
    return dx * c - dz * s, -dx * s - dz * c


class HeadingCourse:
    """A goto episode crawling along a commanded heading: the target is kept on the line from the
    start at ``angle`` (rad, counter-clockwise seen from above, 0 ahead), ``lookahead`` m (the
    task's ``distance``: as far as the targets a goto controller learned) ahead of the middle
    node's place along the line. Same use as :class:`WaypointPath`: :meth:`for_env` before the
    reset (:attr:`first_target` is the reset's target), :meth:`begin` after it, :meth:`advance`
    after every step, :meth:`record` at the end."""

    def __init__(self, angle: float, lookahead: float) -> None:
        if not (math.isfinite(angle) and abs(angle) <= 2.0 * math.pi):
            raise ValueError(f"a heading is an angle in rad within one turn, got {angle!r}")
        if not (math.isfinite(lookahead) and lookahead > 0.0):
            raise ValueError(f"lookahead must be a positive distance in m, got {lookahead!r}")
        self.angle, self.lookahead = float(angle), float(lookahead)
        self.along: list[float] = []
        self.across: list[float] = []

    @classmethod
    def for_env(cls, env: Any, angle: float, target: Any = None) -> HeadingCourse:
        """The course at ``angle`` for ``env`` (a goto environment, its task's ``distance`` ahead);
        ``target`` must be ``None`` (the course sets the target)."""
        _check_course(env, target, "a heading is", "a heading")
        return cls(angle, env.task.distance)

    @property
    def first_target(self) -> tuple[float, float]:
        """The target at the start (forward, left; m): ``lookahead`` along the heading."""
        return self.lookahead * math.cos(self.angle), self.lookahead * math.sin(self.angle)

    def begin(self, env: Any) -> None:
        """After the reset: the middle node starts on the line."""
        self.along, self.across = [0.0], [0.0]

    def advance(self, env: Any, obs: Any, pose: Any = None) -> Any:
        """After a step: the observation with the target moved to ``lookahead`` ahead of the
        middle node's place along the line (``env.retarget``). ``pose``: the floor pose judged
        (default the simulation's; a closed loop's: the tracked one)."""
        if pose is None:
            pose = env.task.position(env.simulation.rod, env.middle_node)
        ahead = self.measure(env, pose) + self.lookahead
        return env.retarget((ahead * math.cos(self.angle), ahead * math.sin(self.angle)))

    def measure(self, env: Any, pose: Any) -> float:
        """Record where the middle node's place ``pose`` (x, z, ...; m) is along the line and off
        it (what :meth:`record` reports); returns the distance along it, m."""
        forward, left = _start_frame(env, pose)
        c, s = math.cos(self.angle), math.sin(self.angle)
        along, across = forward * c + left * s, -forward * s + left * c
        self.along.append(along)
        self.across.append(across)
        return along

    def record(self) -> dict[str, Any]:
        """The course's result: the heading (rad), how far the middle node went along it
        (``distance_along_m``, at the end), how far off the line it ended (``cross_track_m``, + to
        the line's left) and strayed (``max_cross_track_m``), and the heading of its whole
        displacement (``travel_heading_rad``; ``None`` if it did not move)."""
        along, across = self.along[-1], self.across[-1]
        c, s = math.cos(self.angle), math.sin(self.angle)
        forward, left = along * c - across * s, along * s + across * c
        moved = math.hypot(forward, left) > 0.0
        return {"heading_rad": self.angle, "distance_along_m": along, "cross_track_m": across,
                "max_cross_track_m": max(abs(v) for v in self.across),
                "travel_heading_rad": math.atan2(left, forward) if moved else None}


def course_for_env(env: Any, target: Any, waypoints: Any, heading: float | None) -> tuple[Any, Any]:
    """The course of a goto rollout of ``env`` (a :class:`WaypointPath` for ``waypoints``, a
    :class:`HeadingCourse` for ``heading``, else ``None``) and the target its result is judged on (a
    path's last waypoint; ``None`` along a heading; else ``target``). Use the course's
    :attr:`first_target` as the reset's target."""
    if waypoints is not None and heading is not None:
        raise ValueError("give waypoints or a heading, not both")
    if waypoints is not None:
        path = WaypointPath.for_env(env, waypoints, target)
        return path, path.points[-1]
    if heading is not None:
        return HeadingCourse.for_env(env, heading, target), None
    return None, target
