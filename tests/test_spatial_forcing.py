"""MagneticTorques with spatial sources: force from the energy, torque at the element centres,
Newton's third law with a dipole source, and the uniform path left untouched."""

from __future__ import annotations

import elastica as ea
import numpy as np
import pytest

from elastica_magnetic import (
    BatchedRobots,
    ConstantField,
    FieldSum,
    FieldValueError,
    HelmholtzCoils,
    MagneticTorques,
    PointDipoleField,
    RotatingField,
    yao2023_robot,
)
from elastica_magnetic.forcing import _magnetic_torques

N = 16


def bent_rod(seed=3):
    rod = ea.CosseratRod.straight_rod(N, np.zeros(3), np.array([1.0, 0, 0]), np.array([0, 1.0, 0]),
                                      0.05, 1e-3, 1000.0, youngs_modulus=1e6, shear_modulus=1e6 / 3)
    rng = np.random.default_rng(seed)
    rod.position_collection[1] += 0.01 * np.sin(np.linspace(0, np.pi, N + 1))
    rod.position_collection += 1e-4 * rng.normal(size=rod.position_collection.shape)
    angles = 0.3 * rng.normal(size=N)
    for e, a in enumerate(angles):  # rotate each element's directors about z
        c, s = np.cos(a), np.sin(a)
        rot = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
        rod.director_collection[:, :, e] = rod.director_collection[:, :, e] @ rot
    return rod


def magnetization():
    m = np.zeros((3, N))
    m[0], m[1] = 8e4, np.linspace(-3e4, 3e4, N)
    return m


def loads(forcing, rod, time=0.0):
    rod.external_forces[:] = 0.0
    rod.external_torques[:] = 0.0
    forcing.apply_forces(rod, time)
    forcing.apply_torques(rod, time)
    return rod.external_forces.copy(), rod.external_torques.copy()


def energy(source, rod, moment_material, positions, time=0.0):
    centres = 0.5 * (positions[:, :-1] + positions[:, 1:])
    moment_lab = np.einsum("jik,jk->ik", rod.director_collection, moment_material)
    return -float(np.sum(moment_lab * source.at(centres, time)))


@pytest.mark.parametrize("source", [
    PointDipoleField([0.0, 0.02, 0.05], [0.025, -0.02, 0.01]),
    HelmholtzCoils(0.03, current=lambda t: 40.0 * (1 + t), centre=[0.02, 0.0, 0.01], axis=[0, 1, 1]),
])
def test_force_is_minus_the_gradient_of_the_energy(source):
    rod = bent_rod()
    forcing = MagneticTorques(field=source, magnetization=magnetization())
    forces, _ = loads(forcing, rod, 0.3)
    moment = forcing.moment_in_material_frame(rod)
    fd = np.zeros_like(forces)
    h = 1e-7
    for axis in range(3):
        for node in range(N + 1):
            plus, minus = rod.position_collection.copy(), rod.position_collection.copy()
            plus[axis, node] += h
            minus[axis, node] -= h
            fd[axis, node] = -(energy(source, rod, moment, plus, 0.3)
                               - energy(source, rod, moment, minus, 0.3)) / (2 * h)
    assert np.abs(forces).max() > 0
    np.testing.assert_allclose(forces, fd, rtol=0, atol=1e-7 * np.abs(forces).max())


def test_torque_uses_each_element_s_own_field():
    rod = bent_rod()
    source = PointDipoleField([0.0, 0.0, 0.1], [0.02, 0.03, 0.0])
    forcing = MagneticTorques(field=source, magnetization=magnetization())
    _, torques = loads(forcing, rod)
    centres = 0.5 * (rod.position_collection[:, :-1] + rod.position_collection[:, 1:])
    b = source.at(centres)
    moment = forcing.moment_in_material_frame(rod)
    expected = np.cross(moment, np.einsum("ijk,jk->ik", rod.director_collection, b), axis=0)
    np.testing.assert_allclose(torques, expected, rtol=1e-13, atol=0)
    # apply_torques alone (no apply_forces before it) gives the same torques
    rod.external_torques[:] = 0.0
    forcing.apply_torques(rod, 0.0)
    np.testing.assert_array_equal(rod.external_torques, torques)


def test_uniform_field_as_a_spatial_source_gives_no_force_and_the_same_torque():
    rod = bent_rod()
    uniform = ConstantField([1e-3, -2e-3, 3e-3])
    spatial = MagneticTorques(field=FieldSum(uniform), magnetization=magnetization())
    plain = MagneticTorques(field=uniform, magnetization=magnetization())
    forces, torques = loads(spatial, rod)
    forces_plain, torques_plain = loads(plain, rod)
    assert spatial.spatial and not plain.spatial
    assert np.all(forces == 0.0) and np.all(forces_plain == 0.0)
    np.testing.assert_allclose(torques, torques_plain, rtol=1e-15, atol=1e-30)


@pytest.mark.parametrize("field", [ConstantField([1e-3, 2e-3, 0.0]), RotatingField(4e-3, -1.0, 0.3),
                                   lambda t: np.array([0.0, 1e-3 * t, 2e-3])])
