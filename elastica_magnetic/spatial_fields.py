"""Magnetic field sources that vary in space: ``B(x, t)`` and its gradient at many points at once.

Every source here offers

- ``at(points, time) -> (3, n)``: the flux density ``B`` in tesla at ``points`` ``(3, n)`` (m,
  lab frame);
- ``gradient(points, time) -> (3, 3, n)``: ``G[i, j] = dB_i / dx_j`` in T/m;
- ``evaluate(points, time) -> (B, G)``: both at once (what the forcing calls, once per step).

Give one to :class:`~elastica_magnetic.MagneticTorques` as its ``field``: it then applies the
torque ``m x B(x_e)`` at each element centre ``x_e`` and the force ``(grad B)^T m``. The uniform
sources of :mod:`elastica_magnetic.fields` offer ``at`` and ``gradient`` too (zero gradient) and
keep their own, unchanged path through the forcing.

Closed forms, in numba (:mod:`elastica_magnetic._spatial_kernels`): the point dipole and its
analytic gradient; circular current loops by complete elliptic integrals (Cody's polynomial
approximations, as SciPy's) with analytic gradients, and a series about the axis where the
closed form cancels. They agree with Magpylib to round-off and cost a few hundred times less per call
(:doc:`/spatial_fields`). Finite magnets (cuboid, cylinder) come from Magpylib, an optional
dependency: :mod:`elastica_magnetic.magnet_fields`. A field tabulated on a grid (a finite-element
tool's export): :mod:`elastica_magnetic.field_maps`.

A pose may follow a trajectory in time: positions, moments and currents are either constants or
callables of time (e.g. :class:`Waypoints`).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable
from typing import Union

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import _spatial_kernels as kernels

__all__ = [
    "SpatialFieldError",
    "Waypoints",
    "SpatialField",
    "PointDipoleField",
    "CurrentLoopsField",
    "CurrentLoopField",
    "HelmholtzCoils",
    "MaxwellCoils",
    "ConstantGradientField",
    "FieldSum",
    "is_spatial",
    "rotation_to",
]

#: A vector (3,) that is constant or a callable of time (s).
VectorOrPath = Union[ArrayLike, Callable[[float], ArrayLike]]  # noqa: UP007 (a runtime alias)
#: A scalar that is constant or a callable of time (s).
ScalarOrWaveform = Union[float, Callable[[float], float]]  # noqa: UP007


class SpatialFieldError(ValueError):
    """Bad input to a spatial field source (points, pose, waveform); the message names it."""


def is_spatial(field: object) -> bool:
    """Whether ``field`` is a source whose value depends on position: it has ``at`` and
    ``gradient`` and is not marked ``uniform = True`` (the sources of :mod:`~elastica_magnetic.fields`)."""
    return hasattr(field, "at") and hasattr(field, "gradient") and not getattr(field, "uniform", False)


def _vector3(value: ArrayLike, name: str, unit: str) -> NDArray[np.float64]:
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise SpatialFieldError(f"{name} must be a 3-vector in {unit}, got {value!r}") from None
    if array.shape != (3,):
        raise SpatialFieldError(f"{name} must be a 3-vector in {unit}, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise SpatialFieldError(f"{name} must be finite ({unit}), got {array.tolist()}")
    return array


class _Vector:
    """A (3,) vector that is constant or a callable of time, checked where it is evaluated."""

    def __init__(self, value: VectorOrPath, name: str, unit: str) -> None:
        self.name, self.unit = name, unit
        if callable(value):
            self.function = value
            self.constant = None
            self(0.0)  # fail now on a bad path, not mid-run
        else:
            self.function = None
            self.constant = _vector3(value, name, unit)

    def __call__(self, time: float) -> NDArray[np.float64]:
        if self.constant is not None:
            return self.constant
        if type(self.function) is Waypoints:  # checked when built: finite (3,) values
            return self.function(time)
        return _vector3(self.function(time), f"{self.name} at t = {float(time):.6g} s", self.unit)


class _Scalar:
    def __init__(self, value: ScalarOrWaveform, name: str, unit: str) -> None:
        self.name, self.unit = name, unit
        self.function = value if callable(value) else None
        self.constant = None if callable(value) else self._check(value, name)
        if self.function is not None:
            self(0.0)

    def _check(self, value, name) -> float:
        try:
            number = float(value)
        except (TypeError, ValueError):
            raise SpatialFieldError(f"{name} must be a number in {self.unit}, got {value!r}") from None
        if not math.isfinite(number):
            raise SpatialFieldError(f"{name} must be finite ({self.unit}), got {value!r}")
        return number

    def __call__(self, time: float) -> float:
        if self.constant is not None:
            return self.constant
        return self._check(self.function(time), f"{self.name} at t = {float(time):.6g} s")


class Waypoints:
    """A path through ``values`` at ``times``, linear between them and held before and after:
    a callable ``path(time) -> (3,)`` for a pose that follows a trajectory.

    Parameters
    ----------
    times : array_like
        ``(k,)`` strictly increasing times, s.
    values : array_like
        ``(k, 3)`` positions (m) or moments (A m^2) at those times.
    """

    def __init__(self, times: ArrayLike, values: ArrayLike) -> None:
        times = np.asarray(times, dtype=np.float64)
        values = np.asarray(values, dtype=np.float64)
        if times.ndim != 1 or times.shape[0] < 1:
            raise SpatialFieldError(
                f"times must be a list of at least one time in s, got shape {times.shape}")
        if values.shape != (times.shape[0], 3):
            raise SpatialFieldError(f"values must have shape ({times.shape[0]}, 3) (one 3-vector per "
                                    f"time), got {values.shape}")
        if not (np.all(np.isfinite(times)) and np.all(np.isfinite(values))):
            raise SpatialFieldError("times and values must be finite")
        if np.any(np.diff(times) <= 0.0):
            raise SpatialFieldError(f"times must increase strictly (s), got {times.tolist()}")
        self.times = times
        self.values = np.ascontiguousarray(values)
        self._times = times.tolist()
        self._rows = [row.tolist() for row in self.values]
        self._value = np.empty(3)

    def __call__(self, time: float) -> NDArray[np.float64]:
        times = self._times
        if time <= times[0]:
            return self.values[0]
        if time >= times[-1]:
            return self.values[-1]
        i = bisect.bisect_right(times, time) - 1
        w = (time - times[i]) / (times[i + 1] - times[i])
        a, b = self._rows[i], self._rows[i + 1]
        value = self._value
        value[0] = a[0] + w * (b[0] - a[0])
        value[1] = a[1] + w * (b[1] - a[1])
        value[2] = a[2] + w * (b[2] - a[2])
        return value


class SpatialField:
    """Base class of the sources in this module: subclasses implement :meth:`_add`."""

    uniform = False

    def _add(self, points: NDArray[np.float64], time: float, b: NDArray[np.float64],
             g: NDArray[np.float64], with_gradient: bool) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    @staticmethod
    def _points(points: ArrayLike) -> NDArray[np.float64]:
        array = np.asarray(points, dtype=np.float64)
        if array.ndim != 2 or array.shape[0] != 3:
            raise SpatialFieldError(f"points must have shape (3, n) in m, got {array.shape}")
        if not np.all(np.isfinite(array)):
            raise SpatialFieldError("points must be finite (m)")
        return np.ascontiguousarray(array)

    def at(self, points: ArrayLike, time: float = 0.0) -> NDArray[np.float64]:
        """``B`` (T), shape ``(3, n)``, at ``points`` ``(3, n)`` (m, lab frame) and ``time`` (s)."""
        points = self._points(points)
        b = np.zeros(points.shape)
        self._add(points, float(time), b, np.zeros((3, 3, 0)), False)
        return b

    def gradient(self, points: ArrayLike, time: float = 0.0) -> NDArray[np.float64]:
        """``G[i, j] = dB_i/dx_j`` (T/m), shape ``(3, 3, n)``, at ``points`` ``(3, n)`` (m)."""
        return self.evaluate(points, time)[1]

    def evaluate(
        self, points: ArrayLike, time: float = 0.0
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(B, G)``: ``(3, n)`` T and ``(3, 3, n)`` T/m at ``points`` ``(3, n)`` (m)."""
        points = self._points(points)
        b = np.zeros(points.shape)
        g = np.zeros((3, 3, points.shape[1]))
        self._add(points, float(time), b, g, True)
        return b, g

    def __add__(self, other: object) -> FieldSum:
        return FieldSum(self, other)


