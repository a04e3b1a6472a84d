"""Actuation by a moving magnet or by coil currents (elastica_magnetic.actuation): limits, continuity
within a control step, superposition, and the forcing that reads them."""

from __future__ import annotations

import math

import elastica as ea
import numpy as np
import pytest

from elastica_magnetic import CurrentLoopField, MagneticTorques, PointDipoleField
from elastica_magnetic.actuation import CoilCurrents, MagnetPose
from elastica_magnetic.spatial_fields import SpatialFieldError

BOX = [[-0.05, -0.05, 0.05], [0.05, 0.05, 0.15]]
POINTS = np.array([[0.0, 0.01, -0.02], [0.005, 0.0, 0.01], [0.0, 0.002, 0.0]])


def magnet(**changes):
    settings = dict(moment=1.0, position=[0.0, 0.0, 0.1], direction=[0.0, 0.0, 2.0], workspace=BOX,
                    max_speed=0.05, max_turn_rate=1.0)
    return MagnetPose(**{**settings, **changes})


def test_the_magnet_moves_at_the_commanded_velocity_and_continuously():
    m = magnet()
    m.apply([0.8, 0.0, -0.6, 0.0, 0.0], time=0.2, dt=0.01)
    assert np.allclose(m.position_at(0.205), [0.0002, 0.0, 0.1 - 0.00015])  # halfway
    assert np.allclose(m.position_at(0.21), [0.0004, 0.0, 0.1 - 0.0003])
    assert np.allclose(m.position_at(0.5), m.position_at(0.21))  # held after the step
    m.apply([0.0, 0.0, 0.0, 0.0, 0.0], time=0.205, dt=0.01)  # a new command mid-step: from there
    assert np.allclose(m.position_at(0.3), [0.0002, 0.0, 0.1 - 0.00015])


def test_the_speed_is_limited_as_a_vector_and_the_workspace_stops_the_magnet():
    m = magnet()
    m.apply([1.0, 1.0, 1.0, 0.0, 0.0], time=0.0, dt=0.1)
    step = m.position_at(0.1) - np.array([0.0, 0.0, 0.1])
    assert np.linalg.norm(step) == pytest.approx(0.05 * 0.1)
    assert np.allclose(step, step[0])  # along the commanded direction
    for k in range(40):  # push down into the floor of the box
        m.apply([0.0, 0.0, -1.0, 0.0, 0.0], time=0.1 * (k + 1), dt=0.1)
    assert m.position_at(10.0)[2] == pytest.approx(0.05)
    assert np.all(m.position_at(10.0) >= np.array(BOX[0]) - 1e-15)


def test_the_moment_turns_at_the_commanded_rate_and_keeps_its_magnitude():
    m = magnet(max_turn_rate=2.0)
    m.apply([0.0, 0.0, 0.0, 1.0, 0.0], time=0.0, dt=0.25)
    d = m.direction_at(0.25)
    assert np.linalg.norm(d) == pytest.approx(1.0)
    assert math.degrees(math.acos(d[2])) == pytest.approx(math.degrees(0.5))
    assert np.linalg.norm(m.moment_at(0.25)) == pytest.approx(1.0)
    m.apply([0.0, 0.0, 0.0, 1.0, 1.0], time=0.25, dt=0.25)  # diagonal: still at most 2 rad/s
    turned = math.acos(np.clip(m.direction_at(0.5) @ d, -1.0, 1.0))
    assert turned == pytest.approx(0.5)
    m.reset()
    assert np.allclose(m.state(1.0), [0.0, 0.0, 0.1, 0.0, 0.0, 1.0])


def test_the_magnet_s_source_is_the_dipole_at_its_pose():
    m = magnet()
    m.apply([0.3, -0.2, 0.1, 0.5, -0.4], time=0.0, dt=0.02)
    for t in (0.0, 0.013, 0.02):
        fixed = PointDipoleField(m.moment_at(t), m.position_at(t))
        assert np.array_equal(m.source.at(POINTS, t), fixed.at(POINTS, t))
        assert np.array_equal(m.source.gradient(POINTS, t), fixed.gradient(POINTS, t))


