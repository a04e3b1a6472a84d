"""The clamped bases of a batch of rods in one call (:class:`BatchedClamp`): what a
``OneEndFixedBC`` per rod, or an :class:`~elastica_magnetic.insertion.InsertionClamp` with its
:class:`~elastica_magnetic.insertion.Advancer`, does to each rod, done for every rod of a
PyElastica memory block by one numba kernel per constraint call (the per-rod constraints cost
two Python calls per rod and step: most of a clamped catheter's step). Bit for bit the per-rod
constraints: the same assignments and the same arithmetic of the stage's ramp.

Units: m, m/s, s.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .insertion import Advancer

#: Columns of a stage's row (:meth:`BatchedClamp.gather`): the insertion at the command's start
#: (m), its velocity (m/s), the command's start time and span (s): :meth:`Advancer.motion`.
S0, VELOCITY, T0, SPAN = range(4)


@njit(cache=True)
def clamp_values(position, director, node_start, elem_start, start, directors, axes, stages, advanced, times):
    """Hold each robot ``i``'s first node at ``start[:, i]`` plus its stage's insertion at
    ``times[i]`` (s) along ``axes[:, i]``, and its first element's directors at
    ``directors[:, :, i]``. ``stages`` ``(N, 4)``: each stage's command (:data:`S0` ...);
    ``advanced[i]``: robot ``i`` has a stage (else its node is held at ``start`` itself)."""
    for i in range(node_start.shape[0]):
        node, element = node_start[i], elem_start[i]
        if advanced[i]:
            elapsed = min(max(times[i] - stages[i, T0], 0.0), stages[i, SPAN])
            s = stages[i, S0] + stages[i, VELOCITY] * elapsed
            for d in range(3):
                position[d, node] = start[d, i] + axes[d, i] * s
        else:
            for d in range(3):
                position[d, node] = start[d, i]
        for a in range(3):
            for b in range(3):
                director[a, b, element] = directors[a, b, i]


@njit(cache=True)
def clamp_rates(velocity, omega, node_start, elem_start, axes, stages, advanced, times):
    """Each robot's first node moving at its stage's velocity at ``times[i]`` (s) along
    ``axes[:, i]`` (at rest without a stage, or outside the command's span), its first
    element not turning."""
    for i in range(node_start.shape[0]):
        node, element = node_start[i], elem_start[i]
        speed = 0.0
        if advanced[i] and stages[i, T0] <= times[i] < stages[i, T0] + stages[i, SPAN]:
            speed = stages[i, VELOCITY]
        for d in range(3):
            velocity[d, node] = 0.0
            omega[d, element] = 0.0
        if advanced[i]:
            for d in range(3):
                velocity[d, node] = axes[d, i] * speed


class BatchedClamp:
    """The clamps of ``N`` robots: each robot's first node held where it starts (plus its stage's
    insertion) and first element's directors held as they start.

    Parameters
    ----------
    advancers : sequence of Advancer or None, ``N``
        Each robot's insertion stage (``None``: a plain clamp); their commands are read by
        :meth:`gather` before each batch of steps (they change only between steps).
    """

    def __init__(self, advancers: Sequence[Advancer | None]) -> None:
        self.advancers = list(advancers)
        n = len(self.advancers)
        self.advanced = np.array([a is not None for a in self.advancers], dtype=np.bool_)
        self.axes = np.zeros((3, n))
        for i, advancer in enumerate(self.advancers):
            if advancer is not None:
                self.axes[:, i] = advancer.axis
        self.stages = np.zeros((n, 4))
        self.start = np.zeros((3, n))
        self.directors = np.zeros((3, 3, n))
        self.node_start = np.zeros(n, dtype=np.int64)
        self.elem_start = np.zeros(n, dtype=np.int64)
        self.located = False

    def locate(self, block: Any, node_start: NDArray[np.int64], elem_start: NDArray[np.int64]) -> None:
        """Take each robot's held node and element where they are now in ``block`` (as a per-rod
        constraint copies them when the simulator is finalized), at the block indices given."""
        self.node_start, self.elem_start = np.asarray(node_start), np.asarray(elem_start)
        self.start[...] = block.position_collection[:, self.node_start]
        self.directors[...] = block.director_collection[:, :, self.elem_start]
        self.located = True

    def gather(self) -> None:
        """Read every stage's current command (call between steps, after the stages' ``apply``)."""
        for i, advancer in enumerate(self.advancers):
            if advancer is not None:
                self.stages[i] = advancer.motion()

    def constrain_values(self, block: Any, times: NDArray[np.float64]) -> None:
        """Hold the bases' positions and directors, each robot at its own time ``times[i]`` (s)."""
        clamp_values(block.position_collection, block.director_collection, self.node_start, self.elem_start,
                     self.start, self.directors, self.axes, self.stages, self.advanced, times)

    def constrain_rates(self, block: Any, times: NDArray[np.float64]) -> None:
        """Hold the bases' rates, each robot at its own time ``times[i]`` (s)."""
        clamp_rates(block.velocity_collection, block.omega_collection, self.node_start, self.elem_start,
                    self.axes, self.stages, self.advanced, times)