class PointDipoleField(SpatialField):
    """The field of a point magnetic dipole (a permanent magnet seen from afar).

    ``B(x) = mu0 / (4 pi r^3) (3 (m . n) n - m)``, ``r = x - position``, ``n = r / |r|``; the
    gradient is analytic. A sphere magnetized uniformly makes exactly this field outside itself
    (``m = M V``).

    Parameters
    ----------
    moment : array_like (3,) or callable
        Magnetic moment, A m^2 (lab frame), or ``moment(time) -> (3,)``.
    position : array_like (3,) or callable
        Dipole position, m, or ``position(time) -> (3,)`` (e.g. :class:`Waypoints`).
    """

    def __init__(self, moment: VectorOrPath, position: VectorOrPath = (0.0, 0.0, 0.0)) -> None:
        self.moment = _Vector(moment, "moment", "A m^2")
        self.position = _Vector(position, "position", "m")

    def _add(self, points, time, b, g, with_gradient) -> None:
        kernels.dipole_field(self.moment(time), self.position(time), points, b, g, with_gradient)


def _frame(axis: NDArray[np.float64]) -> NDArray[np.float64]:
    """A right-handed orthonormal frame, columns ``(e1, e2, axis)``."""
    axis = axis / np.linalg.norm(axis)
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(helper, axis)
    e1 /= np.linalg.norm(e1)
    return np.column_stack([e1, np.cross(axis, e1), axis])


