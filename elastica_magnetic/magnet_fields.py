"""Finite permanent magnets (cuboid, cylinder) as spatial field sources, computed by Magpylib.

This module is the one place the physics package uses a library beyond PyElastica, numpy and
numba, and only when it is used: Magpylib (``pip install magpylib``, or the package's ``magnets``
extra) is imported when a source is built. Magpylib's analytical fields of homogeneously
magnetized cuboids and cylinders are the field's reference; writing them again would gain
nothing here, since a finite magnet costs Magpylib's per-call overhead either way (see
:doc:`/spatial_fields`).

The gradient is Magpylib's field differentiated by central differences with step ``step``
(default 1e-6 m; truncation ``~ step^2 B''' / 6``, round-off ``~ 1e-16 |B| / step``). Measured
against Richardson-extrapolated differences (step 1e-4 m) for 10 mm cubes and cylinders (J = 1.3 T):
4e-7 of the largest gradient component at 1 mm outside the magnet's circumscribed sphere, 1e-8 at
10 mm, 3e-9 at 30 mm. Each evaluation calls Magpylib once for the 7 point sets together.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .field_maps import MAX_RESAMPLED_NODES, FieldMap
from .spatial_fields import (
    ScalarOrWaveform,
    SpatialField,
    SpatialFieldError,
    VectorOrPath,
    _Scalar,
    _Vector,
    _vector3,
)

__all__ = ["CuboidMagnetField", "CylinderMagnetField", "DEFAULT_STEP", "MagnetMap", "magnet_map"]

#: Finite-difference step of the gradient, m.
DEFAULT_STEP = 1e-6


def _magpylib():
    try:
        import magpylib
    except ImportError:
        raise SpatialFieldError("finite magnets need Magpylib: pip install magpylib "
                                "(or elastica-magnetic[magnets])") from None
    return magpylib


class _MagpylibMagnet(SpatialField):
    """A Magpylib magnet that moves along ``position(time)`` (m) and turns with ``axis(time)``
    (the lab direction of its own z; a constant: a fixed orientation), its field times
    ``scale(time)``."""

    def __init__(self, magnet, position: VectorOrPath, step: float, scale: ScalarOrWaveform = 1.0,
                 axis: VectorOrPath = (0.0, 0.0, 1.0)) -> None:
        if not (step > 0.0 and np.isfinite(step)):
            raise SpatialFieldError(f"step must be a positive length in m, got {step}")
        self.magnet = magnet
        self.axis = _Vector(axis, "axis", "a direction")
        self.magnet.orientation = _orientation(self.axis(0.0))
        self.position = _Vector(position, "position", "m")
        self.scale = _Scalar(scale, "scale", "1")
        self.step = float(step)
        offsets = np.zeros((7, 3))
        for j in range(3):
            offsets[1 + 2 * j, j] = step
            offsets[2 + 2 * j, j] = -step
        self._offsets = offsets

    def _add(self, points, time, b, g, with_gradient) -> None:
        self.magnet.position = self.position(time)
        if self.axis.constant is None:  # a turning magnet: its orientation at this time
            self.magnet.orientation = _orientation(self.axis(time))
        scale = self.scale(time)
        n = points.shape[1]
        if not with_gradient:
            b += scale * np.asarray(self.magnet.getB(points.T), dtype=np.float64).reshape(n, 3).T
            return
        shifted = points.T[None, :, :] + self._offsets[:, None, :]  # (7, n, 3)
        values = np.asarray(self.magnet.getB(shifted.reshape(-1, 3)), dtype=np.float64)
        values = scale * values.reshape(7, n, 3)
        b += values[0].T
        for j in range(3):
            g[:, j, :] += ((values[1 + 2 * j] - values[2 + 2 * j]) / (2.0 * self.step)).T


def _orientation(axis: ArrayLike):
    """The rotation taking +z to ``axis`` the shortest way (scipy's Rotation, what Magpylib
    takes; a cylinder is symmetric about its axis, a cuboid's own x follows that shortest turn)."""
    from scipy.spatial.transform import Rotation

    axis = _vector3(axis, "axis", "a direction")
    norm = np.linalg.norm(axis)
    if norm == 0.0:
        raise SpatialFieldError("axis must be a non-zero direction")
    axis = axis / norm
    rotation, _ = Rotation.align_vectors([axis], [[0.0, 0.0, 1.0]])
    return rotation


class CuboidMagnetField(_MagpylibMagnet):
    """A homogeneously magnetized cuboid (Magpylib ``Cuboid``).

    Parameters
    ----------
    dimension : array_like
        ``(3,)`` edge lengths, m, along the magnet's own x, y, z.
    polarization : array_like
        ``(3,)`` magnetic polarization ``J = mu0 M``, T (a remanence of ~1.3 T for N45 NdFeB),
        in the magnet's own frame.
    position : array_like (3,) or callable
        Centre, m, or ``position(time) -> (3,)``.
    axis : array_like (3,) or callable
        Lab direction of the magnet's own z (default +z: own frame = lab frame), or
        ``axis(time) -> (3,)``: a magnet that turns (e.g. on a motor or a robot arm's wrist).
    step : float
        Finite-difference step of the gradient, m.
    scale : float or callable
        Factor on the field, or ``scale(time)`` (e.g. a ramp).
    """

    def __init__(self, dimension: ArrayLike, polarization: ArrayLike,
                 position: VectorOrPath = (0.0, 0.0, 0.0), axis: VectorOrPath = (0.0, 0.0, 1.0),
                 step: float = DEFAULT_STEP, scale: ScalarOrWaveform = 1.0) -> None:
        dimension = _vector3(dimension, "dimension", "m")
        if np.any(dimension <= 0.0):
            raise SpatialFieldError(f"dimension must be positive lengths in m, got {dimension.tolist()}")
        magnet = _magpylib().magnet.Cuboid(dimension=dimension,
                                           polarization=_vector3(polarization, "polarization", "T"))
        super().__init__(magnet, position, step, scale, axis)

    @property
    def moment(self) -> NDArray[np.float64]:
        """Magnetic moment ``J V / mu0`` (A m^2) in the magnet's own frame."""
        return np.asarray(self.magnet.polarization) * float(np.prod(self.magnet.dimension)) / (4e-7 * np.pi)


class CylinderMagnetField(_MagpylibMagnet):
    """A homogeneously magnetized cylinder (Magpylib ``Cylinder``), its axis along ``axis``.

    Parameters
    ----------
    diameter, height : float
        m.
    polarization : array_like
        ``(3,)`` ``J = mu0 M`` in T, in the magnet's own frame (``(0, 0, J)``: magnetized along
        its axis).
    position, axis, step, scale
        As for :class:`CuboidMagnetField`.
    """

    def __init__(self, diameter: float, height: float, polarization: ArrayLike,
                 position: VectorOrPath | Callable = (0.0, 0.0, 0.0), axis: VectorOrPath = (0.0, 0.0, 1.0),
                 step: float = DEFAULT_STEP, scale: ScalarOrWaveform = 1.0) -> None:
        if not (diameter > 0.0 and height > 0.0 and np.isfinite(diameter) and np.isfinite(height)):
            raise SpatialFieldError(
                f"diameter and height must be positive lengths in m, got {diameter}, {height}")
        magnet = _magpylib().magnet.Cylinder(dimension=(diameter, height),
                                             polarization=_vector3(polarization, "polarization", "T"))
        super().__init__(magnet, position, step, scale, axis)

    @property
    def moment(self) -> NDArray[np.float64]:
        """Magnetic moment ``J V / mu0`` (A m^2) in the magnet's own frame."""
        d, h = self.magnet.dimension
        return np.asarray(self.magnet.polarization) * (np.pi * d * d / 4.0 * h) / (4e-7 * np.pi)


@dataclass(frozen=True)
class MagnetMap:
    """A finite magnet's field tabulated once in its own frame, for a magnet an arm moves
    (:class:`~elastica_magnetic.MagnetPose` ``(..., field_map=)``): the magnet's centre at the map's
    origin, its moment along the map's +z. ``moment`` (A m^2) is the magnitude the map was made
    for: an arm of another moment scales the map by the ratio (a weaker or stronger magnet of the
    same shape)."""

    field_map: FieldMap
    moment: float


def magnet_map(magnet: CuboidMagnetField | CylinderMagnetField, half_width: float,
               spacing: float) -> MagnetMap:
    """The field of ``magnet`` (its polarization along its own z) sampled by Magpylib once on the
    cube ``[-half_width, half_width]^3`` (m, about its centre) at ``spacing`` (m), in its own frame:
    the map an arm moves and turns with the magnet, trilinear between nodes (so a step costs a
    lookup instead of Magpylib's per-call overhead). The gradient is the map's (second-order
    differences of the samples); the map's error against Magpylib falls with ``spacing^2`` and is
    largest near the magnet (:doc:`/spatial_fields` states it for a 10 mm cube). The robot must
    stay inside the cube: a point outside is a :class:`~elastica_magnetic.FieldMapDomainError`."""
    polarization = np.asarray(magnet.magnet.polarization, dtype=np.float64)
    strength = float(np.linalg.norm(polarization))
    if not strength > 0.0 or np.linalg.norm(polarization[:2]) > 1e-12 * strength:
        raise SpatialFieldError(f"magnet_map: the magnet's polarization {polarization.tolist()} T must lie "
                                "along its own z (the moment an arm turns)")
    if not (np.isfinite(half_width) and np.isfinite(spacing) and 0.0 < spacing < half_width):
        raise SpatialFieldError(f"magnet_map: need 0 < spacing < half_width (m), got spacing {spacing}, "
                                f"half_width {half_width}")
    count = int(round(2.0 * half_width / spacing)) + 1
    if count**3 > MAX_RESAMPLED_NODES:
        raise SpatialFieldError(f"magnet_map: {count}^3 nodes (half_width {half_width} m at spacing "
                                f"{spacing} m) exceed {MAX_RESAMPLED_NODES}: a coarser spacing or a "
                                "smaller cube")
    axis = np.linspace(-half_width, half_width, count)
    grid = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1)
    at_origin = magnet.magnet.copy(position=(0.0, 0.0, 0.0), orientation=None)
    samples = np.asarray(at_origin.getB(grid.reshape(-1, 3)), dtype=np.float64)
    samples = samples.reshape(count, count, count, 3)
    moment = float(np.linalg.norm(magnet.moment))
    field_map = FieldMap(axis, axis, axis, samples, source=f"map of a {type(magnet).__name__} "
                         f"({moment:.4g} A m^2, +-{half_width:g} m at {spacing:g} m)")
    return MagnetMap(field_map, moment)