@pytest.mark.parametrize(("changes", "named"), [
    ({"workspace": [[0, 0, 0], [0.1, -0.1, 0.1]]}, "workspace"),
    ({"position": [0.0, 0.0, 0.3]}, "outside the workspace"),
    ({"direction": [0.0, 0.0, 0.0]}, "direction"),
    ({"max_speed": 0.0}, "max_speed"),
    ({"moment": float("nan")}, "moment"),
])
def test_a_bad_magnet_is_named(changes, named):
    with pytest.raises(SpatialFieldError, match=named):
        magnet(**changes)


def test_a_bad_action_is_named():
    with pytest.raises(SpatialFieldError, match="5 components"):
        magnet().apply([0.0, 1.0], time=0.0, dt=0.01)
    with pytest.raises(SpatialFieldError, match="finite"):
        magnet().apply([0.0, 1.0, float("nan"), 0, 0], time=0.0, dt=0.01)


def coils():
    return [CurrentLoopField(0.05, 1.0, centre=[0.0, 0.0, 0.08], axis=[0.0, 0.0, 1.0], turns=100),
            CurrentLoopField(0.05, 1.0, centre=[0.08, 0.0, 0.0], axis=[1.0, 0.0, 0.0], turns=100),
            CurrentLoopField(0.04, 1.0, centre=[0.0, -0.07, 0.0], axis=[0.0, 1.0, 0.0], turns=50)]


def test_coil_fields_add_up_at_their_currents():
    actuator = CoilCurrents(coils(), current_limit=[2.0, 4.0, 1.0])
    actuator.apply([0.5, -0.25, 1.0], time=0.0, dt=0.01)
    assert np.allclose(actuator.currents_at(0.01), [1.0, -1.0, 1.0])
    assert np.allclose(actuator.currents_at(0.005), [0.5, -0.5, 0.5])  # a linear ramp
    expected = [CurrentLoopField(0.05, 1.0, centre=[0.0, 0.0, 0.08], turns=100),
                CurrentLoopField(0.05, -1.0, centre=[0.08, 0.0, 0.0], axis=[1.0, 0.0, 0.0], turns=100),
                CurrentLoopField(0.04, 1.0, centre=[0.0, -0.07, 0.0], axis=[0.0, 1.0, 0.0], turns=50)]
    b = sum(c.at(POINTS, 0.0) for c in expected)
    g = sum(c.gradient(POINTS, 0.0) for c in expected)
    assert np.allclose(actuator.source.at(POINTS, 0.01), b, rtol=1e-12, atol=0.0)
    assert np.allclose(actuator.source.gradient(POINTS, 0.01), g, rtol=1e-12, atol=1e-18)
    assert np.allclose(actuator.state(0.01), [0.5, -0.25, 1.0])


def test_currents_change_no_faster_than_the_slew_limit():
    actuator = CoilCurrents(coils(), current_limit=10.0, max_slew=100.0)
    actuator.apply([1.0, -1.0, 0.05], time=0.0, dt=0.01)
    assert np.allclose(actuator.currents_at(0.01), [1.0, -1.0, 0.5])
    actuator.apply([1.0, -1.0, 0.05], time=0.01, dt=0.01)
    assert np.allclose(actuator.currents_at(0.02), [2.0, -2.0, 0.5])
    actuator.reset()
    assert not np.any(actuator.source.at(POINTS, 1.0))


def test_bad_coils_are_named():
    with pytest.raises(SpatialFieldError, match="at least one coil"):
        CoilCurrents([], 1.0)
    with pytest.raises(SpatialFieldError, match="current_limit"):
        CoilCurrents(coils(), [1.0, 0.0, 1.0])
    with pytest.raises(SpatialFieldError, match="coil 1 is not a spatial field source"):
        CoilCurrents([coils()[0], "coil.npz"], 1.0)
    with pytest.raises(SpatialFieldError, match="3 components"):
        CoilCurrents(coils(), 1.0).apply([1.0], time=0.0, dt=0.01)