class CurrentLoopsField(SpatialField):
    """Coaxial circular current loops that move together (a coil set), driven by one current.

    Loop ``l`` has radius ``radii[l]`` (m), sits at ``centre + offsets[l] * axis`` and carries
    ``current(t) * weights[l]`` amperes, counter-clockwise about ``axis`` (``weights``: turns, with
    a sign for reversed loops). Each loop is a filament: a wound coil of small cross-section is
    well described by its ``turns`` at the mean radius.

    Parameters
    ----------
    radii, offsets, weights : array_like
        ``(L,)`` m, m, turns.
    current : float or callable
        A, or ``current(time) -> float`` (the waveform).
    centre : array_like (3,) or callable
        m, or ``centre(time) -> (3,)``.
    axis : array_like (3,)
        Direction of the common axis (normalized here).
    """

    def __init__(self, radii: ArrayLike, offsets: ArrayLike, weights: ArrayLike,
                 current: ScalarOrWaveform = 1.0, centre: VectorOrPath = (0.0, 0.0, 0.0),
                 axis: ArrayLike = (0.0, 0.0, 1.0)) -> None:
        radii = np.atleast_1d(np.asarray(radii, dtype=np.float64))
        offsets = np.atleast_1d(np.asarray(offsets, dtype=np.float64))
        weights = np.atleast_1d(np.asarray(weights, dtype=np.float64))
        if not (radii.ndim == 1 and radii.shape == offsets.shape == weights.shape):
            raise SpatialFieldError(f"radii, offsets and weights must be lists of one length, got "
                                    f"{radii.shape}, {offsets.shape}, {weights.shape}")
        if not np.all(np.isfinite(radii)) or np.any(radii <= 0.0):
            raise SpatialFieldError(f"radii must be positive lengths in m, got {radii.tolist()}")
        if not (np.all(np.isfinite(offsets)) and np.all(np.isfinite(weights))):
            raise SpatialFieldError("offsets (m) and weights (turns) must be finite")
        axis = _vector3(axis, "axis", "a direction")
        if not np.any(axis):
            raise SpatialFieldError("axis must be a non-zero direction")
        self.radii, self.offsets, self.weights = radii, offsets, weights
        self.frame = _frame(axis)
        self.axis = self.frame[:, 2].copy()
        self.current = _Scalar(current, "current", "A")
        self.centre = _Vector(centre, "centre", "m")
        n = radii.shape[0]
        self._frames = np.ascontiguousarray(np.repeat(self.frame[:, :, None], n, axis=2))
        self._centres = np.empty((3, n))
        self._currents = np.empty(n)

    def _add(self, points, time, b, g, with_gradient) -> None:
        centre = self.centre(time)
        np.add(centre[:, None], self.axis[:, None] * self.offsets[None, :], out=self._centres)
        np.multiply(self.weights, self.current(time), out=self._currents)
        try:
            kernels.loops_field(self._centres, self._frames, self.radii, self._currents, points, b, g,
                                with_gradient)
        except ZeroDivisionError:
            raise self._on_wire(points, time) from None

    def _on_wire(self, points: NDArray[np.float64], time: float) -> SpatialFieldError:
        """The error for a point on a loop's wire, where the field is infinite (the closed form
        divides by the distance to the wire)."""
        best = (math.inf, 0, 0)
        for ell, radius in enumerate(self.radii):
            q = points - self._centres[:, ell][:, None]
            axial = self.axis @ q
            radial = np.linalg.norm(q - np.outer(self.axis, axial), axis=0)
            distance = np.hypot(radial - radius, axial)
            k = int(np.argmin(distance))
            best = min(best, (float(distance[k]), ell, k))
        _, ell, k = best
        return SpatialFieldError(
            f"point {points[:, k].tolist()} m (column {k}) at t = {time:.6g} s lies on the wire of "
            f"current loop {ell} (radius {self.radii[ell]:g} m, centre {self._centres[:, ell].tolist()} m, "
            "axis {}): the field is infinite there; keep the robot off the coil's wire".format(
                self.axis.tolist()))


