"""Magnetic attraction and repulsion between the parts of one rod (dipole-dipole interaction).

Each element ``i`` of a magnetized rod is a point dipole at its centre ``c_i``. With
``r = c_i - c_j``, ``d = |r|``, ``n = r / d`` and ``mu0 = 4 pi 1e-7 T m/A``, element ``j`` makes at
``c_i`` the field ``B_j = mu0 / (4 pi d^3) (3 n (m_j . n) - m_j)``, and element ``i`` receives

- the torque ``m_i x B_j``,
- the force ``F_ij = 3 mu0 / (4 pi d^4) [(m_i . n) m_j + (m_j . n) m_i + (m_i . m_j) n
  - 5 (m_i . n)(m_j . n) n]`` (``F_ji = -F_ij``),

which derive from the pair energy ``U_ij = -m_i . B_j``. Pairs closer along the rod than a cutoff
arclength are left out (see :class:`MagneticInteraction`). Units are SI: m, A/m, T, N, N m.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from elastica.external_forces import NoForces
from numba import njit
from numpy.typing import NDArray

from .forcing import material_magnetization

__all__ = ["MagneticInteraction", "MU0"]

#: Vacuum permeability, T m / A.
MU0 = 4e-7 * np.pi


#: The default cutoff of the interaction, in the rod's radii: pairs nearer than this along the rod
#: are left to the material's measured elasticity (nearer, point dipoles are a poor model and stiff).
DEFAULT_CUTOFF_RADII = 4.0


class MagneticInteraction(NoForces):
    """Forces and torques that the magnetized elements of a rod exert on each other.

    Element ``i`` carries the moment ``m_i = V_i M_i`` (``V_i`` the rod's element volume, ``M_i``
    fixed in the material frame, exactly as in :class:`~elastica_magnetic.MagneticTorques`) and sits
    in the field of every other element ``j`` taken as a point dipole at the element centre (formulas
    in :mod:`elastica_magnetic.interaction`). Cost: ``O(n^2)`` pairs per step in a numba kernel.

    *Near neighbours.* The continuum between two nearby elements is not a pair of point dipoles, and
    the point-dipole sum over close pairs grows without bound as the rod is refined (each pair
    scales as ``l^2 / l^4``). Pairs whose rest arclength separation (between element centres) is
    smaller than ``cutoff`` are left out: their interaction is local, part of the material's
    measured elastic behaviour (its energy density is at most ``mu0 M^2 / 2``, 2.4 kPa for 61.3 kA/m,
    3% of the robot's Young's modulus), and the remaining double sum converges to the continuum
    double integral as elements are refined (see :doc:`/extra_physics`). The pair list is fixed in the
    rest configuration, so the forces stay conservative.

    *Nodes.* The force on element ``i`` acts at its centre, the midpoint of nodes ``i`` and
    ``i + 1``; half goes to each node. That split keeps the resultant and, because the centre is the
    midpoint, also the moment about any point: element torques plus ``sum r x F`` over the nodes
    vanish, as they do for the dipoles. Torques are stored in the material frame (PyElastica's
    convention for external torques).

    *Which moment makes the field.* A rod that stands for a band (the paper's equivalent circular
    rod, :func:`~elastica_magnetic.equivalent_radius`) is the band with every load per unit length
    scaled by ``A_rod / A_band``: its mass, stiffness and magnetic torque (``V_i`` is the circular
    volume). The field one part of the real band makes at another is that of the band's own moment.
    Pass ``source_area = width * height``: the field sources then carry ``(source_area / A_rod) m_j``
    while the responses keep ``m_i``, so the interaction is scaled by ``A_rod / A_band`` like every
    other load. The default (``None``) uses the rod's own area (a genuinely circular rod).

    Parameters
    ----------
    magnetization : numpy.ndarray
        ``(3, n_elements)`` magnetization in A/m, or ``(3,)`` for a uniform one, as for
        :class:`~elastica_magnetic.MagneticTorques`.
    frame : {"lab", "material"}
        Frame of ``magnetization`` (see :class:`~elastica_magnetic.MagneticTorques`).
    cutoff : float
        Pairs of elements whose centres are closer than this rest arclength (m) do not interact.
        ``0`` keeps every pair. Default ``None``: four times the rod's largest radius.
    source_area : float, optional
        Cross-section area (m^2) of the magnetized body that makes the field; default the rod's own
        (uniform) area ``V_i / l_i``.

    Examples
    --------
    >>> sim.add_forcing_to(rod).using(
    ...     MagneticInteraction,
    ...     magnetization=yao2023_magnetization(pattern=2, n_elements=64),
    ...     source_area=8e-3 * 0.8e-3,
    ... )
    """

    def __init__(
        self,
        magnetization: NDArray[np.float64],
        frame: Literal["lab", "material"] = "lab",
        cutoff: float | None = None,
        source_area: float | None = None,
    ) -> None:
        super().__init__()
        if frame not in ("lab", "material"):
            raise ValueError(f"frame must be 'lab' or 'material', got {frame!r}")
        magnetization = np.asarray(magnetization, dtype=np.float64)
        if magnetization.ndim == 1 and magnetization.shape == (3,):
            magnetization = magnetization[:, None]
        if magnetization.ndim != 2 or magnetization.shape[0] != 3:
            raise ValueError(
                f"magnetization must have shape (3,) or (3, n_elements) in A/m, got {magnetization.shape}"
            )
        if not np.all(np.isfinite(magnetization)):
            raise ValueError("magnetization contains NaN or infinite values")
        if cutoff is not None and not (np.isfinite(cutoff) and cutoff >= 0.0):
            raise ValueError(f"cutoff must be a finite arclength >= 0 in m, got {cutoff}")
        if source_area is not None and not (np.isfinite(source_area) and source_area > 0.0):
            raise ValueError(f"source_area must be a positive area in m^2, got {source_area}")
        self.magnetization = magnetization
        self.frame = frame
        self.cutoff = cutoff
        self.source_area = source_area
        self._moment_material: NDArray[np.float64] | None = None
        self._first_partner: NDArray[np.int64] | None = None
        self._source_scale = 1.0

    def _prepare(self, system) -> None:
        """Fix the material-frame moments, the pair list and the source scale at the first call."""
        if self._moment_material is not None:
            return
        n_elements = system.n_elems
        magnetization = material_magnetization(self.magnetization, self.frame, system)
        rest_lengths = np.asarray(system.rest_lengths, dtype=np.float64)
        cutoff = (DEFAULT_CUTOFF_RADII * float(np.max(system.radius)) if self.cutoff is None
                  else float(self.cutoff))
        # Rest arclength of the element centres; partner j of i interacts when s_j - s_i >= cutoff.
        centres = np.cumsum(rest_lengths) - 0.5 * rest_lengths
        first = np.searchsorted(centres, centres + cutoff * (1.0 - 1e-12), side="left")
        self._first_partner = np.maximum(first, np.arange(n_elements) + 1).astype(np.int64)
        self.cutoff_used = cutoff
        if self.source_area is not None:
            area = np.asarray(system.volume) / rest_lengths
            if np.ptp(area) > 1e-9 * area.max():
                raise ValueError("source_area needs a rod of uniform cross-section area")
            self._source_scale = float(self.source_area / area[0])
        self._moment_material = np.ascontiguousarray(magnetization * system.volume[None, :])

    def moment_in_material_frame(self, system) -> NDArray[np.float64]:
        """The ``(3, n_elements)`` magnetic moments ``V M`` (A m^2) in the material frame."""
        self._prepare(system)
        return self._moment_material

    def apply_forces(self, system, time: np.float64 = np.float64(0.0)) -> None:
        # Forces and torques come out of one pair loop; both are applied here (apply_torques is a
        # no-op) so the O(n^2) loop runs once per step.
        self._prepare(system)
        _dipole_interaction(
            self._moment_material,
            system.director_collection,
            system.position_collection,
            self._first_partner,
            self._source_scale,
            system.external_forces,
            system.external_torques,
        )

    def apply_torques(self, system, time: np.float64 = np.float64(0.0)) -> None:
        pass

    def potential_energy(self, system) -> float:
        """Interaction energy ``-sum over pairs m_i . B_j(c_i)`` of the current configuration, J."""
        self._prepare(system)
        return float(
            _dipole_energy(
                self._moment_material,
                system.director_collection,
                system.position_collection,
                self._first_partner,
                self._source_scale,
            )
        )


@njit(cache=True)
def _lab_moments_and_centres(moment_material, directors, positions):
    """Moments ``Q^T m`` in the lab frame and element centres, both ``(3, n)``."""
    n = moment_material.shape[1]
    moments = np.empty((3, n))
    centres = np.empty((3, n))
    for i in range(n):
        for a in range(3):
            moments[a, i] = (
                directors[0, a, i] * moment_material[0, i]
                + directors[1, a, i] * moment_material[1, i]
                + directors[2, a, i] * moment_material[2, i]
            )
            centres[a, i] = 0.5 * (positions[a, i] + positions[a, i + 1])
    return moments, centres


@njit(cache=True)
def _dipole_interaction(
    moment_material: NDArray[np.float64],
    directors: NDArray[np.float64],
    positions: NDArray[np.float64],
    first_partner: NDArray[np.int64],
    source_scale: float,
    external_forces: NDArray[np.float64],
    external_torques: NDArray[np.float64],
) -> None:
    """Add the pair forces (half to each node) and torques (material frame) of all included pairs."""
    n = moment_material.shape[1]
    m, c = _lab_moments_and_centres(moment_material, directors, positions)
    force = np.zeros((3, n))
    torque = np.zeros((3, n))
    k_field = 1e-7 * source_scale  # mu0 / (4 pi), times the source scale
    for i in range(n):
        for j in range(first_partner[i], n):
            r0 = c[0, i] - c[0, j]
            r1 = c[1, i] - c[1, j]
            r2 = c[2, i] - c[2, j]
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            inv_d = 1.0 / np.sqrt(d2)
            n0, n1, n2 = r0 * inv_d, r1 * inv_d, r2 * inv_d
            mi0, mi1, mi2 = m[0, i], m[1, i], m[2, i]
            mj0, mj1, mj2 = m[0, j], m[1, j], m[2, j]
            min_ = mi0 * n0 + mi1 * n1 + mi2 * n2
            mjn = mj0 * n0 + mj1 * n1 + mj2 * n2
            mimj = mi0 * mj0 + mi1 * mj1 + mi2 * mj2
            kb = k_field * inv_d * inv_d * inv_d
            kf = 3.0 * kb * inv_d
            s = mimj - 5.0 * min_ * mjn
            f0 = kf * (min_ * mj0 + mjn * mi0 + s * n0)
            f1 = kf * (min_ * mj1 + mjn * mi1 + s * n1)
            f2 = kf * (min_ * mj2 + mjn * mi2 + s * n2)
            force[0, i] += f0
            force[1, i] += f1
            force[2, i] += f2
            force[0, j] -= f0
            force[1, j] -= f1
            force[2, j] -= f2
            # Field of j at i and of i at j (n flips sign but appears twice).
            bj0 = kb * (3.0 * n0 * mjn - mj0)
            bj1 = kb * (3.0 * n1 * mjn - mj1)
            bj2 = kb * (3.0 * n2 * mjn - mj2)
            bi0 = kb * (3.0 * n0 * min_ - mi0)
            bi1 = kb * (3.0 * n1 * min_ - mi1)
            bi2 = kb * (3.0 * n2 * min_ - mi2)
            torque[0, i] += mi1 * bj2 - mi2 * bj1
            torque[1, i] += mi2 * bj0 - mi0 * bj2
            torque[2, i] += mi0 * bj1 - mi1 * bj0
            torque[0, j] += mj1 * bi2 - mj2 * bi1
            torque[1, j] += mj2 * bi0 - mj0 * bi2
            torque[2, j] += mj0 * bi1 - mj1 * bi0
    for i in range(n):
        for a in range(3):
            half = 0.5 * force[a, i]
            external_forces[a, i] += half
            external_forces[a, i + 1] += half
            # Lab torque to the material frame: Q tau.
            external_torques[a, i] += (
                directors[a, 0, i] * torque[0, i]
                + directors[a, 1, i] * torque[1, i]
                + directors[a, 2, i] * torque[2, i]
            )


@njit(cache=True)
def _dipole_energy(moment_material, directors, positions, first_partner, source_scale) -> float:
    n = moment_material.shape[1]
    m, c = _lab_moments_and_centres(moment_material, directors, positions)
    energy = 0.0
    for i in range(n):
        for j in range(first_partner[i], n):
            r0 = c[0, i] - c[0, j]
            r1 = c[1, i] - c[1, j]
            r2 = c[2, i] - c[2, j]
            d = np.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
            min_ = (m[0, i] * r0 + m[1, i] * r1 + m[2, i] * r2) / d
            mjn = (m[0, j] * r0 + m[1, j] * r1 + m[2, j] * r2) / d
            mimj = m[0, i] * m[0, j] + m[1, i] * m[1, j] + m[2, i] * m[2, j]
            energy -= (3.0 * min_ * mjn - mimj) / (d * d * d)
    return 1e-7 * source_scale * energy
