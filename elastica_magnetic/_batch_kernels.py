"""The numba kernels of :mod:`elastica_magnetic.batch` (private: its
:class:`~elastica_magnetic.batch.BatchedRobots` is the public entry, and
:meth:`~elastica_magnetic.batch.BatchedRobots.apply_forcing` runs the block kernel once): the forcing
of every robot of a PyElastica memory block in one call, and the health check of the block.

They repeat, element by element, the floating-point operations of the per-rod forcing classes and
of PyElastica's array code, in the same order, so a batched robot's trajectory is bit-identical to
the per-rod one (``tests/test_batch.py``). The parameter vector, option flags and scratch rows the
kernels read are laid out by the constants below; :class:`~elastica_magnetic.batch.BatchedRobots`
fills them.

Units: those of the spec (SI for the presets): m, kg, s, N, T.

:func:`block_forcing` and :func:`ground_contact` are longer than the project's ~80 lines, and this
file longer than its ~600, on purpose: they mirror PyElastica's operations one for one (see their
docstrings), the one allowed exception to those limits.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from ._implicit_friction import implicit_coulomb_friction

# Layout of the float parameter vector handed to the kernel.
P_RELATIVE_NU = 0
P_LEGACY_FORCE = 1
P_LEGACY_TORQUE = 2
P_GRAVITY = 3  # 3 entries, m/s^2
P_PLANE_ORIGIN = 6  # 3 entries, m
P_PLANE_NORMAL = 9  # 3 entries
P_K = 12
P_NU = 13
P_SURFACE_TOL = 14
P_SLIP_TOL = 15
P_STATIC_MU = 16  # forward, backward, sideways
P_KINETIC_MU = 19  # forward, backward, sideways
P_SLIDING = 22  # 1: sideways Coulomb sliding (a flat band), 0: PyElastica's rolling (a round rod)
P_IMPLICIT = 23  # 1: implicit Coulomb friction at the nodes (_implicit_friction), 0: PyElastica's explicit
P_DT = 24  # the time step, s (read by the implicit friction only)
N_PARAMS = 25

# Layout of the integer option vector.
O_DAMPING = 0
O_NODE_OFFSET = 1
O_GRAVITY = 2
O_GROUND = 3

# Rows of the per-robot scratch array (each row has one column per element).
S_VELOCITY = 0  # 3 rows: mass-weighted element velocity
S_RESPONSE = 3  # 3 rows: total plane response (normal part) of the element
S_RESPONSE_MAG = 6
S_NO_CONTACT = 7
S_AXIAL = 8  # 3 rows
S_ROLLING = 11  # 3 rows
S_SLIP_AXIAL = 14
S_SLIP_ROLLING = 15
S_ARM = 16  # 3 rows: torque arm -normal * radius
S_FRICTION = 19  # 3 rows: kinetic rolling, then static axial friction force
S_ELEMENT_FORCE = 22  # 3 rows: element total force before the static friction
N_SCRATCH = 25


# --------------------------------------------------------------------------------------------------
# Kernels. They repeat, element by element, the floating-point operations of PyElastica's array code
# (``_calculate_contact_forces_rod_plane_with_anisotropic_friction`` and its helpers) and of the
# per-rod forcing kernels, in the same order, so the results are bit-identical. Do not "simplify"
# expressions such as ``0.0 + a * b``: they mirror accumulators that start from zero.


@njit(cache=True, error_model="numpy")
def _sign(x: float) -> float:
    """``np.sign``: 1, -1, 0, or NaN for NaN."""
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    if x == 0.0:
        return 0.0
    return x


@njit(cache=True, error_model="numpy")
def _minimum(a: float, b: float) -> float:
    """``np.minimum`` of two scalars (NaN propagates)."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a <= b else b


@njit(cache=True, error_model="numpy")
def _slip_function(v0: float, v1: float, v2: float, tolerance: float) -> float:
    """PyElastica's ``_find_slipping_elements`` for one element: 1 sticking, 0 slipping."""
    speed = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    if math.fabs(speed) > tolerance:
        return math.fabs(1.0 - _minimum(1.0, speed / tolerance - 1.0))
    return 1.0