class CurrentLoopField(CurrentLoopsField):
    """One circular loop of ``turns`` turns, radius ``radius`` (m), carrying ``current`` (A,
    counter-clockwise about ``axis``), centred at ``centre`` (m; may be a path)."""

    def __init__(self, radius: float, current: ScalarOrWaveform = 1.0, centre: VectorOrPath = (0.0, 0.0, 0.0),
                 axis: ArrayLike = (0.0, 0.0, 1.0), turns: float = 1.0) -> None:
        super().__init__([radius], [0.0], [turns], current, centre, axis)


class HelmholtzCoils(CurrentLoopsField):
    """A Helmholtz pair: two coaxial loops of radius ``R`` at ``+-R/2`` from ``centre``, same
    current; the most uniform field of two loops, ``B = (4/5)^(3/2) mu0 N I / R`` at the centre.

    Parameters
    ----------
    radius : float
        m. ``current``: A (or a waveform). ``turns``: turns per coil.
    """

    def __init__(self, radius: float, current: ScalarOrWaveform = 1.0, centre: VectorOrPath = (0.0, 0.0, 0.0),
                 axis: ArrayLike = (0.0, 0.0, 1.0), turns: float = 1.0) -> None:
        super().__init__([radius, radius], [-0.5 * radius, 0.5 * radius], [turns, turns], current,
                         centre, axis)


class MaxwellCoils(CurrentLoopsField):
    """A Maxwell gradient pair (anti-Helmholtz): two coaxial loops of radius ``R`` at
    ``+-sqrt(3) R / 2`` with opposite currents; zero field at the centre and the most uniform
    gradient, ``dB_z/dz = 48 sqrt(3) / 7^(5/2) mu0 N I / R^2 = 0.6413 mu0 N I / R^2`` along
    ``axis`` (the loop at ``+sqrt(3) R / 2`` carries ``+I`` about ``axis``, the other ``-I``).
    """

    def __init__(self, radius: float, current: ScalarOrWaveform = 1.0, centre: VectorOrPath = (0.0, 0.0, 0.0),
                 axis: ArrayLike = (0.0, 0.0, 1.0), turns: float = 1.0) -> None:
        half = 0.5 * math.sqrt(3.0) * radius
        super().__init__([radius, radius], [-half, half], [-turns, turns], current, centre, axis)


class ConstantGradientField(SpatialField):
    """A field that grows linearly in space: ``B(x, t) = s(t) G (x - origin(t))``.

    The field near the centre of gradient coils (on a Maxwell pair's axis
    ``G = g diag(-1/2, -1/2, 1)``, :class:`MaxwellCoils`), and the constant-gradient loads of
    the hard-magnetic beam literature. Add a uniform part with :class:`FieldSum`
    (``ConstantGradientField(...) + ConstantField(...)``).

    Parameters
    ----------
    gradient : array_like (3, 3)
        ``G[i, j] = dB_i/dx_j``, T/m. A field in a region free of currents and magnets has no
        curl and no divergence, so ``G`` must be symmetric and traceless (within 1e-9 of its
        largest entry); anything else is refused with the offending entries named.
    scale : float or callable
        Dimensionless factor ``s`` (e.g. a coil current's waveform, ramp), or ``scale(time)``.
    origin : array_like (3,) or callable
        Where the field is zero, m (may be a path).
    """

    def __init__(self, gradient: ArrayLike, scale: ScalarOrWaveform = 1.0,
                 origin: VectorOrPath = (0.0, 0.0, 0.0)) -> None:
        matrix = np.asarray(gradient, dtype=np.float64)
        if matrix.shape != (3, 3) or not np.all(np.isfinite(matrix)):
            raise SpatialFieldError(f"gradient must be a finite 3x3 matrix dB_i/dx_j in T/m, got "
                                    f"{np.asarray(gradient).tolist()!r}")
        tolerance = 1e-9 * max(float(np.abs(matrix).max()), 1e-300)
        asymmetry = np.abs(matrix - matrix.T)
        if asymmetry.max() > tolerance:
            i, j = np.unravel_index(int(asymmetry.argmax()), (3, 3))
            raise SpatialFieldError(
                f"gradient must be symmetric (a curl-free field): G[{i}][{j}] = {matrix[i, j]:g} but "
                f"G[{j}][{i}] = {matrix[j, i]:g} T/m")
        if abs(np.trace(matrix)) > tolerance:
            raise SpatialFieldError(
                f"gradient must be traceless (a divergence-free field): its trace is "
                f"{np.trace(matrix):g} T/m")
        self.matrix = np.ascontiguousarray(matrix)
        self.scale = _Scalar(scale, "scale", "1")
        self.origin = _Vector(origin, "origin", "m")

    def _add(self, points, time, b, g, with_gradient) -> None:
        scaled = self.scale(time) * self.matrix
        b += scaled @ (points - self.origin(time)[:, None])
        if with_gradient:
            g += scaled[:, :, None]


