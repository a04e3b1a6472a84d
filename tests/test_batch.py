"""Batched robots (one simulator, one forcing kernel per step) against the per-rod path.

The batched kernel repeats PyElastica's floating-point operations in the same order, so the
comparison is exact: ``assert_array_equal`` on positions, velocities, directors and angular
velocities (no tolerance).
"""

from dataclasses import replace

import numpy as np
import pytest

from elastica_magnetic import (
    ConstantField,
    ControlledField,
    RotatingField,
    SimulationDivergedError,
    build_simulation,
    hu2018_robot,
    yao2023_robot,
)
from elastica_magnetic.batch import BatchedRobots, BatchedSimulationDivergedError

STATE = ("position_collection", "velocity_collection", "director_collection", "omega_collection")


def _per_rod(spec, n):
    """``n`` independent per-rod simulations whose field the test sets (no clipping at 1 T)."""
    return [build_simulation(spec, ControlledField(limit=1.0, max_increment=1.0)) for _ in range(n)]


def _drive(robots, sims, sources, t0, duration, coverage=None):
    """Step both paths for ``duration`` s, setting each field from ``sources`` every 0.01 s.

    ``sims[i]`` (or ``None``) is driven like robot ``i``. Fields are sampled at the start of each
    0.01 s (zero-order hold) from ``source(t0 + robot time)``.
    """
    spec = robots.spec
    n_actions = int(round(duration / 0.01))
    per_action = spec.steps_per_action
    for _ in range(n_actions):
        for i, source in enumerate(sources):
            value = np.array(source(t0 + robots.robot_time(i)), dtype=np.float64)
            robots.fields[i] = value
            if sims[i] is not None:
                sims[i].field.set(value)
        for chunk in range(0, per_action, per_action // 10):
            n = min(per_action // 10, per_action - chunk)
            robots.step(n)
            for sim in sims:
                if sim is not None:
                    sim.step(n)
            if coverage is not None:
                _count_contact_states(robots, coverage)


def _count_contact_states(robots, coverage):
    """Accumulate element counts: in contact, lifted off, sticking (static friction), slipping."""
    spec = robots.spec
    tol, slip = spec.ground.surface_tolerance, spec.ground.slip_velocity_tol
    for rod in robots.rods:
        p, v, m = rod.position_collection, rod.velocity_collection, rod.mass
        gap = 0.5 * (p[1, 1:] + p[1, :-1]) + spec.radius - rod.radius
        axial_speed = np.abs((m[1:] * v[0, 1:] + m[:-1] * v[0, :-1]) / (m[1:] + m[:-1]))
        contact = gap <= tol
        coverage["contact"] += int(contact.sum())
        coverage["lifted"] += int((~contact).sum())
        coverage["stick"] += int((contact & (axial_speed < 2.0 * slip)).sum())
        coverage["slip"] += int((contact & (axial_speed > 2.0 * slip)).sum())


def _assert_same_state(rod_a, rod_b, label):
    for name in STATE:
        np.testing.assert_array_equal(
            getattr(rod_a, name), getattr(rod_b, name), err_msg=f"{label}: {name} differs"
        )


SOURCES = (
    RotatingField(amplitude=4e-3, frequency=2.0, phase=0.0),
    RotatingField(amplitude=10e-3, frequency=-3.0, phase=1.0),
    ConstantField([0.0, 6e-3, 2e-3]),  # out of plane: twists, slides sideways (rolling friction)
)


def test_batched_robots_match_per_rod_simulations_bit_for_bit():
    spec = yao2023_robot(1, "training")
    robots = BatchedRobots(spec, n_robots=3)
    sims = _per_rod(spec, 3)
    coverage = dict.fromkeys(("contact", "lifted", "stick", "slip"), 0)
    for t_end in (0.1, 0.2, 0.3, 0.4):  # compare every 0.1 s
        _drive(robots, sims, SOURCES, 0.0, 0.1, coverage)
        for i, sim in enumerate(sims):
            _assert_same_state(robots.rod(i), sim.rod, f"robot {i} at t = {t_end:.1f} s")
    # The run went through every regime of the ground model.
    assert coverage["contact"] > 1000 and coverage["lifted"] > 1000, coverage
    assert coverage["stick"] > 50 and coverage["slip"] > 1000, coverage
    # The robots follow different fields, so they are in different states.
    heights = [robots.markers(i)["height_max_m"] for i in range(3)]
    assert max(heights) > 10 * spec.radius and len(set(heights)) == 3
    # Robot 2's out-of-plane field moves it sideways, so the rolling (sideways) friction acts.
    assert np.abs(robots.rod(2).position_collection[2]).max() > 1e-5
    assert robots.markers(0) == sims[0].markers()
    assert robots.time == pytest.approx(0.4)


def test_comparison_detects_a_different_ground():
    """Sanity check of the test itself: a 1e-4 m contact band (PyElastica's default) is caught."""
    spec = yao2023_robot(1, "training")
    other = replace(spec, ground=replace(spec.ground, surface_tolerance=1e-4))
    robots = BatchedRobots(other, n_robots=1)
    sims = _per_rod(spec, 1)
    _drive(robots, sims, SOURCES[:1], 0.0, 0.1)
    with pytest.raises(AssertionError, match="differs"):
        _assert_same_state(robots.rod(0), sims[0].rod, "robot 0")


def test_pattern2_accurate_physics_matches_per_rod():
    spec = yao2023_robot(2, "accurate")
    robots = BatchedRobots(spec, n_robots=2)
    sims = _per_rod(spec, 2)
    sources = (RotatingField(amplitude=10e-3, frequency=5.0, phase=0.5), ConstantField([4e-3, 0, 0]))
    _drive(robots, sims, sources, 0.0, 0.03)
    for i, sim in enumerate(sims):
        _assert_same_state(robots.rod(i), sim.rod, f"robot {i}")
    assert not np.array_equal(robots.rod(0).position_collection, robots.rod(1).position_collection)


def test_robot_without_ground_and_gravity_matches_per_rod():
    spec = hu2018_robot(n_elements=32)  # free sheet: no ground, no gravity
    robots = BatchedRobots(spec, n_robots=2, fields=[[0.0, 5e-3, 0.0], [3e-3, 0.0, 1e-3]])
    sims = _per_rod(spec, 2)
    for i, sim in enumerate(sims):
        sim.field.set(robots.fields[i])
        sim.step(400)
    robots.step(400)
    for i, sim in enumerate(sims):
        _assert_same_state(robots.rod(i), sim.rod, f"robot {i}")
    assert np.abs(robots.rod(0).omega_collection).max() > 0.0


def test_reset_robot_restores_the_initial_state_and_reruns_like_a_fresh_robot():
    spec = yao2023_robot(1, "training")
    robots = BatchedRobots(spec, n_robots=3)
    fresh = BatchedRobots(spec, n_robots=1)
    sims = _per_rod(spec, 3)
    _drive(robots, sims, SOURCES, 0.0, 0.1)
    robots.reset_robot(1)
    rod, initial = robots.rod(1), fresh.rod(0)
    for name, value in vars(initial).items():
        if isinstance(value, np.ndarray):
            np.testing.assert_array_equal(getattr(rod, name), value, err_msg=name)
    assert robots.robot_time(1) == 0.0 and robots.robot_time(0) == pytest.approx(0.1)
    # Robot 1 now reruns from scratch (its source restarts at t = 0); 0 and 2 carry on.
    sims[1] = _per_rod(spec, 1)[0]
    _drive(robots, sims, SOURCES, 0.0, 0.1)
    for i, sim in enumerate(sims):
        _assert_same_state(robots.rod(i), sim.rod, f"robot {i}")
    assert robots.markers(1) == sims[1].markers()


def test_nan_in_one_robot_is_reported_with_its_index():
    spec = yao2023_robot(1, "training")
    robots = BatchedRobots(spec, n_robots=4, fields=[0.0, 4e-3, 0.0])
    robots.step(20)
    robots.rod(2).position_collection[1, 40] = np.nan
    pattern = r"robot 2: .*at t = 0\.0021.* NaN at node \d+ \(element \d+\)"
    with pytest.raises(SimulationDivergedError, match=pattern) as info:
        robots.step(1)
    assert isinstance(info.value, BatchedSimulationDivergedError)
    assert info.value.robot == 2 and info.value.time == pytest.approx(21 * spec.dt)
    for i in (0, 1, 3):
        assert np.all(np.isfinite(robots.rod(i).position_collection))


def test_runaway_speed_is_reported():
    spec = yao2023_robot(1, "training")
    robots = BatchedRobots(spec, n_robots=2)
    robots.rod(1).velocity_collection[0, 10] = 50.0  # m/s, far above max_speed
    with pytest.raises(BatchedSimulationDivergedError, match=r"robot 1: .*runaway speed"):
        robots.step(1)


def test_fields_are_written_in_place_and_checked():
    robots = BatchedRobots(yao2023_robot(1, "training"), n_robots=2, fields=[[1e-3, 0, 0], [0, 2e-3, 0]])
    view = robots.fields
    robots.fields = [0.0, 3e-3, 0.0]  # broadcast to every robot, same array
    assert robots.fields is view and view.shape == (2, 3)
    np.testing.assert_array_equal(view[:, 1], [3e-3, 3e-3])
    with pytest.raises(ValueError, match=r"fields must broadcast to \(2, 3\)"):
        robots.fields = np.zeros((3, 3))
    with pytest.raises(ValueError, match="fields must be finite"):
        robots.fields = [0.0, np.nan, 0.0]
    np.testing.assert_array_equal(view[:, 1], [3e-3, 3e-3])  # unchanged
    with pytest.raises(ValueError, match="n_robots must be a positive integer"):
        BatchedRobots(yao2023_robot(1, "training"), n_robots=0)


def _varied(spec, factor):
    """``spec`` with its material values, magnetization and friction scaled by ``factor``."""
    ground = replace(spec.ground, static_mu=spec.ground.static_mu * factor,
                     kinetic_mu=spec.ground.kinetic_mu * factor)
    return replace(spec, density=spec.density * factor, youngs_modulus=spec.youngs_modulus * factor,
                   shear_modulus=spec.shear_modulus * factor,
                   magnetization=spec.magnetization * factor, ground=ground)


def test_set_robot_gives_a_robot_its_own_spec_and_matches_its_per_rod_simulation():
    spec = yao2023_robot(1, "training")
    robots = BatchedRobots(spec, n_robots=3)
    _drive(robots, [None] * 3, SOURCES, 0.0, 0.05)  # the robots have moved: set_robot restarts one
    varied = [spec, _varied(spec, 0.85), _varied(spec, 1.2)]
    for i in (1, 2):
        robots.set_robot(i, varied[i])
    robots.reset_robot(0)
    assert robots.specs == varied
    sims = [build_simulation(s, ControlledField(limit=1.0, max_increment=1.0)) for s in varied]
    _drive(robots, sims, SOURCES[:1] * 3, 0.0, 0.2)
    for i, sim in enumerate(sims):
        _assert_same_state(robots.rod(i), sim.rod, f"robot {i}")
    # the variants really move differently under the same field
    xs = [robots.markers(i)["mid_x_m"] for i in range(3)]
    assert len(set(xs)) == 3
    # a reset keeps the robot's own spec: it reruns like its per-rod simulation
    robots.reset_robot(2)
    sims[2] = build_simulation(varied[2], ControlledField(limit=1.0, max_increment=1.0))
    _drive(robots, [None, None, sims[2]], SOURCES[:1] * 3, 0.0, 0.1)
    _assert_same_state(robots.rod(2), sims[2].rod, "robot 2 after its reset")


def test_set_robot_refuses_a_spec_that_cannot_share_the_block():
    spec = yao2023_robot(1, "training")
    robots = BatchedRobots(spec, n_robots=2)
    with pytest.raises(ValueError, match="n_elements"):
        robots.set_robot(0, hu2018_robot(n_elements=32))
    with pytest.raises(ValueError, match="dt"):
        robots.set_robot(0, replace(spec, dt=spec.dt / 2))
    with pytest.raises(ValueError, match="forcing"):
        robots.set_robot(1, replace(spec, damping=None))
    with pytest.raises(IndexError):
        robots.set_robot(2, spec)


def _moving_dipole():
    from elastica_magnetic import PointDipoleField, Waypoints

    # ~4 mT at the robot, the magnet passing over it along x
    return PointDipoleField((0.0, -2.5, 0.0), Waypoints([0.0, 0.4], [[-0.01, 0.05, 0.0], [0.03, 0.05, 0.0]]))


def _spatial_sources():
    from elastica_magnetic import ConstantGradientField, FieldMap, PointDipoleField
    from elastica_magnetic.spatial_fields import HelmholtzCoils

    axes = (np.linspace(-0.01, 0.035, 10), np.linspace(-0.01, 0.02, 7), np.linspace(-0.01, 0.01, 5))
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=0).reshape(3, -1)
    above = PointDipoleField((0.0, -2.5, 0.0), (0.012, 0.05, 0.0)).at(grid)
    field_map = FieldMap(*axes, np.moveaxis(above.reshape(3, 10, 7, 5), 0, -1))
    return (_moving_dipole(),
            HelmholtzCoils(0.1, current=300.0, axis=(0.0, 1.0, 0.0), centre=(0.01, 0.0, 0.0)),
            field_map,
            ConstantGradientField([[0.2, 0.0, 0.0], [0.0, -0.1, 0.0], [0.0, 0.0, -0.1]],
                                  origin=(-0.03, 0.0, 0.0))
            + PointDipoleField((0.0, 2.0, 0.0), (0.01, 0.04, 0.0)))


def test_batched_robots_with_spatial_sources_match_per_rod_simulations_bit_for_bit():
    """Issue 53: each robot evaluates its own source at its own elements and time (the force of
    the gradient included): the per-rod simulation of each source, to the last bit; a robot
    without a source beside them is untouched by theirs."""
    spec = yao2023_robot(1, "training")
    sources = _spatial_sources()
    robots = BatchedRobots(spec, n_robots=5, sources=[*sources, None])
    sims = [build_simulation(spec, source) for source in sources]
    alone = build_simulation(spec, ControlledField(limit=1.0, max_increment=1.0))
    robots.fields[4] = [0.0, 4e-3, 0.0]
    alone.field.set([0.0, 4e-3, 0.0])
    per_action = spec.steps_per_action
    for _ in range(30):  # 0.3 s
        robots.step(per_action)
        for sim in (*sims, alone):
            sim.step(per_action)
    for i, sim in enumerate((*sims, alone)):
        _assert_same_state(robots.rod(i), sim.rod, f"robot {i}")
    ends = [robots.rod(i).position_collection for i in range(5)]
    assert min(np.abs(ends[i] - ends[j]).max() for i in range(5) for j in range(i)) > 1e-7  # each its own way
    assert robots.sources[:4] == list(sources) and robots.sources[4] is None


def test_a_source_given_later_acts_on_the_magnetization_of_the_initial_configuration():
    spec = yao2023_robot(1, "training")
    robots = BatchedRobots(spec, n_robots=2, fields=[[0.0, 4e-3, 0.0], [0.0, 4e-3, 0.0]])
    robots.step(spec.steps_per_action * 5)  # the robots move, then get a source
    robots.set_source(0, _moving_dipole())
    robots.fields[0] = 0.0
    robots.reset_robot(0)
    reference = BatchedRobots(spec, n_robots=1, sources=[_moving_dipole()])
    for _ in range(10):
        robots.step(spec.steps_per_action)
        reference.step(spec.steps_per_action)
    # robot 0 runs on its own clock since its reset: the same as a fresh robot with that source
    np.testing.assert_allclose(robots.rod(0).position_collection, reference.rod(0).position_collection,
                               rtol=0, atol=1e-12)
    with pytest.raises(TypeError, match="a uniform field goes in the robot's row of fields"):
        robots.set_source(1, ConstantField([0.0, 1e-3, 0.0]))


def _catheter_in_training_physics():
    from spec_texts import CATHETER_MAGNET_REACH  # its training physics: mass x 100, dt 5e-5 s

    from elastica_magnetic.spec_format import loads
    from elastica_magnetic.specfile import describe_robot

    return describe_robot(loads(CATHETER_MAGNET_REACH, "c.toml"), "c.toml").robot("training")


def _arm(x):
    from elastica_magnetic import MagnetPose

    return MagnetPose(1.0, [x, 0.0, 0.0], [1.0, 0.0, 0.0], [[-0.1, -0.1, -0.1], [0.15, 0.1, 0.1]],
                      max_speed=0.1, max_turn_rate=3.0)


def test_batched_catheters_moved_by_magnet_arms_match_per_rod_simulations_bit_for_bit():
    """Issue 53: robots of a batch, each clamped at its base and driven by its own arm-moved
    magnet (one kernel for all), follow the per-rod simulations of the same commands to the last
    bit, a robot reset mid-run (on its own clock) included; the clamped end stays put."""
    spec = _catheter_in_training_physics()
    starts = (0.09, 0.08, 0.1)
    arms, twins = [_arm(x) for x in starts], [_arm(x) for x in starts]
    robots = BatchedRobots(spec, n_robots=3, sources=[arm.source for arm in arms], clamp=True)
    assert robots.sources == [arm.source for arm in arms]
    base = robots.rod(0).position_collection[:, 0].copy()
    drive_arms_against_their_twins(spec, robots, arms, twins, steps=40, reset_at=25)
    np.testing.assert_array_equal(robots.rod(2).position_collection[:, 0], base)


def drive_arms_against_their_twins(spec, robots, arms, twins, steps, reset_at):
    """Command each robot's arm and its per-rod twin alike for ``steps`` 0.01 s control steps
    (random commands, the moments kept turning so that the catheters bend), robot 1 reset at
    step ``reset_at`` (on its own clock); then each robot equals its per-rod simulation to the
    last bit, and every tip has moved."""
    sims = [build_simulation(spec, twin.source, clamp=True) for twin in twins]
    rng = np.random.default_rng(3)
    for step in range(steps):
        if step == reset_at:
            robots.reset_robot(1)
            arms[1].reset()
            twins[1].reset()
            sims[1] = build_simulation(spec, twins[1].source, clamp=True)
        actions = rng.uniform(-1.0, 1.0, (len(arms), 5))
        actions[:, 3] = 1.0
        for i, action in enumerate(actions):
            arms[i].apply(action, robots.robot_time(i), 0.01)
            twins[i].apply(action, sims[i].time, 0.01)
        robots.step(spec.steps_per_action)
        for sim in sims:
            sim.step(spec.steps_per_action)
    for i, sim in enumerate(sims):
        _assert_same_state(robots.rod(i), sim.rod, f"robot {i}")
    tips = [robots.rod(i).position_collection[:, -1] for i in range(len(arms))]
    assert all(np.linalg.norm(tip - [0.05, 0.0, 0.0]) > 5e-4 for tip in tips), tips  # the magnets bent them


def test_a_magnet_on_a_batched_rod_is_named():
    from elastica_magnetic import FieldValueError

    spec = _catheter_in_training_physics()
    arm = _arm(0.0275)  # on the centre of element 5
    robots = BatchedRobots(spec, n_robots=2, sources=[None, arm.source], clamp=True)
    with pytest.raises(FieldValueError, match=r"robot 1: its magnet \(MagnetPose\).*element 5"):
        robots.step(1)


def test_batched_catheters_on_insertion_stages_match_per_rod_simulations_bit_for_bit():
    """Issue 53: each robot's clamped base pushed along its axis by its own advancer (and bent by
    its arm's magnet) follows the per-rod simulation of the same commands to the last bit, a robot
    reset mid-run included; the base sits where the stage's insertion puts it, within its travel."""
    from elastica_magnetic import Advancer

    spec = _catheter_in_training_physics()
    arms, twins = [_arm(0.09), _arm(0.1)], [_arm(0.09), _arm(0.1)]
    stages = [Advancer((-0.005, 0.02), max_speed=0.02) for _ in range(2)]
    twin_stages = [Advancer((-0.005, 0.02), max_speed=0.02) for _ in range(2)]
    robots = BatchedRobots(spec, n_robots=2, sources=[a.source for a in arms], clamp=True, advancers=stages)
    sims = [build_simulation(spec, t.source, clamp=True, advancer=s)
            for t, s in zip(twins, twin_stages, strict=True)]
    rng = np.random.default_rng(5)
    for step in range(40):
        if step == 25:
            robots.reset_robot(1)
            for thing in (arms[1], twins[1], stages[1], twin_stages[1]):
                thing.reset()
            sims[1] = build_simulation(spec, twins[1].source, clamp=True, advancer=twin_stages[1])
        actions = rng.uniform(-1.0, 1.0, (2, 6))
        actions[:, 5] = 1.0  # push in
        for i in range(2):
            arms[i].apply(actions[i, :5], robots.robot_time(i), 0.01)
            stages[i].apply(actions[i, 5:], robots.robot_time(i), 0.01)
            twins[i].apply(actions[i, :5], sims[i].time, 0.01)
            twin_stages[i].apply(actions[i, 5:], sims[i].time, 0.01)
        robots.step(spec.steps_per_action)
        for sim in sims:
            sim.step(spec.steps_per_action)
    for i, sim in enumerate(sims):
        _assert_same_state(robots.rod(i), sim.rod, f"robot {i}")
    assert stages[0].insertion_at(robots.robot_time(0)) == pytest.approx(0.008)  # 40 x 0.2 mm
    assert robots.rod(0).position_collection[0, 0] == pytest.approx(0.008, abs=1e-12)
    assert robots.rod(1).position_collection[0, 0] == pytest.approx(0.003, abs=1e-12)  # 15 steps since reset


def test_a_batch_mixing_stages_and_plain_clamps_holds_each_base_as_its_per_rod_simulation():
    """The clamps of a batch are one kernel call: a robot with a stage on a slanted axis, one
    with a plain clamp and one reset mid-run (on its own clock) each follow their per-rod
    simulation (a ``OneEndFixedBC``, an ``InsertionClamp``) to the last bit."""
    from elastica_magnetic import Advancer

    spec = _catheter_in_training_physics()
    axis = (1.0, 0.3, -0.2)
    arms, twins = [_arm(x) for x in (0.09, 0.1, 0.08)], [_arm(x) for x in (0.09, 0.1, 0.08)]
    stages = [Advancer((-0.004, 0.01), 0.02, axis), None, Advancer((-0.004, 0.01), 0.02)]
    twin_stages = [Advancer((-0.004, 0.01), 0.02, axis), None, Advancer((-0.004, 0.01), 0.02)]
    robots = BatchedRobots(spec, n_robots=3, sources=[a.source for a in arms], clamp=True, advancers=stages)
    sims = [build_simulation(spec, t.source, clamp=True, advancer=s)
            for t, s in zip(twins, twin_stages, strict=True)]
    base = robots.rod(1).position_collection[:, 0].copy()
    rng = np.random.default_rng(11)
    for step in range(30):
        if step == 17:
            robots.reset_robot(2)
            for thing in (arms[2], twins[2], stages[2], twin_stages[2]):
                thing.reset()
            sims[2] = build_simulation(spec, twins[2].source, clamp=True, advancer=twin_stages[2])
        actions = rng.uniform(-1.0, 1.0, (3, 6))
        actions[:, 5] = 0.8  # push in
        for i in range(3):
            arms[i].apply(actions[i, :5], robots.robot_time(i), 0.01)
            twins[i].apply(actions[i, :5], sims[i].time, 0.01)
            if stages[i] is not None:
                stages[i].apply(actions[i, 5:], robots.robot_time(i), 0.01)
                twin_stages[i].apply(actions[i, 5:], sims[i].time, 0.01)
        robots.step(spec.steps_per_action)
        for sim in sims:
            sim.step(spec.steps_per_action)
    for i, sim in enumerate(sims):
        _assert_same_state(robots.rod(i), sim.rod, f"robot {i}")
    np.testing.assert_array_equal(robots.rod(1).position_collection[:, 0], base)
    moved = robots.rod(0).position_collection[:, 0] - robots.rod(1).position_collection[:, 0]
    assert np.linalg.norm(moved) > 1e-4  # the slanted stage moved its base
    np.testing.assert_allclose(np.cross(moved, np.array(axis)), 0.0, atol=1e-15)


def test_an_advancer_stops_at_the_ends_of_its_travel_and_checks_its_values():
    from elastica_magnetic import Advancer

    stage = Advancer((-0.002, 0.003), max_speed=0.1)
    stage.apply([1.0], 0.0, 0.01)  # 1 mm asked, 1 mm left... then the end
    stage.apply([1.0], 0.01, 0.01)
    stage.apply([1.0], 0.02, 0.01)
    assert stage.insertion_at(0.03) == pytest.approx(0.003) and stage.speed_at(0.025) == pytest.approx(0.1)
    stage.apply([-1.0], 0.03, 0.1)
    assert stage.insertion_at(1.0) == pytest.approx(-0.002)
    with pytest.raises(ValueError, match="low <= 0 <= high"):
        Advancer((0.01, 0.02), max_speed=0.1)
    with pytest.raises(ValueError, match="clamp=True"):
        build_simulation(_catheter_in_training_physics(), lambda t: np.zeros(3), advancer=stage)


def _coils():
    """Three coils around the catheter's tip region (a loop, a Helmholtz pair, a Maxwell pair)
    on three axes, each the field of 1 A."""
    from elastica_magnetic import CurrentLoopField, HelmholtzCoils, MaxwellCoils

    return [CurrentLoopField(0.03, centre=(0.05, 0.0, -0.04), axis=(0.0, 0.0, 1.0), turns=200.0),
            HelmholtzCoils(0.08, centre=(0.04, 0.0, 0.0), axis=(0.0, 1.0, 0.0), turns=100.0),
            MaxwellCoils(0.06, centre=(0.03, 0.0, 0.0), axis=(1.0, 0.0, 0.0), turns=100.0)]


def test_batched_catheters_under_coil_currents_match_per_rod_simulations_bit_for_bit():
    """Issue 53: robots of a batch, each under its own currents in one set of fixed coils (one
    kernel for the coil set), follow the per-rod simulations of the same commands to the last
    bit, a robot reset mid-run (on its own clock) included."""
    from elastica_magnetic import CoilCurrents
    from elastica_magnetic._batch_coils import loop_geometry

    spec = _catheter_in_training_physics()
    coils = _coils()
    actuators = [CoilCurrents(coils, current_limit=2.0, max_slew=100.0) for _ in range(3)]
    twins = [CoilCurrents(_coils(), current_limit=2.0, max_slew=100.0) for _ in range(3)]
    robots = BatchedRobots(spec, n_robots=3, sources=[a.source for a in actuators], clamp=True)
    assert loop_geometry(actuators[0].source) is not None  # the kernel's path, not a call per robot
    assert not robots._sources.general and robots.sources == [a.source for a in actuators]
    sims = [build_simulation(spec, twin.source, clamp=True) for twin in twins]
    rng = np.random.default_rng(5)
    for step in range(24):  # 0.24 s of 0.01 s control steps
        if step == 14:
            robots.reset_robot(1)
            actuators[1].reset()
            twins[1].reset()
            sims[1] = build_simulation(spec, twins[1].source, clamp=True)
        actions = rng.uniform(-1.0, 1.0, (3, 3))
        actions[2, 1] = 0.0  # a coil without current is skipped alike
        for i, action in enumerate(actions):
            actuators[i].apply(action, robots.robot_time(i), 0.01)
            twins[i].apply(action, sims[i].time, 0.01)
        robots.step(spec.steps_per_action)
        for sim in sims:
            sim.step(spec.steps_per_action)
    for i, sim in enumerate(sims):
        _assert_same_state(robots.rod(i), sim.rod, f"robot {i}")
    tips = [robots.rod(i).position_collection[:, -1] for i in range(3)]
    assert all(np.linalg.norm(tip - [0.05, 0.0, 0.0]) > 1e-4 for tip in tips)  # the coils bent them


def test_coils_that_move_or_play_a_waveform_take_the_general_path_and_a_wire_is_named():
    from elastica_magnetic import CoilCurrents, CurrentLoopField, SpatialFieldError, Waypoints
    from elastica_magnetic._batch_coils import loop_geometry

    moving = CurrentLoopField(0.03, centre=Waypoints([0.0, 1.0], [[0.05, 0, -0.04], [0.05, 0, -0.03]]))
    playing = CurrentLoopField(0.03, current=lambda t: 1.0 + t, centre=(0.05, 0.0, -0.04))
    assert loop_geometry(moving) is None and loop_geometry(playing) is None
    assert loop_geometry(CoilCurrents([_coils()[0], moving], 1.0).source) is None
    spec = _catheter_in_training_physics()
    # a loop of radius 5 mm about the x axis through x = 27.5 mm: its wire through element 5's centre
    wire = CoilCurrents([CurrentLoopField(0.005, centre=(0.0275, 0.0, -0.005), axis=(0.0, 1.0, 0.0))], 1.0)
    wire.apply([1.0], 0.0, 0.01)
    robots = BatchedRobots(spec, n_robots=2, sources=[None, wire.source], clamp=True)
    assert not robots._sources.general
    with pytest.raises(SpatialFieldError, match=r"robot 1: .*lies on the wire of current loop 0"):
        robots.step(1)


@pytest.mark.parametrize("clamped", [False, True])
def test_the_direct_step_is_pyelastica_s_step_to_the_last_bit(clamped):
    """A batch whose simulator holds only its own operators takes PositionVerlet's step directly
    (not through the collection's operator groups); both ways give the same state, bit for bit:
    crawlers on the ground in turning fields, or clamped catheters on stages under magnets."""
    from elastica_magnetic import Advancer

    def batch():
        if not clamped:
            return BatchedRobots(yao2023_robot(1, "training"), n_robots=2), [], None
        arms, stage = [_arm(0.09), _arm(0.1)], Advancer((-0.005, 0.01), 0.02)
        return BatchedRobots(_catheter_in_training_physics(), n_robots=2, sources=[a.source for a in arms],
                             clamp=True, advancers=[stage, None]), arms, stage

    (direct, *drive_direct), (grouped, *drive_grouped) = batch(), batch()
    assert direct._direct and grouped._direct
    grouped._direct = False
    rng = np.random.default_rng(2)
    for _ in range(12):
        fields = rng.uniform(-4e-3, 4e-3, (2, 3)) * [1, 1, 0]
        for robots, (arms, stage) in ((direct, drive_direct), (grouped, drive_grouped)):
            robots.fields = fields
            for i, arm in enumerate(arms):
                arm.apply(np.array([0.3, -0.2, 0.1, 1.0, 0.5]), robots.robot_time(i), 0.01)
            if stage is not None:
                stage.apply([0.7], robots.robot_time(0), 0.01)
            robots.step(robots.spec.steps_per_action)
    for i in range(2):
        _assert_same_state(direct.rod(i), grouped.rod(i), f"robot {i}")
    assert not np.array_equal(direct.rod(0).position_collection, batch()[0].rod(0).position_collection)


def test_point_dipoles_are_one_kernel_call_and_follow_the_per_rod_simulations_bit_for_bit():
    """A static dipole, one whose moment turns along waypoints, one moving (its position along
    waypoints) and reset mid-run on its own clock: one kernel call for all, each the per-rod
    simulation of its source to the last bit; a dipole given by another callable keeps the
    general path, as exact."""
    from elastica_magnetic import PointDipoleField, Waypoints

    spec = yao2023_robot(1, "training")

    def sources():
        turning = Waypoints([0.0, 0.1, 0.25], [[0.0, -2.5, 0.0], [1.5, -2.0, 0.0], [2.5, 0.0, 0.5]])
        return [PointDipoleField((0.0, -2.5, 0.0), (0.012, 0.05, 0.0)),
                PointDipoleField(turning, (0.01, 0.05, 0.0)),
                _moving_dipole(),
                PointDipoleField(lambda t: (0.0, -2.5 + t, 0.0), (0.01, 0.05, 0.0))]

    batch_sources, twins = sources(), sources()
    robots = BatchedRobots(spec, n_robots=4, sources=batch_sources)
    assert sorted(robots._sources.dipoles.sources) == [0, 1, 2] and list(robots._sources.general) == [3]
    sims = [build_simulation(spec, source) for source in twins]
    for step in range(30):
        if step == 12:
            robots.reset_robot(2)
            sims[2] = build_simulation(spec, twins[2])
        robots.step(spec.steps_per_action)
        for sim in sims:
            sim.step(spec.steps_per_action)
    for i, sim in enumerate(sims):
        _assert_same_state(robots.rod(i), sim.rod, f"robot {i}")
    assert robots.sources == batch_sources
    robots.set_source(0, None)
    assert sorted(robots._sources.dipoles.sources) == [1, 2] and robots.sources[0] is None


def test_a_dipole_on_a_batched_rod_is_named():
    from elastica_magnetic import FieldValueError, PointDipoleField

    spec = yao2023_robot(1, "training")
    robots = BatchedRobots(spec, n_robots=2)
    nodes = robots.rod(1).position_collection
    robots.set_source(1, PointDipoleField((0.0, 1.0, 0.0), 0.5 * (nodes[:, 5] + nodes[:, 6])))
    with pytest.raises(FieldValueError, match=r"robot 1: its source \(PointDipoleField\).*element 5"):
        robots.step(1)
