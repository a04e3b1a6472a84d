"""Tasks of the crawler environments: what the robot is rewarded for, and what success means.

A task reads what it needs of the rod (:meth:`position`: the x of the robot's middle node, node
``n // 2``, m; for :class:`GotoTask` that node's place on the floor and the robot's heading) and
turns it into a reward per 0.01 s step and, if it needs one, an extra observation block appended
after the robot's blocks. Every method works elementwise on numpy arrays, one entry per robot, so
the single and the vector environment share one implementation.

- :class:`CrawlTask` (the paper's): reward ``reward_scale * dx``, ``dx`` the forward (+x)
  displacement of the middle node during the step (m); no extra observation.
- :class:`ReachTask`: move the middle node to ``target`` m ahead of where it started and stay
  there. Reward ``reward_scale * (|e_before| - |e_after|)`` for closing the distance (``e`` = the
  middle node's x minus the target, m), minus ``speed_penalty * reward_scale * |dx|`` on steps that
  end within ``slow_zone`` m of the target (moving there costs, so the policy learns to stop).
  Extra observation ``target_offset = 100 * (target_x - x_mid)`` per m (the height block's scale:
  10 mm reads 1.0). Success: ``|e| <= tolerance`` at the end of the evaluation.
- :class:`GotoTask`: bring the middle node to a point on the floor (x, z) drawn per episode on a
  ring of radius ``distance`` around the start, at a bearing in ``[angle_low, angle_high]`` from the
  start heading (or given: ``reset(options={"target": (forward, left)})``, m in the robot's start
  frame), and stay. Reward as the reach task's on the distance in the floor plane. Extra
  observation ``heading`` ``(cos h, sin h)`` and ``target_offset`` ``100 *`` the offset to the
  target in the robot's own frame (forward, left; per m): a policy steers by what is ahead and to
  its side, the same for every direction it happens to face; then ``clock`` ``(cos, sin)`` of
  ``2 pi t / GOTO_CLOCK_PERIOD`` (``t`` the episode's time, s): a controller's clock, by which the
  steering yardstick reverses its turning field every turn, so that its command is a function of
  the observation (DAgger's labels) and a policy can time the same manoeuvre. Needs a robot that can leave its
  line: a three-axis case (``[actuation] axes = "xyz"``). Success: ending within ``tolerance`` of
  the target; a policy is judged on a ring of :data:`RING_TARGETS` targets (:func:`ring_targets`,
  :func:`goto_metrics`). With ``heading_share > 0`` that share of the drawn episodes are heading
  episodes: after every step (:meth:`GotoTask.follow`) the target moves to ``distance`` ahead of the
  middle node's place along the line from the start toward the drawn target, so the policy learns
  to crawl along a commanded heading as well as to stop at a point. With ``time_penalty > 0`` (m/s)
  every step that ends beyond ``tolerance`` also costs ``reward_scale * time_penalty * 0.01 s``: as
  much as closing ``time_penalty`` m in a second would pay, so that arriving sooner pays (without
  it, the return is the distance closed, whenever it is closed; only the discount favours speed).

Floor-plane conventions: y is up; the heading ``h`` of the robot is the direction from its back
node to its front node, ``(cos h, 0, -sin h)``, counter-clockwise seen from above (0: +x, the start);
its left is ``(-sin h, 0, -cos h)`` (at the start: -z).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic.robot_spec import ACTION_PERIOD

__all__ = ["CrawlTask", "GOTO_CLOCK_PERIOD", "GotoTask", "RING_TARGETS", "ReachTask", "Task", "TASK_KINDS",
           "TipReachTask", "approach_reward", "TARGET_OFFSET_SCALE", "floor_pose", "goto_metrics", "middle_x",
           "ring_targets"]

#: Scale of the reach task's ``target_offset`` observation, per m.
TARGET_OFFSET_SCALE = 100.0


def middle_x(rod: Any, middle_node: int) -> float:
    """The x of the middle node of ``rod`` (a :class:`elastica.CosseratRod` or a view), m."""
    return float(rod.position_collection[0, middle_node])


def floor_pose(rod: Any, middle_node: int) -> NDArray[np.float64]:
    """``(x, z, h)``: the middle node's place on the floor (m) and the heading of the back-to-front
    direction (rad, counter-clockwise seen from above; 0 along +x)."""
    position = rod.position_collection
    along_x = position[0, -1] - position[0, 0]
    along_z = position[2, -1] - position[2, 0]
    return np.array([position[0, middle_node], position[2, middle_node],
                     math.atan2(-along_z, along_x)])


def approach_reward(task: Any, before: Any, after: Any, moved: Any) -> Any:
    """The reward of the tasks with a target: ``reward_scale`` times the distance closed
    (``before - after``, m), minus ``speed_penalty`` times the distance ``moved`` (m) on a step
    that ends within ``slow_zone`` m of the target (so a policy learns to stop there)."""
    before, after, moved = np.asarray(before), np.asarray(after), np.asarray(moved)
    return task.reward_scale * ((before - after) - task.speed_penalty * moved * (after <= task.slow_zone))


@dataclass(frozen=True)
class CrawlTask:
    """Crawl forward: reward ``reward_scale`` (per m) times the middle node's +x displacement."""

    kind: ClassVar[str] = "crawl"
    #: Extra observation blocks (name, size) after the robot's blocks.
    extra_observation: ClassVar[tuple[tuple[str, int], ...]] = ()
    #: Shape of one robot's task state (here the start x, m).
    state_shape: ClassVar[tuple[int, ...]] = ()
    reward_scale: float = 1e4
    episode_duration: float = 20.0

    @staticmethod
    def position(rod: Any, middle_node: int) -> float:
        """What the task reads of the rod: the middle node's x, m."""
        return middle_x(rod, middle_node)

    def start(self, x_mid: NDArray[np.float64], rng: Any = None, target: Any = None) -> NDArray[np.float64]:
        """The task state of episodes starting with the middle node at ``x_mid`` (m): its start
        (``rng`` and ``target`` are not used: a crawl has no target)."""
        if target is not None:
            raise ValueError("the crawl task has no target; a target option is for the goto task")
        return np.array(x_mid, dtype=np.float64, copy=True)

    def reward(self, x_before: Any, x_after: Any, start: Any) -> Any:
        """Reward of a step moving the middle node from ``x_before`` to ``x_after`` (m)."""
        return self.reward_scale * (np.asarray(x_after) - np.asarray(x_before))

    def observe(self, x_mid: Any, start: Any, time: Any = 0.0) -> NDArray[np.float64]:
        """The extra observation, shape ``(..., 0)`` (``time``, s, unused: as every task's)."""
        return np.zeros(np.shape(x_mid) + (0,))

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, **asdict(self)}