@njit(cache=True, error_model="numpy")
def _times(
    directors: NDArray[np.float64], e: int, x0: float, x1: float, x2: float
) -> tuple[float, float, float]:
    """``Q_e x`` (rows of element ``e``'s director times ``x``), accumulated from zero."""
    y0 = 0.0 + directors[0, 0, e] * x0
    y0 += directors[0, 1, e] * x1
    y0 += directors[0, 2, e] * x2
    y1 = 0.0 + directors[1, 0, e] * x0
    y1 += directors[1, 1, e] * x1
    y1 += directors[1, 2, e] * x2
    y2 = 0.0 + directors[2, 0, e] * x0
    y2 += directors[2, 1, e] * x1
    y2 += directors[2, 2, e] * x2
    return y0, y1, y2


@njit(cache=True, error_model="numpy")
def _transpose_times(
    directors: NDArray[np.float64], e: int, x0: float, x1: float, x2: float
) -> tuple[float, float, float]:
    """``Q_e^T x`` (columns of element ``e``'s director times ``x``), accumulated from zero."""
    y0 = 0.0 + directors[0, 0, e] * x0
    y0 += directors[1, 0, e] * x1
    y0 += directors[2, 0, e] * x2
    y1 = 0.0 + directors[0, 1, e] * x0
    y1 += directors[1, 1, e] * x1
    y1 += directors[2, 1, e] * x2
    y2 = 0.0 + directors[0, 2, e] * x0
    y2 += directors[1, 2, e] * x1
    y2 += directors[2, 2, e] * x2
    return y0, y1, y2


@njit(cache=True, error_model="numpy")
def _element_force(
    internal_forces: NDArray[np.float64],
    external_forces: NDArray[np.float64],
    a: int,
    first: bool,
    last: bool,
) -> tuple[float, float, float]:
    """Total force on the element between nodes ``a`` and ``a + 1`` (N): PyElastica's
    ``node_to_element_pos_or_vel`` of internal + external forces, the end elements taking the
    whole load of their end node."""
    ef0 = 0.0 + 0.5 * (
        (internal_forces[0, a] + external_forces[0, a])
        + (internal_forces[0, a + 1] + external_forces[0, a + 1])
    )
    ef1 = 0.0 + 0.5 * (
        (internal_forces[1, a] + external_forces[1, a])
        + (internal_forces[1, a + 1] + external_forces[1, a + 1])
    )
    ef2 = 0.0 + 0.5 * (
        (internal_forces[2, a] + external_forces[2, a])
        + (internal_forces[2, a + 1] + external_forces[2, a + 1])
    )
    if first:
        ef0 += 0.5 * (internal_forces[0, a] + external_forces[0, a])
        ef1 += 0.5 * (internal_forces[1, a] + external_forces[1, a])
        ef2 += 0.5 * (internal_forces[2, a] + external_forces[2, a])
    if last:
        ef0 += 0.5 * (internal_forces[0, a + 1] + external_forces[0, a + 1])
        ef1 += 0.5 * (internal_forces[1, a + 1] + external_forces[1, a + 1])
        ef2 += 0.5 * (internal_forces[2, a + 1] + external_forces[2, a + 1])
    return ef0, ef1, ef2


@njit(cache=True, error_model="numpy")
def _spread_to_nodes(
    external_forces: NDArray[np.float64], s: NDArray[np.float64], row: int, ns: int, n: int
) -> None:
    """Half of each element's force (scratch rows ``row .. row + 2``) to each of its two nodes,
    for the elements in contact."""
    for k in range(n):
        if s[S_NO_CONTACT, k] != 0.0:
            continue
        a = ns + k
        for d in range(3):
            half = 0.5 * s[row + d, k]
            external_forces[d, a] += half
            external_forces[d, a + 1] += half


