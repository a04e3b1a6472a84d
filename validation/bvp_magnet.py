"""Independent reference: a planar elastica clamped at one end in a field that varies in space (a
point dipole, a constant gradient, any planar field given with its gradient).

Like :mod:`elastica_magnetic_validation.elastica_bvp`, this module depends on numpy and scipy only
(not PyElastica, nothing of the package it checks), so that agreement means something.

Model: a planar Cosserat (Reissner) rod of rest length ``L`` (``s`` the rest arclength), bending
stiffness ``EI``, axial stiffness ``EA`` and shear stiffness ``GA_s`` (``inf``: inextensible,
unshearable), cross-section ``A``, clamped at the origin along +x (``theta(0) = 0``), its material
tangent ``d3 = (cos theta, sin theta)``, normal ``d1 = (-sin theta, cos theta)``. It carries the
magnetization ``|M|`` at a fixed angle ``alpha`` from ``d3`` towards ``d1`` (0: along the axis),
in a field ``B(x, y)`` (e.g. of a point dipole, moment ``m`` at ``p`` in the x-y plane): per unit
rest length the couple ``c = A |M| (cos(theta + alpha) B_y - sin(theta + alpha) B_x)`` and the
force ``f_j = A sum_i M_i dB_i/dx_j``. With the internal force ``n``, its components
``n_t = n . d3``, ``n_n = n . d1``, the strains ``nu3 = 1 + n_t / EA``, ``nu1 = n_n / GA_s`` and the
bending moment ``k = EI theta'``::

    r' = nu3 d3 + nu1 d1,  theta' = k / EI,
    n' = -f,  k' = -(r' x n) - c,

and ``x(0) = y(0) = theta(0) = 0``, ``n(L) = 0``, ``k(L) = 0`` (free end). ``scipy.integrate.solve_bvp``
solves it with continuation in the dipole's moment from zero.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_bvp

__all__ = ["DipoleCantileverSolution", "dipole_field_2d", "linear_field_2d", "solve_dipole_cantilever",
           "solve_magnetic_cantilever"]

MU0 = 4e-7 * math.pi


def dipole_field_2d(moment, position, x, y):
    """In-plane field ``(Bx, By)`` (T) and gradient ``dB_i/dx_j`` (T/m) of a point dipole whose
    moment (A m^2) and position (m) lie in the plane, at arrays ``x``, ``y`` (m)."""
    rx, ry = x - position[0], y - position[1]
    r2 = rx * rx + ry * ry
    r = np.sqrt(r2)
    mr = moment[0] * rx + moment[1] * ry
    c = MU0 / (4 * math.pi) / r**3
    bx = c * (3 * mr * rx / r2 - moment[0])
    by = c * (3 * mr * ry / r2 - moment[1])
    cg = 3 * MU0 / (4 * math.pi) / r**5
    rr = (rx, ry)
    m = moment
    grad = [[cg * (m[i] * rr[j] + m[j] * rr[i] + (mr if i == j else 0.0) - 5 * mr * rr[i] * rr[j] / r2)
             for j in range(2)] for i in range(2)]
    return bx, by, grad


@dataclass
class DipoleCantileverSolution:
    s: np.ndarray  # m
    x: np.ndarray  # m
    y: np.ndarray  # m
    theta: np.ndarray  # rad
    residual: float  # largest relative residual of solve_bvp

    @property
    def tip(self) -> tuple[float, float, float]:
        """``(x, y, theta)`` at the free end (m, m, rad)."""
        return float(self.x[-1]), float(self.y[-1]), float(self.theta[-1])


def solve_dipole_cantilever(length: float, bending_stiffness: float, area: float, magnetization: float,
                            moment, position, steps: int = 40, nodes: int = 400,
                            tol: float = 1e-9, guess=None, axial_stiffness: float = math.inf,
                            shear_stiffness: float = math.inf) -> DipoleCantileverSolution:
    """Solve the clamped rod, magnetized along its axis, in the dipole's field (SI units),
    continuing the moment from zero in ``steps`` equal steps (``RuntimeError`` if a step fails),
    or, with ``guess = (s, x, y, theta)`` (arrays, SI: e.g. a simulated shape), by one Newton
    solve at the full moment started there: past a snap-through (the tip pulled in towards the
    magnet) continuation from zero stops at the fold, and the guess selects the branch."""
    moment = np.asarray(moment, dtype=float)[:2]
    position = np.asarray(position, dtype=float)[:2]

    def field(x, y, scale):
        return dipole_field_2d(scale * moment, position, x, y)

    return solve_magnetic_cantilever(length, bending_stiffness, area, magnetization, field, 0.0, steps,
                                     nodes, tol, guess, axial_stiffness, shear_stiffness)


def linear_field_2d(gradient):
    """The in-plane field ``B = G (x, y)`` of a constant gradient ``G`` (2x2, T/m), as a ``field(x,
    y, scale)`` of :func:`solve_magnetic_cantilever` (the load ``scale`` multiplies ``G``)."""
    g = np.asarray(gradient, dtype=float)

    def field(x, y, scale):
        gs = scale * g
        return (gs[0, 0] * x + gs[0, 1] * y, gs[1, 0] * x + gs[1, 1] * y,
                [[gs[0, 0], gs[0, 1]], [gs[1, 0], gs[1, 1]]])

    return field


def solve_magnetic_cantilever(length: float, bending_stiffness: float, area: float, magnetization: float,
                              field, magnetization_angle: float = 0.0, steps: int = 40, nodes: int = 400,
                              tol: float = 1e-9, guess=None, axial_stiffness: float = math.inf,
                              shear_stiffness: float = math.inf) -> DipoleCantileverSolution:
    """Solve the clamped rod in a planar field ``field(x, y, scale) -> (Bx, By, [[dBx/dx, dBx/dy],
    [dBy/dx, dBy/dy]])`` (T, T/m, at arrays ``x``, ``y`` in m; ``scale`` the load, continued from
    zero to one in ``steps`` equal steps, or one solve at one from ``guess``, as
    :func:`solve_dipole_cantilever`). The magnetization ``|M|`` (A/m) makes the angle
    ``magnetization_angle`` (rad) with the tangent ``d3``, towards the normal ``d1``: 0 along the
    axis, ``pi/2`` across it."""
    am = area * magnetization

    # Scaled unknowns on xi = s / L: x / L, y / L, theta, n L^2 / EI, k L / EI.
    force_scale = length**3 / bending_stiffness
    couple_scale = length**2 / bending_stiffness
    axial = bending_stiffness / (length**2 * axial_stiffness)  # 0 when inextensible
    shear = bending_stiffness / (length**2 * shear_stiffness)

    def rhs(xi, u, scale):
        x, y, theta, nx, ny, k = u
        bx, by, g = field(length * x, length * y, scale)
        ct, st = np.cos(theta), np.sin(theta)
        cm, sm = np.cos(theta + magnetization_angle), np.sin(theta + magnetization_angle)
        couple = am * (cm * by - sm * bx) * couple_scale
        fx = am * (cm * g[0][0] + sm * g[1][0]) * force_scale
        fy = am * (cm * g[0][1] + sm * g[1][1]) * force_scale
        nu3 = 1.0 + axial * (ct * nx + st * ny)
        nu1 = shear * (-st * nx + ct * ny)
        dx = nu3 * ct - nu1 * st
        dy = nu3 * st + nu1 * ct
        return np.vstack([dx, dy, k, -fx, -fy, -(dx * ny - dy * nx) - couple])

    def bc(ua, ub):
        return np.array([ua[0], ua[1], ua[2], ub[3], ub[4], ub[5]])

    xi = np.linspace(0.0, 1.0, nodes)
    u = np.zeros((6, nodes))
    u[0] = xi
    scales = [step / steps for step in range(1, steps + 1)]
    if guess is not None:
        s_guess, x_guess, y_guess, theta_guess = (np.asarray(a, dtype=float) for a in guess)
        u[0] = np.interp(xi, s_guess / length, x_guess / length)
        u[1] = np.interp(xi, s_guess / length, y_guess / length)
        u[2] = np.interp(xi, s_guess / length, theta_guess)
        u[5] = np.gradient(u[2], xi)  # k L / EI = theta' in xi
        scales = [1.0]
    residual = 0.0
    for scale in scales:
        result = solve_bvp(lambda t, v, sc=scale: rhs(t, v, sc), bc, xi, u, tol=tol, max_nodes=100_000)
        if not result.success:
            raise RuntimeError(f"solve_bvp failed at moment scale {scale:.3f}: {result.message}")
        xi, u = result.x, result.y
        residual = float(np.max(result.rms_residuals))
    return DipoleCantileverSolution(length * xi, length * u[0], length * u[1], u[2], residual)