@dataclass(frozen=True)
class ReachTask:
    """Reach ``target`` m ahead of the start and stay there (see the module docstring)."""

    kind: ClassVar[str] = "reach"
    extra_observation: ClassVar[tuple[tuple[str, int], ...]] = (("target_offset", 1),)
    state_shape: ClassVar[tuple[int, ...]] = ()
    target: float = 10e-3
    tolerance: float = 1e-3
    slow_zone: float = 2e-3
    speed_penalty: float = 0.5
    reward_scale: float = 1e4
    episode_duration: float = 20.0

    @staticmethod
    def position(rod: Any, middle_node: int) -> float:
        """What the task reads of the rod: the middle node's x, m."""
        return middle_x(rod, middle_node)

    def start(self, x_mid: NDArray[np.float64], rng: Any = None, target: Any = None) -> NDArray[np.float64]:
        """The task state: the target x of episodes starting with the middle node at ``x_mid``
        (the spec's ``target`` ahead; ``rng`` is not used)."""
        if target is not None:
            raise ValueError("the reach task's target is its spec's [task] target; a target option "
                             "is for the goto task")
        return np.asarray(x_mid, dtype=np.float64) + self.target

    def error(self, x_mid: Any, start: Any) -> Any:
        """Signed distance of the middle node past the target, m."""
        return np.asarray(x_mid) - np.asarray(start)

    def reward(self, x_before: Any, x_after: Any, start: Any) -> Any:
        moved = np.abs(np.asarray(x_after) - np.asarray(x_before))
        return approach_reward(self, np.abs(self.error(x_before, start)), np.abs(self.error(x_after, start)),
                               moved)

    def within_tolerance(self, error: Any) -> Any:
        """The success test: a signed error (m, as :meth:`error`) within ``tolerance`` of zero."""
        return np.abs(error) <= self.tolerance

    def observe(self, x_mid: Any, start: Any, time: Any = 0.0) -> NDArray[np.float64]:
        """``target_offset``: ``100 * (target_x - x_mid)`` per m, shape ``(..., 1)`` (``time`` unused)."""
        return (TARGET_OFFSET_SCALE * -self.error(x_mid, start))[..., None]

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, **asdict(self)}


