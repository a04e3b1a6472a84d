"""The numba kernels of :class:`~elastica_magnetic.viscoelastic.KelvinVoigtDamping` (private: the
class is the public entry).

They compute the viscous loads the way PyElastica computes the elastic ones
(``_compute_shear_stretch_strains``, ``_compute_internal_forces``, ``_compute_bending_twist_strains``,
``_compute_internal_torques``), with the strains replaced by their rates, element by element and Voronoi
region by Voronoi region. SI units.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["kelvin_voigt_loads"]


@njit(cache=True)
def kelvin_voigt_loads(
    shear_viscous: NDArray[np.float64],
    bend_viscous: NDArray[np.float64],
    rest_lengths: NDArray[np.float64],
    rest_voronoi_lengths: NDArray[np.float64],
    positions: NDArray[np.float64],
    velocities: NDArray[np.float64],
    directors: NDArray[np.float64],
    omegas: NDArray[np.float64],
    external_forces: NDArray[np.float64],
    external_torques: NDArray[np.float64],
) -> None:
    """Add the Kelvin-Voigt viscous forces (N, lab frame, ``(3, n + 1)``) and couples (N m,
    material frame, ``(3, n)``) of a rod of ``n`` elements to its external loads: the
    stretch/shear part on the elements, then the bend/twist part on the Voronoi regions.
    ``shear_viscous (3, 3, n)`` and ``bend_viscous (3, 3, n - 1)`` are ``(eta / E) S`` and
    ``(eta / E) B``."""
    _stretch_and_shear(shear_viscous, rest_lengths, positions, velocities, directors, omegas,
                       external_forces, external_torques)
    _bend_and_twist(bend_viscous, rest_voronoi_lengths, directors, omegas, external_torques)


@njit(cache=True)
def _stretch_and_shear(
    shear_viscous: NDArray[np.float64],
    rest_lengths: NDArray[np.float64],
    positions: NDArray[np.float64],
    velocities: NDArray[np.float64],
    directors: NDArray[np.float64],
    omegas: NDArray[np.float64],
    external_forces: NDArray[np.float64],
    external_torques: NDArray[np.float64],
) -> None:
    """Per element: the material-frame stretch/shear rate, its viscous stress, the force on the
    element's two nodes and the couple of that node pair."""
    n = rest_lengths.shape[0]
    qdx = np.empty(3)
    qdv = np.empty(3)
    rate = np.empty(3)
    stress = np.empty(3)
    for e in range(n):
        inv_l0 = 1.0 / rest_lengths[e]
        for a in range(3):
            sx = 0.0
            sv = 0.0
            for b in range(3):
                sx += directors[a, b, e] * (positions[b, e + 1] - positions[b, e])
                sv += directors[a, b, e] * (velocities[b, e + 1] - velocities[b, e])
            qdx[a] = sx
            qdv[a] = sv
        w0, w1, w2 = omegas[0, e], omegas[1, e], omegas[2, e]
        # Material-frame strain rate: Q dv / l0 - omega x (Q dx / l0).
        rate[0] = (qdv[0] - (w1 * qdx[2] - w2 * qdx[1])) * inv_l0
        rate[1] = (qdv[1] - (w2 * qdx[0] - w0 * qdx[2])) * inv_l0
        rate[2] = (qdv[2] - (w0 * qdx[1] - w1 * qdx[0])) * inv_l0
        for a in range(3):
            stress[a] = (
                shear_viscous[a, 0, e] * rate[0]
                + shear_viscous[a, 1, e] * rate[1]
                + shear_viscous[a, 2, e] * rate[2]
            )
        for b in range(3):
            force = directors[0, b, e] * stress[0] + directors[1, b, e] * stress[1]
            force += directors[2, b, e] * stress[2]
            external_forces[b, e] += force
            external_forces[b, e + 1] -= force
        # Couple of the node pair on the element, material frame: (Q dx) x n.
        external_torques[0, e] += qdx[1] * stress[2] - qdx[2] * stress[1]
        external_torques[1, e] += qdx[2] * stress[0] - qdx[0] * stress[2]
        external_torques[2, e] += qdx[0] * stress[1] - qdx[1] * stress[0]


@njit(cache=True)
def _bend_and_twist(
    bend_viscous: NDArray[np.float64],
    rest_voronoi_lengths: NDArray[np.float64],
    directors: NDArray[np.float64],
    omegas: NDArray[np.float64],
    external_torques: NDArray[np.float64],
) -> None:
    """Per Voronoi region: the bend/twist rate (difference of the neighbours' lab-frame angular
    velocities, in the first one's frame), its viscous couple, added to one element and taken
    from the next."""
    n = rest_voronoi_lengths.shape[0] + 1
    rate = np.empty(3)
    stress = np.empty(3)
    omega_lab = np.empty((3, n))
    for e in range(n):
        for b in range(3):
            omega_lab[b, e] = (
                directors[0, b, e] * omegas[0, e]
                + directors[1, b, e] * omegas[1, e]
                + directors[2, b, e] * omegas[2, e]
            )
    couple_lab = np.empty(3)
    for v in range(n - 1):
        inv_d0 = 1.0 / rest_voronoi_lengths[v]
        for a in range(3):
            s = 0.0
            for b in range(3):
                s += directors[a, b, v] * (omega_lab[b, v + 1] - omega_lab[b, v])
            rate[a] = s * inv_d0
        for a in range(3):
            stress[a] = (
                bend_viscous[a, 0, v] * rate[0]
                + bend_viscous[a, 1, v] * rate[1]
                + bend_viscous[a, 2, v] * rate[2]
            )
            external_torques[a, v] += stress[a]
        for b in range(3):
            couple_lab[b] = (
                directors[0, b, v] * stress[0]
                + directors[1, b, v] * stress[1]
                + directors[2, b, v] * stress[2]
            )
        for a in range(3):
            external_torques[a, v + 1] -= (
                directors[a, 0, v + 1] * couple_lab[0]
                + directors[a, 1, v + 1] * couple_lab[1]
                + directors[a, 2, v + 1] * couple_lab[2]
            )