def rotation_to(axis: ArrayLike) -> NDArray[np.float64]:
    """The rotation matrix ``(3, 3)`` turning +z onto the direction ``axis`` the shortest way
    (about ``z x axis``; half a turn about x for ``-z``)."""
    a = np.asarray(axis, dtype=np.float64)
    norm = float(np.linalg.norm(a))
    if not (norm > 0.0 and math.isfinite(norm)):
        raise SpatialFieldError(f"axis must be a non-zero direction, got {a.tolist()}")
    a = a / norm
    c = float(a[2])  # cos of the angle from +z
    if c > 1.0 - 1e-15:
        return np.eye(3)
    if c < -1.0 + 1e-15:
        return np.diag([1.0, -1.0, -1.0])
    v = np.array([-a[1], a[0], 0.0])  # z x a
    k = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + k + k @ k / (1.0 + c)


class _UniformCallable(SpatialField):
    """A uniform callable ``field(time) -> (3,)`` (T) as a spatial source (zero gradient)."""

    def __init__(self, field: Callable[[float], ArrayLike]) -> None:
        self.field = field

    def _add(self, points, time, b, g, with_gradient) -> None:
        b += _vector3(self.field(time), f"uniform field at t = {time:.6g} s", "T")[:, None]


class _UserSource(SpatialField):
    """A user's own spatial source, any object with ``at(points, time)`` -> ``(3, n)`` T and
    ``gradient(points, time)`` -> ``(3, 3, n)`` T/m (what :class:`~elastica_magnetic.MagneticTorques`
    takes), inside a :class:`FieldSum`; what it returns is checked (shape, finite)."""

    def __init__(self, source: object, index: int) -> None:
        self.source, self.index = source, index

    def _add(self, points, time, b, g, with_gradient) -> None:
        n = points.shape[1]
        b += self._checked(self.source.at(points, time), (3, n), "at", "T")
        if with_gradient:
            g += self._checked(self.source.gradient(points, time), (3, 3, n), "gradient", "T/m")

    def _checked(self, value: object, shape: tuple[int, ...], method: str, unit: str) -> NDArray[np.float64]:
        name = f"source {self.index} of FieldSum ({type(self.source).__name__}).{method}"
        try:
            array = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            raise SpatialFieldError(f"{name} returned {value!r}, not numbers in {unit}") from None
        if array.shape != shape:
            raise SpatialFieldError(f"{name} returned shape {array.shape}, expected {shape} ({unit})")
        if not np.all(np.isfinite(array)):
            raise SpatialFieldError(f"{name} returned values that are not finite ({unit})")
        return array


class FieldSum(SpatialField):
    """The sum of field sources: spatial ones (this module's, or any object with ``at`` and
    ``gradient`` as :class:`~elastica_magnetic.MagneticTorques` takes them) and uniform ones (any
    ``field(time) -> (3,)``, e.g. :class:`~elastica_magnetic.ConstantField`) added everywhere with
    zero gradient."""

    def __init__(self, *sources: object) -> None:
        if not sources:
            raise SpatialFieldError("FieldSum needs at least one source")
        parts: list[SpatialField] = []
        for i, source in enumerate(sources):
            if isinstance(source, FieldSum):
                parts.extend(source.sources)
            elif isinstance(source, SpatialField):
                parts.append(source)
            elif is_spatial(source):  # a user's own source (before callable: it may be both)
                parts.append(_UserSource(source, i))
            elif callable(source):
                parts.append(_UniformCallable(source))
            else:
                raise SpatialFieldError(f"source {i} of FieldSum is neither a spatial source (at, gradient) "
                                        f"nor a field(time) -> (3,) callable: {source!r}")
        self.sources = parts

    def _add(self, points, time, b, g, with_gradient) -> None:
        for source in self.sources:
            source._add(points, time, b, g, with_gradient)