#: s: the cycle of the goto task's ``clock`` observation: two turns of the steering yardstick's field
#: (:class:`~elastica_magnetic_rl.envs.yardsticks.SteeringFieldPolicy`, 1 s a turn), one in each sense.
GOTO_CLOCK_PERIOD = 2.0


@dataclass(frozen=True)
class GotoTask:
    """Go to a point on the floor and stay there (see the module docstring). Lengths in m,
    angles in rad."""

    kind: ClassVar[str] = "goto"
    extra_observation: ClassVar[tuple[tuple[str, int], ...]] = (("heading", 2), ("target_offset", 2),
                                                                 ("clock", 2))
    distance: float = 15e-3
    angle_low: float = -math.pi
    angle_high: float = math.pi
    tolerance: float = 2e-3
    slow_zone: float = 4e-3
    speed_penalty: float = 0.5
    reward_scale: float = 1e4
    episode_duration: float = 30.0
    heading_share: float = 0.0
    time_penalty: float = 0.0

    def __post_init__(self) -> None:
        for name in ("distance", "tolerance", "slow_zone", "reward_scale", "episode_duration"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"GotoTask {name} must be a positive finite number, got {value!r}")
        if not (math.isfinite(self.time_penalty) and self.time_penalty >= 0.0):
            raise ValueError(f"GotoTask time_penalty must be a finite speed >= 0 (m/s), got "
                             f"{self.time_penalty!r}")
        if not (-2 * math.pi <= self.angle_low <= self.angle_high <= 2 * math.pi):
            raise ValueError(f"GotoTask angles must satisfy -2 pi <= angle_low <= angle_high <= 2 pi "
                             f"(rad), got {self.angle_low!r}, {self.angle_high!r}")
        if not (0.0 <= self.heading_share <= 1.0):
            raise ValueError(f"GotoTask heading_share must be a fraction in [0, 1], got "
                             f"{self.heading_share!r}")

    @property
    def state_shape(self) -> tuple[int, ...]:
        """One robot's state: its target (x, z), m; with heading episodes (``heading_share > 0``)
        then the line's start (x, z), m, and its direction (x, z): a unit vector, or (0, 0) in an
        episode with a fixed target."""
        return (2,) if self.heading_share == 0.0 else (6,)

    @property
    def moves_target(self) -> bool:
        """Whether some episodes' targets move (heading episodes): :meth:`follow` after each step."""
        return self.heading_share > 0.0

    @staticmethod
    def target(state: Any) -> NDArray[np.float64]:
        """The target (x, z), m, of a state (``(..., 2)`` or ``(..., 6)``): its first two entries."""
        return np.asarray(state, dtype=np.float64)[..., :2]

    @staticmethod
    def position(rod: Any, middle_node: int) -> NDArray[np.float64]:
        """What the task reads of the rod: :func:`floor_pose` ``(x, z, h)``."""
        return floor_pose(rod, middle_node)

    def start(self, pose: Any, rng: np.random.Generator | None = None,
              target: Any = None) -> NDArray[np.float64]:
        """The state (:attr:`state_shape`) of an episode starting at ``pose``: the target (x, z) is
        ``target`` (forward, left) in the start frame (m) when given, else drawn from ``rng`` on
        the ring (one uniform draw; with ``heading_share > 0`` a second draw makes that share of
        the drawn episodes heading episodes: the target stays ``distance`` ahead along the line
        from the start at the drawn bearing, :meth:`follow`)."""
        x, z, heading = (float(v) for v in np.asarray(pose, dtype=np.float64))
        along_line = False
        if target is None:
            if rng is None:
                raise ValueError("the goto task draws its target: give rng (or target)")
            bearing = float(rng.uniform(self.angle_low, self.angle_high))  # from ahead, to the left
            forward, left = self.distance * math.cos(bearing), self.distance * math.sin(bearing)
            along_line = self.moves_target and float(rng.uniform()) < self.heading_share
        else:
            forward, left = (float(v) for v in np.asarray(target, dtype=np.float64).reshape(2))
            if not (math.isfinite(forward) and math.isfinite(left)):
                raise ValueError(f"target must be finite (forward, left) in m, got {target!r}")
        c, s = math.cos(heading), math.sin(heading)
        # forward (cos h, -sin h) and left (-sin h, -cos h) in (x, z)
        dx, dz = forward * c - left * s, -forward * s - left * c
        if not self.moves_target:
            return np.array([x + dx, z + dz])
        direction = (dx / self.distance, dz / self.distance) if along_line else (0.0, 0.0)
        return np.array([x + dx, z + dz, x, z, *direction])

    def follow(self, state: Any, pose: Any) -> NDArray[np.float64]:
        """The state after a step ending at ``pose`` (x, z, ...; m): in a heading episode the
        target moves to ``distance`` ahead of the middle node's place along the line (a carrot the
        robot never reaches), otherwise it stays. ``state`` ``(6,)`` (:meth:`start`'s)."""
        state = np.array(state, dtype=np.float64)
        ux, uz = state[4], state[5]
        if ux != 0.0 or uz != 0.0:
            ahead = (float(pose[0]) - state[2]) * ux + (float(pose[1]) - state[3]) * uz + self.distance
            state[0], state[1] = state[2] + ahead * ux, state[3] + ahead * uz
        return state

    def error(self, pose: Any, target: Any) -> Any:
        """Distance of the middle node from the target (or a state's target) in the floor plane, m."""
        pose, target = np.asarray(pose), np.asarray(target)
        return np.hypot(pose[..., 0] - target[..., 0], pose[..., 1] - target[..., 1])

    def reward(self, pose_before: Any, pose_after: Any, target: Any) -> Any:
        """The approach reward (:func:`approach_reward`) on the floor-plane distance, minus
        ``reward_scale * time_penalty * ACTION_PERIOD`` on a step that ends beyond ``tolerance``."""
        a, b = np.asarray(pose_after), np.asarray(pose_before)
        moved = np.hypot(a[..., 0] - b[..., 0], a[..., 1] - b[..., 1])
        after = self.error(pose_after, target)
        reward = approach_reward(self, self.error(pose_before, target), after, moved)
        if self.time_penalty:  # each 0.01 s away from the target costs time_penalty * 0.01 s of distance
            away = ~self.within_tolerance(after)  # the success test's own comparison
            reward = reward - self.reward_scale * self.time_penalty * ACTION_PERIOD * away
        return reward

    def within_tolerance(self, distance: Any) -> Any:
        """The success test: a distance from the target (m) within ``tolerance``."""
        return np.abs(distance) <= self.tolerance

    def observe(self, pose: Any, target: Any, time: Any = 0.0) -> NDArray[np.float64]:
        """``heading`` ``(cos h, sin h)``, ``target_offset`` ``100 * (forward, left)`` per m, then
        ``clock`` ``(cos, sin)(2 pi time / GOTO_CLOCK_PERIOD)`` (``time``: s into the episode),
        shape ``(..., 6)``."""
        pose, target = np.asarray(pose, dtype=np.float64), np.asarray(target, dtype=np.float64)
        c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
        dx, dz = target[..., 0] - pose[..., 0], target[..., 1] - pose[..., 1]
        forward, left = dx * c - dz * s, -dx * s - dz * c
        phase = np.broadcast_to(2.0 * math.pi * np.asarray(time, dtype=np.float64) / GOTO_CLOCK_PERIOD,
                                c.shape)
        return np.stack([c, s, TARGET_OFFSET_SCALE * forward, TARGET_OFFSET_SCALE * left,
                         np.cos(phase), np.sin(phase)], axis=-1)

    def to_dict(self) -> dict[str, Any]:
        out = {"kind": self.kind, **asdict(self)}
        if not self.moves_target:  # the tables of cases without heading episodes stay as they were
            del out["heading_share"]
        if not self.time_penalty:  # nor those without a time penalty
            del out["time_penalty"]
        return out