def test_uniform_sources_keep_the_uniform_path_bit_for_bit(field):
    """Uniform sources (and plain callables): no force, and the torques of the uniform kernel, to
    the last bit."""
    rod = bent_rod()
    forcing = MagneticTorques(field=field, magnetization=magnetization())
    assert not forcing.spatial
    rod.external_forces[:] = 0.123
    forces, torques = loads(forcing, rod, 0.7)
    assert np.all(forces == 0.0)
    expected = np.zeros_like(torques)
    _magnetic_torques(forcing.moment_in_material_frame(rod), np.asarray(field(0.7), dtype=np.float64),
                      rod.director_collection, expected)
    np.testing.assert_array_equal(torques, expected)


def test_newton_third_law_between_rod_and_dipole():
    """The rod's force and moment on the source dipole (from the rod elements' dipole fields) are
    minus the source's on the rod: sum F + F_src = 0, and sum (x x F + tau) + tau_src = 0."""
    rod = bent_rod()
    source_moment, source_position = np.array([0.02, -0.01, 0.06]), np.array([0.03, -0.025, 0.015])
    forcing = MagneticTorques(field=PointDipoleField(source_moment, source_position),
                              magnetization=magnetization())
    forces, torques_material = loads(forcing, rod)
    positions = rod.position_collection
    torques_lab = np.einsum("jik,jk->ik", rod.director_collection, torques_material)
    centres = 0.5 * (positions[:, :-1] + positions[:, 1:])
    moments_lab = np.einsum("jik,jk->ik", rod.director_collection, forcing.moment_in_material_frame(rod))
    force_on_source = np.zeros(3)
    torque_on_source = np.zeros(3)
    point = source_position[:, None]
    for e in range(N):
        element = PointDipoleField(moments_lab[:, e], centres[:, e])
        b, g = element.evaluate(point)
        force_on_source += g[:, :, 0].T @ source_moment
        torque_on_source += np.cross(source_moment, b[:, 0])
    total_force = forces.sum(axis=1)
    moment_about_origin = np.cross(positions, forces, axis=0).sum(axis=1) + torques_lab.sum(axis=1)
    scale_f = np.abs(force_on_source).max()
    np.testing.assert_allclose(total_force + force_on_source, 0.0, atol=1e-12 * scale_f)
    total_source = torque_on_source + np.cross(source_position, force_on_source)
    np.testing.assert_allclose(moment_about_origin + total_source, 0.0,
                               atol=1e-12 * np.abs(total_source).max())


def test_a_bad_spatial_source_is_named():
    class Broken:
        uniform = False

        def at(self, points, time):
            return np.zeros((3, 2))

        def gradient(self, points, time):
            return np.zeros((3, 3, points.shape[1]))

    rod = bent_rod()
    forcing = MagneticTorques(field=Broken(), magnetization=magnetization())
    with pytest.raises(FieldValueError, match=r"Broken returned B \(T\) of \(3, 2\).*shape \(3, 16\)"):
        loads(forcing, rod)
    on_dipole = MagneticTorques(field=PointDipoleField([0, 0, 1.0], [0.05 / N / 2, 0, 0]),
                                magnetization=magnetization())
    flat = ea.CosseratRod.straight_rod(N, np.zeros(3), np.array([1.0, 0, 0]), np.array([0, 1.0, 0]),
                                       0.05, 1e-3, 1000.0, youngs_modulus=1e6, shear_modulus=1e6 / 3)
    with pytest.raises(FieldValueError, match="non-finite B .* at element 0"):
        loads(on_dipole, flat)


def test_a_spatial_source_as_the_batched_fields_names_set_source():
    from elastica_magnetic import SpatialFieldNotSupportedError

    robots = BatchedRobots(yao2023_robot(1, "training"), 2)
    with pytest.raises(SpatialFieldNotSupportedError, match=r"set_source\(i, source\)"):
        robots.fields = PointDipoleField([0, 0, 1.0], [0, 0, 0.1])


def test_build_simulation_takes_spatial_sources_in_si_only():
    from dataclasses import replace

    from elastica_magnetic import MM_MG_S, build_simulation, run_open_loop

    spec = replace(yao2023_robot(1, "training"), ground=None, gravity=0.0)
    with pytest.raises(ValueError, match="spatial field source works in SI"):
        build_simulation(spec.to_units(MM_MG_S), PointDipoleField([0, 0.1, 0], [0.01, 0.02, 0]))
    source = PointDipoleField([0, 0.1, 0], [0.01, 0.02, 0])
    result = run_open_loop(spec, source, 0.02)
    # the recorded field is the source's at the last element's centre, each 0.01 s
    assert result.fields.shape == (2, 3) and np.all(np.isfinite(result.fields))
    tip0 = np.array([[spec.length - 0.5 * spec.length / spec.n_elements], [0.0], [0.0]])
    np.testing.assert_allclose(result.fields[0], source.at(tip0)[:, 0], rtol=1e-12)
