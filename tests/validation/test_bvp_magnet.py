"""The dipole-field cantilever reference (validation/bvp_magnet.py) against the uniform-field
elastica solver in the limit of a distant dipole, and its basic balances."""

import math

import numpy as np
from elastica_magnetic_validation.bvp_magnet import (
    dipole_field_2d,
    linear_field_2d,
    solve_dipole_cantilever,
    solve_magnetic_cantilever,
)
from elastica_magnetic_validation.bvp_problems import cantilever

LENGTH, RADIUS, E, M = 0.1, 2e-3, 1e6, 1e5
EI, AREA = E * math.pi * RADIUS**4 / 4, math.pi * RADIUS**2


def test_a_distant_dipole_is_the_uniform_field_cantilever():
    """A dipole 50 m below the rod, pointing at it: B ~ 1 mT along +y, uniform to ~3 y / D over
    the rod; q = M B A L^2 / EI = 1 at phi = 90 deg. They agree to 2e-3 (the non-uniformity)."""
    distance = 50.0
    b = 1e-3
    moment = b * distance**3 / 2e-7  # on-axis field mu0 2 m / (4 pi D^3) = 2e-7 m / D^3 = b
    sol = solve_dipole_cantilever(LENGTH, EI, AREA, M, [0.0, moment, 0.0], [LENGTH / 2, -distance, 0.0],
                                  steps=4, nodes=100, tol=1e-10)
    q = M * b * AREA * LENGTH**2 / EI
    reference = cantilever(q, 90.0, degrees=True)
    assert abs(sol.tip[2] - reference.tip_angle) < 5e-3 * abs(reference.tip_angle)
    assert abs(sol.tip[1] / LENGTH - reference.delta_y) < 5e-3 * abs(reference.delta_y)


def test_no_moment_leaves_the_rod_straight_and_the_field_is_the_dipole_s():
    sol = solve_dipole_cantilever(LENGTH, EI, AREA, M, [0.0, 0.0, 0.0], [0.05, -0.04, 0.0], steps=1,
                                  nodes=20)
    np.testing.assert_allclose(sol.tip, (LENGTH, 0.0, 0.0), atol=1e-12)
    bx, by, grad = dipole_field_2d(np.array([0.0, 1.0]), np.array([0.0, 0.0]), np.array([0.0]),
                                   np.array([0.1]))
    np.testing.assert_allclose([bx[0], by[0]], [0.0, 2e-7 / 0.1**3], rtol=1e-14)
    np.testing.assert_allclose(grad[1][1][0], -3 * 2e-7 / 0.1**4, rtol=1e-14)


def test_a_magnetization_across_the_axis_is_the_axial_one_in_a_field_turned_by_90_degrees():
    """Across the axis (alpha = 90 deg) in a uniform field at 180 deg is the axial magnetization in
    the field at 90 deg: the uniform-field cantilever at q = 1."""
    b = 1e-3

    def uniform(x, y, scale):
        zero = 0.0 * x
        return -scale * b + zero, zero, [[zero, zero], [zero, zero]]

    sol = solve_magnetic_cantilever(LENGTH, EI, AREA, M, uniform, math.pi / 2, steps=4, nodes=100, tol=1e-10)
    reference = cantilever(M * b * AREA * LENGTH**2 / EI, 90.0, degrees=True)
    assert abs(sol.tip[2] - reference.tip_angle) < 1e-5 * abs(reference.tip_angle)
    assert abs(sol.tip[1] / LENGTH - reference.delta_y) < 1e-5 * abs(reference.delta_y)


def test_a_small_constant_gradient_bends_the_rod_as_linear_beam_theory_says():
    """Magnetized across the axis (+y) in B = b (-x/2, y): per length a force A M b along +y and a
    couple A M b x / 2; Euler-Bernoulli gives the tip deflection 11/48 lambda L, lambda = A M b L^3 /
    EI (first order in lambda)."""
    lam = 1e-4
    b = lam * EI / (AREA * M * LENGTH**3)
    sol = solve_magnetic_cantilever(LENGTH, EI, AREA, M, linear_field_2d([[-b / 2, 0.0], [0.0, b]]),
                                    math.pi / 2, steps=1, nodes=100, tol=1e-12)
    assert abs(sol.tip[1] / LENGTH - 11 / 48 * lam) < 1e-3 * 11 / 48 * lam