def test_the_forcing_feels_the_magnet_where_it_is_at_each_time():
    """A catheter-like rod along x; the magnet above its tip, then moved: MagneticTorques takes the
    actuator's source and its loads follow the pose at each time, as a dipole fixed there gives."""
    n = 10
    rod = ea.CosseratRod.straight_rod(n, np.zeros(3), np.array([1.0, 0, 0]), np.array([0, 0, 1.0]),
                                      0.05, 5e-4, 1100.0, youngs_modulus=3e6, shear_modulus=1e6)
    magnetization = np.zeros((3, n))
    magnetization[2] = 1e5  # A/m, along lab z
    m = magnet(position=[0.05, 0.0, 0.08], workspace=[[-0.1, -0.1, 0.05], [0.1, 0.1, 0.15]])
    m.apply([-1.0, 0.0, 0.0, 0.0, 1.0], time=0.0, dt=0.2)
    for t in (0.0, 0.1, 0.2):
        moved = MagneticTorques(m.source, magnetization=magnetization)
        fixed = MagneticTorques(PointDipoleField(m.moment_at(t), m.position_at(t)),
                                magnetization=magnetization)
        loads = []
        for forcing in (moved, fixed):
            rod.external_forces[:] = 0.0
            rod.external_torques[:] = 0.0
            forcing.apply_forces(rod, t)
            forcing.apply_torques(rod, t)
            loads.append((rod.external_forces.copy(), rod.external_torques.copy()))
        assert np.array_equal(loads[0][0], loads[1][0]) and np.array_equal(loads[0][1], loads[1][1])
        assert np.any(loads[0][0]) and np.any(loads[0][1])


def test_the_docs_example_runs():
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "docs" / "spatial_fields.md").read_text()
    section = text.split("## Moving the source", 1)[1].split("\n## ", 1)[0]
    (block,) = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    namespace: dict = {}
    exec(compile(block, "spatial_fields.md", "exec"), namespace)
    assert namespace["B_tip"].shape == (3, 1) and np.all(np.isfinite(namespace["B_tip"]))
    assert np.allclose(namespace["coils"].currents_at(0.01), [2.0, 2.0])
    assert namespace["B_centre"][2, 0] > 0.0  # two coaxial coils, same sense: along +z


def test_the_bearing_steering_brings_the_tip_onto_the_targets_bearing():
    """A clamped catheter (50 mm, 10 elements) along +x, a 1 A m^2 magnet 40 mm beyond its tip; the
    target 22 mm from the tip, 45 mm from the base at 26.6 degrees: steered for 1 s, the tip's
    bearing is the target's and it is within 5.5 mm of it (the rest is radial: a field bends the
    catheter but does not shorten it); the magnet never comes nearer the tip than 30 mm."""
    from spec_texts import CATHETER

    from elastica_magnetic import build_simulation
    from elastica_magnetic.spec_format import loads
    from elastica_magnetic.specfile import describe_robot
    from elastica_magnetic.steering import MagnetBearingSteering

    spec = describe_robot(loads(CATHETER, "c.toml"), "c.toml").robot("accurate")
    arm = magnet(position=[0.09, 0.0, 0.0], direction=[1.0, 0.0, 0.0],
                 workspace=[[-0.1, -0.1, -0.05], [0.15, 0.15, 0.05]], max_speed=0.1, max_turn_rate=3.0)
    law = MagnetBearingSteering(arm, base=[0.0, 0.0, 0.0], distance=0.04, gain=5.0)
    simulation = build_simulation(spec, arm.source, clamp=True)
    target = np.array([0.04, 0.02, 0.0])
    nearest = math.inf
    for _ in range(100):  # 1 s of 0.01 s control steps
        t = simulation.time
        tip = simulation.rod.position_collection[:, -1].copy()
        arm.apply(law.action(tip, target, t, 0.01), t, 0.01)
        simulation.advance(0.01)
        nearest = min(nearest, float(np.linalg.norm(arm.position_at(simulation.time) - tip)))
    tip = simulation.rod.position_collection[:, -1]
    bearing = math.degrees(math.atan2(tip[1], tip[0]))
    assert bearing == pytest.approx(math.degrees(math.atan2(0.02, 0.04)), abs=1.0)
    assert np.linalg.norm(tip - target) < 5.5e-3
    assert nearest > 0.03
    law.reset()
    assert law.field_direction is None
