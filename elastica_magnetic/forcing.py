"""Forcing classes for magnetic soft robots, in the style of ``elastica.external_forces``.

Each class is a small :class:`elastica.NoForces` subclass with a numba kernel beside it. Register
them with ``sim.add_forcing_to(rod).using(Class, ...)``, in this order (see :doc:`/tutorial`):
magnetic torques, dampings, gravity, then the ground contact. PyElastica runs forcing and contact in
registration order and the plane contact cancels only the loads already accumulated.

Units are SI throughout: m, kg, s, N, T, A/m.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, Literal

import numpy as np
from elastica.external_forces import NoForces
from numba import njit
from numpy.typing import NDArray

from . import _robot_forcing_kernels as forcing_kernels
from . import _spatial_kernels as spatial_kernels
from .spatial_fields import SpatialField, is_spatial

__all__ = [
    "FieldValueError",
    "MagneticTorques",
    "evaluate_field",
    "RelativeVelocityDamping",
    "LegacyInternalDamping",
]

FieldFunction = Callable[[float], NDArray[np.float64]]


class FieldValueError(ValueError):
    """A field callable returned something other than a finite ``(3,)`` field in tesla."""


def evaluate_field(field: FieldFunction, time: float) -> NDArray[np.float64]:
    """``field(time)``, checked: a finite float64 array of shape ``(3,)`` (T), else
    :class:`FieldValueError` naming the time and what was returned. About 1 us per call."""
    value = field(time)
    if type(value) is not np.ndarray or value.dtype != np.float64 or value.shape != (3,):
        value = _coerce_field(field, time, value)
    if not all(map(math.isfinite, value.tolist())):
        raise FieldValueError(_field_message(field, time, value, "non-finite value"))
    return value


def _coerce_field(field: FieldFunction, time: float, value: Any) -> NDArray[np.float64]:
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise FieldValueError(_field_message(field, time, value, "not numeric")) from None
    if array.shape != (3,):
        raise FieldValueError(_field_message(field, time, value, f"shape {array.shape}"))
    return array


def _field_message(field: FieldFunction, time: float, value: Any, problem: str) -> str:
    text = np.array2string(value, threshold=8) if isinstance(value, np.ndarray) else repr(value)
    text = " ".join(text.split())
    if len(text) > 120:
        text = text[:117] + "..."
    return (f"field callable {getattr(field, '__qualname__', type(field).__name__)} returned "
            f"{text} at t = {float(time):.6g} s ({problem}); expected a finite array of shape (3,) "
            "in tesla")



def material_magnetization(magnetization: NDArray[np.float64], frame: str, system) -> NDArray[np.float64]:
    """Magnetization ``(3, 1)`` or ``(3, n_elements)`` (A/m) as ``(3, n_elements)`` in the rod's
    material frame (``frame="lab"``: given in the lab frame of the rod's current directors)."""
    n_elements = system.n_elems
    if magnetization.shape[1] == 1:
        magnetization = np.repeat(magnetization, n_elements, axis=1)
    if magnetization.shape[1] != n_elements:
        raise ValueError(
            f"magnetization has {magnetization.shape[1]} columns but the rod has "
            f"{n_elements} elements; expected shape (3, {n_elements}) in A/m"
        )
    if frame == "lab":
        magnetization = np.einsum("ijk,jk->ik", system.director_collection, magnetization)
    return magnetization

class MagneticTorques(NoForces):
    """Magnetic torques on a rod whose magnetization moves with the material (paper Eq. 3).

    Each element ``i`` carries the magnetic moment ``m_i = V_i M_i``, fixed in its material frame,
    and receives the torque ``tau_i = m_i x B(t)``. In PyElastica's convention the external torque is
    stored in the material frame: ``tau_i = V_i (M_i x Q_i B)``, with ``Q_i`` the director matrix of
    element ``i`` (rows ``d1, d2, d3``). ``V_i`` is the rod's rest volume of the element (for an
    equivalent circular section, the circular volume: see :func:`~elastica_magnetic.equivalent_radius`).
    A uniform field gives no net force, so only torques are applied.

    *Fields in space.* When ``field`` is a spatial source (``at(points, time)`` and
    ``gradient(points, time)``, see :mod:`elastica_magnetic.spatial_fields`), each element gets
    the field at its centre ``x_e`` (the midpoint of its nodes): the torque ``m_e x B(x_e)`` and,
    in :meth:`apply_forces`, the force ``F_e = (grad B(x_e))^T m_e`` (``F_j = sum_i m_i dB_i/dx_j``,
    ``m_e`` in the lab frame), half on each of the element's two nodes. Both derive from the
    energy ``U = -sum_e m_e . B(x_e)``. The uniform sources of :mod:`elastica_magnetic.fields` (and
    any plain callable) keep the uniform path, bit for bit.

    Parameters
    ----------
    field : callable or spatial source
        ``field(time) -> (3,)`` magnetic flux density in the lab frame, tesla. Any callable works;
        see :mod:`elastica_magnetic.fields` for constant, ramped, rotating, tabulated and controlled
        fields. Or a spatial source (e.g. :class:`~elastica_magnetic.PointDipoleField`), which
        adds the magnetic force.
    magnetization : numpy.ndarray
        ``(3, n_elements)`` magnetization in A/m, or ``(3,)`` for a uniform one.
    frame : {"lab", "material"}
        ``"lab"`` (default): ``magnetization`` is given in the lab frame of the configuration the rod
        has at the first call (the reference configuration when the simulation starts), and is
        turned into the material frame then. ``"material"``: components along ``(d1, d2, d3)``.

    Examples
    --------
    >>> sim.add_forcing_to(rod).using(
    ...     MagneticTorques,
    ...     field=RotatingField(amplitude=4e-3, frequency=1.0),
    ...     magnetization=yao2023_magnetization(pattern=1, n_elements=64),
    ... )
    """

    def __init__(
        self,
        field: FieldFunction,
        magnetization: NDArray[np.float64],
        frame: Literal["lab", "material"] = "lab",
    ) -> None:
        super().__init__()
        self.spatial = is_spatial(field)
        if not (callable(field) or self.spatial):
            raise TypeError(f"field must be a callable field(time) -> (3,) in tesla or a spatial "
                            f"source with at(points, time) and gradient(points, time), got {field!r}")
        if frame not in ("lab", "material"):
            raise ValueError(f"frame must be 'lab' or 'material', got {frame!r}")
        magnetization = np.asarray(magnetization, dtype=np.float64)
        if magnetization.ndim == 1:
            if magnetization.shape != (3,):
                raise ValueError(
                    f"magnetization must have shape (3,) or (3, n_elements) in A/m, "
                    f"got {magnetization.shape}"
                )
            magnetization = magnetization[:, None]
        if magnetization.ndim != 2 or magnetization.shape[0] != 3:
            raise ValueError(
                f"magnetization must have shape (3,) or (3, n_elements) in A/m, "
                f"got {magnetization.shape}"
            )
        if not np.all(np.isfinite(magnetization)):
            raise ValueError("magnetization contains NaN or infinite values")
        self.field = field
        self.magnetization = magnetization
        self.frame = frame
        self._moment_material: NDArray[np.float64] | None = None
        self._centres: NDArray[np.float64] | None = None
        self._b: NDArray[np.float64] | None = None
        self._g: NDArray[np.float64] | None = None
        self._fresh_field: NDArray[np.float64] | None = None  # B at the centres, from apply_forces
        self._fresh_time = math.nan

    def moment_in_material_frame(self, system) -> NDArray[np.float64]:
        """The ``(3, n_elements)`` magnetic moments ``V M`` (A m^2) in the material frame."""
        if self._moment_material is None:
            magnetization = material_magnetization(self.magnetization, self.frame, system)
            self._moment_material = np.ascontiguousarray(magnetization * system.volume[None, :])
        return self._moment_material

    def element_centres(self, system) -> NDArray[np.float64]:
        """``(3, n_elements)`` midpoints of the rod's nodes, m (a buffer reused every call)."""
        if self._centres is None:
            self._centres = np.empty((3, system.n_elems))
        forcing_kernels.element_centres(system.position_collection, self._centres)
        return self._centres

    def field_at_elements(self, system, time: float, gradient: bool = False):
        """The spatial source at the element centres: ``B`` ``(3, n)`` T, and with ``gradient``
        the pair ``(B, G)`` with ``G`` ``(3, 3, n)`` T/m; shapes and finiteness checked."""
        centres = self.element_centres(system)
        n = centres.shape[1]
        if isinstance(self.field, SpatialField):
            # The package's own sources: buffers reused, one finiteness check in numba.
            if self._b is None:
                self._b, self._g = np.empty((3, n)), np.empty((3, 3, n))
            b, g = self._b, self._g
            b.fill(0.0)
            if gradient:
                g.fill(0.0)
            self.field._add(centres, float(time), b, g, gradient)
            bad = spatial_kernels.first_nonfinite(b, g, gradient)
            if bad >= 0:
                raise FieldValueError(
                    f"spatial source {type(self.field).__name__} returned a non-finite B (T) or "
                    f"gradient (T/m) at element {bad} at t = {float(time):.6g} s (an element at a "
                    "dipole or on a wire?)")
            return (b, g) if gradient else b
        if gradient:
            evaluate = getattr(self.field, "evaluate", None)
            if evaluate is not None:
                b, g = evaluate(centres, time)
            else:
                b, g = self.field.at(centres, time), self.field.gradient(centres, time)
            _check_spatial(self.field, time, b, (3, n), "B (T)")
            _check_spatial(self.field, time, g, (3, 3, n), "gradient (T/m)")
            return b, g
        b = self.field.at(centres, time)
        _check_spatial(self.field, time, b, (3, n), "B (T)")
        return b

    def apply_forces(self, system, time: np.float64 = np.float64(0.0)) -> None:
        if not self.spatial:
            return
        b, g = self.field_at_elements(system, time, gradient=True)
        forcing_kernels.magnetic_forces(
            self.moment_in_material_frame(system), system.director_collection, g, system.external_forces
        )
        # PyElastica calls apply_torques right after, on the same state: it reuses this B once.
        self._fresh_field, self._fresh_time = b, float(time)

    def apply_torques(self, system, time: np.float64 = np.float64(0.0)) -> None:
        if self.spatial:
            b = self._fresh_field
            if b is None or self._fresh_time != float(time):
                b = self.field_at_elements(system, time)
            self._fresh_field = None
            forcing_kernels.magnetic_torques_at_elements(
                self.moment_in_material_frame(system), b, system.director_collection,
                system.external_torques,
            )
            return
        _magnetic_torques(
            self.moment_in_material_frame(system),
            evaluate_field(self.field, time),
            system.director_collection,
            system.external_torques,
        )


def _check_spatial(field: Any, time: float, value: Any, shape: tuple[int, ...], what: str) -> None:
    if type(value) is not np.ndarray or value.shape != shape or value.dtype != np.float64:
        raise FieldValueError(
            f"spatial source {type(field).__name__} returned {what} of "
            f"{getattr(value, 'shape', type(value).__name__)} at t = {float(time):.6g} s; expected a "
            f"float64 array of shape {shape}")
    if not np.isfinite(value).all():
        column = int(np.argwhere(~np.isfinite(value.reshape(-1, shape[-1])))[0, 1])
        raise FieldValueError(
            f"spatial source {type(field).__name__} returned a non-finite {what} at element "
            f"{column} at t = {float(time):.6g} s (an element at a dipole or on a wire?)")


@njit(cache=True)
def _magnetic_torques(
    moment_material: NDArray[np.float64],
    field_lab: NDArray[np.float64],
    directors: NDArray[np.float64],
    external_torques: NDArray[np.float64],
) -> None:
    """Add ``m x (Q B)`` to the material-frame torques. Shapes ``(3, n)``, ``(3,)``, ``(3, 3, n)``."""
    for i in range(moment_material.shape[1]):
        # Field in the material frame of element i: b = Q_i B.
        b0 = directors[0, 0, i] * field_lab[0] + directors[0, 1, i] * field_lab[1]
        b0 += directors[0, 2, i] * field_lab[2]
        b1 = directors[1, 0, i] * field_lab[0] + directors[1, 1, i] * field_lab[1]
        b1 += directors[1, 2, i] * field_lab[2]
        b2 = directors[2, 0, i] * field_lab[0] + directors[2, 1, i] * field_lab[1]
        b2 += directors[2, 2, i] * field_lab[2]
        m0 = moment_material[0, i]
        m1 = moment_material[1, i]
        m2 = moment_material[2, i]
        external_torques[0, i] += m1 * b2 - m2 * b1
        external_torques[1, i] += m2 * b0 - m0 * b2
        external_torques[2, i] += m0 * b1 - m1 * b0


class RelativeVelocityDamping(NoForces):
    """Damping on the relative velocity of nodes ``j`` and ``j + k`` (paper Eq. 4-5).

    For every node pair ``(j, j + k)``, ``j = 0 .. n_nodes - 1 - k``, the force
    ``f = nu * l_j * (v_{j+k} - v_j)`` is added to node ``j`` and subtracted from node ``j + k``,
    with ``l_j`` the current length of element ``j`` (the authors' implementation). The forces cancel
    in pairs, so the net force (and the momentum change) is zero; a rigid translation is not damped.

    Parameters
    ----------
    nu : float
        Damping coefficient per unit length, N s / m^2. The paper's robot uses 20 N s/m^2
        (the authors' ``2e4`` in mm-mg-s units).
    node_offset : int
        ``k``, the distance between the damped node pairs. The paper uses 4 ("slightly magnifying
        the interval between the two nodes helps coarse-tune dissipation").
    """

    def __init__(self, nu: float, node_offset: int = 4) -> None:
        super().__init__()
        nu = float(nu)
        if not np.isfinite(nu) or nu < 0.0:
            raise ValueError(f"nu must be a finite damping coefficient >= 0 in N s/m^2, got {nu}")
        if int(node_offset) != node_offset or node_offset < 1:
            raise ValueError(f"node_offset must be a positive integer, got {node_offset!r}")
        self.nu = np.float64(nu)
        self.node_offset = int(node_offset)

    def apply_forces(self, system, time: np.float64 = np.float64(0.0)) -> None:
        if self.node_offset >= system.n_elems + 1:
            raise ValueError(
                f"node_offset {self.node_offset} must be smaller than the number of nodes "
                f"({system.n_elems + 1})"
            )
        _relative_velocity_damping(
            self.nu,
            self.node_offset,
            system.lengths,
            system.velocity_collection,
            system.external_forces,
        )


@njit(cache=True)
def _relative_velocity_damping(
    nu: np.float64,
    offset: int,
    lengths: NDArray[np.float64],
    velocities: NDArray[np.float64],
    external_forces: NDArray[np.float64],
) -> None:
    n_nodes = velocities.shape[1]
    for j in range(n_nodes - offset):
        c = nu * lengths[j]
        for d in range(3):
            f = c * (velocities[d, j + offset] - velocities[d, j])
            external_forces[d, j] += f
            external_forces[d, j + offset] -= f


class LegacyInternalDamping(NoForces):
    """The internal damping of PyElastica before 0.3 (rod keyword ``nu``), as a forcing.

    Yao et al. used it together with :class:`RelativeVelocityDamping`; PyElastica 1.0 removed it, so
    this class restores it to reproduce the paper. With element velocities
    ``v_e = (v_i + v_{i+1}) / 2`` and current element lengths ``l_e``:

    - node forces: ``-quadrature(c_f * v_e * l_e)``, i.e. node ``i`` gets minus half of the elemental
      force of each adjacent element;
    - element torques (material frame): ``-c_t * omega_e * l_e``.

    Unlike :class:`RelativeVelocityDamping`, it also damps rigid-body motion (like a viscous medium).

    Parameters
    ----------
    force_coefficient : float
        ``c_f``, N s / m^2. The paper's robot: 0.15 (the authors' ``nu = 150`` in mm-mg-s units).
    torque_coefficient : float
        ``c_t``, N s. The paper's robot: 1.5e-7 (the same ``nu = 150``, by its dimension).
    """

    def __init__(self, force_coefficient: float, torque_coefficient: float) -> None:
        super().__init__()
        for name, value in (
            ("force_coefficient (N s/m^2)", force_coefficient),
            ("torque_coefficient (N s)", torque_coefficient),
        ):
            if not np.isfinite(value) or value < 0.0:
                raise ValueError(f"{name} must be finite and >= 0, got {value}")
        self.force_coefficient = np.float64(force_coefficient)
        self.torque_coefficient = np.float64(torque_coefficient)

    def apply_forces(self, system, time: np.float64 = np.float64(0.0)) -> None:
        _legacy_damping_forces(
            self.force_coefficient,
            system.lengths,
            system.velocity_collection,
            system.external_forces,
        )

    def apply_torques(self, system, time: np.float64 = np.float64(0.0)) -> None:
        _legacy_damping_torques(
            self.torque_coefficient,
            system.lengths,
            system.omega_collection,
            system.external_torques,
        )


@njit(cache=True)
def _legacy_damping_forces(
    coefficient: np.float64,
    lengths: NDArray[np.float64],
    velocities: NDArray[np.float64],
    external_forces: NDArray[np.float64],
) -> None:
    n_elements = lengths.shape[0]
    for e in range(n_elements):
        c = 0.25 * coefficient * lengths[e]  # half for the element velocity, half per node
        for d in range(3):
            f = c * (velocities[d, e] + velocities[d, e + 1])
            external_forces[d, e] -= f
            external_forces[d, e + 1] -= f


@njit(cache=True)
def _legacy_damping_torques(
    coefficient: np.float64,
    lengths: NDArray[np.float64],
    omegas: NDArray[np.float64],
    external_torques: NDArray[np.float64],
) -> None:
    for e in range(lengths.shape[0]):
        c = coefficient * lengths[e]
        for d in range(3):
            external_torques[d, e] -= c * omegas[d, e]
