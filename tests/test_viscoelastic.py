"""Kelvin-Voigt internal damping: zero for rigid motion, the expected stress, the modal damping ratio."""

import elastica as ea
import numpy as np
import pytest

from elastica_magnetic import (
    KelvinVoigtDamping,
    LegacyInternalDamping,
    MagneticRodSimulator,
    RelativeVelocityDamping,
    rectangular_band_rod,
)


def straight_rod(n=10, length=1.0, radius=0.05, youngs=1e6, density=1000.0):
    return ea.CosseratRod.straight_rod(
        n,
        np.zeros(3),
        np.array([1.0, 0.0, 0.0]),
        np.array([0.0, 1.0, 0.0]),
        length,
        radius,
        density,
        youngs_modulus=youngs,
        shear_modulus=youngs / 3.0,
    )


def test_uniform_stretch_rate_gives_eta_area_rate_at_the_ends():
    rod = straight_rod()
    eta, rate = 37.0, 0.8  # Pa s, 1/s
    rod.velocity_collection[0, :] = rate * rod.position_collection[0, :]
    KelvinVoigtDamping(eta).apply_forces(rod, 0.0)
    area = np.pi * 0.05**2
    expected = eta * area * rate  # N, pulling the ends back together
    np.testing.assert_allclose(rod.external_forces[:, 0], [expected, 0, 0], rtol=1e-12)
    np.testing.assert_allclose(rod.external_forces[:, -1], [-expected, 0, 0], rtol=1e-12)
    np.testing.assert_allclose(rod.external_forces[:, 1:-1], 0.0, atol=1e-12 * expected)
    np.testing.assert_allclose(rod.external_torques, 0.0, atol=1e-12 * expected)


def test_uniform_bending_rate_gives_eta_i_rate():
    rod = straight_rod()
    eta, rate = 5.0, 0.3  # Pa s, curvature rate 1/(m s)
    # Element e turns about d1 (lab y) at rate * s_e, and the nodes follow (no shear rate): a
    # uniform curvature rate. The tangent x turns as omega_y (y x x) = -omega_y z.
    s = np.cumsum(rod.rest_lengths) - 0.5 * rod.rest_lengths
    rod.omega_collection[0, :] = rate * s  # material d1 component
    rod.velocity_collection[2, 1:] = -np.cumsum(rate * s * rod.rest_lengths)
    KelvinVoigtDamping(eta).apply_forces(rod, 0.0)
    inertia = np.pi * 0.05**4 / 4
    couple = eta * inertia * rate
    # Interior elements: +c from the right Voronoi region, -c from the left: zero; the ends +-c.
    np.testing.assert_allclose(rod.external_torques[0, 0], couple, rtol=1e-10)
    np.testing.assert_allclose(rod.external_torques[0, -1], -couple, rtol=1e-10)
    np.testing.assert_allclose(rod.external_torques[0, 1:-1], 0.0, atol=1e-10 * couple)


def angular_momentum(rod):
    orbital = np.cross(rod.position_collection.T, (rod.mass * rod.velocity_collection).T).sum(axis=0)
    spin_material = np.einsum("ijk,jk->ik", rod.mass_second_moment_of_inertia, rod.omega_collection)
    spin = np.einsum("jik,jk->i", rod.director_collection, spin_material)
    return orbital + spin


def spin_freely(forcing, n_steps=10000):
    """The paper's crawler, free in space, spinning rigidly at 2 rad/s about its middle (z)."""
    rod = rectangular_band_rod(64, 20e-3, 8e-3, 0.8e-3, 1860.0, 84.5e3, 84.5e3 / 1.48)
    spin = np.array([0.0, 0.0, 2.0])
    middle = rod.position_collection[:, 32].copy()
    rod.velocity_collection[:] = np.cross(spin, (rod.position_collection.T - middle)).T
    rod.omega_collection[:] = np.einsum("ijk,j->ik", rod.director_collection, spin)
    sim = MagneticRodSimulator()
    sim.append(rod)
    if forcing is not None:
        sim.add_forcing_to(rod).using(*forcing)
    sim.finalize()
    start = angular_momentum(rod)[2]
    stepper, t = ea.PositionVerlet(), 0.0
    if forcing is not None and forcing[0] is KelvinVoigtDamping:
        # In a rigid spin the viscous loads vanish to round-off.
        probe = KelvinVoigtDamping(forcing[1])
        rod.external_forces[:] = 0.0
        rod.external_torques[:] = 0.0
        probe.apply_forces(rod, 0.0)
        assert np.abs(rod.external_forces).max() < 1e-15
        assert np.abs(rod.external_torques).max() < 1e-18
    for _ in range(n_steps):
        t = stepper.step(sim, t, 8e-6)
    return angular_momentum(rod)[2] / start


