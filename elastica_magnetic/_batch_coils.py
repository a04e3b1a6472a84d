"""Coils of circular current loops in :class:`~elastica_magnetic.BatchedRobots` (private): the
robots whose source is a fixed coil set (:class:`~elastica_magnetic.CurrentLoopsField` and its
subclasses, or :class:`~elastica_magnetic.CoilCurrents` of such coils) are driven by one numba
kernel per coil geometry (:func:`~elastica_magnetic._robot_forcing_kernels.coil_loops_forcing`), not by a
Python call per robot and time step: the same operations in the same order as
:class:`~elastica_magnetic.MagneticTorques`, so bit for bit the per-rod simulation.

A coil set qualifies when nothing in it varies but the currents: each loop group's centre and its
own current are constants (a moving coil or a waveform goes through the general path).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from . import _robot_forcing_kernels as kernels
from ._spatial_kernels import R_CURRENTS
from .actuation import CoilCurrents, _CoilSum
from .spatial_fields import CurrentLoopsField, SpatialFieldError


@dataclass(frozen=True)
class LoopGeometry:
    """The loops of ``C`` coils: coil ``c`` is loops ``loop_start[c]:loop_start[c + 1]``;
    ``centres`` (3, L) m, ``frames`` (3, 3, L), ``radii`` (L,) m, ``unit_currents`` (L,) A turns
    at 1 A of the coil's current."""

    loop_start: NDArray[np.int64]
    centres: NDArray[np.float64]
    frames: NDArray[np.float64]
    radii: NDArray[np.float64]
    unit_currents: NDArray[np.float64]

    def same_as(self, other: LoopGeometry) -> bool:
        return all(np.array_equal(getattr(self, name), getattr(other, name))
                   for name in ("loop_start", "centres", "frames", "radii", "unit_currents"))


def _fixed_loops(coil: Any) -> CurrentLoopsField | None:
    """``coil`` if it is a loop group with a constant centre and current, else ``None``."""
    # a subclass of the user's may compute its field otherwise: only the package's own loops
    if not isinstance(coil, CurrentLoopsField) or type(coil)._add is not CurrentLoopsField._add:
        return None
    if coil.centre.constant is None or coil.current.constant is None:
        return None
    return coil


def loop_geometry(source: Any) -> LoopGeometry | None:
    """The loops of ``source`` if the batched kernel can drive it (a fixed loop group, or
    :class:`~elastica_magnetic.CoilCurrents` of fixed loop groups), else ``None``. The centres and
    currents are computed as :class:`~elastica_magnetic.CurrentLoopsField` computes them at each
    call, so the kernel sees the same numbers."""
    if isinstance(source, _CoilSum):
        coils = [_fixed_loops(coil) for coil in source.owner.coils]
    else:
        coils = [_fixed_loops(source)]
    if any(coil is None for coil in coils):
        return None
    centres, frames, radii, currents, start = [], [], [], [], [0]
    for coil in coils:
        centre = coil.centre(0.0)
        centres.append(centre[:, None] + coil.axis[:, None] * coil.offsets[None, :])
        frames.append(coil._frames)
        radii.append(coil.radii)
        currents.append(coil.weights * coil.current(0.0))
        start.append(start[-1] + coil.radii.shape[0])
    return LoopGeometry(np.array(start, dtype=np.int64),
                        np.ascontiguousarray(np.concatenate(centres, axis=1)),
                        np.ascontiguousarray(np.concatenate(frames, axis=2)), np.concatenate(radii),
                        np.concatenate(currents))


def ramp_row(source: Any) -> NDArray[np.float64]:
    """The currents' ramp row of ``source`` (see :data:`~elastica_magnetic._spatial_kernels.R_T0`):
    a coil set's commanded ramp, or a loop group's constant 1 (its current is in its loops)."""
    if isinstance(source, _CoilSum):
        owner: CoilCurrents = source.owner
        return owner.motion()
    return np.array([0.0, 0.0, 1.0, 1.0])


class BatchedCoils:
    """The robots of a batch driven by fixed coils, grouped by coil geometry (one kernel call per
    group and time step)."""

    def __init__(self, n_elements: int) -> None:
        self.n_elements = n_elements
        self.sources: dict[int, Any] = {}  # robot -> its source
        self._groups: list[tuple[LoopGeometry, list[int]]] = []
        self._rows: list[tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]] = []
        n = n_elements
        self._scratch = (np.empty((3, n)), np.empty((3, n)), np.empty((3, 3, n)), np.empty((3, n)),
                         np.empty((3, 3, n)))

    def add(self, robot: int, source: Any, geometry: LoopGeometry) -> None:
        self.remove(robot)
        self.sources[robot] = source
        for known, robots in self._groups:
            if known.same_as(geometry):
                robots.append(robot)
                return
        self._groups.append((geometry, [robot]))

    def remove(self, robot: int) -> None:
        if self.sources.pop(robot, None) is None:
            return
        for _, robots in self._groups:
            if robot in robots:
                robots.remove(robot)
        self._groups = [(g, robots) for g, robots in self._groups if robots]

    def gather(self, behind: NDArray[np.int64]) -> None:
        """Each group's ramp rows (the currents commanded before the coming steps), robots and how
        many steps each is behind the block's clock (``behind``, per robot of the batch)."""
        self._rows = []
        for _, robots in self._groups:
            index = np.array(robots, dtype=np.int64)
            ramps = np.array([ramp_row(self.sources[i]) for i in robots])
            self._rows.append((ramps, index, behind[index]))

    def apply(self, robot_time: Any, moments, node_start, elem_start, elem_end, block) -> None:
        """Add every group's force and torque at the block's forcing time; ``robot_time(behind)``
        gives each robot's own time (s)."""
        points, b, g, unit_b, unit_g = self._scratch
        for (geometry, _), (ramps, robots, behind) in zip(self._groups, self._rows, strict=True):
            currents = np.empty((ramps.shape[1] - R_CURRENTS) // 2)
            times = np.atleast_1d(robot_time(behind)).astype(np.float64)
            try:
                bad = kernels.coil_loops_forcing(
                    ramps, robots, times, geometry.loop_start, geometry.centres, geometry.frames,
                    geometry.radii, geometry.unit_currents, moments, node_start, elem_start, elem_end,
                    block.position_collection, block.director_collection, block.external_forces,
                    block.external_torques, points, b, g, unit_b, unit_g, currents)
            except ZeroDivisionError:
                raise self._on_wire(robots, times, node_start, block) from None
            if bad >= 0:
                k, element = divmod(bad, self.n_elements)
                raise SpatialFieldError(
                    f"robot {int(robots[k])}: its coils gave a non-finite B (T) or gradient (T/m) at "
                    f"element {element} at t = {float(times[k]):.6g} s")

    def _on_wire(self, robots, times, node_start, block) -> SpatialFieldError:
        """The general path's error (naming the loop and the point) for the robot on a wire."""
        n = self.n_elements
        for k, i in enumerate(robots):
            nodes = block.position_collection[:, node_start[i]:node_start[i] + n + 1]
            centres = 0.5 * (nodes[:, 1:] + nodes[:, :-1])
            try:
                self.sources[int(i)].at(centres, float(times[k]))
            except (SpatialFieldError, ZeroDivisionError) as exc:
                return SpatialFieldError(f"robot {int(i)}: {exc}")
        return SpatialFieldError("a robot's element lies on a coil's wire (the field is infinite there)")
