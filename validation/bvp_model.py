"""The planar magnetic elastica's inputs and results, for the independent reference solver
(:mod:`elastica_magnetic_validation.elastica_bvp`, where the model and its conventions are
described): the rod (:class:`MagneticRod`), an equilibrium (:class:`ElasticaSolution`), a set of
equilibria for one load (:class:`Equilibria`) and the comparisons of shapes. Depends on numpy only,
like the solver (the reference must not depend on the simulator it checks)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]
Profile = float | Callable[[FloatArray], ArrayLike]
"""A constant, or a function of the arc length ``s`` (m, array) returning an array."""

BOUNDARY_CONDITIONS = ("clamped-free", "free-free")


STABILITY_TOLERANCE = 1e-8
"""Equilibria with a stability eigenvalue above ``-STABILITY_TOLERANCE`` count as stable
(the neutral rotation of a free rod in zero field has eigenvalue 0)."""


# --------------------------------------------------------------------------------------
# Problem definition
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class MagneticRod:
    """Geometry, stiffness and magnetization of a planar magnetic rod.

    Parameters
    ----------
    length : float
        Rod length ``L`` (m).
    bending_stiffness : float
        ``EI`` (N m^2).
    area : float
        Cross-section area ``A`` (m^2).
    magnetization : float or callable
        Magnitude ``|M|`` (A/m); constant, or ``f(s) -> |M|`` for ``s`` (m) an array of
        shape ``(n,)`` returning shape ``(n,)``.
    alpha_m : float or callable
        Direction of the magnetization relative to the tangent (rad, counter-clockwise);
        constant, or ``f(s) -> alpha_m`` with the same shapes as above.
    """

    length: float
    bending_stiffness: float
    area: float
    magnetization: Profile
    alpha_m: Profile = 0.0

    def magnetization_at(self, s: ArrayLike) -> FloatArray:
        """``|M|(s)`` (A/m) at arc lengths ``s`` (m), same shape as ``s``."""
        return evaluate_profile(self.magnetization, s)

    def alpha_at(self, s: ArrayLike) -> FloatArray:
        """``alpha_m(s)`` (rad) at arc lengths ``s`` (m), same shape as ``s``."""
        return evaluate_profile(self.alpha_m, s)


def evaluate_profile(profile: Profile, s: ArrayLike) -> FloatArray:
    s = np.asarray(s, dtype=float)
    if callable(profile):
        return np.broadcast_to(np.asarray(profile(s), dtype=float), s.shape).astype(float)
    return np.full(s.shape, float(profile))


# --------------------------------------------------------------------------------------
# Result
# --------------------------------------------------------------------------------------


@dataclass
class ElasticaSolution:
    """An equilibrium of the planar magnetic elastica (SI units).

    Attributes
    ----------
    s : ndarray, shape (n,)
        Uniform output grid of arc lengths (m), ``s[0] = 0``, ``s[-1] = L``.
    theta : ndarray, shape (n,)
        Tangent angle (rad, lab frame).
    dtheta : ndarray, shape (n,)
        Curvature ``theta'`` (1/m).
    x, y : ndarray, shape (n,)
        Centreline (m), with ``x[0] = y[0] = 0``.
    tip_angle : float
        End rotation ``theta(L) - theta(0)`` (rad); for a cantilever the tip angle.
    tip_deflection : float
        Displacement of the ``s = L`` end perpendicular to the ``s = 0`` tangent (m),
        positive to the left of it (the ``delta_y`` of a cantilever).
    tip_shortening : float
        ``L`` minus the displacement of the ``s = L`` end along the ``s = 0`` tangent (m)
        (the ``delta_x`` of a cantilever, >= 0).
    end_to_end : float
        Distance between the two ends (m).
    peak_curvature : float
        ``max |theta'|`` (1/m).
    energy : float
        ``int (EI theta'^2/2 - A M.B) ds`` (J).
    bending_energy, magnetic_energy : float
        The two parts of ``energy`` (J).
    stability_eigenvalue : float
        Lowest eigenvalue of the dimensionless second variation
        ``-d^2/dxi^2 + (A |M| |B| L^2/EI) cos(beta - alpha_m - theta)`` with the problem's
        boundary conditions (``> 0``: locally stable).
    stable : bool
        ``stability_eigenvalue > -STABILITY_TOLERANCE`` (marginal counts as stable).
    residual : float
        Largest relative collocation residual reported by ``solve_bvp``.
    bc_residual : float
        Largest boundary-condition residual (dimensionless).
    converged : bool
        Always ``True`` for a returned object (failures raise).
    message : str
        Solver message.
    n_nodes : int
        Number of collocation nodes of the final mesh.
    snapped : bool
        ``True`` when the load continuation had to jump to another branch (snap-through).
    field_strength, field_angle : float
        ``|B|`` (T) and ``beta`` (rad).
    bc : str
        Boundary conditions.
    rod : MagneticRod
        The rod.
    """

    s: FloatArray
    theta: FloatArray
    dtheta: FloatArray
    x: FloatArray
    y: FloatArray
    tip_angle: float
    tip_deflection: float
    tip_shortening: float
    end_to_end: float
    peak_curvature: float
    energy: float
    bending_energy: float
    magnetic_energy: float
    stability_eigenvalue: float
    stable: bool
    residual: float
    bc_residual: float
    converged: bool
    message: str
    n_nodes: int
    snapped: bool
    field_strength: float
    field_angle: float
    bc: str
    rod: MagneticRod = field(repr=False)
    _fn: Callable[[FloatArray], FloatArray] = field(repr=False)

    def evaluate(self, s: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Interpolate the solution.

        Parameters
        ----------
        s : array_like, shape (m,)
            Arc lengths (m) in ``[0, L]``.

        Returns
        -------
        theta : ndarray, shape (m,)
            Tangent angle (rad).
        dtheta : ndarray, shape (m,)
            Curvature (1/m).
        """
        xi = np.atleast_1d(np.asarray(s, dtype=float)) / self.rod.length
        y = self._fn(xi)
        return y[0].copy(), y[1] / self.rod.length

    def __call__(self, s: ArrayLike) -> FloatArray:
        """Tangent angle ``theta(s)`` (rad); makes a solution usable as an initial guess."""
        return self.evaluate(s)[0]


GuessLike = ElasticaSolution | Callable[[FloatArray], ArrayLike] | tuple[ArrayLike, ArrayLike]
"""An initial shape: a solution, a function ``theta(s)`` (s in m), or samples ``(s, theta)``."""


# --------------------------------------------------------------------------------------
# Comparing shapes and collecting equilibria
# --------------------------------------------------------------------------------------


def same_state(a: ElasticaSolution, b: ElasticaSolution, atol: float = 1e-4) -> bool:
    """Whether two solutions are the same state: ``theta`` equal modulo 2 pi (``atol`` rad)."""
    sg = np.linspace(0.0, a.rod.length, 201)
    d = a.evaluate(sg)[0] - b.evaluate(sg * b.rod.length / a.rod.length)[0]
    d = (d + math.pi) % (2.0 * math.pi) - math.pi
    return bool(np.max(np.abs(d)) < atol)


def max_matched_distance(
    xa: ArrayLike, ya: ArrayLike, xb: ArrayLike, yb: ArrayLike, align: bool = True
) -> float:
    """Largest distance between matched points of two centrelines (m).

    Parameters
    ----------
    xa, ya, xb, yb : array_like, shape (n,)
        Two centrelines sampled at the same material points (m).
    align : bool
        First remove the best rigid motion (least-squares rotation and translation,
        2-D Kabsch), as is appropriate for free-free bodies.

    Returns
    -------
    float
        ``max_i |r_a(i) - r_b(i)|`` after alignment (m).
    """
    pa = np.column_stack([np.asarray(xa, float), np.asarray(ya, float)])
    pb = np.column_stack([np.asarray(xb, float), np.asarray(yb, float)])
    if pa.shape != pb.shape:
        raise ValueError("the two centrelines need the same number of points")
    if align:
        ca, cb = pa.mean(axis=0), pb.mean(axis=0)
        qa, qb = pa - ca, pb - cb
        # rotation angle maximizing sum qb . R qa
        num = float(np.sum(qa[:, 0] * qb[:, 1] - qa[:, 1] * qb[:, 0]))
        den = float(np.sum(qa[:, 0] * qb[:, 0] + qa[:, 1] * qb[:, 1]))
        ang = math.atan2(num, den)
        rot = np.array([[math.cos(ang), -math.sin(ang)], [math.sin(ang), math.cos(ang)]])
        pa = qa @ rot.T
        pb = qb
    return float(np.max(np.linalg.norm(pa - pb, axis=1)))


@dataclass
class Equilibria:
    """Distinct equilibria found for one load, sorted by increasing energy.

    Attributes
    ----------
    solutions : list of ElasticaSolution
        Sorted by ``energy`` (J), lowest first.
    n_attempts : int
        Number of starting guesses tried.
    n_failed : int
        Number of starting guesses whose solve or continuation failed.
    """

    solutions: list[ElasticaSolution]
    n_attempts: int
    n_failed: int

    @property
    def lowest(self) -> ElasticaSolution:
        """The lowest-energy equilibrium found (the stable one, barring missed branches)."""
        return self.solutions[0]

    @property
    def energies(self) -> list[float]:
        """Energies (J) of all equilibria, increasing."""
        return [sol.energy for sol in self.solutions]

    def closest_to(self, other: ElasticaSolution) -> ElasticaSolution:
        """The equilibrium whose ``theta(s)`` is closest (max norm, modulo 2 pi) to ``other``."""
        sg = np.linspace(0.0, other.rod.length, 201)
        ref = other.evaluate(sg)[0]

        def dist(sol: ElasticaSolution) -> float:
            d = sol.evaluate(sg)[0] - ref
            return float(np.max(np.abs((d + math.pi) % (2.0 * math.pi) - math.pi)))

        return min(self.solutions, key=dist)
