"""Hand-designed steering of a clamped magnetic catheter's tip by a magnet on an arm: the baseline
a learned controller has to beat.

:class:`MagnetBearingSteering` turns the field at the tip until the tip's bearing from the clamped
base is the target's. The magnet is kept at ``distance`` from the tip along a direction ``f``, its
moment along ``f``: on a dipole's axis the field is parallel to its moment (``2 mu0 m / (4 pi R^3)``),
so the field at the tip points along ``f``, and the tip's magnetization bends the catheter toward
it (the gradient pulls the same way). ``f`` starts along the catheter and turns, at each command,
by ``gain`` times the bearing error (the difference of the unit directions from the base to the
target and to the tip, across ``f``) times the control step: an integral action, so the tip
settles on the target's bearing. Moving the magnet only around the tip (never across the catheter)
keeps the field there bounded.

What it cannot do: a field at one point bends the catheter along one family of shapes, so the
distance of the tip from the base is not controlled; a target off that family is approached to its
nearest point (the catheter's tip is 4 mm from a target 45 mm from the base of a 50 mm catheter,
at the target's bearing).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .actuation import CoilCurrents, MagnetPose
from .spatial_fields import SpatialFieldError, _frame, _vector3

__all__ = ["CoilFieldSteering", "MagnetBearingSteering"]


def _unit(v: NDArray[np.float64]) -> NDArray[np.float64]:
    norm = float(np.linalg.norm(v))
    return v / norm if norm > 0.0 else v


def _turned_toward(f: NDArray[np.float64], base: NDArray[np.float64], tip_bearing: NDArray[np.float64],
                   target: NDArray[np.float64], step: float) -> NDArray[np.float64]:
    """The field direction ``f`` turned by ``step`` (gain x control step) times the bearing error
    (the unit direction from ``base`` to ``target`` minus the tip's, across ``f``)."""
    error = _unit(target - base) - tip_bearing
    error = error - (error @ f) * f
    return _unit(f + step * error)


class _BearingLaw:
    """The bearing law both steering laws share: the field direction at the tip, starting along
    the catheter each episode and turned toward the target's bearing from ``base`` (m) at
    ``gain`` (1/s) per unit of bearing error."""

    base: NDArray[np.float64]
    gain: float
    field_direction: NDArray[np.float64] | None

    def reset(self) -> None:
        """Forget the field direction (a new episode: it starts again along the catheter)."""
        self.field_direction = None

    def _next_direction(self, tip: ArrayLike, target: ArrayLike,
                        dt: float) -> tuple[NDArray[np.float64], ...]:
        """The tip and target (m, (3,) arrays) and the field direction after a control step of
        ``dt`` s (kept as :attr:`field_direction`)."""
        tip, target = np.asarray(tip, dtype=np.float64), np.asarray(target, dtype=np.float64)
        tip_bearing = _unit(tip - self.base)
        if self.field_direction is None:
            self.field_direction = tip_bearing.copy()
        self.field_direction = _turned_toward(self.field_direction, self.base, tip_bearing, target,
                                              self.gain * dt)
        return tip, target, self.field_direction


class MagnetBearingSteering(_BearingLaw):
    """Steer a clamped catheter's tip toward a target with a
    :class:`~elastica_magnetic.actuation.MagnetPose`.

    Parameters
    ----------
    magnet : MagnetPose
        The arm and its magnet (its speed and turn-rate limits bound every command).
    base : array_like (3,)
        m, the clamped end of the catheter.
    distance : float
        m, how far from the tip the magnet is kept (the field scales as ``moment / distance^3``: a
        1 A m^2 magnet at 40 mm gives ~3 mT).
    gain : float
        1/s, how fast the field's direction turns per unit of bearing error.
    position_gain : float
        1/s: the commanded velocity is ``position_gain`` times the magnet's distance to its goal
        (before the speed limit).
    turn_gain : float
        rad: within this angle of ``f`` the moment's turn rate falls linearly to zero.
    """

    def __init__(self, magnet: MagnetPose, base: ArrayLike, distance: float, gain: float = 5.0,
                 position_gain: float = 10.0, turn_gain: float = 0.2) -> None:
        for name, value, unit in (("distance", distance, "m"), ("gain", gain, "1/s"),
                                  ("position_gain", position_gain, "1/s"), ("turn_gain", turn_gain, "rad")):
            if not (math.isfinite(value) and value > 0.0):
                raise SpatialFieldError(f"{name} must be a positive number of {unit}, got {value!r}")
        self.magnet = magnet
        self.base = _vector3(base, "base", "m")
        self.distance, self.gain = float(distance), float(gain)
        self.position_gain, self.turn_gain = float(position_gain), float(turn_gain)
        self.field_direction: NDArray[np.float64] | None = None

    def action(self, tip: ArrayLike, target: ArrayLike, time: float, dt: float) -> NDArray[np.float64]:
        """The command (5,) in [-1, 1] at ``time`` (s) for the control step ``dt`` (s), the tip at
        ``tip`` and the target at ``target`` (m, (3,) each)."""
        tip, target, f = self._next_direction(tip, target, dt)
        goal = tip + self.distance * f
        action = np.zeros(5)
        velocity = self.position_gain * (goal - self.magnet.position_at(time)) / self.magnet.max_speed
        speed = float(np.linalg.norm(velocity))
        action[:3] = velocity / speed if speed > 1.0 else velocity
        d = self.magnet.direction_at(time)
        angle = math.acos(min(max(float(d @ f), -1.0), 1.0))
        if angle > 0.0:
            axis = np.cross(d, f)
            norm = float(np.linalg.norm(axis))
            frame = _frame(d)
            axis = axis / norm if norm > 0.0 else frame[:, 0]  # opposite: about any cross axis
            rate = min(angle / self.turn_gain, 1.0)
            action[3] = rate * float(axis @ frame[:, 0])
            action[4] = rate * float(axis @ frame[:, 1])
        return action


class CoilFieldSteering(_BearingLaw):
    """Steer a clamped catheter's tip toward a target with fixed coils
    (:class:`~elastica_magnetic.actuation.CoilCurrents`): the bearing law of
    :class:`MagnetBearingSteering` chooses the field direction ``f`` at the tip, and the currents
    are the least-norm solution of ``A I = field f`` (``A`` the coils' field per ampere at the tip,
    :meth:`~elastica_magnetic.actuation.CoilCurrents.field_matrix`), scaled down together where one
    would pass its limit (the direction kept, the magnitude lowered).

    Parameters
    ----------
    coils : CoilCurrents
        The coils and their limits.
    base : array_like (3,)
        m, the clamped end of the catheter.
    field : float
        T, the field asked at the tip.
    gain : float
        1/s, how fast the field's direction turns per unit of bearing error. Slower than the
        magnet's default, as measured on the shipped coil case (training physics, 3 s): at 5/s
        the tip swings through its targets and ends 1-9 mm from them (0 of 20 within 1 mm); at
        2/s it settles (20 of 20).
    """

    def __init__(self, coils: CoilCurrents, base: ArrayLike, field: float, gain: float = 2.0) -> None:
        for name, value, unit in (("field", field, "T"), ("gain", gain, "1/s")):
            if not (math.isfinite(value) and value > 0.0):
                raise SpatialFieldError(f"{name} must be a positive number of {unit}, got {value!r}")
        self.coils = coils
        self.base = _vector3(base, "base", "m")
        self.field, self.gain = float(field), float(gain)
        self.field_direction: NDArray[np.float64] | None = None

    def action(self, tip: ArrayLike, target: ArrayLike, time: float, dt: float) -> NDArray[np.float64]:
        """The command (N,) in [-1, 1] (currents over their limits) at ``time`` (s) for the
        control step ``dt`` (s), the tip at ``tip`` and the target at ``target`` (m, (3,) each)."""
        tip, target, f = self._next_direction(tip, target, dt)
        currents = np.linalg.lstsq(self.coils.field_matrix(tip, time), self.field * f, rcond=None)[0]
        fraction = currents / self.coils.current_limit
        largest = float(np.abs(fraction).max())
        return fraction / largest if largest > 1.0 else fraction
