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

Across the rod, PyElastica's model is that of a round rod, which rolls; the robots here are flat
bands, which cannot. ``sideways="sliding"`` gives a band's Coulomb friction across the rod (the
block kernel of :class:`~elastica_magnetic.BatchedRobots` on this one rod); in the plane of a planar
robot both models give the same motion to the last bit.

PyElastica's friction is explicit: a contact moving faster than ``slip_velocity_tol`` feels the
whole kinetic friction, which overshoots once a slide is slower than ``kinetic_mu g dt`` (the
speed it removes in one step), so a slide never quite stops and static friction never takes over
again. ``friction="implicit"`` (with ``sideways="sliding"``) solves Coulomb friction at each node
for its velocity at the end of the step instead (``_implicit_friction``): a slide ends at rest, a
node at rest needs ``static_mu`` N to start, friction never adds energy.
"""

from __future__ import annotations

import math

import numpy as np
from elastica.contact_forces import RodPlaneContactWithAnisotropicFriction
from numpy.typing import ArrayLike

from ._batch_kernels import (
    N_PARAMS,
    N_SCRATCH,
    P_DT,
    P_IMPLICIT,
    P_K,
    P_KINETIC_MU,
    P_NU,
    P_PLANE_NORMAL,
    P_PLANE_ORIGIN,
    P_SLIDING,
    P_SLIP_TOL,
    P_STATIC_MU,
    P_SURFACE_TOL,
    ground_contact,
)
from .robot_spec import FRICTION_INTEGRATION, IMPLICIT_NEEDS_SLIDING, SIDEWAYS_FRICTION

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
    sideways : {"rolling", "sliding"}
        Friction across the rod. ``"rolling"`` (default): PyElastica's model of a round rod,
        which rolls sideways (its no-slip force is that of a solid cylinder, ``F/3`` for a free
        element, and it spins the element about its axis). ``"sliding"``: a flat band, which
        cannot roll: Coulomb friction sideways as along the rod (sticks while the sideways load
        is below ``static_mu`` N, slides against ``kinetic_mu`` N) and no torque. Along the rod
        and in the plane of the paper's robot both give the same loads.
    friction : {"explicit", "implicit"}
        How the friction is integrated. ``"explicit"`` (default): PyElastica's (kinetic friction
        while a contact moves faster than ``slip_velocity_tol``; once a slide is slower than
        ``kinetic_mu g dt`` it overshoots every step and never quite stops). ``"implicit"``:
        Coulomb friction solved at each node for its velocity at the end of the step (a slide ends at
        rest, a node at rest needs ``static_mu`` N to start, friction never gains energy); needs
        ``sideways="sliding"``, one ``static_mu`` and one ``kinetic_mu`` (isotropic), and
        ``time_step``.
    time_step : float, optional
        The simulation's time step, s (``"implicit"`` only: the friction that stops a node within
        one step depends on it).
    """

    def __init__(
        self,
        k: float,
        nu: float,
        static_mu: float | ArrayLike,
        kinetic_mu: float | ArrayLike,
        surface_tolerance: float = 1e-7,
        slip_velocity_tol: float = 1e-8,
        sideways: str = "rolling",
        friction: str = "explicit",
        time_step: float | None = None,
    ) -> None:
        if sideways not in SIDEWAYS_FRICTION:
            raise ValueError(f"sideways must be one of {', '.join(SIDEWAYS_FRICTION)}, got "
                             f"{sideways!r}")
        if friction not in FRICTION_INTEGRATION:
            raise ValueError(f"friction must be one of {', '.join(FRICTION_INTEGRATION)}, got "
                             f"{friction!r}")
        if friction == "implicit":
            _check_implicit(sideways, static_mu, kinetic_mu, time_step)
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
        self.sideways = sideways
        self._params = np.zeros(N_PARAMS)
        self._params[P_K], self._params[P_NU] = self.k, self.nu
        self._params[P_SURFACE_TOL] = self.surface_tol
        self._params[P_SLIP_TOL] = slip_velocity_tol
        self._params[P_STATIC_MU:P_STATIC_MU + 3] = _mu_array(static_mu, "static_mu")
        self._params[P_KINETIC_MU:P_KINETIC_MU + 3] = _mu_array(kinetic_mu, "kinetic_mu")
        self._params[P_SLIDING] = 1.0 if sideways == "sliding" else 0.0
        self.friction = friction
        if friction == "implicit":
            self._params[P_IMPLICIT], self._params[P_DT] = 1.0, time_step
        self._scratch = np.zeros((N_SCRATCH, 0))

    def apply_contact(self, system_one, system_two, time: np.float64 = np.float64(0.0)) -> None:
        """PyElastica's kernel for ``"rolling"``; for ``"sliding"`` the block kernel of
        :class:`~elastica_magnetic.BatchedRobots` on this one rod (the same loads along the rod,
        Coulomb sliding across it, or the implicit friction)."""
        if self.sideways == "rolling":
            super().apply_contact(system_one, system_two, time)
            return
        n = system_one.n_elems
        if self._scratch.shape[1] < n:
            self._scratch = np.zeros((N_SCRATCH, n))
        self._params[P_PLANE_ORIGIN:P_PLANE_ORIGIN + 3] = np.ravel(system_two.origin)
        self._params[P_PLANE_NORMAL:P_PLANE_NORMAL + 3] = np.ravel(system_two.normal)
        ground_contact(0, 0, n, self._params, system_one.mass, system_one.radius,
                       system_one.tangents, system_one.position_collection,
                       system_one.director_collection, system_one.velocity_collection,
                       system_one.omega_collection, system_one.internal_forces,
                       system_one.external_forces, system_one.internal_torques,
                       system_one.external_torques, self._scratch)


def _check_implicit(sideways: str, static_mu: float | ArrayLike, kinetic_mu: float | ArrayLike,
                    time_step: float | None) -> None:
    """Refuses what the implicit friction cannot do: a rolling rod, anisotropic friction, no step."""
    if sideways != "sliding":
        raise ValueError(IMPLICIT_NEEDS_SLIDING)
    for name, mu in (("static_mu", static_mu), ("kinetic_mu", kinetic_mu)):
        array = _mu_array(mu, name)
        if not np.all(array == array[0]):
            raise ValueError(f'friction = "implicit" takes one {name} (isotropic friction), got {mu!r}')
    if time_step is None or not (math.isfinite(time_step) and time_step > 0.0):
        raise ValueError(f'friction = "implicit" needs the time_step in s (> 0), got {time_step!r}')


def _mu_array(mu: float | ArrayLike, name: str) -> np.ndarray:
    array = np.asarray(mu, dtype=np.float64)
    if array.ndim == 0:
        array = np.full(3, float(array))
    if array.shape != (3,) or not np.all(np.isfinite(array)) or np.any(array < 0.0):
        raise ValueError(
            f"{name} must be a coefficient >= 0 or (forward, backward, sideways), got {mu!r}"
        )
    return array
