"""Tests of the independent planar-elastica reference solver (validation/elastica_bvp.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from elastica_magnetic_validation.bvp_problems import (
    cantilever,
    hu2018_free_free,
    hu2018_rod,
    lum2016_curvature,
)
from elastica_magnetic_validation.elastica_bvp import (
    ElasticaConvergenceError,
    Equilibria,
    MagneticRod,
    max_matched_distance,
    solve_elastica,
)
from scipy.special import ellipk

Q_CRIT = math.pi**2 / 4.0  # buckling load of the cantilever at phi = 180 deg


# ------------------------------------------------------------------------------------
# Cantilever (Wang et al. 2020)
# ------------------------------------------------------------------------------------


@pytest.mark.parametrize("phi_deg", [30.0, 90.0, 150.0])
@pytest.mark.parametrize("q", [0.02, 0.1])
def test_cantilever_small_load_limits(q: float, phi_deg: float) -> None:
    """Perturbation series of theta'' = -q sin(phi - theta), theta(0) = 0, theta'(1) = 0.

    theta = q sin(phi) (xi - xi^2/2) + q^2 sin(phi) cos(phi) (xi^3/6 - xi^4/24 - xi/3) + O(q^3),
    so theta(1) = q s/2 - 5/24 q^2 s c + O(q^3) and delta_y = int theta - int theta^3/6 =
    q s/3 - 2/15 q^2 s c + O(q^3).  The O(q^3) coefficients are below 0.05 in magnitude
    for every phi (they are combinations of 1/k! -type integrals of the lower orders), so
    0.1 q^3 bounds the truncation error: the first-order formula must hold to within the
    second-order term plus that, the second-order formula to within 0.1 q^3 alone.
    """
    phi = math.radians(phi_deg)
    s, c = math.sin(phi), math.cos(phi)
    res = cantilever(q, phi_deg, degrees=True)
    third = 0.1 * q**3
    # leading order, with the neglected second-order term as the tolerance
    assert abs(res.tip_angle - q * s / 2) <= 5 / 24 * q**2 * abs(s * c) + third
    assert abs(res.delta_y - q * s / 3) <= 2 / 15 * q**2 * abs(s * c) + third
    # second order
    assert abs(res.tip_angle - (q * s / 2 - 5 / 24 * q**2 * s * c)) <= third
    assert abs(res.delta_y - (q * s / 3 - 2 / 15 * q**2 * s * c)) <= third
    # shortening is second order: delta_x = int theta^2/2 = q^2 s^2 / 15 + O(q^3)
    assert abs(res.delta_x - q**2 * s**2 / 15) <= third
    # rotates towards the field
    assert res.tip_angle > 0
    assert res.solution.residual < 1e-6
    assert res.solution.stable


def test_cantilever_third_order_convergence() -> None:
    """The second-order formula's error falls like q^3 (halving q divides it by ~8)."""
    phi = math.radians(90.0)  # sin*cos = 0 here, so the first-order formula is O(q^3)
    errs = [abs(cantilever(q, phi).tip_angle - q / 2) for q in (0.2, 0.1)]
    assert 7.0 < errs[0] / errs[1] < 9.0


def test_zero_load_cantilever_is_straight() -> None:
    res = cantilever(0.0, 1.0)
    assert np.all(res.solution.theta == 0.0)
    assert res.delta_y == 0.0
    assert abs(res.delta_x) < 1e-12
    assert res.solution.energy == 0.0


def test_cantilever_large_load_sane_and_mesh_independent() -> None:
    """Large deflection: tip angle below phi, solution insensitive to tolerance/mesh."""
    res = cantilever(10.0, 150.0, degrees=True)
    assert 0 < res.tip_angle < math.radians(150.0)
    assert res.solution.stable
    assert res.solution.residual < 1e-6 and res.solution.bc_residual < 1e-6
    fine = cantilever(10.0, 150.0, degrees=True, tol=1e-10)
    assert abs(fine.tip_angle - res.tip_angle) < 1e-7
    assert abs(fine.delta_y - res.delta_y) < 1e-7
    assert abs(fine.delta_x - res.delta_x) < 1e-7
    # the monotone approach to the field: more load, more rotation
    assert cantilever(5.0, 150.0, degrees=True).tip_angle < res.tip_angle


def test_buckling_straight_below_buckled_above() -> None:
    below = cantilever(0.97 * Q_CRIT, math.pi)
    assert abs(below.tip_angle) < 1e-8 and abs(below.delta_y) < 1e-8
    assert below.solution.stable
    # second variation of the straight rod: -d2/dxi2 - q with theta(0)=0, theta'(1)=0,
    # lowest eigenvalue (pi/2)^2 - q
    assert below.solution.stability_eigenvalue == pytest.approx(0.03 * Q_CRIT, abs=2e-4)

    above = cantilever(1.03 * Q_CRIT, math.pi)
    assert above.tip_angle > 0.1
    assert above.solution.stable
    straight = solve_elastica(MagneticRod(1.0, 1.0, 1.0, 1.03 * Q_CRIT), 1.0, math.pi)
    assert abs(straight.tip_angle) < 1e-8 and not straight.stable
    assert above.solution.energy < straight.energy


