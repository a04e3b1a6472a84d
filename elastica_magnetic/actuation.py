"""Actuation by a source that moves or whose currents change: what a controller (a policy, a
steering law) commands when the field is not uniform.

Two actuators, each with a fixed-size action in ``[-1, 1]`` per component (what a policy outputs)
applied at a control step, a field source that follows it (give :attr:`source` to
:class:`~elastica_magnetic.MagneticTorques` as its ``field``), and the state a controller observes:

- :class:`MagnetPose`: a permanent magnet (a point dipole) carried by a robot arm inside a
  workspace box: the action is its linear velocity (3 components, up to ``max_speed`` m/s) and its
  turn rate about the two directions across its moment (2 components, up to ``max_turn_rate``
  rad/s). State: position (m) and moment direction.
- :class:`CoilCurrents`: ``N`` fixed coils (any sources, each the field of its coil at 1 A), the
  action the currents as fractions of ``current_limit`` (A), reached no faster than ``max_slew``
  (A/s) when given. State: the currents (A). The field is the sum of each coil's at its current
  (superposition: the coils carry no iron that saturates).

A command made at time ``t0`` for a control step ``dt`` is followed continuously over
``[t0, t0 + dt]`` (the arm moves at constant velocity and turns at a constant rate; the currents ramp
linearly), so the rod's many time steps between control steps see a smooth motion, not a jump.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import _spatial_kernels as kernels
from ._spatial_kernels import (
    M_DIRECTION,
    M_MOMENT,
    M_POSITION,
    M_SPAN,
    M_T0,
    M_TURN_AXIS,
    M_TURN_RATE,
    M_VELOCITY,
)
from .field_maps import FieldMapDomainError
from .magnet_fields import MagnetMap
from .spatial_fields import SpatialField, SpatialFieldError, _frame, _vector3

__all__ = ["CoilCurrents", "MagnetPose", "MovedDipoleField", "MovedMapField"]


def _action(action: ArrayLike, size: int, who: str) -> NDArray[np.float64]:
    array = np.asarray(action, dtype=np.float64).reshape(-1)
    if array.shape != (size,):
        raise SpatialFieldError(f"{who}: expected an action of {size} components in [-1, 1], "
                                f"got shape {np.shape(action)}")
    if not np.all(np.isfinite(array)):
        raise SpatialFieldError(f"{who}: the action must be finite, got {array.tolist()}")
    return np.clip(array, -1.0, 1.0)


def _positive(value: float, name: str, unit: str) -> float:
    number = float(value)
    if not (math.isfinite(number) and number > 0.0):
        raise SpatialFieldError(f"{name} must be a positive number of {unit}, got {value!r}")
    return number


class MagnetPose:
    """A permanent magnet of moment ``moment`` (A m^2, its magnitude) moved by an arm.

    Parameters
    ----------
    moment : float
        A m^2, the magnet's dipole moment (a 1 A m^2 magnet is a ~10 mm NdFeB cube).
    position : array_like (3,)
        m, the start position, inside ``workspace``.
    direction : array_like (3,)
        The start direction of the moment (normalized here).
    workspace : array_like (2, 3)
        m, ``[[xmin, ymin, zmin], [xmax, ymax, zmax]]``: the box the magnet's centre stays in.
    max_speed : float
        m/s, the largest speed of the magnet's centre (an action of norm 1 or more).
    max_turn_rate : float
        rad/s, the largest rate at which the moment turns.
    field_map : MagnetMap, optional
        The field of a finite magnet in its own frame (:func:`~elastica_magnetic.magnet_map`),
        moved and turned with the arm and scaled by ``moment`` over the map's own moment; default
        ``None``: a point dipole of ``moment``. The map's roll about the moment follows the
        shortest turn of +z onto it (exact for a magnet symmetric about its moment, as an axially
        magnetized cylinder).
    """

    #: Components of the action: velocity along x, y, z, turn rate about the two directions
    #: across the moment (the first two columns of its frame).
    action_size = 5

    def __init__(self, moment: float, position: ArrayLike, direction: ArrayLike, workspace: ArrayLike,
                 max_speed: float, max_turn_rate: float, field_map: MagnetMap | None = None) -> None:
        self.moment = _positive(moment, "moment", "A m^2")
        self.max_speed = _positive(max_speed, "max_speed", "m/s")
        self.max_turn_rate = _positive(max_turn_rate, "max_turn_rate", "rad/s")
        box = np.asarray(workspace, dtype=np.float64)
        if box.shape != (2, 3) or not np.all(np.isfinite(box)) or np.any(box[1] <= box[0]):
            raise SpatialFieldError(f"workspace must be [[xmin, ymin, zmin], [xmax, ymax, zmax]] (m) "
                                    f"with each min below its max, got {np.asarray(workspace).tolist()}")
        self.workspace = box
        start = _vector3(position, "position", "m")
        if np.any(start < box[0]) or np.any(start > box[1]):
            raise SpatialFieldError(f"position {start.tolist()} m lies outside the workspace "
                                    f"{box.tolist()} m")
        axis = _vector3(direction, "direction", "a direction")
        if not np.any(axis):
            raise SpatialFieldError("direction must be a non-zero direction")
        self._start = (start.copy(), axis / np.linalg.norm(axis))
        #: The motion over the current control step (layout: ``_spatial_kernels.M_*``); the batched
        #: simulator's kernel reads it as this class does.
        self.motion = np.zeros(kernels.MOTION_SIZE)
        self.reset()
        self.field_map = field_map
        self.source: SpatialField = (MovedDipoleField(self) if field_map is None
                                     else MovedMapField(self, field_map))

    def reset(self) -> None:
        """Back to the start pose, at rest."""
        motion = self.motion
        motion[:] = 0.0
        motion[M_POSITION:M_POSITION + 3] = self._start[0]
        motion[M_DIRECTION:M_DIRECTION + 3] = self._start[1]
        motion[M_TURN_AXIS + 2] = 1.0
        motion[M_MOMENT] = self.moment

    def apply(self, action: ArrayLike, time: float, dt: float) -> None:
        """Command the arm at ``time`` (s) for the control step ``dt`` (s): the pose moves from where
        it is at ``time`` at the commanded velocity and turn rate, the centre stopping at the
        workspace's walls."""
        a = _action(action, self.action_size, "MagnetPose")
        dt = _positive(dt, "dt", "s")
        p, d = self.position_at(time), self.direction_at(time)
        velocity = a[:3] * self.max_speed
        speed = np.linalg.norm(velocity)
        if speed > self.max_speed:
            velocity *= self.max_speed / speed
        target = np.clip(p + velocity * dt, self.workspace[0], self.workspace[1])
        frame = _frame(d)
        omega = self.max_turn_rate * (a[3] * frame[:, 0] + a[4] * frame[:, 1])
        rate = float(np.linalg.norm(omega))
        if rate > self.max_turn_rate:
            omega *= self.max_turn_rate / rate
            rate = self.max_turn_rate
        motion = self.motion
        motion[M_POSITION:M_POSITION + 3] = p
        motion[M_DIRECTION:M_DIRECTION + 3] = d
        motion[M_VELOCITY:M_VELOCITY + 3] = (target - p) / dt
        motion[M_TURN_AXIS:M_TURN_AXIS + 3] = omega / rate if rate > 0.0 else (0.0, 0.0, 1.0)
        motion[M_TURN_RATE], motion[M_T0], motion[M_SPAN] = rate, float(time), dt

    def follow(self, position: ArrayLike, direction: ArrayLike, time: float, dt: float) -> None:
        """Move from the pose at ``time`` (s) to ``position`` (m, ``(3,)``) and ``direction``
        (``(3,)``, normalized here) over ``dt`` (s), as :meth:`apply` moves (constant velocity, a
        constant turn rate about one axis), with neither the speed limits nor the workspace
        applied: a pose the arm reported is replayed as it happened (``msr real identify``)."""
        dt = _positive(dt, "dt", "s")
        end = _vector3(position, "position", "m")
        axis = _vector3(direction, "direction", "a direction")
        norm = float(np.linalg.norm(axis))
        if not norm > 0.0:
            raise SpatialFieldError("direction must be a non-zero direction")
        axis = axis / norm
        p, d = self.position_at(time), self.direction_at(time)
        across = np.cross(d, axis)
        angle = math.atan2(float(np.linalg.norm(across)), float(d @ axis))
        motion = self.motion
        motion[M_POSITION:M_POSITION + 3] = p
        motion[M_DIRECTION:M_DIRECTION + 3] = d
        motion[M_VELOCITY:M_VELOCITY + 3] = (end - p) / dt
        turn_axis = across / np.linalg.norm(across) if angle > 0.0 else (0.0, 0.0, 1.0)
        motion[M_TURN_AXIS:M_TURN_AXIS + 3] = turn_axis
        motion[M_TURN_RATE], motion[M_T0], motion[M_SPAN] = angle / dt, float(time), dt

    def _pose(self, time: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        position, direction = np.empty(3), np.empty(3)
        kernels.magnet_pose_at(self.motion, float(time), position, direction)
        return position, direction

    def position_at(self, time: float) -> NDArray[np.float64]:
        """m, (3,): the magnet's centre at ``time`` (s)."""
        return self._pose(time)[0]

    def direction_at(self, time: float) -> NDArray[np.float64]:
        """(3,), unit: the moment's direction at ``time`` (s)."""
        return self._pose(time)[1]

    def moment_at(self, time: float) -> NDArray[np.float64]:
        """A m^2, (3,): the moment vector at ``time`` (s)."""
        return self.moment * self.direction_at(time)

    def state(self, time: float) -> NDArray[np.float64]:
        """(6,): position (m) and moment direction at ``time`` (s), what a controller observes."""
        return np.concatenate(self._pose(time))


class MovedDipoleField(SpatialField):
    """The field of a :class:`MagnetPose`'s magnet, a point dipole at the arm's pose at each time
    (:attr:`MagnetPose.source`). A robot of :class:`~elastica_magnetic.BatchedRobots` given one
    is driven by a kernel that reads the arm's :attr:`MagnetPose.motion` (no Python call per time
    step)."""

    def __init__(self, magnet: MagnetPose) -> None:
        self.magnet = magnet

    def _add(self, points, time, b, g, with_gradient) -> None:
        kernels.moved_dipole_field(self.magnet.motion, float(time), points, b, g, with_gradient)


class MovedMapField(SpatialField):
    """The field of a :class:`MagnetPose`'s finite magnet, its map in the magnet's frame
    (:class:`~elastica_magnetic.MagnetMap`) at the arm's pose at each time. A robot of
    :class:`~elastica_magnetic.BatchedRobots` given one is driven by a kernel that reads the arm's
    :attr:`MagnetPose.motion` (no Python call per time step)."""

    def __init__(self, magnet: MagnetPose, field_map: MagnetMap) -> None:
        self.magnet = magnet
        self.map = field_map

    def _add(self, points, time, b, g, with_gradient) -> None:
        grid = self.map.field_map
        outside = kernels.moved_map_field(self.magnet.motion, float(time), grid.origin, grid.spacing,
                                          grid.shape, grid.samples, grid.gradients, self.map.moment, points,
                                          b, g, with_gradient)
        if outside >= 0:
            raise FieldMapDomainError(
                f"{grid.source}: point {points[:, outside].tolist()} m (column {outside}) at "
                f"t = {time:.6g} s is outside the magnet's map (the magnet at "
                f"{self.magnet.position_at(time).tolist()} m)")


class CoilCurrents:
    """``N`` fixed coils whose currents a controller sets.

    Parameters
    ----------
    coils : sequence of spatial sources
        Each the field of one coil carrying 1 A (T per A; e.g. a
        :class:`~elastica_magnetic.CurrentLoopField` with ``current=1.0``, or a field map of the coil
        at 1 A).
    current_limit : float or array_like (N,)
        A, the largest absolute current of each coil (an action of +-1).
    max_slew : float, optional
        A/s, the fastest change of a current (the drivers' and the coils' inductance limit);
        ``None``: a current reaches its command within the control step.
    """

    def __init__(self, coils: Sequence[SpatialField], current_limit: float | ArrayLike,
                 max_slew: float | None = None) -> None:
        coils = list(coils)
        if not coils:
            raise SpatialFieldError("CoilCurrents needs at least one coil")
        for k, coil in enumerate(coils):
            if not isinstance(coil, SpatialField):
                raise SpatialFieldError(f"coil {k} is not a spatial field source: {coil!r}")
        self.coils = coils
        limits = np.broadcast_to(np.asarray(current_limit, dtype=np.float64), (len(coils),)).copy()
        if not np.all(np.isfinite(limits)) or np.any(limits <= 0.0):
            raise SpatialFieldError(f"current_limit must be positive (A), got {limits.tolist()}")
        self.current_limit = limits
        self.max_slew = None if max_slew is None else _positive(max_slew, "max_slew", "A/s")
        self.action_size = len(coils)
        self.reset()
        self.source: SpatialField = _CoilSum(self)

    def reset(self) -> None:
        """All currents back to zero."""
        self._i0 = np.zeros(self.action_size)
        self._i1 = np.zeros(self.action_size)
        self._t0, self._dt = 0.0, 0.0

    def apply(self, action: ArrayLike, time: float, dt: float) -> None:
        """Command the currents ``action * current_limit`` at ``time`` (s) for the control step
        ``dt`` (s): each ramps from its value at ``time``, at most ``max_slew * dt`` away."""
        a = _action(action, self.action_size, "CoilCurrents")
        dt = _positive(dt, "dt", "s")
        now = self.currents_at(time)
        target = a * self.current_limit
        if self.max_slew is not None:
            step = self.max_slew * dt
            target = np.clip(target, now - step, now + step)
        self._i0, self._i1 = now, target
        self._t0, self._dt = float(time), dt

    def currents_at(self, time: float) -> NDArray[np.float64]:
        """A, (N,): the coils' currents at ``time`` (s)."""
        if self._dt == 0.0:
            return self._i1.copy()
        f = min(max((float(time) - self._t0) / self._dt, 0.0), 1.0)
        return self._i0 + (self._i1 - self._i0) * f

    def state(self, time: float) -> NDArray[np.float64]:
        """(N,): the currents as fractions of their limits at ``time`` (s)."""
        return self.currents_at(time) / self.current_limit

    def motion(self) -> NDArray[np.float64]:
        """The commanded ramp ``[t0, dt, i0..., i1...]`` (s, s, A, A): everything that decides the
        currents from now on (:meth:`set_motion` restores it)."""
        return np.concatenate([[self._t0, self._dt], self._i0, self._i1])

    def set_motion(self, motion: ArrayLike) -> None:
        """Restore a :meth:`motion` row."""
        row = np.asarray(motion, dtype=np.float64).reshape(-1)
        if row.shape != (2 + 2 * self.action_size,):
            raise SpatialFieldError(f"CoilCurrents: a motion row of {2 + 2 * self.action_size} numbers "
                                    f"expected, got shape {row.shape}")
        self._t0, self._dt = float(row[0]), float(row[1])
        self._i0, self._i1 = row[2:2 + self.action_size].copy(), row[2 + self.action_size:].copy()

    def field_matrix(self, point: ArrayLike, time: float = 0.0) -> NDArray[np.float64]:
        """``(3, N)`` T/A: the field each coil makes at ``point`` ``(3,)`` (m) per ampere, so that
        the field there is ``field_matrix(point) @ currents`` (superposition)."""
        column = np.asarray(point, dtype=np.float64).reshape(3, 1)
        return np.column_stack([coil.at(column, time)[:, 0] for coil in self.coils])


class _CoilSum(SpatialField):
    """The field of :class:`CoilCurrents`: each coil's unit field times its current."""

    def __init__(self, coils: CoilCurrents) -> None:
        self.owner = coils
        self._unit_b, self._unit_g = np.empty((3, 0)), np.empty((3, 3, 0))

    def _add(self, points, time, b, g, with_gradient) -> None:
        currents = self.owner.currents_at(time)
        n = points.shape[1]
        if self._unit_b.shape[1] != n:  # called every time step: buffers reused, not allocated
            self._unit_b, self._unit_g = np.empty((3, n)), np.empty((3, 3, n))
        unit_b, unit_g = self._unit_b, self._unit_g
        for coil, current in zip(self.owner.coils, currents, strict=True):
            if current == 0.0:
                continue
            unit_b.fill(0.0)
            unit_g.fill(0.0)
            coil._add(points, time, unit_b, unit_g, with_gradient)
            b += current * unit_b
            if with_gradient:
                g += current * unit_g
