"""The sources in space of :class:`~elastica_magnetic.batch.BatchedRobots`, one per robot at most,
each driven the cheapest way its kind allows: arm-moved magnets all in one kernel call (point
dipoles), or one per magnet map (finite magnets, :class:`~elastica_magnetic.MagnetMap`), field maps
fixed in the lab one kernel call per map, fixed coil
sets one kernel call per coil geometry (:mod:`~elastica_magnetic._batch_coils`), point dipoles on
their paths one kernel call (:mod:`~elastica_magnetic._batch_dipoles`), any other source its own
:class:`~elastica_magnetic.MagneticTorques` called per robot and time step. Every kind adds the
same force and torque as the per-rod simulation of its robot, bit for bit, on the robot's own
clock (a robot reset since the block started runs behind it)."""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from . import _robot_forcing_kernels as forcing_kernels
from ._batch_coils import BatchedCoils, loop_geometry
from ._batch_dipoles import BatchedDipoles, dipole_paths
from ._batch_kernels import robot_times
from ._spatial_kernels import MOTION_SIZE
from .actuation import MovedDipoleField, MovedMapField
from .field_maps import FieldMap, FieldMapDomainError
from .forcing import FieldValueError, MagneticTorques
from .spatial_fields import is_spatial, rotation_to

__all__ = ["BatchedSources"]


