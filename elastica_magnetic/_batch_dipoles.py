"""Point dipoles in :class:`~elastica_magnetic.BatchedRobots` (private): the robots whose source is a
:class:`~elastica_magnetic.PointDipoleField` with a constant moment and position, or paths of
:class:`~elastica_magnetic.Waypoints`, are driven by one numba kernel
(:func:`~elastica_magnetic._robot_forcing_kernels.dipole_paths_forcing`), not by a Python call per robot
and time step: the same operations in the same order as :class:`~elastica_magnetic.MagneticTorques`,
so bit for bit the per-rod simulation. A dipole whose moment or position is another callable goes
through the general path.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from . import _robot_forcing_kernels as kernels
from .forcing import FieldValueError
from .spatial_fields import PointDipoleField, Waypoints


def _path(vector: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """The times (P,) s and values (P, 3) of a dipole's moment or position (a constant: one
    point), or ``None`` for a callable the kernel cannot follow."""
    if vector.constant is not None:
        return np.zeros(1), np.asarray(vector.constant, dtype=np.float64).reshape(1, 3)
    if type(vector.function) is Waypoints:
        return np.asarray(vector.function.times, dtype=np.float64), vector.function.values
    return None


def dipole_paths(source: Any) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]] | None:
    """The moment's and the position's paths of ``source`` if the batched kernel can drive it (the
    package's own :class:`~elastica_magnetic.PointDipoleField` with constant or waypoint vectors),
    else ``None``."""
    if type(source) is not PointDipoleField:  # a subclass may compute its field otherwise
        return None
    paths = [_path(source.moment), _path(source.position)]
    return None if any(p is None for p in paths) else paths  # type: ignore[return-value]


class BatchedDipoles:
    """The robots of a batch driven by their own point dipole (``sources``: robot -> source), in
    one kernel call per time step."""

    def __init__(self, n_elements: int) -> None:
        self.n_elements = n_elements
        self.sources: dict[int, PointDipoleField] = {}
        self._paths: dict[int, list[tuple[NDArray[np.float64], NDArray[np.float64]]]] = {}
        self._scratch = (np.empty((3, n_elements)), np.empty((3, n_elements)),
                         np.empty((3, 3, n_elements)), np.empty(3), np.empty(3))
        self._pack()

    def add(self, robot: int, source: PointDipoleField,
            paths: list[tuple[NDArray[np.float64], NDArray[np.float64]]]) -> None:
        self.sources[robot], self._paths[robot] = source, paths
        self._pack()

    def remove(self, robot: int) -> None:
        if self.sources.pop(robot, None) is not None:
            del self._paths[robot]
            self._pack()

    def _pack(self) -> None:
        """The robots in order and their paths in flat arrays (moment, then position, per robot)."""
        robots = sorted(self.sources)
        paths = [path for i in robots for path in self._paths[i]]
        start = np.zeros(len(paths) + 1, dtype=np.int64)
        start[1:] = np.cumsum([times.shape[0] for times, _ in paths])
        self._robots = np.array(robots, dtype=np.int64)
        self._start = start
        self._times = np.concatenate([t for t, _ in paths]) if paths else np.zeros(0)
        values = np.concatenate([v for _, v in paths]) if paths else np.zeros((0, 3))
        self._values = np.ascontiguousarray(values)

    def apply(self, times: NDArray[np.float64], moments, node_start, elem_start, elem_end, block) -> None:
        """Add every dipole's force and torque; ``times`` (N,) s: every robot's own time."""
        centres, b, g, moment, position = self._scratch
        robots = self._robots
        bad = kernels.dipole_paths_forcing(
            robots, np.ascontiguousarray(times[robots]), self._start, self._times, self._values, moments,
            node_start, elem_start, elem_end, block.position_collection, block.director_collection,
            block.external_forces, block.external_torques, centres, b, g, moment, position)
        if bad >= 0:
            k, element = divmod(bad, self.n_elements)
            raise FieldValueError(
                f"robot {int(robots[k])}: its source (PointDipoleField) gave a non-finite B (T) or gradient "
                f"(T/m) at element {element} at t = {float(times[robots[k]]):.6g} s (the dipole on the rod?)")
