"""A finite magnet on an arm through its field map in its own frame (issue 53): the map against
Magpylib, the map's pose against a Magpylib magnet of the same pose, and batched catheters under
mapped magnets against their per-rod simulations, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from test_batch import _assert_same_state, _catheter_in_training_physics, drive_arms_against_their_twins

from elastica_magnetic import (
    CuboidMagnetField,
    CylinderMagnetField,
    MagnetPose,
    SpatialFieldError,
    build_simulation,
    magnet_map,
)
from elastica_magnetic._spatial_kernels import shortest_rotation
from elastica_magnetic.batch import BatchedRobots
from elastica_magnetic.field_maps import FieldMapDomainError
from elastica_magnetic.spatial_fields import rotation_to

#: A 10 mm N45-class cube magnetized along its z (about 1 A m^2), as the catheter cases' magnet.
CUBE = dict(dimension=[0.01, 0.01, 0.01], polarization=[0.0, 0.0, 1.3])
WORKSPACE = [[-0.1, -0.1, -0.1], [0.15, 0.1, 0.1]]


@pytest.fixture(scope="module")
def cube_map():
    return magnet_map(CuboidMagnetField(**CUBE), half_width=0.16, spacing=0.004)


def _relative_errors(mapped, exact, points):
    b_error = np.linalg.norm(mapped.at(points, 0.0) - exact.at(points, 0.0), axis=0)
    g_error = np.linalg.norm((mapped.gradient(points, 0.0) - exact.gradient(points, 0.0)).reshape(9, -1),
                             axis=0)
    return (b_error / np.linalg.norm(exact.at(points, 0.0), axis=0),
            g_error / np.linalg.norm(exact.gradient(points, 0.0).reshape(9, -1), axis=0))


def test_the_shortest_rotation_kernel_is_rotation_to():
    out = np.empty((3, 3))
    rng = np.random.default_rng(1)
    for direction in [(0, 0, 1), (0, 0, -1), (1, 0, 0), (0, -1, 0), *rng.normal(size=(20, 3))]:
        shortest_rotation(np.asarray(direction, dtype=np.float64), out)
        np.testing.assert_allclose(out, rotation_to(direction), rtol=0, atol=1e-15)


def test_the_map_of_a_cube_follows_magpylib(cube_map):
    """Trilinear at 4 mm (measured over 60 000 points, docs/spatial_fields.md): B within 1 % and its
    gradient within 3 % of Magpylib's 50 mm or more from the centre, within 3 % and 7 % from 30 to
    50 mm; the map's moment is J V / mu0."""
    assert cube_map.moment == pytest.approx(1.3 * 1e-6 / (4e-7 * np.pi), rel=1e-12)
    rng = np.random.default_rng(0)
    points = rng.uniform(-0.15, 0.15, (3, 6000))
    distance = np.linalg.norm(points, axis=0)
    b_error, g_error = _relative_errors(cube_map.field_map, CuboidMagnetField(**CUBE), points)
    far, near = distance > 0.05, (distance > 0.03) & (distance <= 0.05)
    assert b_error[far].max() < 1e-2 and g_error[far].max() < 3e-2
    assert b_error[near].max() < 3e-2 and g_error[near].max() < 7e-2


def test_an_arm_moves_and_turns_the_map_as_magpylib_moves_the_magnet(cube_map):
    """The arm's magnet at a pose (centre, moment turned away from +z) and a Magpylib cylinder of
    that pose agree as the map agrees with the magnet at the origin: the pose is applied right (a
    wrong rotation would put the errors at order one). An arm of half the map's moment halves it."""
    cylinder = dict(diameter=0.012, height=0.01, polarization=[0.0, 0.0, 1.2])
    mapped = magnet_map(CylinderMagnetField(**cylinder), half_width=0.16, spacing=0.004)
    direction = np.array([0.6, -0.3, 0.74])
    direction /= np.linalg.norm(direction)
    centre = [0.09, 0.02, -0.01]
    arm = MagnetPose(mapped.moment, centre, direction, WORKSPACE, max_speed=0.1, max_turn_rate=3.0,
                     field_map=mapped)
    exact = CylinderMagnetField(**cylinder, position=centre, axis=direction)
    rng = np.random.default_rng(2)
    points = np.asarray(centre)[:, None] + rng.uniform(-0.1, 0.1, (3, 3000))
    points = points[:, np.linalg.norm(points - np.asarray(centre)[:, None], axis=0) > 0.05]
    b_error, g_error = _relative_errors(arm.source, exact, points)
    assert b_error.max() < 1e-2 and g_error.max() < 3e-2
    half = MagnetPose(mapped.moment / 2, centre, direction, WORKSPACE, max_speed=0.1, max_turn_rate=3.0,
                      field_map=mapped)
    np.testing.assert_allclose(half.source.at(points, 0.0), 0.5 * arm.source.at(points, 0.0), rtol=1e-14)


def test_a_magnet_map_refuses_what_it_cannot_tabulate():
    with pytest.raises(SpatialFieldError, match="along its own z"):
        magnet_map(CuboidMagnetField([0.01] * 3, [1.3, 0.0, 0.0]), 0.05, 0.005)
    with pytest.raises(SpatialFieldError, match="0 < spacing < half_width"):
        magnet_map(CuboidMagnetField(**CUBE), 0.05, 0.1)
    with pytest.raises(SpatialFieldError, match="exceed"):
        magnet_map(CuboidMagnetField(**CUBE), 0.2, 0.001)


def _arm(x, field_map):
    return MagnetPose(field_map.moment, [x, 0.0, 0.0], [1.0, 0.0, 0.0], WORKSPACE, max_speed=0.1,
                      max_turn_rate=3.0, field_map=field_map)


