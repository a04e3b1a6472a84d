"""Ground contact with Coulomb friction and an adjustable surface tolerance.

PyElastica 1.0's :class:`~elastica.contact_forces.RodPlaneContactWithAnisotropicFriction` hard-codes
the contact detection band to 1e-4 m: an element closer than that to the plane counts as touching
(gets the normal response and friction). That is a fifth of the paper robot's radius (0.46 mm), so
elements visibly lifted off still feel friction. :class:`FrictionalGroundContact` is the same model
with the tolerance as a parameter (the authors' setting corresponds to 1e-7 m).

Use with the ``Contact`` mixin::

    plane = ea.Plane(plane_origin=np.array([0.0, -radius, 0.0]), plane_normal=np.array([0.0, 1, 0]))
    sim.append(plane)
    sim.detect_contact_between(rod, plane).using(
        FrictionalGroundContact, k=0.08, nu=6e-3, static_mu=0.8, kinetic_mu=0.6,
        surface_tolerance=1e-7,
    )

Register it after every other forcing of the rod: the plane's normal response cancels the loads
already accumulated on the rod when it runs.
"""

from __future__ import annotations

import math

import numpy as np
from elastica.contact_forces import RodPlaneContactWithAnisotropicFriction
from numpy.typing import ArrayLike

__all__ = ["FrictionalGroundContact"]


class FrictionalGroundContact(RodPlaneContactWithAnisotropicFriction):
    """Rod-plane contact (Gazzola et al. 2018, Eq. 4.8) with static and kinetic friction.

    Parameters
    ----------
    k : float
        Contact stiffness, N/m (normal force per unit penetration, per element).
    nu : float
        Contact damping, N s/m.
    static_mu, kinetic_mu : float or array_like
        Friction coefficients: one number for isotropic friction, or ``(forward, backward,
        sideways)`` as in PyElastica.
    surface_tolerance : float
        Detection band, m: an element whose surface is closer than this to the plane is in contact.
    slip_velocity_tol : float
        Velocity (m/s) below which an element counts as sticking (static friction).
    """

    def __init__(
        self,
        k: float,
        nu: float,
        static_mu: float | ArrayLike,
        kinetic_mu: float | ArrayLike,
        surface_tolerance: float = 1e-7,
        slip_velocity_tol: float = 1e-8,
    ) -> None:
        for name, value, unit in (
            ("k", k, "N/m"),
            ("nu", nu, "N s/m"),
            ("surface_tolerance", surface_tolerance, "m"),
            ("slip_velocity_tol", slip_velocity_tol, "m/s"),
        ):
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be finite and >= 0 in {unit}, got {value}")
        super().__init__(
            k=k,
            nu=nu,
            slip_velocity_tol=slip_velocity_tol,
            static_mu_array=_mu_array(static_mu, "static_mu"),
            kinetic_mu_array=_mu_array(kinetic_mu, "kinetic_mu"),
        )
        self.surface_tol = np.float64(surface_tolerance)


def _mu_array(mu: float | ArrayLike, name: str) -> np.ndarray:
    array = np.asarray(mu, dtype=np.float64)
    if array.ndim == 0:
        array = np.full(3, float(array))
    if array.shape != (3,) or not np.all(np.isfinite(array)) or np.any(array < 0.0):
        raise ValueError(
            f"{name} must be a coefficient >= 0 or (forward, backward, sideways), got {mu!r}"
        )
    return array
