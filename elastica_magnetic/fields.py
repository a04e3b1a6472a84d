"""Uniform magnetic field sources: callables ``field(time) -> (3,)`` in tesla, lab frame.

Any callable with that signature can drive :class:`~elastica_magnetic.MagneticTorques`; these are
the common ones. Each returns a float64 array of shape ``(3,)``.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .field_csv import FIELD_CSV_RATE_HZ, read_field_csv

__all__ = [
    "UniformField",
    "ConstantField",
    "RampedField",
    "RotatingField",
    "TabulatedField",
    "ControlledField",
]


def _vector3(value: ArrayLike, name: str) -> NDArray[np.float64]:
    array = np.asarray(value, dtype=np.float64)
    if array.shape != (3,):
        raise ValueError(f"{name} must be a 3-vector in tesla, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} contains NaN or infinite values: {array}")
    return array


def _per_axis(value: float | ArrayLike, name: str) -> NDArray[np.float64]:
    """``value`` (T) as one positive finite bound per axis ``(3,)``: a number for every axis, or
    three."""
    array = np.asarray(value, dtype=np.float64)
    if array.ndim == 0:
        array = np.full(3, float(array))
    if array.shape != (3,):
        raise ValueError(f"{name} must be a field in tesla or one per axis (3), got shape "
                         f"{array.shape}")
    if not (np.all(array > 0.0) and np.all(np.isfinite(array))):
        raise ValueError(f"{name} must be a positive field in tesla, got {value}")
    return array


class UniformField:
    """Base of the uniform sources: ``field(time) -> (3,)`` (T), the same at every point.

    Besides the call, it offers the methods of the spatial sources
    (:mod:`elastica_magnetic.spatial_fields`): ``at(points, time)`` gives the field broadcast to
    ``(3, n)`` and ``gradient(points, time)`` zeros ``(3, 3, n)``. ``uniform = True`` keeps such a
    source on :class:`~elastica_magnetic.MagneticTorques`'s uniform path (torques only, no force).
    """

    uniform = True

    def __call__(self, time: float) -> NDArray[np.float64]:  # pragma: no cover - abstract
        raise NotImplementedError

    @staticmethod
    def _count(points: ArrayLike) -> int:
        shape = np.shape(points)
        if len(shape) != 2 or shape[0] != 3:
            raise ValueError(f"points must have shape (3, n) in m, got {shape}")
        return shape[1]

    def at(self, points: ArrayLike, time: float = 0.0) -> NDArray[np.float64]:
        """The field (T) at every one of ``points`` ``(3, n)``: shape ``(3, n)``."""
        n = self._count(points)
        return np.repeat(np.asarray(self(time), dtype=np.float64)[:, None], n, axis=1)

    def gradient(self, points: ArrayLike, time: float = 0.0) -> NDArray[np.float64]:
        """Zero, shape ``(3, 3, n)`` (T/m)."""
        return np.zeros((3, 3, self._count(points)))

    def evaluate(
        self, points: ArrayLike, time: float = 0.0
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(at(points, time), gradient(points, time))``."""
        return self.at(points, time), self.gradient(points, time)


class ConstantField(UniformField):
    """A constant uniform field ``B`` (T)."""

    def __init__(self, field: ArrayLike) -> None:
        self.value = _vector3(field, "field")

    def __call__(self, time: float) -> NDArray[np.float64]:
        return self.value


class RampedField(UniformField):
    """A field that grows linearly from zero to ``field`` (T) over ``ramp_time`` (s), then holds.

    Useful to reach a static equilibrium by dynamic relaxation without exciting vibrations.
    """

    def __init__(self, field: ArrayLike, ramp_time: float) -> None:
        if not (ramp_time > 0.0 and math.isfinite(ramp_time)):
            raise ValueError(f"ramp_time must be a positive time in s, got {ramp_time}")
        self.final = _vector3(field, "field")
        self.ramp_time = float(ramp_time)
        self._value = np.zeros(3)

    def __call__(self, time: float) -> NDArray[np.float64]:
        scale = min(max(time / self.ramp_time, 0.0), 1.0)
        np.multiply(self.final, scale, out=self._value)
        return self._value