@njit(cache=True, error_model="numpy")
def block_forcing(
    fields: NDArray[np.float64],
    moments: NDArray[np.float64],
    node_start: NDArray[np.int64],
    node_end: NDArray[np.int64],
    elem_start: NDArray[np.int64],
    elem_end: NDArray[np.int64],
    options: NDArray[np.int64],
    params: NDArray[np.float64],
    mass: NDArray[np.float64],
    radius: NDArray[np.float64],
    lengths: NDArray[np.float64],
    tangents: NDArray[np.float64],
    positions: NDArray[np.float64],
    directors: NDArray[np.float64],
    velocities: NDArray[np.float64],
    omegas: NDArray[np.float64],
    internal_forces: NDArray[np.float64],
    external_forces: NDArray[np.float64],
    internal_torques: NDArray[np.float64],
    external_torques: NDArray[np.float64],
    scratch: NDArray[np.float64],
) -> None:
    """All forcing of all robots of a memory block, in the per-rod registration order.

    Longer than the project's ~80 lines on purpose: it mirrors, operation for operation, the
    per-rod forcing classes PyElastica would call one after the other (magnetic torques, damping,
    gravity, the ground), so that the batched trajectory is bit-identical to the per-rod one;
    split into functions, the order of the floating-point operations would be harder to check
    against them.

    Shapes: ``fields (N, 3)`` T; ``moments (3, n_elems)`` A m^2 (material frame); ``params
    (N, N_PARAMS)``, one row per robot (each robot may have its own damping, gravity, ground and
    friction; ``options`` are shared); index arrays
    ``(N,)`` (start inclusive, end exclusive, block indices, ghosts excluded); block arrays as in
    :class:`~elastica.memory_block.memory_block_rod.MemoryBlockCosseratRod` (``(n_nodes,)``,
    ``(3, n_nodes)``, ``(n_elems,)``, ``(3, n_elems)``, ``(3, 3, n_elems)``); ``scratch
    (N_SCRATCH, n_elements_per_robot)``. Forces in N, torques in N m (material frame), added to
    ``external_forces`` and ``external_torques``.
    """
    offset = options[O_NODE_OFFSET]
    for r in range(fields.shape[0]):
        ns = node_start[r]
        ne = node_end[r]
        es = elem_start[r]
        ee = elem_end[r]
        p = params[r]
        # Magnetic torques, m x (Q B) (MagneticTorques).
        bx = fields[r, 0]
        by = fields[r, 1]
        bz = fields[r, 2]
        for e in range(es, ee):
            b0 = directors[0, 0, e] * bx + directors[0, 1, e] * by
            b0 += directors[0, 2, e] * bz
            b1 = directors[1, 0, e] * bx + directors[1, 1, e] * by
            b1 += directors[1, 2, e] * bz
            b2 = directors[2, 0, e] * bx + directors[2, 1, e] * by
            b2 += directors[2, 2, e] * bz
            m0 = moments[0, e]
            m1 = moments[1, e]
            m2 = moments[2, e]
            external_torques[0, e] += m1 * b2 - m2 * b1
            external_torques[1, e] += m2 * b0 - m0 * b2
            external_torques[2, e] += m0 * b1 - m1 * b0
        if options[O_DAMPING]:
            # RelativeVelocityDamping.
            nu = p[P_RELATIVE_NU]
            for j in range(ne - ns - offset):
                c = nu * lengths[es + j]
                a = ns + j
                for d in range(3):
                    f = c * (velocities[d, a + offset] - velocities[d, a])
                    external_forces[d, a] += f
                    external_forces[d, a + offset] -= f
            # LegacyInternalDamping: forces, then torques.
            coefficient = p[P_LEGACY_FORCE]
            for k in range(ee - es):
                c = 0.25 * coefficient * lengths[es + k]
                a = ns + k
                for d in range(3):
                    f = c * (velocities[d, a] + velocities[d, a + 1])
                    external_forces[d, a] -= f
                    external_forces[d, a + 1] -= f
            coefficient = p[P_LEGACY_TORQUE]
            for e in range(es, ee):
                c = coefficient * lengths[e]
                for d in range(3):
                    external_torques[d, e] -= c * omegas[d, e]
        if options[O_GRAVITY]:
            for d in range(3):
                g = p[P_GRAVITY + d]
                for a in range(ns, ne):
                    external_forces[d, a] += g * mass[a]
        if options[O_GROUND]:
            ground_contact(
                ns,
                es,
                ee - es,
                p,
                mass,
                radius,
                tangents,
                positions,
                directors,
                velocities,
                omegas,
                internal_forces,
                external_forces,
                internal_torques,
                external_torques,
                scratch,
            )


