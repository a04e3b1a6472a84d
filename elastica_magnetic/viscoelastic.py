"""Kelvin-Voigt internal damping: viscous stresses proportional to the strain rates of the rod.

Unlike the paper's dampings (:class:`~elastica_magnetic.RelativeVelocityDamping`,
:class:`~elastica_magnetic.LegacyInternalDamping`), it vanishes for every rigid motion, so a rod spinning
freely keeps spinning, and it conserves linear and angular momentum exactly. Units are SI.
"""

from __future__ import annotations

import numpy as np
from elastica.external_forces import NoForces
from numpy.typing import NDArray

from ._viscoelastic_kernels import kelvin_voigt_loads

__all__ = ["KelvinVoigtDamping"]


class KelvinVoigtDamping(NoForces):
    """Internal damping of a Kelvin-Voigt solid: stress = elastic stress + viscosity x strain rate.

    The viscous stress tensor is the elastic one with Young's modulus ``E`` replaced by the viscosity
    ``eta`` (the viscous part has the elastic part's Poisson ratio), so on each element ``e`` and
    each Voronoi region ``v`` between elements:

    - force (material frame) ``n_e = (eta / E) S_e d(sigma_e)/dt``: the axial part is
      ``eta A_e`` times the stretch rate, the shear parts ``eta (G / E) alpha_c A_e`` times the shear
      rates (``S`` is the rod's shear/stretch matrix);
    - couple ``c_v = (eta / E) B_v d(kappa_v)/dt``: ``eta I`` times the bending rates and
      ``eta (G / E) J`` times the twist rate (``B`` is the rod's bend/twist matrix).

    ``E`` is read from the rod (``S[2, 2] / A``). Every mode of the rod is then damped like a
    stiffness-proportional (Rayleigh) damping, with damping ratio ``zeta = eta * omega / (2 E)``
    at its angular frequency ``omega``.

    Strain rates, linear in the velocities and exact zero for rigid motion:
    ``d(sigma_e)/dt = (Q_e (v_{e+1} - v_e) - omega_e x Q_e (x_{e+1} - x_e)) / l0_e`` and
    ``d(kappa_v)/dt = Q_e (omega^lab_{e+1} - omega^lab_e) / D0_v`` (``l0``, ``D0`` rest lengths).
    Loads, as pairs that cancel: node ``e`` gets ``+Q_e^T n_e`` and node ``e + 1`` minus it,
    element ``e`` the couple ``(x_{e+1} - x_e) x Q_e^T n_e``; element ``e`` gets ``+c_v`` and
    element ``e + 1`` minus it (voronoi ``v = e``). Small strains: rest areas and moments of area.

    *Time step.* With an explicit integrator the viscous term is stable only for
    ``dt < 2 E / (eta omega_max^2)``, with ``omega_max`` the rod's highest frequency (element-scale
    bending and stretching): stiff viscosities need small steps (see :doc:`/extra_physics`).

    Parameters
    ----------
    viscosity : float
        ``eta``, Pa s (>= 0).
    """

    def __init__(self, viscosity: float) -> None:
        super().__init__()
        viscosity = float(viscosity)
        if not (np.isfinite(viscosity) and viscosity >= 0.0):
            raise ValueError(f"viscosity must be finite and >= 0 in Pa s, got {viscosity}")
        self.viscosity = np.float64(viscosity)
        self._shear_viscous: NDArray[np.float64] | None = None
        self._bend_viscous: NDArray[np.float64] | None = None

    def _prepare(self, system) -> None:
        """Viscous matrices ``(eta / E) S`` and ``(eta / E) B``, from the rod's rest state."""
        if self._shear_viscous is not None:
            return
        rest_lengths = np.asarray(system.rest_lengths)
        area = np.asarray(system.volume) / rest_lengths
        youngs = system.shear_matrix[2, 2, :] / area
        self._shear_viscous = np.ascontiguousarray(system.shear_matrix * (self.viscosity / youngs))
        # Voronoi regions: the rest-length-weighted mean modulus, as PyElastica averages B.
        youngs_v = (youngs[1:] * rest_lengths[1:] + youngs[:-1] * rest_lengths[:-1]) / (
            rest_lengths[1:] + rest_lengths[:-1]
        )
        self._bend_viscous = np.ascontiguousarray(system.bend_matrix * (self.viscosity / youngs_v))

    def apply_forces(self, system, time: np.float64 = np.float64(0.0)) -> None:
        # Forces and couples come from the same strain rates; both are added here (apply_torques
        # is a no-op), once per step.
        self._prepare(system)
        kelvin_voigt_loads(
            self._shear_viscous,
            self._bend_viscous,
            system.rest_lengths,
            system.rest_voronoi_lengths,
            system.position_collection,
            system.velocity_collection,
            system.director_collection,
            system.omega_collection,
            system.external_forces,
            system.external_torques,
        )

    def apply_torques(self, system, time: np.float64 = np.float64(0.0)) -> None:
        pass