class RotatingField(UniformField):
    """A field of constant amplitude rotating in a vertical plane: the x-y plane, or that plane
    turned about the vertical (y) axis by ``heading``.

    ``B(t) = amplitude * (cos(a) u + sin(a) e_y)`` with ``a = 2 pi f t + phase`` and the plane's
    horizontal direction ``u = (cos h, 0, -sin h)`` (``h = heading``, counter-clockwise seen from
    above, +y); ``heading = 0`` is the paper's x-y field ``(cos a, sin a, 0)``, where a positive
    frequency rotates counter-clockwise seen from +z. A clockwise field (``f < 0``) rolls the
    paper's robots along ``u``: ``heading = pi / 2`` rolls them sideways, toward -z.

    Parameters
    ----------
    amplitude : float
        T.
    frequency : float
        Hz (negative for clockwise rotation).
    phase : float
        rad, angle of the field at ``t = 0``.
    ramp_time : float
        s; if positive, the amplitude grows linearly from zero over this time.
    heading : float
        rad, the rotation plane turned about +y (0: the x-y plane).
    """

    def __init__(
        self, amplitude: float, frequency: float, phase: float = 0.0, ramp_time: float = 0.0,
        heading: float = 0.0,
    ) -> None:
        for name, value in (("amplitude (T)", amplitude), ("frequency (Hz)", frequency),
                            ("heading (rad)", heading)):
            if not math.isfinite(value):
                raise ValueError(f"{name} must be finite, got {value}")
        if amplitude < 0.0:
            raise ValueError(f"amplitude must be >= 0 in tesla, got {amplitude}")
        if ramp_time < 0.0:
            raise ValueError(f"ramp_time must be >= 0 in s, got {ramp_time}")
        self.amplitude = float(amplitude)
        self.frequency = float(frequency)
        self.phase = float(phase)
        self.ramp_time = float(ramp_time)
        self.heading = float(heading)
        self._horizontal = (math.cos(self.heading), -math.sin(self.heading))  # u_x, u_z
        self._value = np.zeros(3)

    def __call__(self, time: float) -> NDArray[np.float64]:
        amplitude = self.amplitude
        if self.ramp_time > 0.0 and time < self.ramp_time:
            amplitude *= max(time, 0.0) / self.ramp_time
        angle = 2.0 * math.pi * self.frequency * time + self.phase
        if self.heading == 0.0:  # the paper's plane, exactly
            self._value[0] = amplitude * math.cos(angle)
        else:
            across = amplitude * math.cos(angle)
            self._value[0] = across * self._horizontal[0]
            self._value[2] = across * self._horizontal[1]
        self._value[1] = amplitude * math.sin(angle)
        return self._value


class TabulatedField(UniformField):
    """A field sampled at a fixed rate and played with a zero-order hold.

    Sample ``i`` holds on ``[i / rate, (i + 1) / rate)``. Before ``t = 0`` the first sample holds;
    after the table the last sample holds (``after_end="hold"``) or the field is zero
    (``after_end="zero"``, what the coil driver does at the end of a waveform).

    Parameters
    ----------
    samples : array_like
        ``(n_samples, 3)`` field in tesla.
    rate : float
        Samples per second (100 for the paper's field CSV files).
    """

    def __init__(
        self,
        samples: ArrayLike,
        rate: float = FIELD_CSV_RATE_HZ,
        after_end: Literal["hold", "zero"] = "hold",
    ) -> None:
        samples = np.asarray(samples, dtype=np.float64)
        if samples.ndim != 2 or samples.shape[1] != 3 or samples.shape[0] == 0:
            raise ValueError(f"samples must have shape (n_samples, 3) in tesla, got {samples.shape}")
        if not np.all(np.isfinite(samples)):
            row = int(np.argwhere(~np.isfinite(samples))[0, 0])
            raise ValueError(f"samples contain a non-finite value at row {row}")
        if not (rate > 0.0 and math.isfinite(rate)):
            raise ValueError(f"rate must be a positive number of samples per second, got {rate}")
        if after_end not in ("hold", "zero"):
            raise ValueError(f"after_end must be 'hold' or 'zero', got {after_end!r}")
        self.samples = np.ascontiguousarray(samples)
        self.rate = float(rate)
        self.after_end = after_end
        self._zero = np.zeros(3)

    @classmethod
    def from_csv(cls, path: str | Path, after_end: Literal["hold", "zero"] = "hold"):
        """Load a field CSV file (mT, 100 rows per second; see :mod:`elastica_magnetic.field_csv`),
        its largest field judged as a coil field (``read_field_csv(path, plausible=True)``)."""
        return cls(read_field_csv(path, plausible=True), rate=FIELD_CSV_RATE_HZ, after_end=after_end)

    @property
    def duration(self) -> float:
        """Length of the table, s."""
        return self.samples.shape[0] / self.rate

    def index(self, time: float) -> int:
        """Row held at ``time`` (a tiny tolerance absorbs round-off of accumulated time steps)."""
        return int(math.floor(time * self.rate + 1e-9))

    def __call__(self, time: float) -> NDArray[np.float64]:
        i = self.index(time)
        if i < 0:
            return self.samples[0]
        if i >= self.samples.shape[0]:
            return self.samples[-1] if self.after_end == "hold" else self._zero
        return self.samples[i]