@pytest.mark.parametrize("factor", [1.03, 1.5, 3.0])
def test_buckled_branch_exact_elliptic(factor: float) -> None:
    """theta'' = -q sin(theta): quarter period, sqrt(q) = K(k), k = sin(theta_tip / 2)."""
    q = factor * Q_CRIT
    tip = cantilever(q, math.pi).tip_angle
    assert math.sqrt(q) == pytest.approx(ellipk(math.sin(tip / 2) ** 2), rel=1e-6)


def test_buckling_load_by_bisection() -> None:
    lo, hi = 1.0, 4.0
    assert cantilever(lo, math.pi).tip_angle < 1e-3 < cantilever(hi, math.pi).tip_angle
    while hi - lo > 0.005 * Q_CRIT:
        mid = 0.5 * (lo + hi)
        if cantilever(mid, math.pi).tip_angle > 1e-3:
            hi = mid
        else:
            lo = mid
    assert 0.5 * (lo + hi) == pytest.approx(Q_CRIT, rel=0.01)


# ------------------------------------------------------------------------------------
# Free-free: Hu et al. 2018 robot and Lum et al. 2016 first order
# ------------------------------------------------------------------------------------


def _field_for(kl2: float) -> float:
    rod = hu2018_rod()
    return kl2 * rod.bending_stiffness / (rod.area * rod.magnetization * rod.length**2)


def test_free_free_zero_field_straight() -> None:
    eq = hu2018_free_free(0.0, 0.3)
    assert len(eq.solutions) == 1
    sol = eq.lowest
    assert np.ptp(sol.theta) == 0.0
    assert sol.end_to_end == pytest.approx(sol.rod.length, rel=1e-12)
    assert sol.peak_curvature == 0.0 and sol.energy == 0.0


@pytest.mark.parametrize("kl2", [0.1, 0.5])
def test_free_free_small_load_matches_lum(kl2: float) -> None:
    """Small load: curvature equals Lum's first order to O(K L^2), relative."""
    B = _field_for(kl2)
    beta = 0.3
    eq = hu2018_free_free(B, beta, phi0=0.2, n_orientations=4)
    rod = eq.lowest.rod
    K = rod.area * rod.magnetization * B / rod.bending_stiffness
    scale = K * rod.length / math.pi  # peak first-order curvature
    phases = []
    for sol in eq.solutions:
        assert sol.residual < 1e-6
        c = (beta - sol.theta[0] - 0.2) % (2 * math.pi)
        kappa = lum2016_curvature(sol.s, K, c, rod.length)
        # the neglected terms are O((K L^2)^2) against O(K L^2): relative error 0.1 K L^2
        assert np.max(np.abs(sol.dtheta - kappa)) < 0.1 * kl2 * scale
        phases.append((c, sol.stable))
    # second-order torque balance: c in {0, pi} stable (C), {pi/2, 3pi/2} unstable (S)
    assert len(phases) == 4
    for c, stable in phases:
        nearest = round(c / (math.pi / 2)) % 4
        assert abs(c - round(c / (math.pi / 2)) * math.pi / 2) < 0.1 * kl2
        assert stable == (nearest in (0, 2))


@pytest.fixture(scope="module")
def hu_10mT() -> Equilibria:
    return hu2018_free_free(10e-3, 0.0, n_orientations=4)


def test_hu2018_multiple_equilibria_lowest_is_stable(hu_10mT) -> None:
    eq = hu_10mT
    assert len(eq.solutions) >= 3
    energies = eq.energies
    assert energies == sorted(energies)
    low = eq.lowest
    assert low.stable and low.stability_eigenvalue > 1.0
    for sol in eq.solutions[1:]:
        assert sol.energy > low.energy
        assert sol.residual < 1e-6 and sol.bc_residual < 1e-6
    unstable = [s for s in eq.solutions if not s.stable]
    assert unstable and all(s.energy > low.energy for s in unstable)
    # the S-shaped pair (mirror images of each other) has equal energies
    assert len(unstable) == 2
    assert unstable[0].energy == pytest.approx(unstable[1].energy, rel=1e-6)
    # zero net torque: int A M B sin(beta - alpha - theta) ds = EI (theta'(0)-theta'(L)) = 0
    rod = low.rod
    torque = np.trapezoid(
        rod.area * rod.magnetization * 10e-3 * np.sin(0.0 - rod.alpha_at(low.s) - low.theta), low.s
    )
    assert abs(torque) < 1e-6 * rod.bending_stiffness / rod.length


