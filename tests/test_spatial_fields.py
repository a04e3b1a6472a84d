"""Spatial field sources: closed forms against Magpylib and finite differences, poses in time,
sums, and bad input (field maps: test_field_maps.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from elastica_magnetic import (
    ConstantField,
    ConstantGradientField,
    CurrentLoopField,
    FieldSum,
    HelmholtzCoils,
    MaxwellCoils,
    PointDipoleField,
    RotatingField,
    SpatialFieldError,
    Waypoints,
)
from elastica_magnetic.spatial_fields import is_spatial

MU0 = 4e-7 * math.pi
RNG = np.random.default_rng(7)
POINTS = RNG.normal(size=(3, 25)) * 0.04 + np.array([[0.0], [0.0], [0.03]])


def fd_gradient(source, points, h, time=0.0):
    """Richardson-extrapolated central differences of ``source.at``: (3, 3, n)."""
    def central(step):
        return np.stack([(source.at(points + step * np.eye(3)[:, [j]], time)
                          - source.at(points - step * np.eye(3)[:, [j]], time)) / (2 * step)
                         for j in range(3)], axis=1)
    return (4.0 * central(h / 2) - central(h)) / 3.0


def test_point_dipole_closed_form_and_gradient():
    moment, position = np.array([0.1, -0.2, 0.9]), np.array([0.01, 0.0, -0.02])
    source = PointDipoleField(moment, position)
    b, g = source.evaluate(POINTS)
    r = POINTS - position[:, None]
    d = np.linalg.norm(r, axis=0)
    n = r / d
    expected = MU0 / (4 * np.pi * d**3) * (3 * n * (moment @ n) - moment[:, None])
    np.testing.assert_allclose(b, expected, rtol=1e-13)
    assert b.shape == (3, 25) and g.shape == (3, 3, 25)
    np.testing.assert_allclose(source.at(POINTS), b)
    np.testing.assert_allclose(source.gradient(POINTS), g)
    np.testing.assert_allclose(g, fd_gradient(source, POINTS, 1e-5), rtol=0, atol=1e-9 * np.abs(g).max())
    # curl-free and divergence-free outside the source
    np.testing.assert_allclose(g, np.transpose(g, (1, 0, 2)), atol=1e-12 * np.abs(g).max())
    np.testing.assert_allclose(np.trace(g), 0.0, atol=1e-12 * np.abs(g).max())


def test_point_dipole_matches_magpylib():
    magpy = pytest.importorskip("magpylib")
    moment, position = np.array([0.3, 0.1, -0.5]), np.array([0.0, 0.02, 0.0])
    ours = PointDipoleField(moment, position).at(POINTS)
    theirs = magpy.misc.Dipole(moment=moment, position=position).getB(POINTS.T).T
    # Magpylib's mu0 is CODATA 2018's (1.25663706212e-6), ours 4 pi 1e-7: 5e-10 apart.
    np.testing.assert_allclose(ours, theirs, rtol=2e-9)


@pytest.mark.parametrize("cls", [CurrentLoopField, HelmholtzCoils, MaxwellCoils])
def test_loops_match_magpylib_and_their_gradient(cls):
    magpy = pytest.importorskip("magpylib")
    from scipy.spatial.transform import Rotation

    centre, current, turns = np.array([0.01, 0.02, 0.0]), 2.5, 30
    source = cls(0.05, current=current, centre=centre, axis=[0.3, 0.1, 1.0], turns=turns)
    b, g = source.evaluate(POINTS)
    loops = magpy.Collection()
    for radius, offset, weight in zip(source.radii, source.offsets, source.weights, strict=True):
        loops.add(magpy.current.Circle(current=current * weight, diameter=2 * radius,
                                       position=centre + offset * source.axis,
                                       orientation=Rotation.from_matrix(source.frame)))
    np.testing.assert_allclose(b, loops.getB(POINTS.T).T, rtol=0, atol=2e-9 * np.abs(b).max())
    np.testing.assert_allclose(g, fd_gradient(source, POINTS, 1e-5), rtol=0, atol=1e-8 * np.abs(g).max())
    np.testing.assert_allclose(np.trace(g), 0.0, atol=1e-12 * np.abs(g).max())


def test_loop_near_and_on_its_axis():
    """The series about the axis and the closed form meet smoothly; on the axis, the textbook
    ``B_z = mu0 I a^2 / (2 (a^2 + z^2)^(3/2))``."""
    a, z = 0.05, 0.03
    loop = CurrentLoopField(a, current=1.0)
    on_axis = loop.at(np.array([[0.0], [0.0], [z]]))[:, 0]
    np.testing.assert_allclose(on_axis, [0, 0, MU0 * a * a / (2 * (a * a + z * z) ** 1.5)], rtol=1e-14)
    rho = np.geomspace(1e-9, 1e-2, 60)
    points = np.vstack([0.6 * rho, 0.8 * rho, np.full_like(rho, z)])
    b, g = loop.evaluate(points)
    h = 1e-6
    reference = fd_gradient(loop, points, h)
    scale = np.abs(b).max() / a
    assert np.abs(g - reference).max() < 1e-7 * scale
    # B_rho / rho and B_z are continuous across the switch (rho^2 = 1e-6 (a^2 + z^2))
    switch = math.sqrt(1e-6 * (a * a + z * z))
    pair = np.array([[switch * (1 - 1e-12), switch * (1 + 1e-12)], [0, 0], [z, z]])
    ratio = loop.at(pair) / np.array([[switch], [1.0], [1.0]])
    np.testing.assert_allclose(ratio[:, 1], ratio[:, 0], rtol=1e-10)


def test_coil_pair_centre_values():
    radius, current, turns = 0.1, 3.0, 50
    centre = np.zeros((3, 1))
    helmholtz = HelmholtzCoils(radius, current=current, turns=turns)
    np.testing.assert_allclose(helmholtz.at(centre)[:, 0],
                               [0, 0, 0.8**1.5 * MU0 * turns * current / radius], rtol=1e-14)
    maxwell = MaxwellCoils(radius, current=current, turns=turns)
    b, g = maxwell.evaluate(centre)
    assert np.abs(b).max() < 1e-18
    gz = 48 * math.sqrt(3) / 7**2.5 * MU0 * turns * current / radius**2
    np.testing.assert_allclose(np.diag(g[:, :, 0]), [-gz / 2, -gz / 2, gz], rtol=1e-12)


def test_constant_gradient_field_is_a_maxwell_pair_near_its_centre():
    g = 0.2  # T/m
    source = ConstantGradientField(np.diag([-g / 2, -g / 2, g]), scale=lambda t: min(t, 1.0),
                                   origin=[0.0, 0.0, 0.01])
    b, grad = source.evaluate(POINTS, 0.5)
    np.testing.assert_allclose(b, 0.5 * np.diag([-g / 2, -g / 2, g]) @ (POINTS - [[0], [0], [0.01]]),
                               rtol=1e-14)
    np.testing.assert_allclose(grad, fd_gradient(source, POINTS, 1e-3, 0.5), rtol=1e-10, atol=1e-15)
    assert is_spatial(source)
    radius = 0.2  # a pair large enough that its gradient is uniform to 1e-3 within 2 mm
    maxwell = MaxwellCoils(radius, current=10.0, turns=100)
    gz = maxwell.gradient(np.zeros((3, 1)))[2, 2, 0]
    near = RNG.normal(size=(3, 8)) * 1e-3
    linear = ConstantGradientField(np.diag([-gz / 2, -gz / 2, gz]))
    np.testing.assert_allclose(maxwell.at(near), linear.at(near), rtol=0, atol=1e-3 * gz * 3e-3)


def test_pose_and_current_follow_time():
    path = Waypoints([0.0, 1.0, 3.0], [[0, 0, 0], [0.01, 0, 0], [0.01, 0.02, 0]])
    np.testing.assert_allclose(path(0.5), [0.005, 0, 0])
    np.testing.assert_allclose(path(2.0), [0.01, 0.01, 0])
    np.testing.assert_allclose(path(-1.0), [0, 0, 0])
    np.testing.assert_allclose(path(9.0), [0.01, 0.02, 0])
    moving = PointDipoleField([0, 0, 1.0], path)
    fixed = PointDipoleField([0, 0, 1.0], [0.01, 0.01, 0.0])
    np.testing.assert_array_equal(moving.at(POINTS, 2.0), fixed.at(POINTS, 0.0))
    coil = HelmholtzCoils(0.1, current=lambda t: 2.0 * math.sin(t))
    np.testing.assert_allclose(coil.at(POINTS, 0.5), HelmholtzCoils(0.1, 2.0 * math.sin(0.5)).at(POINTS))


def test_sum_of_sources_and_uniform_sources():
    dipole = PointDipoleField([0, 0.5, 0], [0, 0, -0.05])
    loop = CurrentLoopField(0.04, 2.0)
    uniform = ConstantField([1e-3, 0.0, 2e-3])
    total = FieldSum(dipole, loop, uniform)
    b, g = total.evaluate(POINTS)
    np.testing.assert_allclose(b, dipole.at(POINTS) + loop.at(POINTS) + uniform.at(POINTS), rtol=1e-14)
    np.testing.assert_allclose(g, dipole.gradient(POINTS) + loop.gradient(POINTS), rtol=1e-14)
    assert is_spatial(total) and is_spatial(dipole + loop)
    # uniform sources: the same methods, zero gradient, and still not "spatial"
    rotating = RotatingField(4e-3, 1.0)
    np.testing.assert_array_equal(rotating.at(POINTS, 0.1), np.repeat(rotating(0.1)[:, None], 25, axis=1))
    np.testing.assert_array_equal(rotating.gradient(POINTS, 0.1), np.zeros((3, 3, 25)))
    assert not is_spatial(rotating) and not is_spatial(uniform)


@pytest.mark.parametrize("make, message", [
    (lambda: PointDipoleField([1, 0], [0, 0, 0]), "moment must be a 3-vector in A m\\^2"),
    (lambda: PointDipoleField([1, 0, 0], lambda t: [0, np.nan, 0]), "position at t = 0 s must be finite"),
    (lambda: HelmholtzCoils(-0.1), "radii must be positive lengths in m"),
    (lambda: CurrentLoopField(0.1, axis=[0, 0, 0]), "axis must be a non-zero direction"),
    (lambda: Waypoints([0, 0], [[0, 0, 0], [1, 0, 0]]), "times must increase strictly"),
    (lambda: PointDipoleField([1, 0, 0]).at(np.zeros((2, 4))), r"points must have shape \(3, n\)"),
    (lambda: ConstantGradientField(np.diag([1.0, 1.0, 1.0])), "traceless .* trace is 3 T/m"),
    (lambda: ConstantGradientField([[0, 1, 0], [0, 0, 0], [0, 0, 0]]),
     r"symmetric .* G\[0\]\[1\] = 1 but G\[1\]\[0\] = 0 T/m"),
    (lambda: ConstantGradientField(np.eye(2)), "finite 3x3 matrix dB_i/dx_j in T/m"),
])
def test_bad_input_is_named(make, message):
    with pytest.raises(SpatialFieldError, match=message):
        make()


def test_finite_magnets_match_dipole_far_away_and_their_gradient():
    pytest.importorskip("magpylib")
    from elastica_magnetic.magnet_fields import CuboidMagnetField, CylinderMagnetField

    cylinder = CylinderMagnetField(0.01, 0.01, [0, 0, 1.3], position=[0, 0, -0.02])
    far = np.array([[0.0, 0.3, 0.2], [0.0, 0.0, 0.1], [0.5, 0.1, 0.3]])
    dipole = PointDipoleField(cylinder.moment, [0, 0, -0.02])
    np.testing.assert_allclose(cylinder.at(far), dipole.at(far), rtol=2e-3, atol=0)
    cuboid = CuboidMagnetField([0.01, 0.02, 0.01], [1.2, 0, 0], position=lambda t: [0, 0, -0.03 - t])
    near = np.array([[0.001, 0.003, -0.002], [0.0, 0.004, 0.0], [-0.015, -0.01, -0.005]])
    b, g = cuboid.evaluate(near, 0.0)
    np.testing.assert_allclose(g, fd_gradient(cuboid, near, 1e-4), rtol=0, atol=1e-6 * np.abs(g).max())
    np.testing.assert_allclose(np.trace(g), 0.0, atol=1e-6 * np.abs(g).max())
    assert not np.allclose(cuboid.at(near, 0.01), b)  # it moved


class _GradientSource:
    """A user's own source: a constant gradient dB_z/dx = 0.1 T/m on a 1 mT offset, and (as some
    user classes are) also callable with a time."""

    def at(self, points, time=0.0):
        return np.array([[0.0], [0.0], [1e-3]]) + np.outer([0.0, 0.0, 0.1], points[0])

    def gradient(self, points, time=0.0):
        g = np.zeros((3, 3, points.shape[1]))
        g[2, 0, :] = 0.1
        return g

    def __call__(self, time):
        return np.zeros(3)


def test_field_sum_takes_a_users_own_source_and_keeps_its_gradient():
    """Issue 53: FieldSum refused an object with at/gradient that MagneticTorques accepts, and
    took one that is also callable for a uniform field (force 0 instead of the gradient's)."""
    from elastica_magnetic.spatial_fields import FieldSum, PointDipoleField

    dipole = PointDipoleField((0.0, 1.0, 0.0), (0.0, 0.05, 0.0))
    points = np.array([[0.01, 0.02], [0.0, 0.0], [0.0, 0.0]])
    total = FieldSum(_GradientSource(), dipole)
    b, g = total.evaluate(points)
    np.testing.assert_allclose(g[2, 0], 0.1 + dipole.gradient(points)[2, 0])
    np.testing.assert_allclose(b, _GradientSource().at(points) + dipole.at(points))

    class NotCallable(_GradientSource):
        __call__ = None

    np.testing.assert_allclose(FieldSum(NotCallable()).gradient(points)[2, 0], [0.1, 0.1])


def test_field_sum_names_a_users_source_that_returns_the_wrong_shape():
    from elastica_magnetic.spatial_fields import FieldSum, SpatialFieldError

    class Flat(_GradientSource):
        def at(self, points, time=0.0):
            return np.zeros(3)

    with pytest.raises(SpatialFieldError, match=r"source 0 of FieldSum \(Flat\)\.at returned shape \(3,\)"):
        FieldSum(Flat()).at(np.zeros((3, 2)))


def test_a_finite_magnet_turns_with_its_axis():
    """Issue 53: a finite magnet could not rotate (only a point dipole could). With ``axis(t)``
    it is, at every time, the magnet with that fixed axis; and from afar a turning dipole."""
    pytest.importorskip("magpylib")
    from elastica_magnetic import CuboidMagnetField, PointDipoleField

    def axis(t):
        return (math.sin(t), 0.0, math.cos(t))

    turning = CuboidMagnetField((0.01, 0.01, 0.01), (0.0, 0.0, 1.3), position=(0.0, 0.0, 0.0), axis=axis)
    points = np.array([[0.05, -0.02], [0.01, 0.03], [0.08, 0.06]])
    moment = 1.3 * 1e-6 / (4e-7 * math.pi)  # J V / mu0, A m^2
    for t in (0.0, 0.7, math.pi / 2, 2.5):
        fixed = CuboidMagnetField((0.01, 0.01, 0.01), (0.0, 0.0, 1.3), axis=axis(t))
        b, g = turning.evaluate(points, t)
        fb, fg = fixed.evaluate(points, t)
        np.testing.assert_allclose(b, fb, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(g, fg, rtol=1e-12, atol=1e-12)
        far = PointDipoleField(moment * np.array(axis(t))).at(points)
        np.testing.assert_allclose(b, far, rtol=0.02, atol=1e-3 * np.abs(far).max())


def test_the_elliptic_integrals_agree_with_scipy_to_round_off():
    """The loops' K(m) and E(m) (Cody's approximations, with the vectorizing logarithm) against
    SciPy's over [0, 1), the approach to the wire (m -> 1, K's logarithm) included."""
    special = pytest.importorskip("scipy.special")
    from elastica_magnetic._spatial_kernels import elliptic_ke, log_positive

    ms = np.concatenate([np.linspace(0.0, 0.999, 1001), 1.0 - np.logspace(-15, -3, 100)])
    m1 = 1.0 - ms
    log_m1 = np.empty_like(m1)
    log_positive(m1, np.empty(m1.shape, dtype=np.int64), log_m1)
    values = np.array([elliptic_ke(a, b) for a, b in zip(m1, log_m1, strict=True)])
    np.testing.assert_allclose(values[:, 0], special.ellipk(ms), rtol=4.5e-16, atol=0)
    np.testing.assert_allclose(values[:, 1], special.ellipe(ms), rtol=4.5e-16, atol=0)
    assert elliptic_ke(1.0, 0.0) == pytest.approx((np.pi / 2, np.pi / 2), rel=2.3e-16)


def test_the_vectorizing_logarithm_agrees_with_math_log_to_round_off():
    """``log_positive`` over the doubles' whole normal range, near 1 and across the mantissa's
    reduction at sqrt(2) against ``math.log``: the two differ by at most one ulp (each is within
    one of the true logarithm)."""
    from elastica_magnetic._spatial_kernels import log_positive

    rng = np.random.default_rng(7)
    x = np.concatenate([np.logspace(-307, 307, 4001), 1.0 + rng.uniform(-1e-3, 1e-3, 2000),
                        rng.uniform(0.5, 2.0, 20000), [np.sqrt(0.5), np.sqrt(2.0), 0.5, 1.0, 2.0]])
    out = np.empty_like(x)
    log_positive(x, np.empty(x.shape, dtype=np.int64), out)
    expected = np.array([math.log(v) for v in x])
    assert np.all(np.abs(out - expected) <= np.spacing(np.abs(expected)))
    assert out[-2] == 0.0