class ControlledField(UniformField):
    """A field changed by increments, as an agent does at 100 Hz (the paper's actuation rule).

    Each :meth:`apply_increment` adds ``delta`` (each component clipped to its axis's
    ``+-max_increment``), clips each component of the new field to its axis's ``+-limit``, then
    scales the field down to the largest axis limit (the amplitude limit) if it is longer.

    Parameters
    ----------
    limit : float or array_like (3,)
        Largest field component, T: one for every axis (the paper: 4e-3 or 10e-3), or one per
        axis ``(x, y, z)`` (coil pairs with different amplifiers). The amplitude limit is the
        largest of them (:attr:`limit`).
    max_increment : float or array_like (3,)
        Largest change of one component per increment, T (the paper: 0.3e-3), or one per axis.
    initial : array_like
        Field at the start, T (clipped by the same rule).
    """

    def __init__(
        self, limit: float | ArrayLike, max_increment: float | ArrayLike = 0.3e-3,
        initial: ArrayLike = (0.0, 0.0, 0.0)
    ) -> None:
        self.axis_limits = _per_axis(limit, "limit")
        self.axis_increments = _per_axis(max_increment, "max_increment")
        #: The amplitude limit, T: the largest axis limit.
        self.limit = float(self.axis_limits.max())
        #: The largest increment of any axis, T.
        self.max_increment = float(self.axis_increments.max())
        self._uniform = bool(np.all(self.axis_limits == self.limit)
                             and np.all(self.axis_increments == self.max_increment))
        self.value = np.zeros(3)
        self.set(initial)

    def _clip(self) -> None:
        if self._uniform:  # one limit for every axis: scalar bounds, as the paper's rule
            np.clip(self.value, -self.limit, self.limit, out=self.value)
        else:
            np.clip(self.value, -self.axis_limits, self.axis_limits, out=self.value)
        amplitude = math.sqrt(float(self.value @ self.value))
        if amplitude > self.limit:
            self.value *= self.limit / amplitude

    def set(self, field: ArrayLike) -> NDArray[np.float64]:
        """Set the field (T), clipped by the rule; returns the field now applied."""
        self.value[:] = _vector3(field, "field")
        self._clip()
        return self.value

    def apply_increment(self, delta: ArrayLike) -> NDArray[np.float64]:
        """Add an increment (T, ``(3,)`` or ``(2,)`` for x-y); returns the field now applied."""
        delta = np.asarray(delta, dtype=np.float64)
        if delta.shape not in ((2,), (3,)):
            raise ValueError(f"delta must have shape (2,) or (3,) in tesla, got {delta.shape}")
        if not np.all(np.isfinite(delta)):
            raise ValueError(f"delta contains NaN or infinite values: {delta}")
        if self._uniform:
            delta = np.clip(delta, -self.max_increment, self.max_increment)
        else:
            bound = self.axis_increments[: delta.shape[0]]
            delta = np.clip(delta, -bound, bound)
        self.value[: delta.shape[0]] += delta
        self._clip()
        return self.value

    def __call__(self, time: float) -> NDArray[np.float64]:
        return self.value
