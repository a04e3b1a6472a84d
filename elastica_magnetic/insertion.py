"""An insertion stage: the clamped base of a rod pushed along its axis (a catheter fed through a
sheath by an advancer), so that a fixed-length magnetic segment reaches targets at every distance
in its travel, not only on the sheet its bends sweep.

- :class:`Advancer`: the stage's state and command. Its insertion ``s`` (m, along ``axis`` from the
  base's start) stays within ``travel``; a command (one component in ``[-1, 1]``, the velocity as a
  fraction of ``max_speed`` m/s) is followed at a constant velocity over its control step, stopping
  at the ends of the travel.
- :class:`InsertionClamp`: PyElastica's one-end clamp (``OneEndFixedBC``: the first node and
  element held) whose held position is the base's start plus ``s(t) axis``, and whose first node
  moves at the stage's velocity. ``build_simulation(..., clamp=True, advancer=stage)`` and
  ``BatchedRobots(..., clamp=True, advancers=[...])`` register it.

Units: m, m/s, s.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from elastica.boundary_conditions import OneEndFixedBC
from numpy.typing import ArrayLike, NDArray

__all__ = ["Advancer", "InsertionClamp"]


class Advancer:
    """A linear stage that pushes a rod's clamped base along ``axis``.

    Parameters
    ----------
    travel : array_like (2,)
        m, ``[low, high]``: the insertion's range, from the base's start position along ``axis``
        (``low <= 0 <= high``: the rod starts where it is built).
    max_speed : float
        m/s, the stage's fastest speed (a command of +-1).
    axis : array_like (3,)
        The direction the base moves in (normalized here); default +x, the axis of a rod built
        straight along +x.
    """

    #: Components of the action: the stage's velocity as a fraction of ``max_speed``.
    action_size = 1

    def __init__(self, travel: ArrayLike, max_speed: float, axis: ArrayLike = (1.0, 0.0, 0.0)) -> None:
        low, high = (float(v) for v in np.asarray(travel, dtype=np.float64).reshape(2))
        if not (math.isfinite(low) and math.isfinite(high) and low <= 0.0 <= high and low < high):
            raise ValueError(f"travel must be [low, high] in m with low <= 0 <= high and low < high, "
                             f"got {np.asarray(travel).tolist()}")
        speed = float(max_speed)
        if not (math.isfinite(speed) and speed > 0.0):
            raise ValueError(f"max_speed must be a positive speed in m/s, got {max_speed!r}")
        direction = np.asarray(axis, dtype=np.float64).reshape(3)
        norm = float(np.linalg.norm(direction))
        if not (math.isfinite(norm) and norm > 0.0):
            raise ValueError(f"axis must be a non-zero direction, got {np.asarray(axis).tolist()}")
        self.travel, self.max_speed, self.axis = (low, high), speed, direction / norm
        self.reset()

    def reset(self) -> None:
        """Back to insertion 0, at rest."""
        self._s0, self._velocity, self._t0, self._span = 0.0, 0.0, 0.0, 0.0

    def apply(self, action: ArrayLike, time: float, dt: float) -> None:
        """Command the stage at ``time`` (s) for ``dt`` (s): from where it is, at ``action`` times
        ``max_speed``, stopping at the ends of the travel."""
        a = np.asarray(action, dtype=np.float64).reshape(-1)
        if a.shape != (1,) or not math.isfinite(float(a[0])):
            raise ValueError(f"Advancer: expected one finite action component in [-1, 1], got "
                             f"{np.asarray(action).tolist()}")
        if not (math.isfinite(dt) and dt > 0.0):
            raise ValueError(f"dt must be a positive time in s, got {dt!r}")
        s = self.insertion_at(time)
        target = min(max(s + float(np.clip(a[0], -1.0, 1.0)) * self.max_speed * dt, self.travel[0]),
                     self.travel[1])
        self._s0, self._velocity, self._t0, self._span = s, (target - s) / dt, float(time), float(dt)

    def follow(self, insertion: float, time: float, dt: float) -> None:
        """Move from the insertion at ``time`` (s) to ``insertion`` (m) over ``dt`` (s) at constant
        speed, with neither the speed limit nor the travel applied: a stage's reported position
        replayed as it happened (``msr real identify``)."""
        end = float(insertion)
        if not (math.isfinite(end) and math.isfinite(dt) and dt > 0.0):
            raise ValueError(f"insertion (m) and dt (s) must be finite, dt positive; got {insertion!r}, "
                             f"{dt!r}")
        s = self.insertion_at(time)
        self._s0, self._velocity, self._t0, self._span = s, (end - s) / dt, float(time), float(dt)

    def motion(self) -> list[float]:
        """The command being followed: ``[s0 (m), velocity (m/s), t0 (s), span (s)]`` (to save it)."""
        return [self._s0, self._velocity, self._t0, self._span]

    def set_motion(self, values: ArrayLike) -> None:
        """Restore a :meth:`motion`."""
        self._s0, self._velocity, self._t0, self._span = (float(v) for v in np.asarray(values).reshape(4))

    def _elapsed(self, time: float) -> float:
        return min(max(float(time) - self._t0, 0.0), self._span)

    def insertion_at(self, time: float) -> float:
        """m: how far the base has moved along :attr:`axis` at ``time`` (s)."""
        return self._s0 + self._velocity * self._elapsed(time)

    def speed_at(self, time: float) -> float:
        """m/s: the stage's velocity along :attr:`axis` at ``time`` (s)."""
        return self._velocity if self._t0 <= float(time) < self._t0 + self._span else 0.0

    def state(self, time: float) -> NDArray[np.float64]:
        """(1,): the insertion (m) at ``time`` (s), what a controller observes."""
        return np.array([self.insertion_at(time)])


class InsertionClamp(OneEndFixedBC):
    """The first node and element of a rod held (``OneEndFixedBC``), the node at its start
    position plus the :class:`Advancer`'s insertion along its axis, moving at its velocity.
    ``clock`` maps the simulator's time to the advancer's (a batched robot reset mid-run has its
    own clock); default: the same."""

    def __init__(self, fixed_position: Any, fixed_directors: Any, advancer: Advancer,
                 clock: Callable[[float], float] | None = None, **kwargs: Any) -> None:
        super().__init__(fixed_position, fixed_directors, **kwargs)
        self.advancer, self.clock = advancer, clock
        self._start = np.array(self.fixed_position_collection, dtype=np.float64, copy=True)
        self._axis = advancer.axis.reshape(self._start.shape[0], *([1] * (self._start.ndim - 1)))

    def _time(self, time: float) -> float:
        return float(time) if self.clock is None else float(self.clock(time))

    def constrain_values(self, system: Any, time: np.float64) -> None:
        s = self.advancer.insertion_at(self._time(time))
        self.fixed_position_collection[...] = self._start + self._axis * s
        super().constrain_values(system, time)

    def constrain_rates(self, system: Any, time: np.float64) -> None:
        super().constrain_rates(system, time)
        system.velocity_collection[:, 0] = self.advancer.axis * self.advancer.speed_at(self._time(time))
