"""The batched kernel's parameters of one robot: how a :class:`~elastica_magnetic.RobotSpec`
fills its row of :func:`~elastica_magnetic._batch_kernels.block_forcing`'s parameter table
(damping, gravity, the ground plane and its friction) and its option flags."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._batch_kernels import (
    N_PARAMS,
    O_DAMPING,
    O_GRAVITY,
    O_GROUND,
    O_NODE_OFFSET,
    P_DT,
    P_GRAVITY,
    P_IMPLICIT,
    P_K,
    P_KINETIC_MU,
    P_LEGACY_FORCE,
    P_LEGACY_TORQUE,
    P_NU,
    P_PLANE_NORMAL,
    P_PLANE_ORIGIN,
    P_RELATIVE_NU,
    P_SLIDING,
    P_SLIP_TOL,
    P_STATIC_MU,
    P_SURFACE_TOL,
)
from .robot_spec import RobotSpec

__all__ = ["kernel_parameters"]


def kernel_parameters(spec: RobotSpec) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """One robot's row of the block kernel's parameters ``(N_PARAMS,)`` (damping, gravity in m/s^2, the ground
    plane, its stiffness, damping and friction) and option flags ``(4,)`` for ``spec``; refuses a
    damping ``node_offset`` beyond the rod's nodes."""
    params = np.zeros(N_PARAMS)
    options = np.zeros(4, dtype=np.int64)
    if spec.damping is not None:
        options[O_DAMPING] = 1
        options[O_NODE_OFFSET] = spec.damping.node_offset
        if spec.damping.node_offset >= spec.n_elements + 1:
            raise ValueError(
                f"node_offset {spec.damping.node_offset} must be smaller than the number of nodes "
                f"({spec.n_elements + 1})"
            )
        params[P_RELATIVE_NU] = spec.damping.relative_nu
        params[P_LEGACY_FORCE] = spec.damping.legacy_force
        params[P_LEGACY_TORQUE] = spec.damping.legacy_torque
    if spec.gravity > 0.0:
        options[O_GRAVITY] = 1
        params[P_GRAVITY : P_GRAVITY + 3] = [0.0, -spec.effective_gravity, 0.0]
    if spec.ground is not None:
        g = spec.ground
        options[O_GROUND] = 1
        params[P_PLANE_ORIGIN : P_PLANE_ORIGIN + 3] = [0.0, -spec.radius, 0.0]
        params[P_PLANE_NORMAL : P_PLANE_NORMAL + 3] = [0.0, 1.0, 0.0]
        params[P_K] = g.k
        params[P_NU] = g.nu
        params[P_SURFACE_TOL] = g.surface_tolerance
        params[P_SLIP_TOL] = g.slip_velocity_tol
        params[P_STATIC_MU : P_STATIC_MU + 3] = _mu3(g.static_mu)
        params[P_KINETIC_MU : P_KINETIC_MU + 3] = _mu3(g.kinetic_mu)
        params[P_SLIDING] = 1.0 if g.sideways == "sliding" else 0.0
        params[P_IMPLICIT] = 1.0 if g.friction == "implicit" else 0.0
        params[P_DT] = spec.dt
    return params, options


def _mu3(mu: float | ArrayLike) -> NDArray[np.float64]:
    """Friction coefficients as ``(forward, backward, sideways)``."""
    array = np.asarray(mu, dtype=np.float64)
    return np.full(3, float(array)) if array.ndim == 0 else array.reshape(3)