@njit(cache=True, error_model="numpy")
def ground_contact(
    ns: int,
    es: int,
    n: int,
    params: NDArray[np.float64],
    mass: NDArray[np.float64],
    radius: NDArray[np.float64],
    tangents: NDArray[np.float64],
    positions: NDArray[np.float64],
    directors: NDArray[np.float64],
    velocities: NDArray[np.float64],
    omegas: NDArray[np.float64],
    internal_forces: NDArray[np.float64],
    external_forces: NDArray[np.float64],
    internal_torques: NDArray[np.float64],
    external_torques: NDArray[np.float64],
    s: NDArray[np.float64],
) -> None:
    """Rod-plane contact with anisotropic Coulomb friction for one robot of the block.

    PyElastica's ``_calculate_contact_forces_rod_plane_with_anisotropic_friction`` restricted to
    nodes ``ns .. ns + n`` and elements ``es .. es + n - 1``; ``s`` is scratch ``(N_SCRATCH, >= n)``.
    Longer than the project's ~80 lines on purpose: it mirrors that PyElastica function operation
    for operation (bit-identical loads, ``tests/test_batch.py``), so it keeps its structure.
    Elements farther than the surface tolerance from the plane are skipped: PyElastica computes
    their response and friction and then sets all of them to zero, so skipping them gives the same
    loads (up to the sign of zero). With ``params[P_IMPLICIT]`` set the friction after the normal
    response is :func:`~elastica_magnetic._implicit_friction.implicit_coulomb_friction` instead.
    """
    o0 = params[P_PLANE_ORIGIN]
    o1 = params[P_PLANE_ORIGIN + 1]
    o2 = params[P_PLANE_ORIGIN + 2]
    n0 = params[P_PLANE_NORMAL]
    n1 = params[P_PLANE_NORMAL + 1]
    n2 = params[P_PLANE_NORMAL + 2]
    k_contact = params[P_K]
    nu_contact = params[P_NU]
    surface_tol = params[P_SURFACE_TOL]
    slip_tol = params[P_SLIP_TOL]
    static_forward = params[P_STATIC_MU]
    static_backward = params[P_STATIC_MU + 1]
    static_sideways = params[P_STATIC_MU + 2]
    kinetic_forward = params[P_KINETIC_MU]
    kinetic_backward = params[P_KINETIC_MU + 1]
    kinetic_sideways = params[P_KINETIC_MU + 2]
    sliding = params[P_SLIDING] != 0.0
    last = n - 1

    # 1. Normal response (_calculate_contact_forces_rod_plane): computed for every element in
    # contact from the loads accumulated so far, then spread to the nodes.
    for k in range(n):
        a = ns + k
        e = es + k
        distance = 0.0 + n0 * (0.5 * (positions[0, a + 1] + positions[0, a]) - o0)
        distance += n1 * (0.5 * (positions[1, a + 1] + positions[1, a]) - o1)
        distance += n2 * (0.5 * (positions[2, a + 1] + positions[2, a]) - o2)
        gap = distance - radius[e]
        if gap > surface_tol:
            # Lifted off: PyElastica computes this element's loads and then zeroes them all.
            s[S_NO_CONTACT, k] = 1.0
            continue
        s[S_NO_CONTACT, k] = 0.0
        ef0, ef1, ef2 = _element_force(internal_forces, external_forces, a, k == 0, k == last)
        f_normal = 0.0 + n0 * ef0
        f_normal += n1 * ef1
        f_normal += n2 * ef2
        if f_normal > 0.0:
            r0 = -0.0
            r1 = -0.0
            r2 = -0.0
        else:
            r0 = -(n0 * f_normal)
            r1 = -(n1 * f_normal)
            r2 = -(n2 * f_normal)
        penetration = _minimum(gap, 0.0)
        m_sum = mass[a + 1] + mass[a]
        v0 = (mass[a + 1] * velocities[0, a + 1] + mass[a] * velocities[0, a]) / m_sum
        v1 = (mass[a + 1] * velocities[1, a + 1] + mass[a] * velocities[1, a]) / m_sum
        v2 = (mass[a + 1] * velocities[2, a + 1] + mass[a] * velocities[2, a]) / m_sum
        v_normal = 0.0 + n0 * v0
        v_normal += n1 * v1
        v_normal += n2 * v2
        t0 = (r0 + -k_contact * (n0 * penetration)) + -nu_contact * (n0 * v_normal)
        t1 = (r1 + -k_contact * (n1 * penetration)) + -nu_contact * (n1 * v_normal)
        t2 = (r2 + -k_contact * (n2 * penetration)) + -nu_contact * (n2 * v_normal)
        s[S_VELOCITY, k] = v0
        s[S_VELOCITY + 1, k] = v1
        s[S_VELOCITY + 2, k] = v2
        s[S_RESPONSE, k] = t0
        s[S_RESPONSE + 1, k] = t1
        s[S_RESPONSE + 2, k] = t2
        s[S_RESPONSE_MAG, k] = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
    _spread_to_nodes(external_forces, s, S_RESPONSE, ns, n)
    if params[P_IMPLICIT] != 0.0:  # the ground's friction = "implicit": solved at the nodes instead
        implicit_coulomb_friction(ns, n, static_forward, kinetic_forward, slip_tol, params[P_DT],
                                  params[P_PLANE_NORMAL:P_PLANE_NORMAL + 3], mass, velocities,
                                  internal_forces, external_forces, s[S_RESPONSE_MAG], s[S_NO_CONTACT])
        return

    # 2. Kinetic friction, axial then rolling (reads no loads: axial forces are spread in the loop).
    for k in range(n):
        if s[S_NO_CONTACT, k] != 0.0:
            continue
        a = ns + k
        e = es + k
        tg0 = tangents[0, e]
        tg1 = tangents[1, e]
        tg2 = tangents[2, e]
        tg_normal = 0.0 + n0 * tg0
        tg_normal += n1 * tg1
        tg_normal += n2 * tg2
        p0 = tg0 - n0 * tg_normal
        p1 = tg1 - n1 * tg_normal
        p2 = tg2 - n2 * tg_normal
        inv = 1 / (math.sqrt(p0 * p0 + p1 * p1 + p2 * p2) + 1e-14)
        ax0 = inv * p0
        ax1 = inv * p1
        ax2 = inv * p2
        v0 = s[S_VELOCITY, k]
        v1 = s[S_VELOCITY + 1, k]
        v2 = s[S_VELOCITY + 2, k]
        v_axial = 0.0 + v0 * ax0
        v_axial += v1 * ax1
        v_axial += v2 * ax2
        va0 = v_axial * ax0
        va1 = v_axial * ax1
        va2 = v_axial * ax2
        sign = _sign(v_axial)
        kinetic_mu = 0.5 * (kinetic_forward * (1 + sign) + kinetic_backward * (1 - sign))
        slip_axial = _slip_function(va0, va1, va2, slip_tol)
        ro0 = ax1 * n2 - ax2 * n1
        ro1 = ax2 * n0 - ax0 * n2
        ro2 = ax0 * n1 - ax1 * n0
        arm0 = -n0 * radius[e]
        arm1 = -n1 * radius[e]
        arm2 = -n2 * radius[e]
        v_rolling = 0.0 + v0 * ro0
        v_rolling += v1 * ro1
        v_rolling += v2 * ro2
        if sliding:  # a band slides sideways: its spin moves no contact point
            slip_speed = v_rolling
        else:  # a round rod's contact point moves with the spin: Q^T (omega x (Q arm))
            q0, q1, q2 = _times(directors, e, arm0, arm1, arm2)
            w0 = omegas[0, e]
            w1 = omegas[1, e]
            w2 = omegas[2, e]
            c0 = w1 * q2 - w2 * q1
            c1 = w2 * q0 - w0 * q2
            c2 = w0 * q1 - w1 * q0
            rv0, rv1, rv2 = _transpose_times(directors, e, c0, c1, c2)
            rv_rolling = 0.0 + rv0 * ro0
            rv_rolling += rv1 * ro1
            rv_rolling += rv2 * ro2
            slip_speed = v_rolling + rv_rolling
        sr0 = slip_speed * ro0
        sr1 = slip_speed * ro1
        sr2 = slip_speed * ro2
        slip_rolling = _slip_function(sr0, sr1, sr2, slip_tol)
        u0 = sr0 + va0
        u1 = sr1 + va1
        u2 = sr2 + va2
        d0 = u0 + 1e-14
        d1 = u1 + 1e-14
        d2 = u2 + 1e-14
        u_norm = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        u0 = u0 / u_norm
        u1 = u1 / u_norm
        u2 = u2 / u_norm
        magnitude = s[S_RESPONSE_MAG, k]
        u_axial = 0.0 + u0 * ax0
        u_axial += u1 * ax1
        u_axial += u2 * ax2
        scale = (1.0 - slip_axial) * kinetic_mu * magnitude * u_axial
        fa0 = -(scale * ax0)
        fa1 = -(scale * ax1)
        fa2 = -(scale * ax2)
        u_rolling = 0.0 + u0 * ro0
        u_rolling += u1 * ro1
        u_rolling += u2 * ro2
        scale = (1.0 - slip_rolling) * kinetic_sideways * magnitude * u_rolling
        fr0 = -(scale * ro0)
        fr1 = -(scale * ro1)
        fr2 = -(scale * ro2)
        half = 0.5 * fa0
        external_forces[0, a] += half
        external_forces[0, a + 1] += half
        half = 0.5 * fa1
        external_forces[1, a] += half
        external_forces[1, a + 1] += half
        half = 0.5 * fa2
        external_forces[2, a] += half
        external_forces[2, a + 1] += half
        s[S_AXIAL, k] = ax0
        s[S_AXIAL + 1, k] = ax1
        s[S_AXIAL + 2, k] = ax2
        s[S_ROLLING, k] = ro0
        s[S_ROLLING + 1, k] = ro1
        s[S_ROLLING + 2, k] = ro2
        s[S_SLIP_AXIAL, k] = slip_axial
        s[S_SLIP_ROLLING, k] = slip_rolling
        s[S_ARM, k] = arm0
        s[S_ARM + 1, k] = arm1
        s[S_ARM + 2, k] = arm2
        s[S_FRICTION, k] = fr0
        s[S_FRICTION + 1, k] = fr1
        s[S_FRICTION + 2, k] = fr2
    _spread_to_nodes(external_forces, s, S_FRICTION, ns, n)
    for k in range(n):
        if sliding or s[S_NO_CONTACT, k] != 0.0:  # a sliding band's friction turns nothing
            continue
        # external_torques += Q (arm x f_rolling)
        e = es + k
        add_arm_torque(directors, external_torques, e, s, k, S_FRICTION)

    # 3. Static axial friction, from the loads after the kinetic friction.
    for k in range(n):
        if s[S_NO_CONTACT, k] != 0.0:
            continue
        a = ns + k
        ef0, ef1, ef2 = _element_force(internal_forces, external_forces, a, k == 0, k == last)
        ax0 = s[S_AXIAL, k]
        ax1 = s[S_AXIAL + 1, k]
        ax2 = s[S_AXIAL + 2, k]
        f_axial = 0.0 + ef0 * ax0
        f_axial += ef1 * ax1
        f_axial += ef2 * ax2
        sign = _sign(f_axial)
        static_mu = 0.5 * (static_forward * (1 + sign) + static_backward * (1 - sign))
        max_friction = s[S_SLIP_AXIAL, k] * static_mu * s[S_RESPONSE_MAG, k]
        scale = _minimum(math.fabs(f_axial), max_friction) * sign
        s[S_FRICTION, k] = -(scale * ax0)
        s[S_FRICTION + 1, k] = -(scale * ax1)
        s[S_FRICTION + 2, k] = -(scale * ax2)
        s[S_ELEMENT_FORCE, k] = ef0
        s[S_ELEMENT_FORCE + 1, k] = ef1
        s[S_ELEMENT_FORCE + 2, k] = ef2
    _spread_to_nodes(external_forces, s, S_FRICTION, ns, n)

    # 4. Static rolling friction (reads element loads computed before the static axial friction and
    # the torques of its own element only, so it can be spread to the nodes in the loop).
    for k in range(n):
        if s[S_NO_CONTACT, k] != 0.0:
            continue
        a = ns + k
        e = es + k
        tw0 = internal_torques[0, e] + external_torques[0, e]
        tw1 = internal_torques[1, e] + external_torques[1, e]
        tw2 = internal_torques[2, e] + external_torques[2, e]
        tt0, tt1, tt2 = _transpose_times(directors, e, tw0, tw1, tw2)
        tt_axial = 0.0 + tt0 * s[S_AXIAL, k]
        tt_axial += tt1 * s[S_AXIAL + 1, k]
        tt_axial += tt2 * s[S_AXIAL + 2, k]
        ro0 = s[S_ROLLING, k]
        ro1 = s[S_ROLLING + 1, k]
        ro2 = s[S_ROLLING + 2, k]
        f_rolling = 0.0 + s[S_ELEMENT_FORCE, k] * ro0
        f_rolling += s[S_ELEMENT_FORCE + 1, k] * ro1
        f_rolling += s[S_ELEMENT_FORCE + 2, k] * ro2
        r = radius[e]
        if sliding:  # Coulomb: hold the whole sideways load, up to mu_s N
            noslip = -f_rolling
        else:  # the no-slip force of a solid cylinder rolling under the load and axial torque
            noslip = -((r * f_rolling - 2.0 * tt_axial) / 3.0 / r)
        max_friction = s[S_SLIP_ROLLING, k] * static_sideways * s[S_RESPONSE_MAG, k]
        scale = _minimum(math.fabs(noslip), max_friction) * _sign(noslip)
        f0 = scale * ro0
        f1 = scale * ro1
        f2 = scale * ro2
        half = 0.5 * f0
        external_forces[0, a] += half
        external_forces[0, a + 1] += half
        half = 0.5 * f1
        external_forces[1, a] += half
        external_forces[1, a + 1] += half
        half = 0.5 * f2
        external_forces[2, a] += half
        external_forces[2, a + 1] += half
        s[S_FRICTION, k] = f0
        s[S_FRICTION + 1, k] = f1
        s[S_FRICTION + 2, k] = f2
        if not sliding:
            add_arm_torque(directors, external_torques, e, s, k, S_FRICTION)