def test_hu2018_start_from_perturbed_shape_finds_same_branch(hu_10mT) -> None:
    """Solving from a perturbed (e.g. simulated) shape recovers the nearby branch."""
    low = hu_10mT.lowest
    s = low.s[::20]
    noisy = low.theta[::20] + 0.05 * np.sin(7 * math.pi * s / low.rod.length)
    sol = solve_elastica(low.rod, 10e-3, 0.0, "free-free", initial_guess=(s, noisy))
    assert hu_10mT.closest_to(sol).energy == pytest.approx(sol.energy, rel=1e-8)
    assert max_matched_distance(sol.x, sol.y, low.x, low.y) < 1e-6 * low.rod.length


@pytest.mark.parametrize("gamma_deg", [90, 180, 270])
def test_hu2018_rotation_invariance(hu_10mT, gamma_deg: int) -> None:
    """Rotating the field by gamma rotates every equilibrium rigidly by gamma."""
    gamma = math.radians(gamma_deg)
    rot = hu2018_free_free(10e-3, gamma, n_orientations=4)
    assert len(rot.solutions) == len(hu_10mT.solutions)
    assert rot.lowest.energy == pytest.approx(hu_10mT.lowest.energy, rel=1e-7)

    def mismatch(sol, ref) -> float:
        d = (sol.theta - ref.theta - gamma + math.pi) % (2 * math.pi) - math.pi
        return float(np.max(np.abs(d)))

    for i, ref in enumerate(hu_10mT.solutions):
        # equal-energy states (the S pair) may come in either order: match by shape
        sol = min(rot.solutions, key=lambda s, ref=ref: mismatch(s, ref))
        assert mismatch(sol, ref) < 1e-5
        assert sol.energy == pytest.approx(ref.energy, rel=1e-7)
        assert sol.energy == pytest.approx(rot.energies[i], rel=1e-7)
        cg, sg = math.cos(gamma), math.sin(gamma)
        xr, yr = cg * ref.x - sg * ref.y, sg * ref.x + cg * ref.y
        assert max_matched_distance(sol.x, sol.y, xr, yr, align=False) < 1e-6 * ref.rod.length
        assert sol.end_to_end == pytest.approx(ref.end_to_end, rel=1e-6)
        assert sol.tip_angle == pytest.approx(ref.tip_angle, abs=1e-6)


def test_hu2018_mesh_independence(hu_10mT) -> None:
    low = hu_10mT.lowest
    fine = solve_elastica(
        low.rod, 10e-3, 0.0, "free-free", initial_guess=low, tol=1e-10, n_out=2001
    )
    assert fine.n_nodes > low.n_nodes
    assert np.max(np.abs(fine.evaluate(low.s)[0] - low.theta)) < 1e-6
    assert fine.energy == pytest.approx(low.energy, rel=1e-7)
    assert fine.end_to_end == pytest.approx(low.end_to_end, rel=1e-7)
    assert fine.peak_curvature == pytest.approx(low.peak_curvature, rel=1e-5)


def test_phi0_is_a_rotation_of_the_field() -> None:
    """A constant magnetization offset phi0 equals rotating the field by -phi0."""
    B = 5e-3
    a = hu2018_free_free(B, 0.0, phi0=0.7, n_orientations=4).lowest
    b = hu2018_free_free(B, -0.7, phi0=0.0, n_orientations=4).lowest
    assert a.energy == pytest.approx(b.energy, rel=1e-7)
    assert max_matched_distance(a.x, a.y, b.x, b.y, align=False) < 1e-6 * a.rod.length


def test_equivalent_circular_rod_same_shape() -> None:
    """Only A/EI matters: the r = h/sqrt(3) circular rod gives the same shape."""
    h, E = 185e-6, 84.5e3
    r = h / math.sqrt(3.0)
    band = hu2018_free_free(5e-3, 0.0, n_orientations=0).lowest
    circ = hu2018_free_free(
        5e-3, 0.0, EI=E * math.pi * r**4 / 4, area=math.pi * r**2, n_orientations=0
    ).lowest
    assert max_matched_distance(band.x, band.y, circ.x, circ.y, align=False) < 1e-8


def test_nonconvergence_raises() -> None:
    rod = hu2018_rod()
    with pytest.raises(ElasticaConvergenceError):
        solve_elastica(rod, 20e-3, 0.0, "free-free", initial_guess=lambda s: 0 * s, max_nodes=50)
    with pytest.raises(ValueError):
        solve_elastica(rod, 1e-3, 0.0, "clamped-clamped")
