"""Numba kernels of the fields in space (private): the sources of
:mod:`elastica_magnetic.spatial_fields` and :mod:`elastica_magnetic.field_maps`, and how a moved
magnet, a coil's current ramp or a dipole's path changes over one control step. SI units: m, T, A,
A m^2, s. The force and torque they exert on robots: :mod:`elastica_magnetic._robot_forcing_kernels`.

Field kernels *add* into ``b_out`` ``(3, n)`` (T) and ``g_out`` ``(3, 3, n)`` (``g[i, j]`` =
``dB_i/dx_j``, T/m), so that a sum of sources shares two buffers.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: mu0 / (4 pi), T m / A.
MU0_OVER_4PI = 1e-7
#: mu0 / (2 pi), T m / A.
MU0_OVER_2PI = 2e-7
#: Where ``rho^2 < AXIS_SERIES (a^2 + z^2)`` a loop's field is taken from its series about the
#: axis (truncated after ``rho^3``: relative error ~``AXIS_SERIES^2``); farther out, from the closed
#: form, whose ``B_rho / rho`` loses ~``eps / m^2`` to cancellation (``m`` the elliptic parameter).
AXIS_SERIES = 1e-6


@njit(cache=True)
def dipole_field(moment, position, points, b_out, g_out, with_gradient):
    """Point dipole ``moment`` (3,) A m^2 at ``position`` (3,) m, at ``points`` (3, n) m:
    ``B = mu0/(4 pi r^3) (3 (m.n) n - m)``, ``dB_i/dx_j = 3 mu0/(4 pi r^5) (m_i r_j + m_j r_i +
    (m.r) delta_ij - 5 (m.r) r_i r_j / r^2)``. A point at the dipole gets NaN."""
    m0, m1, m2 = moment[0], moment[1], moment[2]
    for k in range(points.shape[1]):
        r0 = points[0, k] - position[0]
        r1 = points[1, k] - position[1]
        r2 = points[2, k] - position[2]
        r_sq = r0 * r0 + r1 * r1 + r2 * r2
        if r_sq == 0.0:
            for i in range(3):
                b_out[i, k] = np.nan
            continue
        inv_r = 1.0 / math.sqrt(r_sq)
        inv_r2 = inv_r * inv_r
        inv_r3 = inv_r2 * inv_r
        mr = m0 * r0 + m1 * r1 + m2 * r2
        c = MU0_OVER_4PI * inv_r3
        s = 3.0 * mr * inv_r2
        b_out[0, k] += c * (s * r0 - m0)
        b_out[1, k] += c * (s * r1 - m1)
        b_out[2, k] += c * (s * r2 - m2)
        if with_gradient:
            cg = 3.0 * MU0_OVER_4PI * inv_r3 * inv_r2
            q = 5.0 * mr * inv_r2
            r = (r0, r1, r2)
            m = (m0, m1, m2)
            for i in range(3):
                for j in range(3):
                    value = m[i] * r[j] + m[j] * r[i] - q * r[i] * r[j]
                    if i == j:
                        value += mr
                    g_out[i, j, k] += cg * value


#: Cody's polynomial approximations of the complete elliptic integrals in ``m1 = 1 - m`` (as in
#: Cephes' ``ellpk`` and ``ellpe``, which SciPy's ``ellipk``/``ellipe`` use): ``K = P_K(m1) - ln(m1)
#: Q_K(m1)``, ``E = P_E(m1) - ln(m1) m1 Q_E(m1)``, relative error ~1e-16 over [0, 1). Highest power
#: first (Horner).
ELLIPTIC_PK = np.array([
    1.37982864606273237150e-4, 2.28025724005875567385e-3, 7.97404013220415179367e-3,
    9.85821379021226008714e-3, 6.87489687449949877925e-3, 6.18901033637687613229e-3,
    8.79078273952743772254e-3, 1.49380448916805252718e-2, 3.08851465246711995998e-2,
    9.65735902811690126535e-2, 1.38629436111989062502e0])
ELLIPTIC_QK = np.array([
    2.94078955048598507511e-5, 9.14184723865917226571e-4, 5.94058303753167793257e-3,
    1.54850516649762399335e-2, 2.39089602715924892727e-2, 3.01204715227604046988e-2,
    3.73774314173823228969e-2, 4.88280347570998239232e-2, 7.03124996963957469739e-2,
    1.24999999999870820058e-1, 4.99999999999999999821e-1])
ELLIPTIC_PE = np.array([
    1.53552577301013293365e-4, 2.50888492163602060990e-3, 8.68786816565889628429e-3,
    1.07350949056076193403e-2, 7.77395492516787092951e-3, 7.58395289413514708519e-3,
    1.15688436810574127319e-2, 2.18317996015557253103e-2, 5.68051945617860553470e-2,
    4.43147180560990850618e-1, 1.00000000000000000299e0])
ELLIPTIC_QE = np.array([
    3.27954898576485872656e-5, 1.00962792679356715133e-3, 6.50609489976927491433e-3,
    1.68862163993311317300e-2, 2.61769742454493659583e-2, 3.34833904888224918614e-2,
    4.27180926518931511717e-2, 5.85936634471101055642e-2, 9.37499997197644278445e-2,
    2.49999999999888314361e-1])


#: ``ln 2`` split for :func:`log_positive` (Cody and Waite): ``LN2_HI`` ends in zero bits, so that
#: ``e LN2_HI`` is exact for every exponent ``e`` of a double.
LN2_HI = 6.93147180369123816490e-01
LN2_LO = 1.90821492927058770002e-10
#: fdlibm's ``log`` (Sun Microsystems, 1993): ``ln(1 + f) = f - f^2/2 + s (f^2/2 + R(s^2))`` with
#: ``s = f / (2 + f)``; the minimax polynomial ``R(z) = z (LOG_SERIES[0] + z (LOG_SERIES[1] +
#: ...))``, error below 2^-58.45 for a mantissa in [1/sqrt(2), sqrt(2)].
LOG_SERIES = np.array([6.666666666666735130e-01, 3.999999999940941908e-01, 2.857142874366239149e-01,
                       2.222219843214978396e-01, 1.818357216161805012e-01, 1.531383769920937332e-01,
                       1.479819860511658591e-01])
#: A double's mantissa bits, and the bits of 1.0 (exponent 0).
MANTISSA_BITS = 0x000FFFFFFFFFFFFF
ONE_BITS = 0x3FF0000000000000


@njit(cache=True, fastmath={"contract"}, error_model="numpy")
def log_positive(x, bits, out):
    """Natural logarithm of positive normal doubles ``x`` (n,) into ``out`` (n,), ``bits`` (n,)
    int64 scratch; within an ulp (fdlibm's algorithm, :data:`LOG_SERIES`). ``math.log`` would
    keep a loop over points scalar (numba has no vector logarithm without Intel's SVML): here the
    exponent ``e`` and mantissa ``1 + f`` come apart by their bits, ``ln x = e ln 2 + ln(1 + f)``,
    and every step vectorizes."""
    x_bits = x.view(np.int64)
    for k in range(x.shape[0]):
        b = x_bits[k]
        out[k] = float((b >> 52) - 1023)
        bits[k] = (b & MANTISSA_BITS) | ONE_BITS
    mantissa = bits.view(np.float64)
    for k in range(x.shape[0]):
        m = mantissa[k]
        e = out[k]
        high = m > math.sqrt(2.0)
        f = (0.5 * m if high else m) - 1.0
        e = e + 1.0 if high else e
        s = f / (2.0 + f)
        z = s * s
        series = LOG_SERIES[-1]
        for i in range(LOG_SERIES.shape[0] - 2, -1, -1):
            series = series * z + LOG_SERIES[i]
        half_f_sq = 0.5 * f * f
        out[k] = e * LN2_HI - ((half_f_sq - (s * (half_f_sq + z * series) + e * LN2_LO)) - f)


@njit(cache=True, fastmath={"contract"}, error_model="numpy", inline="always")
def elliptic_ke(m1, log_m1):
    """Complete elliptic integrals ``K(m)``, ``E(m)`` (parameter ``m = k^2`` in [0, 1)) to
    round-off, by Cody's approximations (:data:`ELLIPTIC_PK` ...) in ``m1 = 1 - m``, given with its
    logarithm ``log_m1`` (from :func:`log_positive`, for loops over points that vectorize): some 40
    multiplications, a third of the time of the arithmetic-geometric mean's square roots."""
    pk = ELLIPTIC_PK[0]
    qk = ELLIPTIC_QK[0]
    pe = ELLIPTIC_PE[0]
    qe = ELLIPTIC_QE[0]
    for i in range(1, 11):
        pk = pk * m1 + ELLIPTIC_PK[i]
        qk = qk * m1 + ELLIPTIC_QK[i]
        pe = pe * m1 + ELLIPTIC_PE[i]
    for i in range(1, 10):
        qe = qe * m1 + ELLIPTIC_QE[i]
    return pk - log_m1 * qk, pe - log_m1 * m1 * qe


@njit(cache=True, fastmath={"contract"}, error_model="numpy", inline="always")
def loop_axis_series(a, rho, z):
    """A unit-current loop's field near its axis (radius ``a`` m, at ``(rho, z)`` m), divided by
    ``mu0 / (2 pi)``: the series ``b_z = f - rho^2 f''/4``, ``b_rho = -rho f'/2 + rho^3 f'''/16``
    (truncated after ``rho^3``) of ``f(z) = pi a^2 / u^(3/2)``, ``u = a^2 + z^2``. Returns
    ``b_rho / rho, b_z, d b_z/d rho, d b_z/d z``."""
    u = a * a + z * z
    inv_u = 1.0 / u
    u_15 = inv_u / math.sqrt(u)
    u_25 = u_15 * inv_u
    u_35 = u_25 * inv_u
    u_45 = u_35 * inv_u
    u_55 = u_45 * inv_u
    c = math.pi * a * a
    f1 = -3.0 * c * z * u_25
    f2 = c * (-3.0 * u_25 + 15.0 * z * z * u_35)
    f3 = c * (45.0 * z * u_35 - 105.0 * z * z * z * u_45)
    f4 = c * (45.0 * u_35 - 630.0 * z * z * u_45 + 945.0 * z * z * z * z * u_55)
    rho_sq = rho * rho
    return (-0.5 * f1 + rho_sq * f3 / 16.0, c * u_15 - 0.25 * rho_sq * f2,
            -0.5 * rho * f2 + rho * rho_sq * f4 / 16.0, f1 - 0.25 * rho_sq * f3)


@njit(cache=True, fastmath={"contract"}, error_model="numpy", inline="always")
def loop_closed_form(a, rho, z, m1, log_m1):
    """A unit-current loop's field off its axis (radius ``a`` m, in the plane z = 0, axis +z,
    current counter-clockwise seen from +z) at ``(rho, z)`` m, divided by ``mu0 / (2 pi)``, by the
    complete elliptic integrals of ``m = 4 a rho / alpha`` (given as ``m1 = 1 - m = beta / alpha``,
    exact near the wire, and its logarithm), ``alpha, beta = (a +- rho)^2 + z^2``. Returns ``b_rho /
    rho, b_z, d b_z/d rho, d b_z/d z`` (``d b_rho/dz = d b_z/d rho``: the field is curl-free)."""
    k, e = elliptic_ke(m1, log_m1)
    alpha = (a + rho) ** 2 + z * z
    # Reciprocals once (a division costs several multiplications).
    inv_alpha = 1.0 / alpha
    inv_beta = inv_alpha / m1
    inv_sqrt_alpha = 1.0 / math.sqrt(alpha)
    inv_rho = 1.0 / rho
    m = 4.0 * a * rho * inv_alpha
    inv_m = 0.25 * alpha * inv_rho / a
    gamma_over_beta = (a * a - rho * rho - z * z) * inv_beta
    bracket = k + gamma_over_beta * e
    b_rho_over_rho = (z * inv_rho * inv_rho * inv_sqrt_alpha
                      * (-k + (a * a + rho * rho + z * z) * inv_beta * e))
    # d/dm of K and E (1 / (1 - m) = alpha / beta).
    dk = (e - m1 * k) * 0.5 * inv_m * alpha * inv_beta
    de = (e - k) * 0.5 * inv_m
    # d/dz: alpha_z = beta_z = 2 z, gamma_z = -2 z, m_z = -2 z m / alpha.
    m_z = -2.0 * z * m * inv_alpha
    d_bracket_z = dk * m_z - 2.0 * z * inv_beta * (1.0 + gamma_over_beta) * e + gamma_over_beta * de * m_z
    inv_alpha_sqrt = inv_alpha * inv_sqrt_alpha
    db_z_dz = -z * inv_alpha_sqrt * bracket + d_bracket_z * inv_sqrt_alpha
    # d/drho: alpha_r = 2 (a + rho), beta_r = -2 (a - rho), gamma_r = -2 rho,
    # m_r = 4 a / alpha - 2 m (a + rho) / alpha.
    m_r = (4.0 * a - 2.0 * m * (a + rho)) * inv_alpha
    d_bracket_r = (dk * m_r + 2.0 * inv_beta * (-rho + gamma_over_beta * (a - rho)) * e
                   + gamma_over_beta * de * m_r)
    db_z_drho = -(a + rho) * inv_alpha_sqrt * bracket + d_bracket_r * inv_sqrt_alpha
    return b_rho_over_rho, bracket * inv_sqrt_alpha, db_z_drho, db_z_dz


@njit(cache=True, fastmath={"contract"}, error_model="numpy")
def add_loop(a, offset, scale, rho, z_local, m1, log_m1, bits, acc):
    """Add ``scale`` times a unit-current loop's field over ``mu0 / (2 pi)`` (radius ``a`` m, its
    plane at ``z = offset`` m of the frame) at points ``(rho, z_local)`` (n,) m into ``acc`` (6, n):
    ``b_rho, b_z, d b_rho/d rho, b_rho / rho, d b_z/d rho, d b_z/d z`` (``d b_rho / d rho = -b_rho /
    rho - d b_z / d z``: div B = 0). Within ``AXIS_SERIES`` of the axis, the series. ``m1``,
    ``log_m1``, ``bits``: (n,) scratch. A point on the wire raises ZeroDivisionError."""
    on_wire = 0
    for k in range(rho.shape[0]):
        z = z_local[k] - offset
        beta = (a - rho[k]) ** 2 + z * z
        on_wire += beta == 0.0
        m1[k] = beta / ((a + rho[k]) ** 2 + z * z)
    if on_wire:
        raise ZeroDivisionError("a point on a current loop's wire")
    log_positive(m1, bits, log_m1)
    for k in range(rho.shape[0]):
        z = z_local[k] - offset
        r = rho[k]
        brr, b_z, dbzr, dbzz = loop_closed_form(a, r, z, m1[k], log_m1[k])
        s_brr, s_b_z, s_dbzr, s_dbzz = loop_axis_series(a, r, z)
        # Both computed, one kept: a branch would keep the loop scalar.
        near = r * r < AXIS_SERIES * (a * a + z * z)
        brr = s_brr if near else brr
        dbzz = s_dbzz if near else dbzz
        acc[0, k] += scale * brr * r
        acc[1, k] += scale * (s_b_z if near else b_z)
        acc[2, k] += scale * (-brr - dbzz)
        acc[3, k] += scale * brr
        acc[4, k] += scale * (s_dbzr if near else dbzr)
        acc[5, k] += scale * dbzz


@njit(cache=True)
def coaxial_end(centres, frames, start):
    """The end of the run of loops from ``start`` that share its frame and lie on its axis (a
    coil's windings, a Helmholtz or Maxwell pair): their fields add in the shared frame and turn to
    the lab once."""
    end = start + 1
    a0, a1, a2 = frames[0, 2, start], frames[1, 2, start], frames[2, 2, start]
    while end < centres.shape[1]:
        for i in range(3):
            for j in range(3):
                if frames[i, j, end] != frames[i, j, start]:
                    return end
        d0 = centres[0, end] - centres[0, start]
        d1 = centres[1, end] - centres[1, start]
        d2 = centres[2, end] - centres[2, start]
        across = math.sqrt((a1 * d2 - a2 * d1) ** 2 + (a2 * d0 - a0 * d2) ** 2 + (a0 * d1 - a1 * d0) ** 2)
        if across > 1e-12 * math.sqrt(d0 * d0 + d1 * d1 + d2 * d2):  # beyond round-off: another axis
            return end
        end += 1
    return end


@njit(cache=True, fastmath={"contract"}, error_model="numpy")
def loop_frame_coordinates(frames, loop, centre, points, rho, z_local, cos_phi, sin_phi):
    """Cylindrical coordinates (m) of ``points`` (3, n) m about the axis of ``frames[:, :, loop]``
    (columns ``e1, e2, axis``) through ``centre`` (3,): ``rho``, ``z_local`` and the azimuth's
    cosine and sine (1 and 0 on the axis), each (n,)."""
    r00, r01, r02 = frames[0, 0, loop], frames[0, 1, loop], frames[0, 2, loop]
    r10, r11, r12 = frames[1, 0, loop], frames[1, 1, loop], frames[1, 2, loop]
    r20, r21, r22 = frames[2, 0, loop], frames[2, 1, loop], frames[2, 2, loop]
    for k in range(points.shape[1]):
        d0 = points[0, k] - centre[0]
        d1 = points[1, k] - centre[1]
        d2 = points[2, k] - centre[2]
        x = r00 * d0 + r10 * d1 + r20 * d2
        y = r01 * d0 + r11 * d1 + r21 * d2
        z_local[k] = r02 * d0 + r12 * d1 + r22 * d2
        r = math.sqrt(x * x + y * y)
        rho[k] = r
        cos_phi[k] = x / r if r > 0.0 else 1.0
        sin_phi[k] = y / r if r > 0.0 else 0.0


@njit(cache=True, fastmath={"contract"}, error_model="numpy")
def add_local_to_lab(frames, loop, cos_phi, sin_phi, acc, b_out, g_out, with_gradient):
    """Add the axially symmetric field ``acc`` (6, n) (:func:`add_loop`'s, times ``mu0 / (2 pi)``:
    T, T/m) given in ``frames[:, :, loop]`` at points of azimuth ``cos_phi``, ``sin_phi`` (n,) to
    ``b_out`` (3, n) and, ``with_gradient``, ``g_out`` (3, 3, n) in the lab: ``B = R b``,
    ``G = R G_local R^T``."""
    # The frame in scalars: read in the loop, it would be read again after every store to g_out.
    r00, r01, r02 = frames[0, 0, loop], frames[0, 1, loop], frames[0, 2, loop]
    r10, r11, r12 = frames[1, 0, loop], frames[1, 1, loop], frames[1, 2, loop]
    r20, r21, r22 = frames[2, 0, loop], frames[2, 1, loop], frames[2, 2, loop]
    for k in range(cos_phi.shape[0]):
        c = cos_phi[k]
        s = sin_phi[k]
        bx = acc[0, k] * c
        by = acc[0, k] * s
        b_z = acc[1, k]
        b_out[0, k] += r00 * bx + r01 * by + r02 * b_z
        b_out[1, k] += r10 * bx + r11 * by + r12 * b_z
        b_out[2, k] += r20 * bx + r21 * by + r22 * b_z
        if not with_gradient:
            continue
        db_rho, brr, dbzr, gzz = acc[2, k], acc[3, k], acc[4, k], acc[5, k]
        # Local gradient (symmetric: curl-free, d b_rho/dz = d b_z/d rho).
        gxx = db_rho * c * c + brr * s * s
        gxy = (db_rho - brr) * c * s
        gyy = db_rho * s * s + brr * c * c
        gxz = dbzr * c
        gyz = dbzr * s
        # T = R G_local (rows i), then G_lab = T R^T.
        t00 = r00 * gxx + r01 * gxy + r02 * gxz
        t01 = r00 * gxy + r01 * gyy + r02 * gyz
        t02 = r00 * gxz + r01 * gyz + r02 * gzz
        t10 = r10 * gxx + r11 * gxy + r12 * gxz
        t11 = r10 * gxy + r11 * gyy + r12 * gyz
        t12 = r10 * gxz + r11 * gyz + r12 * gzz
        t20 = r20 * gxx + r21 * gxy + r22 * gxz
        t21 = r20 * gxy + r21 * gyy + r22 * gyz
        t22 = r20 * gxz + r21 * gyz + r22 * gzz
        g01 = t00 * r10 + t01 * r11 + t02 * r12
        g02 = t00 * r20 + t01 * r21 + t02 * r22
        g12 = t10 * r20 + t11 * r21 + t12 * r22
        g_out[0, 0, k] += t00 * r00 + t01 * r01 + t02 * r02
        g_out[0, 1, k] += g01
        g_out[0, 2, k] += g02
        g_out[1, 0, k] += g01
        g_out[1, 1, k] += t10 * r10 + t11 * r11 + t12 * r12
        g_out[1, 2, k] += g12
        g_out[2, 0, k] += g02
        g_out[2, 1, k] += g12
        g_out[2, 2, k] += t20 * r20 + t21 * r21 + t22 * r22


@njit(cache=True, fastmath={"contract"}, error_model="numpy")
def loops_field(centres, frames, radii, currents, points, b_out, g_out, with_gradient):
    """Circular current loops: ``centres`` (3, L) m, ``frames`` (3, 3, L) with columns
    ``(e1, e2, axis)`` of each loop, ``radii`` (L,) m, ``currents`` (L,) A (counter-clockwise about
    ``axis``; turns included). Adds B and its gradient at ``points`` (3, n). Coaxial loops (the same
    frame, centres along its axis: :func:`coaxial_end`) are summed in their frame and turned to the
    lab once. Each step is a loop over the points that vectorizes (SIMD); multiplications and
    additions may fuse (FMA). A point on a wire raises ZeroDivisionError."""
    n = points.shape[1]
    rho, z_local, cos_phi, sin_phi = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    m1, log_m1, bits = np.empty(n), np.empty(n), np.empty(n, dtype=np.int64)
    acc = np.empty((6, n))
    start = 0
    while start < radii.shape[0]:
        end = coaxial_end(centres, frames, start)
        centre = centres[:, start]
        loop_frame_coordinates(frames, start, centre, points, rho, z_local, cos_phi, sin_phi)
        acc[...] = 0.0
        for ell in range(start, end):
            scale = MU0_OVER_2PI * currents[ell]
            if scale == 0.0:
                continue
            offset = (frames[0, 2, start] * (centres[0, ell] - centre[0])
                      + frames[1, 2, start] * (centres[1, ell] - centre[1])
                      + frames[2, 2, start] * (centres[2, ell] - centre[2]))
            add_loop(radii[ell], offset, scale, rho, z_local, m1, log_m1, bits, acc)
        add_local_to_lab(frames, start, cos_phi, sin_phi, acc, b_out, g_out, with_gradient)
        start = end


@njit(cache=True)
def grid_field(origin, spacing, shape, samples, gradients, scale, points, b_out, g_out, with_gradient):
    """Trilinear interpolation of ``samples`` (3, nx, ny, nz) T and ``gradients`` (3, 3, nx, ny, nz)
    T/m on a regular grid (``origin``, ``spacing`` (3,) m), times ``scale``. Returns the index of
    the first point outside the grid, or -1."""
    idx = np.empty(3, dtype=np.int64)
    frac = np.empty(3)
    for k in range(points.shape[1]):
        for d in range(3):
            u = (points[d, k] - origin[d]) / spacing[d]
            if not (u >= -1e-9 and u <= shape[d] - 1 + 1e-9):
                return k
            i = int(math.floor(u))
            i = min(max(i, 0), shape[d] - 2)
            idx[d] = i
            frac[d] = u - i
        for corner in range(8):
            cx = corner & 1
            cy = (corner >> 1) & 1
            cz = (corner >> 2) & 1
            w = ((frac[0] if cx else 1.0 - frac[0]) * (frac[1] if cy else 1.0 - frac[1])
                 * (frac[2] if cz else 1.0 - frac[2])) * scale
            if w == 0.0:
                continue
            ix, iy, iz = idx[0] + cx, idx[1] + cy, idx[2] + cz
            for i in range(3):
                b_out[i, k] += w * samples[i, ix, iy, iz]
            if with_gradient:
                for i in range(3):
                    for j in range(3):
                        g_out[i, j, k] += w * gradients[i, j, ix, iy, iz]
    return -1


@njit(cache=True)
def first_nonfinite(b, g, with_gradient):
    """Index of the first column of ``b`` (3, n) (or, ``with_gradient``, of ``g`` (3, 3, n)) that
    holds NaN or an infinity; -1 if none."""
    for k in range(b.shape[1]):
        for i in range(3):
            if not math.isfinite(b[i, k]):
                return k
            if with_gradient:
                for j in range(3):
                    if not math.isfinite(g[i, j, k]):
                        return k
    return -1


# A magnet moved by an arm (:class:`~elastica_magnetic.MagnetPose`) keeps its motion over one
# control step in a row of MOTION_SIZE floats: from its pose at ``t0`` it moves at a constant
# velocity and turns at a constant rate about a fixed axis for ``span`` s, then holds.
M_POSITION = 0  # 3 entries: the centre at t0, m
M_VELOCITY = 3  # 3 entries, m/s
M_DIRECTION = 6  # 3 entries: the unit moment direction at t0
M_TURN_AXIS = 9  # 3 entries, unit
M_TURN_RATE = 12  # rad/s
M_T0 = 13  # s
M_SPAN = 14  # s
M_MOMENT = 15  # A m^2, the moment's magnitude
MOTION_SIZE = 16


@njit(cache=True)
def magnet_pose_at(motion, time, position_out, direction_out):
    """The centre (m) and unit moment direction of the magnet whose motion row is ``motion``
    (``(MOTION_SIZE,)``) at ``time`` (s), into ``position_out`` and ``direction_out`` ``(3,)``: the
    direction turned by Rodrigues' formula ``v c + (a x v) s + a (a.v)(1 - c)``."""
    elapsed = min(max(time - motion[M_T0], 0.0), motion[M_SPAN])
    for i in range(3):
        position_out[i] = motion[M_POSITION + i] + motion[M_VELOCITY + i] * elapsed
    angle = motion[M_TURN_RATE] * elapsed
    c, s = math.cos(angle), math.sin(angle)
    a0, a1, a2 = motion[M_TURN_AXIS], motion[M_TURN_AXIS + 1], motion[M_TURN_AXIS + 2]
    v0, v1, v2 = motion[M_DIRECTION], motion[M_DIRECTION + 1], motion[M_DIRECTION + 2]
    dot = (a0 * v0 + a1 * v1 + a2 * v2) * (1.0 - c)
    direction_out[0] = v0 * c + (a1 * v2 - a2 * v1) * s + a0 * dot
    direction_out[1] = v1 * c + (a2 * v0 - a0 * v2) * s + a1 * dot
    direction_out[2] = v2 * c + (a0 * v1 - a1 * v0) * s + a2 * dot


@njit(cache=True)
def moved_dipole_field(motion, time, points, b_out, g_out, with_gradient):
    """:func:`dipole_field` of the magnet of ``motion`` at its pose at ``time`` (s)."""
    position, moment = np.empty(3), np.empty(3)
    magnet_pose_at(motion, time, position, moment)
    for i in range(3):
        moment[i] *= motion[M_MOMENT]
    dipole_field(moment, position, points, b_out, g_out, with_gradient)


@njit(cache=True)
def shortest_rotation(direction, out):
    """The rotation ``out`` (3, 3) turning +z onto ``direction`` (3,) (normalized here) the
    shortest way, as :func:`~elastica_magnetic.spatial_fields.rotation_to`: ``I + K + K^2 / (1 + c)``
    with ``K`` the cross-product matrix of ``z x a`` and ``c = a_z``; half a turn about x for -z."""
    norm = math.sqrt(direction[0] ** 2 + direction[1] ** 2 + direction[2] ** 2)
    a0, a1, c = direction[0] / norm, direction[1] / norm, direction[2] / norm
    out[...] = 0.0
    if c > 1.0 - 1e-15:
        for i in range(3):
            out[i, i] = 1.0
        return
    if c < -1.0 + 1e-15:
        out[0, 0], out[1, 1], out[2, 2] = 1.0, -1.0, -1.0
        return
    f = 1.0 / (1.0 + c)
    # v = z x a = (-a1, a0, 0); K v-cross; K^2 = v v^T - |v|^2 I.
    v0, v1 = -a1, a0
    vv = v0 * v0 + v1 * v1
    out[0, 0] = 1.0 + (v0 * v0 - vv) * f
    out[0, 1] = v0 * v1 * f
    out[0, 2] = v1
    out[1, 0] = v0 * v1 * f
    out[1, 1] = 1.0 + (v1 * v1 - vv) * f
    out[1, 2] = -v0
    out[2, 0] = -v1
    out[2, 1] = v0
    out[2, 2] = 1.0 - vv * f


@njit(cache=True)
def posed_grid_field(position, rotation, scale, origin, spacing, shape, samples, gradients, points, b_out,
                     g_out, with_gradient, local, b_local, g_local):
    """:func:`grid_field` of a map posed in the lab: its origin's frame at ``position`` (3,) m,
    turned by ``rotation`` (3, 3) (its columns the map's axes in the lab). Each point is looked up
    at ``R^T (x - position)``; the field ``R b`` and the gradient ``R G R^T`` are added to ``b_out``
    (3, n) T and ``g_out`` (3, 3, n) T/m. ``local`` (3, n), ``b_local`` (3, n), ``g_local``
    (3, 3, n): scratch. Returns the first point outside the map, else -1 (nothing added then)."""
    n = points.shape[1]
    for k in range(n):
        d0 = points[0, k] - position[0]
        d1 = points[1, k] - position[1]
        d2 = points[2, k] - position[2]
        for i in range(3):
            local[i, k] = rotation[0, i] * d0 + rotation[1, i] * d1 + rotation[2, i] * d2
    b_local[...] = 0.0
    g_local[...] = 0.0
    outside = grid_field(origin, spacing, shape, samples, gradients, scale, local, b_local, g_local,
                         with_gradient)
    if outside >= 0:
        return outside
    for k in range(n):
        for i in range(3):
            b_out[i, k] += (rotation[i, 0] * b_local[0, k] + rotation[i, 1] * b_local[1, k]
                            + rotation[i, 2] * b_local[2, k])
        if with_gradient:
            for i in range(3):
                for j in range(3):
                    total = 0.0
                    for a in range(3):
                        row = (g_local[a, 0, k] * rotation[j, 0] + g_local[a, 1, k] * rotation[j, 1]
                               + g_local[a, 2, k] * rotation[j, 2])
                        total += rotation[i, a] * row
                    g_out[i, j, k] += total
    return -1


@njit(cache=True)
def moved_map_field_into(motion, time, origin, spacing, shape, samples, gradients, reference_moment, points,
                         b_out, g_out, with_gradient, rotation, local, b_local, g_local):
    """A magnet's field map in its own frame (its moment along the map's +z; ``samples``,
    ``gradients`` as :func:`grid_field`, tabulated for a magnet of moment ``reference_moment``
    A m^2) at the pose of ``motion`` at ``time`` (s), times the motion's moment over the
    reference: :func:`posed_grid_field` with ``R`` the shortest turn of +z onto the moment
    (:func:`shortest_rotation`). ``rotation`` (3, 3) and the rest: scratch. Returns the first
    point outside the map, else -1 (nothing added then)."""
    position, direction = np.empty(3), np.empty(3)
    magnet_pose_at(motion, time, position, direction)
    shortest_rotation(direction, rotation)
    return posed_grid_field(position, rotation, motion[M_MOMENT] / reference_moment, origin, spacing, shape,
                            samples, gradients, points, b_out, g_out, with_gradient, local, b_local, g_local)


@njit(cache=True)
def moved_map_field(motion, time, origin, spacing, shape, samples, gradients, reference_moment, points,
                    b_out, g_out, with_gradient):
    """:func:`moved_map_field_into` with its own scratch (one robot's call)."""
    n = points.shape[1]
    return moved_map_field_into(motion, time, origin, spacing, shape, samples, gradients, reference_moment,
                                points, b_out, g_out, with_gradient, np.empty((3, 3)), np.empty((3, n)),
                                np.empty((3, n)), np.empty((3, 3, n)))


# The currents of coils commanded by :class:`~elastica_magnetic.CoilCurrents` over one control step
# in a row: from ``i0`` (A, one per coil) at ``t0`` they ramp linearly to ``i1`` over ``span`` s,
# then hold (``span`` 0: ``i1`` at once). Row: ``[t0, span, i0..., i1...]``.
R_T0 = 0
R_SPAN = 1
R_CURRENTS = 2


@njit(cache=True)
def coil_currents_at(ramp, time, out):
    """The currents (A) of the ramp row ``ramp`` (``(2 + 2 C,)``) at ``time`` (s), into ``out``
    ``(C,)``: the same operations as :meth:`~elastica_magnetic.CoilCurrents.currents_at`."""
    n_coils = out.shape[0]
    span = ramp[R_SPAN]
    if span == 0.0:
        for c in range(n_coils):
            out[c] = ramp[R_CURRENTS + n_coils + c]
        return
    f = min(max((time - ramp[R_T0]) / span, 0.0), 1.0)
    for c in range(n_coils):
        i0 = ramp[R_CURRENTS + c]
        out[c] = i0 + (ramp[R_CURRENTS + n_coils + c] - i0) * f


@njit(cache=True)
def path_value(times, values, start, end, time, out):
    """The value ``out`` (3,) at ``time`` (s) of the path ``times[start:end]``, ``values[start:end]``
    (``(P,)`` s, ``(P, 3)``): held before its first time and after its last, linear between, as
    :class:`~elastica_magnetic.Waypoints` computes it (a path of one point is a constant)."""
    if time <= times[start]:
        for d in range(3):
            out[d] = values[start, d]
        return
    if time >= times[end - 1]:
        for d in range(3):
            out[d] = values[end - 1, d]
        return
    i = start
    while times[i + 1] <= time:  # the last time at or before ``time`` (bisect_right - 1)
        i += 1
    w = (time - times[i]) / (times[i + 1] - times[i])
    for d in range(3):
        out[d] = values[i, d] + w * (values[i + 1, d] - values[i, d])