def tip_position(rod: Any, node: int = -1) -> NDArray[np.float64]:
    """The position of node ``node`` of ``rod`` (default its last: a catheter's tip), m, ``(3,)``."""
    return np.array(rod.position_collection[:, node], dtype=np.float64)


@dataclass(frozen=True)
class TipReachTask:
    """Bring a clamped rod's tip (its last node) to a target point in space and hold it there.

    The target is drawn per episode uniformly in ``target_box`` ``[[xmin, ymin, zmin], [xmax, ymax,
    zmax]]`` (m, the spec's frame), or given (``reset(options={"target": (x, y, z)})``, m). Reward
    ``reward_scale * (d_before - d_after)`` for closing the distance ``d`` (m) from the tip to the
    target, minus ``speed_penalty * reward_scale`` times the tip's displacement on steps that end
    within ``slow_zone`` m of the target (so the policy learns to hold). Extra observation
    ``target_offset`` ``100 * (target - tip)`` per m (10 mm reads 1.0). Success: ending within
    ``tolerance`` m of the target.
    """

    kind: ClassVar[str] = "tip-reach"
    extra_observation: ClassVar[tuple[tuple[str, int], ...]] = (("target_offset", 3),)
    #: One robot's state: its target (x, y, z), m.
    state_shape: ClassVar[tuple[int, ...]] = (3,)
    target_box: tuple[tuple[float, float, float], tuple[float, float, float]] = (
        (0.035, -0.02, -0.02), (0.05, 0.02, 0.02))
    tolerance: float = 1e-3
    slow_zone: float = 3e-3
    speed_penalty: float = 0.5
    reward_scale: float = 1e4
    episode_duration: float = 5.0

    def __post_init__(self) -> None:
        box = np.asarray(self.target_box, dtype=np.float64)
        if box.shape != (2, 3) or not np.all(np.isfinite(box)) or np.any(box[1] < box[0]):
            raise ValueError("TipReachTask target_box must be [[xmin, ymin, zmin], [xmax, ymax, zmax]] "
                             f"(m) with each min at most its max, got {self.target_box!r}")
        object.__setattr__(self, "target_box", tuple(tuple(float(v) for v in row) for row in box))
        for name in ("tolerance", "slow_zone", "reward_scale", "episode_duration"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"TipReachTask {name} must be a positive finite number, got {value!r}")
        if not (math.isfinite(self.speed_penalty) and self.speed_penalty >= 0.0):
            raise ValueError("TipReachTask speed_penalty must be finite and >= 0, got "
                             f"{self.speed_penalty!r}")

    @staticmethod
    def position(rod: Any, middle_node: int = -1) -> NDArray[np.float64]:
        """What the task reads of the rod: its tip (last node), m, ``(3,)`` (``middle_node`` is not
        used: the tip is what is steered)."""
        return tip_position(rod)

    def start(self, tip: Any, rng: np.random.Generator | None = None,
              target: Any = None) -> NDArray[np.float64]:
        """The target of an episode (m, ``(3,)``): ``target`` when given, else one uniform draw
        (three numbers) from ``rng`` in :attr:`target_box`."""
        if target is None:
            if rng is None:
                raise ValueError("the tip-reach task draws its target: give rng (or target)")
            low, high = np.asarray(self.target_box)
            return rng.uniform(low, high)
        point = np.asarray(target, dtype=np.float64).reshape(-1)
        if point.shape != (3,) or not np.all(np.isfinite(point)):
            raise ValueError(f"target must be a finite point (x, y, z) in m, got {target!r}")
        return point

    def error(self, tip: Any, target: Any) -> Any:
        """Distance from the tip to the target, m."""
        return np.linalg.norm(np.asarray(tip) - np.asarray(target), axis=-1)

    def reward(self, tip_before: Any, tip_after: Any, target: Any) -> Any:
        moved = np.linalg.norm(np.asarray(tip_after) - np.asarray(tip_before), axis=-1)
        return approach_reward(self, self.error(tip_before, target), self.error(tip_after, target), moved)

    def within_tolerance(self, distance: Any) -> Any:
        """The success test: a distance from the target (m) within ``tolerance``."""
        return np.abs(distance) <= self.tolerance

    def observe(self, tip: Any, target: Any, time: Any = 0.0) -> NDArray[np.float64]:
        """``target_offset``: ``100 * (target - tip)`` per m, shape ``(..., 3)`` (``time`` unused)."""
        offset = np.asarray(target, dtype=np.float64) - np.asarray(tip, dtype=np.float64)
        return TARGET_OFFSET_SCALE * offset

    def to_dict(self) -> dict[str, Any]:
        out = {"kind": self.kind, **asdict(self)}
        out["target_box"] = [list(row) for row in self.target_box]
        return out


