"""A path of waypoints for a goto episode: each waypoint the target until the robot's middle node
comes within the task's tolerance of it, the last one to the end of the episode (the ``path`` a
lab walks a robot along, around an obstacle, with any goto controller)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..cases.tasks import GotoTask

__all__ = ["WaypointPath", "Waypoints"]


@dataclass(frozen=True)
class Waypoints:
    """A path given where a single target is taken (e.g.
    :func:`~elastica_magnetic_rl.shipping.generate.generate`'s ``target``): ``points``, the
    waypoints in the order they are visited, each (forward, left) in m in the start frame."""

    points: tuple[tuple[float, float], ...]


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
        if not isinstance(env.task, GotoTask):
            raise ValueError(f"waypoints are for a goto case; this environment's task is {env.task.kind}")
        if target is not None:
            raise ValueError("give a target or waypoints, not both")
        return cls(points, env.task.tolerance)

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