def test_rigid_spin_keeps_its_angular_momentum_under_kelvin_voigt_but_not_under_the_paper_dampings():
    free = spin_freely(None)
    kelvin_voigt = spin_freely((KelvinVoigtDamping, 5.0))
    relative = spin_freely((RelativeVelocityDamping, 20.0))
    legacy = spin_freely((LegacyInternalDamping, 0.15, 1.5e-7))
    # Over 10000 steps (0.08 s) PositionVerlet itself lets the free spin drift by ~1e-8; the viscous
    # forces cancel in pairs (forces and moments) and add no drift of their own.
    assert abs(free - 1.0) < 1e-7
    assert abs(kelvin_voigt - 1.0) < 1e-7
    assert relative < 0.5  # the paper's damper stops the spin within a few ms ...
    assert legacy < 0.9  # ... and so does the legacy damping


def first_mode_shape(s, length):
    beta = 1.8751040687119611 / length
    bl = beta * length
    sigma = (np.cosh(bl) + np.cos(bl)) / (np.sinh(bl) + np.sin(bl))
    return np.cosh(beta * s) - np.cos(beta * s) - sigma * (np.sinh(beta * s) - np.sin(beta * s))


# dt below the explicit stability limit of the viscous term (set by the element-rotation shear mode).
@pytest.mark.parametrize(("zeta_target", "dt"), [(0.01, 1e-4), (0.02, 4e-5)])
def test_cantilever_first_mode_decays_with_zeta_eta_omega_over_2e(zeta_target, dt):
    length, radius, youngs, density = 1.0, 0.05, 1e6, 1000.0
    n = 10  # few elements: the explicit viscous term is stable for dt < 2 E / (eta omega_max^2)
    rod = straight_rod(n, length, radius, youngs, density)
    omega_euler = 1.8751040687119611**2 * np.sqrt(youngs * radius**2 / 4 / density) / length**2
    eta = 2 * youngs * zeta_target / omega_euler
    sim = MagneticRodSimulator()
    sim.append(rod)
    sim.constrain(rod).using(ea.OneEndFixedBC, constrained_position_idx=(0,), constrained_director_idx=(0,))
    sim.add_forcing_to(rod).using(KelvinVoigtDamping, viscosity=eta)
    sim.finalize()
    s = rod.position_collection[0, :]
    rod.velocity_collection[1, :] = 1e-3 * first_mode_shape(s, length) / first_mode_shape(length, length)
    # Elements turn with the nodes (about lab z = material d2), so the start has no shear rate.
    rod.omega_collection[1, :] = np.diff(rod.velocity_collection[1, :]) / rod.rest_lengths
    stepper, t = ea.PositionVerlet(), 0.0
    period = 2 * np.pi / omega_euler
    n_steps = int(5.2 * period / dt)
    tip = np.empty(n_steps)
    for k in range(n_steps):
        t = stepper.step(sim, t, dt)
        tip[k] = rod.position_collection[1, -1]
    # Upward zero crossings give the period; the largest value between two of them is a peak.
    up = np.flatnonzero((tip[:-1] < 0) & (tip[1:] >= 0))
    assert len(up) >= 4
    times = (up + 1) * dt
    peaks = np.array([tip[a:b].max() for a, b in zip(up[:-1], up[1:], strict=True)])
    decrement = np.mean(np.diff(np.log(peaks)))
    omega_d = 2 * np.pi / np.mean(np.diff(times))
    zeta = -decrement / np.sqrt(4 * np.pi**2 + decrement**2)
    omega_n = omega_d / np.sqrt(1 - zeta**2)
    # The clamp holds node 0 and element 0's direction: the free length lies between L - l and L.
    assert omega_euler < omega_n < omega_euler * (length / (length - length / n)) ** 2
    assert zeta == pytest.approx(eta * omega_n / (2 * youngs), rel=0.01)


def test_rejects_negative_viscosity():
    with pytest.raises(ValueError):
        KelvinVoigtDamping(-1.0)


def test_robot_spec_damping_choice_registers_kelvin_voigt_only_when_asked(monkeypatch):
    from dataclasses import replace

    from elastica_magnetic import MM_MG_S, ConstantField, DampingSpec, build_simulation, yao2023_robot

    calls = []
    original = KelvinVoigtDamping.apply_forces

    def counted(self, system, time=0.0):
        calls.append(self.viscosity)
        original(self, system, time)

    monkeypatch.setattr(KelvinVoigtDamping, "apply_forces", counted)
    default = yao2023_robot(1)
    assert default.damping.kelvin_voigt == 0.0
    build_simulation(default, ConstantField(np.zeros(3))).step(5)
    assert calls == []  # the paper's model is unchanged
    kv = replace(default, damping=DampingSpec(0.0, 4, 0.0, 0.0, kelvin_voigt=3.0))
    build_simulation(kv, ConstantField(np.zeros(3))).step(5)
    assert calls == [3.0] * 5
    assert kv.to_units(MM_MG_S).damping.kelvin_voigt == pytest.approx(3.0 * 1e-3 * 1e6)  # Pa s -> mPa s
