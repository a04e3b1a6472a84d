"""Magnetic torques and the two dampings, checked against independent computations."""

import elastica as ea
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from elastica_magnetic import (
    ConstantField,
    LegacyInternalDamping,
    MagneticRodSimulator,
    MagneticTorques,
    RelativeVelocityDamping,
    rectangular_band_rod,
    uniform_magnetization,
    yao2023_magnetization,
)

N = 16
L, W, H = 20e-3, 8e-3, 0.8e-3


def make_rod(n=N):
    return rectangular_band_rod(n, L, W, H, 1860.0, 84.5e3, 84.5e3 / 3)


def rotate_rod(rod, rotation: Rotation):
    """Rigidly rotate a rod about the origin (positions and directors)."""
    matrix = rotation.as_matrix()
    rod.position_collection[:] = matrix @ rod.position_collection
    # Directors are rows d1, d2, d3 in lab components: Q' = Q R^T.
    rod.director_collection[:] = np.einsum("ijk,lj->ilk", rod.director_collection, matrix)


def lab_torques(rod):
    """External torques turned back to the lab frame: Q^T tau."""
    return np.einsum("jik,jk->ik", rod.director_collection, rod.external_torques)


def test_torque_on_straight_rod_equals_v_m_cross_b_lab_frame():
    rod = make_rod()
    m = yao2023_magnetization(2, N)
    b = np.array([1.5e-3, -2e-3, 0.7e-3])
    MagneticTorques(ConstantField(b), m).apply_torques(rod, 0.0)
    volume = np.pi * (H / np.sqrt(3)) ** 2 * (L / N)
    expected = volume * np.cross(m.T, b).T  # lab frame, computed without the rod's directors
    np.testing.assert_allclose(lab_torques(rod), expected, rtol=1e-12, atol=1e-20)
    assert np.abs(expected).max() > 0


def test_material_frame_input_gives_same_torque():
    rod_lab, rod_mat = make_rod(), make_rod()
    m_lab = yao2023_magnetization(1, N) + yao2023_magnetization(2, N)
    # Material components of the lab vectors: Q m.
    m_material = np.einsum("ijk,jk->ik", rod_mat.director_collection, m_lab)
    b = np.array([0.0, 3e-3, 1e-3])
    MagneticTorques(ConstantField(b), m_lab, frame="lab").apply_torques(rod_lab, 0.0)
    MagneticTorques(ConstantField(b), m_material, frame="material").apply_torques(rod_mat, 0.0)
    np.testing.assert_allclose(rod_lab.external_torques, rod_mat.external_torques, rtol=1e-12)


def test_magnetization_follows_the_material_when_rotated():
    rod = make_rod()
    m = uniform_magnetization(N, 61.3e3, (1.0, 0.0, 0.0))
    b = np.array([0.0, 4e-3, 0.0])
    forcing = MagneticTorques(ConstantField(b), m)
    forcing.apply_torques(rod, 0.0)  # fixes the magnetization in the material frame
    rotation = Rotation.from_euler("xyz", [0.3, -0.4, 1.1])
    rotate_rod(rod, rotation)
    rod.external_torques[:] = 0.0
    forcing.apply_torques(rod, 1.0)
    volume = np.pi * (H / np.sqrt(3)) ** 2 * (L / N)
    m_rotated = rotation.apply(m.T).T  # the magnetization turned with the body
    expected = volume * np.cross(m_rotated.T, b).T
    np.testing.assert_allclose(lab_torques(rod), expected, rtol=1e-10, atol=1e-22)
    # and not the torque of the unrotated magnetization
    assert not np.allclose(lab_torques(rod), volume * np.cross(m.T, b).T, atol=1e-14)