class BatchedSources:
    """Each robot's source in space of the batch ``owner`` (a
    :class:`~elastica_magnetic.batch.BatchedRobots`), by kind (see the module docstring)."""

    def __init__(self, owner: Any) -> None:
        self.owner = owner
        n_elements = owner.spec.n_elements
        self.general: dict[int, MagneticTorques] = {}  # robot -> the forcing of its source
        self.moved: dict[int, MovedDipoleField] = {}  # robot -> its arm's magnet (one kernel for all)
        self.mapped: dict[int, MovedMapField] = {}  # robot -> its arm's finite magnet (a kernel per map)
        self.maps: dict[int, FieldMap] = {}  # robot -> its field map fixed in the lab (a kernel per map)
        self.coils = BatchedCoils(n_elements)  # robots under fixed coils (one kernel per coil set)
        self.dipoles = BatchedDipoles(n_elements)  # robots under their own point dipole (one kernel)
        self._moved_rows = (np.zeros((0, MOTION_SIZE)), np.zeros(0, dtype=np.int64),
                            np.zeros(0, dtype=np.int64))
        self._moved_scratch = (np.empty((3, n_elements)), np.empty((3, n_elements)),
                               np.empty((3, 3, n_elements)))
        self._map_scratch = (np.empty((3, 3)), np.empty((3, n_elements)), np.empty((3, n_elements)),
                             np.empty((3, 3, n_elements)))
        self._mapped_rows: list[tuple[MovedMapField, Any, Any, Any]] = []

    def __bool__(self) -> bool:
        return bool(self.general or self.moved or self.mapped or self.maps or self.coils.sources
                    or self.dipoles.sources)

    @property
    def sources(self) -> list[Any]:
        """Each robot's spatial source (``None``: its uniform row alone)."""
        coils, dipoles = self.coils.sources, self.dipoles.sources
        return [self.moved[i] if i in self.moved else self.mapped[i] if i in self.mapped else
                self.maps[i] if i in self.maps else coils[i] if i in coils else
                dipoles[i] if i in dipoles else self.general[i].field if i in self.general else None
                for i in range(self.owner.n_robots)]

    def remove(self, i: int) -> None:
        """Robot ``i`` by its uniform row alone."""
        self.general.pop(i, None)
        self.moved.pop(i, None)
        self.mapped.pop(i, None)
        self.maps.pop(i, None)
        self.coils.remove(i)
        self.dipoles.remove(i)

    def set(self, i: int, source: Any) -> None:
        """Drive robot ``i`` by ``source`` (``None``: by its uniform row alone), checked: a source
        varying in space, a spec in SI."""
        owner = self.owner
        if not 0 <= i < owner.n_robots:
            raise IndexError(f"robot index {i} out of range for {owner.n_robots} robots")
        if source is None:
            self.remove(i)
            return
        if not is_spatial(source):
            raise TypeError(f"robot {i}: a source must vary in space (at(points, time), "
                            f"gradient(points, time)); got {type(source).__name__} (a uniform "
                            "field goes in the robot's row of fields)")
        if owner.spec.units.factor("length") != 1.0:
            raise ValueError(f"a spatial field source works in SI (m, T); the spec is in "
                             f"{owner.spec.units.name}: build it in SI")
        self.remove(i)
        geometry, paths = loop_geometry(source), dipole_paths(source)
        if isinstance(source, MovedDipoleField):
            self.moved[i] = source
        elif type(source) is MovedMapField:
            self.mapped[i] = source
        elif type(source) is FieldMap and source.fixed:  # a subclass may compute its field otherwise
            self.maps[i] = source
        elif geometry is not None:
            self.coils.add(i, source, geometry)
        elif paths is not None:
            self.dipoles.add(i, source, paths)
        else:
            self.general[i] = self.forcing_of(i, source)

    def forcing_of(self, i: int, source: Any) -> MagneticTorques:
        """The forcing of ``source`` on robot ``i``: its magnetization taken into the material
        frame of the robot's initial configuration (as a fresh simulation's first call does,
        wherever the robot is now)."""
        owner = self.owner
        initial = np.einsum("ijk,jk->ik", owner._initial_state[i]["director_collection"],
                            np.asarray(owner.specs[i].magnetization, dtype=np.float64))
        return MagneticTorques(source, initial, frame="material")

    def respecified(self, i: int) -> None:
        """Robot ``i`` has a new spec: a general source now acts on its new magnetization."""
        if i in self.general:
            self.general[i] = self.forcing_of(i, self.general[i].field)

    def gather(self, behind: Any) -> None:
        """Before a run of steps: each arm's motion over the coming steps (set by its ``apply``
        between steps) and the coil sets' currents, with how many steps each robot is ``behind``
        the block's clock (an int array ``(n_robots,)``)."""
        if self.moved:
            robots = np.fromiter(self.moved, dtype=np.int64, count=len(self.moved))
            motions = np.array([self.moved[int(i)].magnet.motion for i in robots]).reshape(-1, MOTION_SIZE)
            self._moved_rows = (motions, robots, behind[robots])
        if self.mapped:
            groups: dict[int, list[int]] = {}  # one kernel call per map (robots may share one)
            for i, source in self.mapped.items():
                groups.setdefault(id(source.map), []).append(i)
            self._mapped_rows = []
            for members in groups.values():
                robots = np.array(members, dtype=np.int64)
                motions = np.array([self.mapped[i].magnet.motion for i in members]).reshape(-1, MOTION_SIZE)
                self._mapped_rows.append((self.mapped[members[0]], motions, robots, behind[robots]))
        if self.coils.sources:
            self.coils.gather(behind)

    def apply(self, time: float) -> None:
        """Every source's force and torque (N, N m) on its robot at the block's forcing ``time``
        (s), each robot at its own time."""
        owner = self.owner
        if self.moved:
            self._apply_moved_magnets(time)
        if self.mapped:
            self._apply_mapped_magnets(time)
        if self.maps:
            self._apply_fixed_maps(time)
        if self.dipoles.sources:
            robot_times(time, owner._step_index, owner.spec.dt, owner._behind, owner._times)
            self.dipoles.apply(owner._times, owner._moments, owner._node_start, owner._elem_start,
                               owner._elem_end, owner.block)
        if self.coils.sources:
            self.coils.apply(functools.partial(owner._robot_time, time), owner._moments,
                             owner._node_start, owner._elem_start, owner._elem_end, owner.block)
        for i, forcing in self.general.items():
            robot_time = owner._robot_time(time, owner.step_count - int(owner.robot_step_count[i]))
            rod = owner.rods[i]
            forcing.apply_forces(rod, robot_time)
            forcing.apply_torques(rod, robot_time)

    def _apply_moved_magnets(self, time: float) -> None:
        """The force and torque of every robot's arm-moved magnet, in one kernel call."""
        owner = self.owner
        motions, robots, behind = self._moved_rows
        block = owner.block
        times = owner._robot_time(time, behind)
        bad = forcing_kernels.moved_dipoles_forcing(
            motions, robots, times, owner._moments, owner._node_start,
            owner._elem_start, owner._elem_end, block.position_collection, block.director_collection,
            block.external_forces, block.external_torques, *self._moved_scratch)
        if bad >= 0:
            k, element = divmod(bad, owner.spec.n_elements)
            raise FieldValueError(
                f"robot {int(robots[k])}: its magnet (MagnetPose) gave a non-finite B (T) or gradient "
                f"(T/m) at element {element} at t = {time:.6g} s (the magnet on the rod?)")

    def _apply_mapped_magnets(self, time: float) -> None:
        """The force and torque of every robot's arm-moved finite magnet, one kernel call per map."""
        owner = self.owner
        block = owner.block
        for source, motions, robots, behind in self._mapped_rows:
            grid = source.map.field_map
            times = owner._robot_time(time, behind)
            bad = forcing_kernels.moved_maps_forcing(
                motions, robots, times, grid.origin, grid.spacing, grid.shape, grid.samples, grid.gradients,
                source.map.moment, owner._moments, owner._node_start, owner._elem_start, owner._elem_end,
                block.position_collection, block.director_collection, block.external_forces,
                block.external_torques, *self._moved_scratch, *self._map_scratch)
            if bad >= 0:
                k, element = divmod(bad, owner.spec.n_elements)
                robot = int(robots[k])
                raise FieldMapDomainError(
                    f"robot {robot}: element {element} at t = {time:.6g} s is outside its magnet's map "
                    f"({grid.source}; the magnet at {source.magnet.position_at(float(times[k])).tolist()} m) "
                    "or its field there is not finite")

    def _apply_fixed_maps(self, time: float) -> None:
        """The force and torque of every robot's field map fixed in the lab, one kernel call per map
        (its pose, rotation and scale as :class:`~elastica_magnetic.FieldMap` computes them)."""
        owner = self.owner
        block = owner.block
        groups: dict[int, list[int]] = {}
        for i, field_map in self.maps.items():
            groups.setdefault(id(field_map), []).append(i)
        for members in groups.values():
            grid = self.maps[members[0]]
            robots = np.array(members, dtype=np.int64)
            bad = forcing_kernels.fixed_maps_forcing(
                robots, grid.posed, grid.position(0.0), rotation_to(grid.axis(0.0)), grid.scale(0.0),
                grid.origin, grid.spacing, grid.shape, grid.samples, grid.gradients, owner._moments,
                owner._node_start, owner._elem_start, owner._elem_end, block.position_collection,
                block.director_collection, block.external_forces, block.external_torques,
                *self._moved_scratch[:3], *self._map_scratch[1:])
            if bad >= 0:
                k, element = divmod(bad, owner.spec.n_elements)
                raise FieldMapDomainError(
                    f"robot {int(robots[k])}: element {element} at t = {time:.6g} s is outside its field map "
                    f"({grid.source}) or its field there is not finite")

