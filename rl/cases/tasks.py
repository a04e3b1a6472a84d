"""Tasks of the crawler environments: what the robot is rewarded for, and what success means.

A task turns the x position of the robot's middle node (node ``n // 2``, m) into a reward per
0.01 s step and, if it needs one, an extra observation block appended after the robot's blocks.
Every method works elementwise on numpy arrays, one entry per robot, so the single and the vector
environment share one implementation.

- :class:`CrawlTask` (the paper's): reward ``reward_scale * dx``, ``dx`` the forward (+x)
  displacement of the middle node during the step (m); no extra observation.
- :class:`ReachTask`: move the middle node to ``target`` m ahead of where it started and stay
  there. Reward ``reward_scale * (|e_before| - |e_after|)`` for closing the distance (``e`` = the
  middle node's x minus the target, m), minus ``speed_penalty * reward_scale * |dx|`` on steps that
  end within ``slow_zone`` m of the target (moving there costs, so the policy learns to stop).
  Extra observation ``target_offset = 100 * (target_x - x_mid)`` per m (the height block's scale:
  10 mm reads 1.0). Success: ``|e| <= tolerance`` at the end of the evaluation.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

__all__ = ["CrawlTask", "ReachTask", "Task", "TASK_KINDS", "TARGET_OFFSET_SCALE"]

#: Scale of the reach task's ``target_offset`` observation, per m.
TARGET_OFFSET_SCALE = 100.0


@dataclass(frozen=True)
class CrawlTask:
    """Crawl forward: reward ``reward_scale`` (per m) times the middle node's +x displacement."""

    kind: ClassVar[str] = "crawl"
    #: Extra observation blocks (name, size) after the robot's blocks.
    extra_observation: ClassVar[tuple[tuple[str, int], ...]] = ()
    reward_scale: float = 1e4
    episode_duration: float = 20.0

    def start(self, x_mid: NDArray[np.float64]) -> NDArray[np.float64]:
        """The task state of episodes starting with the middle node at ``x_mid`` (m): its start."""
        return np.array(x_mid, dtype=np.float64, copy=True)

    def reward(self, x_before: Any, x_after: Any, start: Any) -> Any:
        """Reward of a step moving the middle node from ``x_before`` to ``x_after`` (m)."""
        return self.reward_scale * (np.asarray(x_after) - np.asarray(x_before))

    def observe(self, x_mid: Any, start: Any) -> NDArray[np.float64]:
        """The extra observation, shape ``(..., 0)``."""
        return np.zeros(np.shape(x_mid) + (0,))

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, **asdict(self)}


@dataclass(frozen=True)
class ReachTask:
    """Reach ``target`` m ahead of the start and stay there (see the module docstring)."""

    kind: ClassVar[str] = "reach"
    extra_observation: ClassVar[tuple[tuple[str, int], ...]] = (("target_offset", 1),)
    target: float = 10e-3
    tolerance: float = 1e-3
    slow_zone: float = 2e-3
    speed_penalty: float = 0.5
    reward_scale: float = 1e4
    episode_duration: float = 20.0

    def start(self, x_mid: NDArray[np.float64]) -> NDArray[np.float64]:
        """The task state: the target x of episodes starting with the middle node at ``x_mid``."""
        return np.asarray(x_mid, dtype=np.float64) + self.target

    def error(self, x_mid: Any, start: Any) -> Any:
        """Signed distance of the middle node past the target, m."""
        return np.asarray(x_mid) - np.asarray(start)

    def reward(self, x_before: Any, x_after: Any, start: Any) -> Any:
        e_before, e_after = np.abs(self.error(x_before, start)), np.abs(self.error(x_after, start))
        near = e_after <= self.slow_zone
        moved = np.abs(np.asarray(x_after) - np.asarray(x_before))
        return self.reward_scale * ((e_before - e_after) - self.speed_penalty * moved * near)

    def within_tolerance(self, error: Any) -> Any:
        """The success test: a signed error (m, as :meth:`error`) within ``tolerance`` of zero."""
        return np.abs(error) <= self.tolerance

    def observe(self, x_mid: Any, start: Any) -> NDArray[np.float64]:
        """``target_offset``: ``100 * (target_x - x_mid)`` per m, shape ``(..., 1)``."""
        return (TARGET_OFFSET_SCALE * -self.error(x_mid, start))[..., None]

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, **asdict(self)}


Task = CrawlTask | ReachTask

#: Task classes by the ``kind`` of a spec's ``[task]`` table.
TASK_KINDS: dict[str, type] = {"crawl": CrawlTask, "reach": ReachTask}