@njit(cache=True, error_model="numpy")
def add_arm_torque(
    directors: NDArray[np.float64],
    external_torques: NDArray[np.float64],
    e: int,
    s: NDArray[np.float64],
    k: int,
    row: int,
) -> None:
    """``external_torques[:, e] += Q_e (arm_k x f_k)`` with ``f`` in scratch rows ``row .. row + 2``."""
    arm0 = s[S_ARM, k]
    arm1 = s[S_ARM + 1, k]
    arm2 = s[S_ARM + 2, k]
    f0 = s[row, k]
    f1 = s[row + 1, k]
    f2 = s[row + 2, k]
    c0 = arm1 * f2 - arm2 * f1
    c1 = arm2 * f0 - arm0 * f2
    c2 = arm0 * f1 - arm1 * f0
    t0, t1, t2 = _times(directors, e, c0, c1, c2)
    external_torques[0, e] += t0
    external_torques[1, e] += t1
    external_torques[2, e] += t2


@njit(cache=True, error_model="numpy")
def first_unhealthy(
    positions: NDArray[np.float64],
    velocities: NDArray[np.float64],
    node_start: NDArray[np.int64],
    node_end: NDArray[np.int64],
    limit2: float,
) -> tuple[int, int, bool, float, int]:
    """First robot with a non-finite position or a node speed^2 above ``limit2`` (m^2/s^2).

    Returns ``(robot, node, is_nan, speed2, n_bad_robots)`` with ``robot = -1`` if all are
    healthy; ``node`` is the robot's own node index. Ghost nodes are not checked.
    """
    first_robot = -1
    first_node = -1
    first_nan = False
    first_speed2 = 0.0
    n_bad = 0
    for r in range(node_start.shape[0]):
        for a in range(node_start[r], node_end[r]):
            speed2 = (
                velocities[0, a] * velocities[0, a]
                + velocities[1, a] * velocities[1, a]
                + velocities[2, a] * velocities[2, a]
            )
            finite = (
                math.isfinite(positions[0, a])
                and math.isfinite(positions[1, a])
                and math.isfinite(positions[2, a])
            )
            if not (speed2 <= limit2) or not finite:
                if first_robot < 0:
                    first_robot = r
                    first_node = a - node_start[r]
                    first_nan = not (finite and math.isfinite(speed2))
                    first_speed2 = speed2
                n_bad += 1
                break
    return first_robot, first_node, first_nan, first_speed2, n_bad


@njit(cache=True)
def robot_times(time: float, index: int, dt: float, behind: NDArray[np.int64],
                out: NDArray[np.float64]) -> None:
    """``out[i]``: the time (s) of a robot ``behind[i]`` steps behind the block's clock when the
    block's stepper, taking step ``index`` of ``dt`` s, is at ``time``: PositionVerlet's forcing
    time (its own steps x dt, plus dt / 2) or the constraints' time after the second half step
    (plus dt / 2 again), computed as a per-rod simulation of that robot computes it, so that both
    round alike; any other ``time`` is shifted by ``behind[i] * dt``."""
    half = index * dt + 0.5 * dt
    for i in range(behind.shape[0]):
        if behind[i] == 0:
            out[i] = time
        elif time == half:
            out[i] = (index - behind[i]) * dt + 0.5 * dt
        elif time == half + 0.5 * dt:
            out[i] = (index - behind[i]) * dt + 0.5 * dt + 0.5 * dt
        else:
            out[i] = time - behind[i] * dt