def test_uniform_field_on_free_rod_zero_net_force_and_expected_torque():
    rod = make_rod()
    m = uniform_magnetization(N, 61.3e3, (0.0, 1.0, 0.0))
    b = np.array([2e-3, 0.0, 0.0])
    sim = MagneticRodSimulator()
    sim.append(rod)
    sim.add_forcing_to(rod).using(MagneticTorques, field=ConstantField(b), magnetization=m)
    sim.finalize()
    stepper = ea.PositionVerlet()
    dt = 1e-6
    for k in range(20):
        stepper.step(sim, k * dt, dt)
    # No net force: the centre of mass stays at rest (linear momentum zero).
    momentum = (rod.mass * rod.velocity_collection).sum(axis=1)
    assert np.abs(momentum).max() < 1e-15
    # The net torque is V_total M x B about -z: the rod starts spinning clockwise.
    rod.external_torques[:] = 0.0
    MagneticTorques(ConstantField(b), m).apply_torques(rod, 0.0)
    net = lab_torques(rod).sum(axis=1)
    v_total = np.pi * (H / np.sqrt(3)) ** 2 * L
    np.testing.assert_allclose(net, v_total * np.cross(m[:, 0], b), rtol=1e-3)
    assert net[2] < 0
    spin = np.einsum("jik,jk->ik", rod.director_collection, rod.omega_collection)[2]
    assert np.all(spin < 0)


def test_wrong_magnetization_shape_is_reported():
    rod = make_rod()
    with pytest.raises(ValueError, match=r"shape \(3,\) or \(3, n_elements\)"):
        MagneticTorques(ConstantField([0, 0, 1e-3]), np.zeros((2, N)))
    forcing = MagneticTorques(ConstantField([0, 0, 1e-3]), np.zeros((3, N + 1)))
    with pytest.raises(ValueError, match=f"expected shape \\(3, {N}\\)"):
        forcing.apply_torques(rod, 0.0)
    with pytest.raises(ValueError, match="NaN"):
        MagneticTorques(ConstantField([0, 0, 1e-3]), np.full((3, N), np.nan))


# --- relative-velocity damping -------------------------------------------------------------


def damper_forces(damper, rod):
    rod.external_forces[:] = 0.0
    damper.apply_forces(rod, 0.0)
    return rod.external_forces.copy()


def test_relative_damping_matches_equation_and_conserves_momentum():
    rod = make_rod()
    rng = np.random.default_rng(1)
    rod.velocity_collection[:] = rng.normal(size=rod.velocity_collection.shape)
    forces = damper_forces(RelativeVelocityDamping(nu=20.0, node_offset=4), rod)
    v, lengths = rod.velocity_collection, rod.lengths
    expected = np.zeros_like(forces)
    for j in range(N + 1 - 4):  # paper Eq. 4-5 written out
        f = 20.0 * lengths[j] * (v[:, j + 4] - v[:, j])
        expected[:, j] += f
        expected[:, j + 4] -= f
    np.testing.assert_allclose(forces, expected, rtol=1e-13)
    np.testing.assert_allclose(forces.sum(axis=1), 0.0, atol=1e-15)


def test_relative_damping_ignores_rigid_translation():
    rod = make_rod()
    rod.velocity_collection[:] = np.array([0.3, -0.2, 0.1])[:, None]
    assert np.abs(damper_forces(RelativeVelocityDamping(nu=20.0), rod)).max() == 0.0


def test_relative_damping_dissipates():
    rod = make_rod()
    rng = np.random.default_rng(2)
    rod.velocity_collection[:] = rng.normal(size=rod.velocity_collection.shape)
    forces = damper_forces(RelativeVelocityDamping(nu=20.0), rod)
    power = np.sum(forces * rod.velocity_collection)
    assert power < 0.0


def test_relative_damping_bad_parameters():
    with pytest.raises(ValueError, match="N s/m"):
        RelativeVelocityDamping(nu=-1.0)
    with pytest.raises(ValueError, match="N s/m"):
        RelativeVelocityDamping(nu=float("nan"))
    with pytest.raises(ValueError, match="node_offset"):
        RelativeVelocityDamping(nu=1.0, node_offset=0)
    rod = make_rod(4)
    with pytest.raises(ValueError, match="smaller than the number of nodes"):
        RelativeVelocityDamping(nu=1.0, node_offset=5).apply_forces(rod, 0.0)