def test_batched_catheters_under_mapped_magnets_match_per_rod_simulations_bit_for_bit(cube_map):
    """Three catheters, two arms sharing one map and one with a map of its own (two kernel calls),
    a robot reset mid-run: each follows its per-rod simulation (the map through the same kernel,
    one robot at a time) to the last bit, and the magnets bend them."""
    spec = _catheter_in_training_physics()
    other = magnet_map(CuboidMagnetField([0.008, 0.008, 0.012], [0.0, 0.0, 1.3]), 0.16, 0.005)
    maps = (cube_map, cube_map, other)
    starts = (0.09, 0.08, 0.1)
    arms = [_arm(x, m) for x, m in zip(starts, maps, strict=True)]
    twins = [_arm(x, m) for x, m in zip(starts, maps, strict=True)]
    robots = BatchedRobots(spec, n_robots=3, sources=[arm.source for arm in arms], clamp=True)
    assert not robots._sources.general and sorted(robots._sources.mapped) == [0, 1, 2]  # the kernel's
    drive_arms_against_their_twins(spec, robots, arms, twins, steps=30, reset_at=12)


def test_a_catheter_outside_its_magnets_map_is_named():
    small = magnet_map(CuboidMagnetField(**CUBE), half_width=0.03, spacing=0.005)
    spec = _catheter_in_training_physics()
    robots = BatchedRobots(spec, n_robots=2, sources=[None, _arm(0.09, small).source], clamp=True)
    with pytest.raises(FieldMapDomainError, match=r"robot 1: element \d+ .*outside its magnet's map"):
        robots.step(1)
    sim = build_simulation(spec, _arm(0.09, small).source, clamp=True)
    with pytest.raises(FieldMapDomainError, match="outside the magnet's map"):
        sim.step(1)


def _dipole_map(posed: bool):
    """A dipole's field tabulated around the paper's robot; ``posed``: the same field in a map whose
    frame is turned (its z along the lab's y) and moved, so that it lands where the unposed one is."""
    from elastica_magnetic import FieldMap, PointDipoleField

    axes = (np.linspace(-0.01, 0.035, 10), np.linspace(-0.01, 0.02, 7), np.linspace(-0.01, 0.01, 5))
    if not posed:
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=0).reshape(3, -1)
        above = PointDipoleField((0.0, -2.5, 0.0), (0.012, 0.05, 0.0)).at(grid)
        return FieldMap(*axes, np.moveaxis(above.reshape(3, 10, 7, 5), 0, -1))
    rotation = rotation_to([0.0, 1.0, 0.0])
    local_axes = (np.linspace(-0.03, 0.03, 13), np.linspace(-0.03, 0.03, 13), np.linspace(-0.03, 0.03, 13))
    grid = np.stack(np.meshgrid(*local_axes, indexing="ij"), axis=0).reshape(3, -1)
    centre = np.array([0.01, 0.0, 0.0])
    lab = rotation @ grid + centre[:, None]
    above = rotation.T @ PointDipoleField((0.0, -2.5, 0.0), (0.012, 0.05, 0.0)).at(lab)
    return FieldMap(*local_axes, np.moveaxis(above.reshape(3, 13, 13, 13), 0, -1), position=centre,
                    axis=[0.0, 1.0, 0.0], scale=0.9)


def test_batched_robots_under_fixed_field_maps_match_per_rod_simulations_bit_for_bit():
    """Field maps fixed in the lab, one in the lab's frame (shared by two robots) and one posed
    (turned, moved, scaled), drive their robots by one kernel call per map, to the last bit of the
    per-rod simulations; a map whose scale plays a waveform stays on the general path."""
    from elastica_magnetic import ControlledField, FieldMap, yao2023_robot

    spec = yao2023_robot(1, "training")
    lab, posed = _dipole_map(False), _dipole_map(True)
    waveform = FieldMap(lab.axes[0], lab.axes[1], lab.axes[2], np.moveaxis(lab.samples, 0, -1),
                        scale=lambda t: 1.0 + t)
    sources = [lab, lab, posed, waveform]
    robots = BatchedRobots(spec, n_robots=4, sources=sources)
    assert sorted(robots._sources.maps) == [0, 1, 2] and list(robots._sources.general) == [3]
    sims = [build_simulation(spec, source) for source in sources]
    sims[1] = build_simulation(spec, ControlledField(limit=1.0, max_increment=1.0))
    robots.set_source(1, None)
    robots.fields[1] = [0.0, 4e-3, 0.0]
    sims[1].field.set([0.0, 4e-3, 0.0])
    assert sorted(robots._sources.maps) == [0, 2]
    for _ in range(20):
        robots.step(spec.steps_per_action)
        for sim in sims:
            sim.step(spec.steps_per_action)
    for i, sim in enumerate(sims):
        _assert_same_state(robots.rod(i), sim.rod, f"robot {i}")
    uniform = sims[1].rod.position_collection
    assert min(np.abs(robots.rod(i).position_collection - uniform).max() for i in (0, 2)) > 1e-6


def test_a_robot_outside_its_fixed_map_is_named():
    from elastica_magnetic import FieldMap, yao2023_robot

    small = FieldMap(*(np.linspace(-0.005, 0.005, 3),) * 3, np.zeros((3, 3, 3, 3)))
    robots = BatchedRobots(yao2023_robot(1, "training"), n_robots=2, sources=[None, small])
    with pytest.raises(FieldMapDomainError, match=r"robot 1: element \d+ .*outside its field map"):
        robots.step(1)