Task = CrawlTask | ReachTask | GotoTask | TipReachTask

#: Task classes by the ``kind`` of a spec's ``[task]`` table.
TASK_KINDS: dict[str, type] = {"crawl": CrawlTask, "reach": ReachTask, "goto": GotoTask,
                               "tip-reach": TipReachTask}

#: Targets of a goto evaluation ring: evenly spaced bearings around the start.
RING_TARGETS = 12


def ring_targets(distance: float, n: int = RING_TARGETS) -> NDArray[np.float64]:
    """``n`` targets evenly spaced on a ring of radius ``distance`` (m) around the start, the
    first straight ahead, then counter-clockwise seen from above: ``(n, 2)`` (forward, left), m."""
    if n < 1:
        raise ValueError(f"a ring needs at least one target, got {n}")
    bearing = 2.0 * np.pi * np.arange(n) / n
    return distance * np.stack([np.cos(bearing), np.sin(bearing)], axis=1)


def goto_metrics(times: Any, pose: Any, target: Any, tolerance: float) -> dict[str, Any]:
    """A goto episode's result from the middle node's floor pose ``(T, 3)`` (x, z, heading; m, m,
    rad) at ``times`` ``(T,)`` (s) and the target ``(2,)`` (x, z; m): ``final_distance_to_target_m``,
    ``success`` (ending within ``tolerance``, m), ``time_to_target_s`` (the first time within the
    tolerance; ``None`` if never) and ``settle_time_s`` (from when it stays within it to the end;
    ``None`` if it does not end there)."""
    times, pose = np.asarray(times, dtype=np.float64), np.asarray(pose, dtype=np.float64)
    target = np.asarray(target, dtype=np.float64)
    distance = np.hypot(pose[:, 0] - target[0], pose[:, 1] - target[1])
    inside = distance <= tolerance
    first = np.flatnonzero(inside)
    settle = None
    if inside[-1]:
        outside = np.flatnonzero(~inside)
        settle = float(times[outside[-1] + 1] if outside.size else times[0])
    return {"final_distance_to_target_m": float(distance[-1]), "success": bool(inside[-1]),
            "time_to_target_s": float(times[first[0]]) if first.size else None,
            "settle_time_s": settle, "closest_distance_m": float(distance.min())}