def test_free_rod_with_relative_damping_loses_energy_keeps_momentum():
    rod = make_rod()
    sim = MagneticRodSimulator()
    sim.append(rod)
    sim.add_forcing_to(rod).using(RelativeVelocityDamping, nu=20.0, node_offset=4)
    sim.finalize()
    rng = np.random.default_rng(3)
    rod.velocity_collection[:] = 1e-3 * rng.normal(size=rod.velocity_collection.shape)
    rod.velocity_collection[:] += np.array([1e-3, 0.0, 0.0])[:, None]
    p0 = (rod.mass * rod.velocity_collection).sum(axis=1)
    e0 = rod.compute_translational_energy() + rod.compute_shear_energy()
    stepper, dt = ea.PositionVerlet(), 2e-6
    for k in range(2000):
        stepper.step(sim, k * dt, dt)
    p1 = (rod.mass * rod.velocity_collection).sum(axis=1)
    e1 = rod.compute_translational_energy() + rod.compute_shear_energy()
    np.testing.assert_allclose(p1, p0, atol=1e-10 * np.abs(p0).max())
    assert e1 < 0.9 * e0


# --- legacy internal damping ----------------------------------------------------------------


def test_legacy_damping_matches_old_pyelastica_formula():
    rod = make_rod()
    rng = np.random.default_rng(4)
    rod.velocity_collection[:] = rng.normal(size=rod.velocity_collection.shape)
    rod.omega_collection[:] = rng.normal(size=rod.omega_collection.shape)
    damper = LegacyInternalDamping(force_coefficient=0.15, torque_coefficient=1.5e-7)
    rod.external_forces[:] = 0.0
    rod.external_torques[:] = 0.0
    damper.apply_forces(rod, 0.0)
    damper.apply_torques(rod, 0.0)
    # old PyElastica: elemental = nu * v_elem * l; nodal = quadrature (half to each node)
    v_elem = 0.5 * (rod.velocity_collection[:, 1:] + rod.velocity_collection[:, :-1])
    elemental = 0.15 * v_elem * rod.lengths
    quadrature = np.zeros((3, N + 1))
    quadrature[:, :-1] += 0.5 * elemental
    quadrature[:, 1:] += 0.5 * elemental
    np.testing.assert_allclose(rod.external_forces, -quadrature, rtol=1e-13)
    np.testing.assert_allclose(
        rod.external_torques, -1.5e-7 * rod.omega_collection * rod.lengths, rtol=1e-13
    )
    with pytest.raises(ValueError, match="force_coefficient"):
        LegacyInternalDamping(-1.0, 0.0)


@pytest.mark.parametrize(
    "returned, problem",
    [
        (np.zeros(8)[:2], "shape (2,)"),
        (np.zeros(4), "shape (4,)"),
        (1e-3, "shape ()"),
        (None, "shape ()"),
        (np.zeros((3, 1)), "shape (3, 1)"),
        ("abc", "not numeric"),
        (np.array([0.0, np.nan, 1e-3]), "non-finite value"),
        ([0.0, np.inf, 0.0], "non-finite value"),
    ],
)
def test_bad_field_value_is_named_with_the_time(returned, problem):
    """A field callable returning anything but a finite (3,) array: an error naming the time and
    the value, before the kernel reads it (issue: (2,) read past the array, NaN gave NaN torques)."""
    rod = make_rod()
    forcing = MagneticTorques(lambda t: returned, uniform_magnetization(N, 6e4))
    with pytest.raises(ValueError, match=r"returned .* at t = 0\.25 s") as info:
        forcing.apply_torques(rod, 0.25)
    assert problem in str(info.value) and "shape (3,)" in str(info.value)
    assert np.all(rod.external_torques == 0.0)


def test_field_as_a_list_or_int_array_still_works():
    rod_a, rod_b = make_rod(), make_rod()
    m = uniform_magnetization(N, 6e4)
    MagneticTorques(lambda t: [0, 1, 0], m).apply_torques(rod_a, 0.0)
    MagneticTorques(ConstantField([0.0, 1.0, 0.0]), m).apply_torques(rod_b, 0.0)
    np.testing.assert_array_equal(rod_a.external_torques, rod_b.external_torques)


def test_run_open_loop_checks_the_field_callable():
    from elastica_magnetic import FieldValueError, run_open_loop, yao2023_robot

    with pytest.raises(FieldValueError, match=r"at t = 0 s \(shape \(2,\)\)"):
        run_open_loop(yao2023_robot(pattern=1, physics="training"), lambda t: np.zeros(2), 0.01)
