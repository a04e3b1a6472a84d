"""Independent planar-elastica boundary-value solver for magnetic rods.

This module is the *reference* of the validation suite.  It deliberately depends on
nothing but numpy and scipy (no PyElastica, nothing else from this package), so that
agreement between it and the simulator means something.

Model
-----
A planar, inextensible, unshearable rod of length ``L`` (m), bending stiffness ``EI``
(N m^2) and cross-section area ``A`` (m^2) carries a magnetization of magnitude
``|M|(s)`` (A/m) whose direction makes the angle ``alpha_m(s)`` (rad) with the local
tangent (the body frame, measured counter-clockwise from the tangent).  A uniform
field of magnitude ``|B|`` (T) points at the lab angle ``beta`` (rad).  The unknown is
the tangent angle ``theta(s)`` (rad, lab frame, counter-clockwise from the x axis),
so that the lab angle of the magnetization is ``theta + alpha_m``.

The total energy (J) is::

    E[theta] = integral_0^L ( EI theta'^2 / 2 - A |M| |B| cos(theta + alpha_m - beta) ) ds

and its Euler-Lagrange equation with natural (free-end) boundary terms is::

    EI theta'' + A |M(s)| |B| sin(beta - alpha_m(s) - theta) = 0.

Sign convention: a magnetization lying along the tangent (``alpha_m = 0``) is rotated
*towards* the field: with ``theta = 0`` and ``0 < beta < pi`` the couple is positive,
so ``theta`` increases.  The curvature is ``kappa = theta'`` (1/m), positive when the
centreline turns counter-clockwise.  The centreline is ``x(s) = int cos theta``,
``y(s) = int sin theta``, starting at the origin.

Boundary conditions
-------------------
``"clamped-free"``
    ``theta(0) = theta_clamp``, ``theta'(L) = 0``.
``"free-free"``
    ``theta'(0) = theta'(L) = 0``.  Integrating the equation over ``[0, L]`` shows that
    these two conditions imply zero net magnetic torque, i.e. the statics of a free
    body in a uniform field (a uniform field exerts no net force).  For a non-zero
    field the absolute orientation is *not* a free gauge: it is fixed by that torque
    balance, so the problem has isolated solutions and no gauge condition is imposed.
    Only for a zero field (or zero magnetization) is every straight state at any
    orientation a solution; the orientation is then taken from the initial guess or
    from ``theta0``.  Rotating the field by ``gamma`` maps every solution ``theta`` to
    ``theta + gamma`` (rigid rotation); a constant offset of ``alpha_m`` (e.g. the
    ``phi0`` of the Hu et al. robot) is equivalent to rotating the field.

Numerics: ``scipy.integrate.solve_bvp`` on the scaled arc length ``xi = s / L`` with an
analytic Jacobian, natural-parameter load continuation from zero (secant predictor,
adaptive step, branch-jump detection), or a direct Newton solve from a given initial
shape.  The stability of an equilibrium is judged by the lowest eigenvalue of the
second variation of the energy, computed by finite differences.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.integrate import cumulative_simpson, simpson, solve_bvp
from scipy.linalg import eigh_tridiagonal

from .bvp_model import (
    BOUNDARY_CONDITIONS,
    STABILITY_TOLERANCE,
    ElasticaSolution,
    Equilibria,
    FloatArray,
    GuessLike,
    MagneticRod,
    Profile,
    max_matched_distance,
    same_state,
)

__all__ = [
    "BOUNDARY_CONDITIONS",
    "STABILITY_TOLERANCE",
    "ElasticaConvergenceError",
    "ElasticaSolution",
    "Equilibria",
    "FloatArray",
    "GuessLike",
    "MagneticRod",
    "Profile",
    "continue_from",
    "max_matched_distance",
    "same_state",
    "solve_elastica",
]

class ElasticaConvergenceError(RuntimeError):
    """Raised when the boundary-value solver (or the continuation) does not converge."""


@dataclass(frozen=True)
class _Problem:
    """The scaled problem ``theta_xixi = -lam q(xi) sin(beta - alpha(xi) - theta)``."""

    rod: MagneticRod
    field_strength: float  # T, >= 0
    field_angle: float  # rad
    bc: str
    theta_clamp: float

    def q(self, xi: FloatArray) -> FloatArray:
        r = self.rod
        return (
            r.area
            * r.magnetization_at(xi * r.length)
            * self.field_strength
            * r.length**2
            / r.bending_stiffness
        )

    def alpha(self, xi: FloatArray) -> FloatArray:
        return self.rod.alpha_at(xi * self.rod.length)

    @property
    def unloaded(self) -> bool:
        xi = np.linspace(0.0, 1.0, 65)
        return bool(np.all(self.q(xi) == 0.0))


# --------------------------------------------------------------------------------------
# Core solver
# --------------------------------------------------------------------------------------


def _bvp_functions(prob: _Problem, lam: float):
    beta = prob.field_angle

    def fun(xi: FloatArray, y: FloatArray) -> FloatArray:
        lq = lam * prob.q(xi)
        return np.vstack([y[1], -lq * np.sin(beta - prob.alpha(xi) - y[0])])

    def fun_jac(xi: FloatArray, y: FloatArray) -> FloatArray:
        lq = lam * prob.q(xi)
        jac = np.zeros((2, 2, xi.size))
        jac[0, 1] = 1.0
        jac[1, 0] = lq * np.cos(beta - prob.alpha(xi) - y[0])
        return jac

    if prob.bc == "clamped-free":

        def bc(ya: FloatArray, yb: FloatArray) -> FloatArray:
            return np.array([ya[0] - prob.theta_clamp, yb[1]])

        def bc_jac(ya: FloatArray, yb: FloatArray) -> tuple[FloatArray, FloatArray]:
            return np.array([[1.0, 0.0], [0.0, 0.0]]), np.array([[0.0, 0.0], [0.0, 1.0]])

    else:

        def bc(ya: FloatArray, yb: FloatArray) -> FloatArray:
            return np.array([ya[1], yb[1]])

        def bc_jac(ya: FloatArray, yb: FloatArray) -> tuple[FloatArray, FloatArray]:
            return np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[0.0, 0.0], [0.0, 1.0]])

    return fun, fun_jac, bc, bc_jac


def _solve_at(
    prob: _Problem, lam: float, xi: FloatArray, y: FloatArray, tol: float, max_nodes: int
):
    fun, fun_jac, bc, bc_jac = _bvp_functions(prob, lam)
    res = solve_bvp(
        fun, bc, xi, y, fun_jac=fun_jac, bc_jac=bc_jac, tol=tol, max_nodes=max_nodes, bc_tol=tol
    )
    return res


def _guess_function(guess, length: float) -> Callable[[FloatArray], FloatArray]:
    """Turn an initial guess into ``f(xi) -> y`` with ``y`` of shape ``(2, n)``."""
    if isinstance(guess, ElasticaSolution):
        return lambda xi: np.vstack(guess.evaluate(xi * length)) * np.array([[1.0], [length]])
    if callable(guess):

        def from_callable(xi: FloatArray) -> FloatArray:
            th = np.asarray(guess(xi * length), dtype=float) * np.ones_like(xi)
            return np.vstack([th, np.gradient(th, xi)])

        return from_callable
    s_g, th_g = (np.asarray(a, dtype=float) for a in guess)
    if s_g.ndim != 1 or s_g.shape != th_g.shape or s_g.size < 3:
        raise ValueError("an initial guess (s, theta) needs two 1-D arrays of equal length >= 3")
    order = np.argsort(s_g)
    s_g, th_g = s_g[order], np.unwrap(th_g[order])
    xi_g = s_g / length

    def from_samples(xi: FloatArray) -> FloatArray:
        th = np.interp(xi, xi_g, th_g)
        # a smooth derivative: fit locally via the gradient of the sampled curve
        dth = np.interp(xi, xi_g, np.gradient(th_g, xi_g))
        return np.vstack([th, dth])

    return from_samples


def _continuation(
    prob: _Problem,
    y0_fn: Callable[[FloatArray], FloatArray],
    lam0: float,
    *,
    n_steps: int,
    tol: float,
    max_nodes: int,
    n_mesh: int,
    max_jump: float,
    allow_snap: bool,
):
    """Follow the solution from load factor ``lam0`` (solution ``y0_fn``) to 1."""
    xi = np.linspace(0.0, 1.0, n_mesh)
    if lam0 > 0.0:
        res = _solve_at(prob, lam0, xi, y0_fn(xi), tol, max_nodes)
        if res.status != 0:
            raise ElasticaConvergenceError(
                f"no convergence at the starting load factor {lam0:g}: {res.message}"
            )
        cur: tuple[float, Callable, FloatArray] = (lam0, res.sol, res.x)
        last = res
    else:
        cur = (0.0, y0_fn, xi)
        last = None
    prev: tuple[float, Callable, FloatArray] | None = None
    step0 = (1.0 - lam0) / max(n_steps, 1)
    step = step0
    min_step = step0 * 1e-4
    snapped = False
    while cur[0] < 1.0 - 1e-14:
        lam_try = min(1.0, cur[0] + step)
        xg = cur[2]
        yg = cur[1](xg)
        if prev is not None:
            yg = yg + (lam_try - cur[0]) / (cur[0] - prev[0]) * (yg - prev[1](xg))
        res = _solve_at(prob, lam_try, xg, yg, tol, max_nodes)
        jumped = False
        if res.status == 0:
            jumped = float(np.max(np.abs(res.sol(xg)[0] - yg[0]))) > max_jump
        if res.status == 0 and (not jumped or (step <= min_step and allow_snap)):
            snapped = snapped or jumped
            prev = None if jumped else cur
            cur = (lam_try, res.sol, res.x)
            last = res
            step = min(1.5 * step, 2.0 * step0)
            continue
        step *= 0.5
        if step < min_step:
            why = "the branch jumps (fold)" if jumped else res.message
            raise ElasticaConvergenceError(
                f"load continuation stalled at load factor {cur[0]:.6g}: {why}"
            )
    if last is None:  # lam0 == 1 handled by caller; zero steps cannot happen here
        raise ElasticaConvergenceError("continuation produced no solution")
    return last, snapped


def _lowest_mode(
    prob: _Problem, lam: float, xi: FloatArray, theta: FloatArray
) -> tuple[float, FloatArray]:
    """Lowest eigenpair of ``-d2/dxi2 + lam q cos(beta - alpha - theta)`` (FD, O(h^2)).

    The operator is the second variation of the energy in units of ``EI / L``; the
    eigenvector is returned on ``xi`` (zero at a clamp), scaled to ``max |v| = 1``.
    """
    n = xi.size
    h = xi[1] - xi[0]
    v = lam * prob.q(xi) * np.cos(prob.field_angle - prob.alpha(xi) - theta)
    w = np.ones(n)
    w[0] = w[-1] = 0.5
    kdiag = np.full(n, 2.0 / h)
    kdiag[0] = kdiag[-1] = 1.0 / h
    d = kdiag / (h * w) + v
    e = -1.0 / (h * h * np.sqrt(w[:-1] * w[1:]))
    start = 1 if prob.bc == "clamped-free" else 0
    vals, vecs = eigh_tridiagonal(d[start:], e[start:], select="i", select_range=(0, 0))
    mode = np.zeros(n)
    mode[start:] = vecs[:, 0] / np.sqrt(w[start:])
    mode /= mode[np.argmax(np.abs(mode))]
    return float(vals[0]), mode


def _build_solution(
    prob: _Problem,
    fn: Callable[[FloatArray], FloatArray],
    *,
    residual: float,
    bc_residual: float,
    message: str,
    n_nodes: int,
    snapped: bool,
    n_out: int,
) -> ElasticaSolution:
    rod = prob.rod
    L = rod.length
    xi = np.linspace(0.0, 1.0, n_out)
    y = fn(xi)
    theta, dth = y[0].copy(), y[1] / L
    s = xi * L
    h = s[1] - s[0]
    x = cumulative_simpson(np.cos(theta), dx=h, initial=0.0)
    yy = cumulative_simpson(np.sin(theta), dx=h, initial=0.0)
    mag = rod.area * rod.magnetization_at(s) * prob.field_strength
    e_bend = float(simpson(0.5 * rod.bending_stiffness * dth**2, dx=h))
    e_mag = float(simpson(-mag * np.cos(theta + rod.alpha_at(s) - prob.field_angle), dx=h))
    c0, s0 = math.cos(theta[0]), math.sin(theta[0])
    dxl = c0 * x[-1] + s0 * yy[-1]
    dyl = -s0 * x[-1] + c0 * yy[-1]
    eig, _ = _lowest_mode(prob, 1.0, xi, theta)
    return ElasticaSolution(
        s=s,
        theta=theta,
        dtheta=dth,
        x=x,
        y=yy,
        tip_angle=float(theta[-1] - theta[0]),
        tip_deflection=float(dyl),
        tip_shortening=float(L - dxl),
        end_to_end=float(math.hypot(x[-1], yy[-1])),
        peak_curvature=float(np.max(np.abs(dth))),
        energy=e_bend + e_mag,
        bending_energy=e_bend,
        magnetic_energy=e_mag,
        stability_eigenvalue=eig,
        stable=eig > -STABILITY_TOLERANCE,
        residual=residual,
        bc_residual=bc_residual,
        converged=True,
        message=message,
        n_nodes=n_nodes,
        snapped=snapped,
        field_strength=prob.field_strength,
        field_angle=prob.field_angle,
        bc=prob.bc,
        rod=rod,
        _fn=fn,
    )


def _solution_of_bvp(prob: _Problem, res, snapped: bool, n_out: int) -> ElasticaSolution:
    """:func:`_build_solution` from a converged ``scipy.integrate.solve_bvp`` result."""
    return _build_solution(
        prob,
        res.sol,
        residual=float(np.max(res.rms_residuals)),
        bc_residual=_bc_residual(prob, res),
        message=res.message,
        n_nodes=int(res.x.size),
        snapped=snapped,
        n_out=n_out,
    )


def _bc_residual(prob: _Problem, res) -> float:
    _, _, bc, _ = _bvp_functions(prob, 1.0)
    return float(np.max(np.abs(bc(res.y[:, 0], res.y[:, -1]))))


def _make_problem(
    rod: MagneticRod, field_strength: float, field_angle: float, bc: str, theta_clamp: float
) -> _Problem:
    if bc not in BOUNDARY_CONDITIONS:
        raise ValueError(f"bc must be one of {BOUNDARY_CONDITIONS}, not {bc!r}")
    if rod.length <= 0 or rod.bending_stiffness <= 0 or rod.area <= 0:
        raise ValueError("length, bending stiffness and area must be positive")
    if field_strength < 0:  # a negative magnitude means the reversed field
        field_strength, field_angle = -field_strength, field_angle + math.pi
    return _Problem(rod, float(field_strength), float(field_angle), bc, float(theta_clamp))


def solve_elastica(
    rod: MagneticRod,
    field_strength: float,
    field_angle: float,
    bc: str = "clamped-free",
    *,
    theta0: float = 0.0,
    initial_guess: GuessLike | None = None,
    ramp_steps: int = 10,
    tol: float = 1e-7,
    n_mesh: int = 81,
    max_nodes: int = 20000,
    n_out: int = 1001,
    max_jump: float = 1.0,
    allow_snap: bool = True,
    seek_stable: bool = False,
) -> ElasticaSolution:
    """Solve the planar magnetic elastica ``EI theta'' + A|M||B| sin(beta - alpha_m - theta) = 0``.

    Parameters
    ----------
    rod : MagneticRod
        Rod properties (SI units).
    field_strength : float
        ``|B|`` (T).  A negative value is read as the reversed field.
    field_angle : float
        ``beta``, the lab-frame field direction (rad).
    bc : {"clamped-free", "free-free"}
        Boundary conditions (see the module docstring).
    theta0 : float
        Clamp angle ``theta(0)`` (rad) for ``"clamped-free"``; for ``"free-free"`` the
        orientation of the straight starting state of the ramp (and of the solution at
        zero field).
    initial_guess : ElasticaSolution, callable or (s, theta), optional
        If given, Newton starts from this shape directly at the full load (no ramp):
        a callable ``theta(s)`` (``s`` in m, shape (n,)), or sample arrays ``s`` (m) and
        ``theta`` (rad) of equal shape (n,), e.g. a simulated shape.  The solver then
        converges to the nearby equilibrium (the branch the guess is on).  If omitted,
        the load is ramped from zero starting from the straight rod at ``theta0``.
    ramp_steps : int
        Initial number of continuation steps (the step adapts).
    tol : float
        Relative collocation tolerance of ``solve_bvp`` (also used for the boundary
        conditions).
    n_mesh : int
        Initial number of mesh nodes.
    max_nodes : int
        Mesh size limit of ``solve_bvp``.
    n_out : int
        Size of the uniform output grid (odd is best for Simpson's rule).
    max_jump : float
        Largest change of ``theta`` (rad) from the continuation predictor accepted
        without treating it as a jump to another branch.
    allow_snap : bool
        When the branch ends at a fold, accept the jump to the other branch (the
        snap-through a quasi-static ramp would show) instead of raising.
    seek_stable : bool
        If the equilibrium reached is unstable (e.g. the straight rod past a
        bifurcation, which a ramp without imperfection follows), perturb it along its
        unstable mode (amplitudes 0.05 to 2 rad, both signs, positive first) and return
        the first *stable* equilibrium Newton converges to; the unstable one is
        returned if none is found.

    Returns
    -------
    ElasticaSolution

    Raises
    ------
    ElasticaConvergenceError
        If ``solve_bvp`` or the continuation does not converge.
    """
    prob = _make_problem(rod, field_strength, field_angle, bc, theta0)
    L = rod.length
    if prob.unloaded:
        if bc == "clamped-free" or initial_guess is None:
            const = prob.theta_clamp
        else:
            gfn = _guess_function(initial_guess, L)
            const = float(np.mean(gfn(np.linspace(0.0, 1.0, 201))[0]))

        def straight(xi: FloatArray) -> FloatArray:
            xi = np.atleast_1d(xi)
            return np.vstack([np.full(xi.shape, const), np.zeros(xi.shape)])

        return _build_solution(
            prob,
            straight,
            residual=0.0,
            bc_residual=0.0,
            message="zero load: straight rod",
            n_nodes=0,
            snapped=False,
            n_out=n_out,
        )
    if initial_guess is not None:
        gfn = _guess_function(initial_guess, L)
        xi = np.linspace(0.0, 1.0, n_mesh)
        res = _solve_at(prob, 1.0, xi, gfn(xi), tol, max_nodes)
        if res.status != 0:
            raise ElasticaConvergenceError(
                f"solve_bvp did not converge from the initial guess: {res.message}"
            )
        snapped = False
    else:

        def straight0(xi: FloatArray) -> FloatArray:
            return np.vstack([np.full(xi.shape, prob.theta_clamp), np.zeros(xi.shape)])

        res, snapped = _continuation(
            prob,
            straight0,
            0.0,
            n_steps=ramp_steps,
            tol=tol,
            max_nodes=max_nodes,
            n_mesh=n_mesh,
            max_jump=max_jump,
            allow_snap=allow_snap,
        )
    sol = _solution_of_bvp(prob, res, snapped, n_out)
    if seek_stable and not sol.stable:
        sol = _seek_stable(prob, sol, tol=tol, n_mesh=n_mesh, max_nodes=max_nodes, n_out=n_out)
    return sol


STABILITY_SEARCH_AMPLITUDES = (0.05, 0.2, 0.5, 1.0, 2.0)
"""Perturbation amplitudes (rad) along the unstable mode tried by ``seek_stable``."""


def _seek_stable(prob: _Problem, sol: ElasticaSolution, **kw) -> ElasticaSolution:
    _, mode = _lowest_mode(prob, 1.0, sol.s / prob.rod.length, sol.theta)
    for amp in STABILITY_SEARCH_AMPLITUDES:
        for sign in (1.0, -1.0):
            guess = (sol.s, sol.theta + sign * amp * mode)
            try:
                cand = solve_elastica(
                    prob.rod,
                    prob.field_strength,
                    prob.field_angle,
                    prob.bc,
                    theta0=prob.theta_clamp,
                    initial_guess=guess,
                    **kw,
                )
            except ElasticaConvergenceError:
                continue
            if cand.stable:
                return cand
    return sol


def continue_from(
    rod: MagneticRod,
    field_strength: float,
    field_angle: float,
    bc: str,
    guess: GuessLike,
    start_fraction: float,
    *,
    ramp_steps: int = 10,
    tol: float = 1e-7,
    n_mesh: int = 81,
    max_nodes: int = 20000,
    n_out: int = 1001,
    max_jump: float = 1.0,
    allow_snap: bool = False,
    theta0: float = 0.0,
) -> ElasticaSolution:
    """Solve at ``start_fraction * |B|`` from ``guess``, then continue the branch to ``|B|``.

    Parameters are as in :func:`solve_elastica`; ``start_fraction`` is in ``(0, 1]``.
    By default a fold (branch end) raises instead of snapping.
    """
    if not 0.0 < start_fraction <= 1.0:
        raise ValueError("start_fraction must be in (0, 1]")
    prob = _make_problem(rod, field_strength, field_angle, bc, theta0)
    gfn = _guess_function(guess, rod.length)
    if start_fraction == 1.0:
        return solve_elastica(
            rod,
            field_strength,
            field_angle,
            bc,
            theta0=theta0,
            initial_guess=guess,
            tol=tol,
            n_mesh=n_mesh,
            max_nodes=max_nodes,
            n_out=n_out,
        )
    res, snapped = _continuation(
        prob,
        gfn,
        start_fraction,
        n_steps=ramp_steps,
        tol=tol,
        max_nodes=max_nodes,
        n_mesh=n_mesh,
        max_jump=max_jump,
        allow_snap=allow_snap,
    )
    return _solution_of_bvp(prob, res, snapped, n_out)
