"""Implicit Coulomb friction at the nodes of a rod on a plane (the ground's ``friction = "implicit"``).

PyElastica's friction is explicit: an element slides against ``kinetic_mu N`` whenever its speed is
above ``slip_velocity_tol`` (1e-8 m/s), and only below that does static friction hold. Once a slide
slows below ``kinetic_mu g dt`` (the speed the kinetic friction removes in one step, 56 um/s for the
paper's robot) the friction overshoots every step: the velocity flips sign, never gets below the
tolerance, static friction never takes over, and the kinetic energy can grow.

Here the friction of each node is solved for the node's velocity at the end of the step (PyElastica's
steppers update ``v += dt F / m`` with the loads of the step), given every other load on it:

- trial momentum ``p = m v_t + dt F_t`` (tangential parts: in the plane);
- the node sticks (friction ``-p / dt``, its tangential velocity ends at 0) if the kinetic friction
  would stop it within the step, ``|p| <= dt mu_k N``, or if it is at rest (``|v_t| <=
  slip_velocity_tol``) and the static friction holds the load, ``|p| <= dt mu_s N``;
- otherwise it slides against ``mu_k N`` opposite the trial velocity: it slows, never reverses.

So a slide ends at rest, a node at rest needs ``mu_s N`` to start, and the friction's work is never
positive within a step. ``N`` of a node is half the normal load of each element beside it that
touches the plane (PyElastica's normal response). Friction is isotropic (one ``mu_s``, one ``mu_k``):
a flat band slides the same along and across itself; no torque (a band does not roll).

Units: m, kg, s, N.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray


@njit(cache=True, error_model="numpy")
def implicit_coulomb_friction(
    ns: int,
    n: int,
    mu_s: float,
    mu_k: float,
    slip_tol: float,
    dt: float,
    normal: NDArray[np.float64],
    mass: NDArray[np.float64],
    velocities: NDArray[np.float64],
    internal_forces: NDArray[np.float64],
    external_forces: NDArray[np.float64],
    element_load: NDArray[np.float64],
    no_contact: NDArray[np.float64],
) -> None:
    """Adds the friction of nodes ``ns .. ns + n`` (the ``n`` elements' nodes) to ``external_forces``.

    ``slip_tol``: the speed (m/s) below which a node is at rest; ``dt``: the time step, s;
    ``normal``: the plane's unit normal ``(3,)``; ``element_load``: each element's normal load, N
    ``(>= n,)``, read where ``no_contact`` is 0. Call it last, once every other load of the step is
    in ``internal_forces + external_forces``.
    """
    n0 = normal[0]
    n1 = normal[1]
    n2 = normal[2]
    for j in range(n + 1):
        load = 0.0
        if j > 0 and no_contact[j - 1] == 0.0:
            load += 0.5 * element_load[j - 1]
        if j < n and no_contact[j] == 0.0:
            load += 0.5 * element_load[j]
        if load <= 0.0:
            continue
        a = ns + j
        m = mass[a]
        f0 = internal_forces[0, a] + external_forces[0, a]
        f1 = internal_forces[1, a] + external_forces[1, a]
        f2 = internal_forces[2, a] + external_forces[2, a]
        v0 = velocities[0, a]
        v1 = velocities[1, a]
        v2 = velocities[2, a]
        v_normal = v0 * n0 + v1 * n1 + v2 * n2
        f_normal = f0 * n0 + f1 * n1 + f2 * n2
        v0 -= v_normal * n0
        v1 -= v_normal * n1
        v2 -= v_normal * n2
        p0 = m * v0 + dt * (f0 - f_normal * n0)
        p1 = m * v1 + dt * (f1 - f_normal * n1)
        p2 = m * v2 + dt * (f2 - f_normal * n2)
        momentum = math.sqrt(p0 * p0 + p1 * p1 + p2 * p2)
        speed = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
        if momentum <= dt * mu_k * load or (speed <= slip_tol and momentum <= dt * mu_s * load):
            scale = 1.0 / dt  # stick: the tangential velocity ends the step at 0
        else:
            scale = mu_k * load / momentum  # slide against mu_k N, opposite the trial velocity
        external_forces[0, a] -= scale * p0
        external_forces[1, a] -= scale * p1
        external_forces[2, a] -= scale * p2
