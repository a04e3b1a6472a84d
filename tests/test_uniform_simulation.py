"""One robot under a uniform field on the batched kernel (``elastica_magnetic.uniform_simulation``):
the environments' simulator and ``run_open_loop``'s. Its trajectory is the per-rod simulator's to the
last bit, for robots of every form a spec takes, under a held field and under fields that vary in
time."""

from __future__ import annotations

import numpy as np
import pytest
from spec_texts import CATHETER, CATHETER_ON_GROUND, SMALL_BAND

from elastica_magnetic import (
    MM_MG_S,
    ConstantField,
    ControlledField,
    FieldValueError,
    PointDipoleField,
    RampedField,
    RobotSimulation,
    RotatingField,
    SimulationDivergedError,
    TabulatedField,
    UniformFieldSimulation,
    build_simulation,
    load_robot,
    openloop,
    run_open_loop,
    uniform_field_simulation,
    yao2023_robot,
)

SEGMENTS = SMALL_BAND + """
[robot.ground]
static_mu = 0.6
kinetic_mu = 0.4
[robot.magnetization]
kind = "segments"
magnitude = 60000.0
segments = [{elements = 3, direction = [1, 0, 0]}, {elements = 2, direction = [0, 1, 1]},
            {elements = 3, direction = [-1, 0, 0]}]
[physics.accurate]
dt = 2e-5
"""


def _spec(form: str, tmp_path):
    if form == "mm-mg-s":  # the paper's robot in another unit system
        return yao2023_robot(1, "accurate").to_units(MM_MG_S)
    if form.startswith("yao2023"):
        name, physics = form.split(":")
        return yao2023_robot(int(name[-1]), physics)
    text = {"segments": SEGMENTS, "catheter": CATHETER, "catheter-ground": CATHETER_ON_GROUND}[form]
    path = tmp_path / f"{form}.toml"
    path.write_text(text)
    return load_robot(path, "accurate")


FORMS = ["yao2023-m1:accurate", "yao2023-m2:training", "mm-mg-s", "segments", "catheter", "catheter-ground"]


def _tesla(spec) -> float:
    """One tesla in the spec's units."""
    return spec.units.factor("field")


@pytest.mark.parametrize("form", FORMS)
def test_a_held_field_follows_the_per_rod_simulator_bit_for_bit(form, tmp_path):
    """A 3-axis field changed by increments every 0.01 s, as an agent changes it."""
    spec = _spec(form, tmp_path)
    increments = np.random.default_rng(0).uniform(-1.0, 1.0, (12, 3)) * 0.3e-3 * _tesla(spec)
    single_field, held_field = ControlledField(4e-3 * _tesla(spec)), ControlledField(4e-3 * _tesla(spec))
    single, held = build_simulation(spec, single_field), UniformFieldSimulation(spec, held_field)
    for delta in increments:
        single_field.apply_increment(delta)
        held_field.apply_increment(delta)
        single.step(spec.steps_per_action)
        held.step(spec.steps_per_action)
        assert held.time == single.time and held.step_count == single.step_count
    assert np.array_equal(held.rod.position_collection, single.rod.position_collection)
    assert np.array_equal(held.rod.velocity_collection, single.rod.velocity_collection)
    assert np.array_equal(held.rod.director_collection, single.rod.director_collection)
    assert held.markers() == single.markers()
    assert np.ptp(held.rod.position_collection[0]) > 0.5 * spec.length  # a rod that moved, not NaN


def _fields(spec):
    """Uniform fields that vary in time (T, in the spec's units): a 100 Hz table (after its end,
    zero), a rotating field ramped up and turned out of the x-y plane, a ramp."""
    rows = np.random.default_rng(1).uniform(-4e-3, 4e-3, (9, 3)) * _tesla(spec)
    return {"table": TabulatedField(rows, after_end="zero"),
            "rotating": RotatingField(4e-3 * _tesla(spec), 7.0, phase=0.3, ramp_time=0.02, heading=0.7),
            "ramp": RampedField((0.0, 4e-3 * _tesla(spec), 1e-3 * _tesla(spec)), 0.05)}


@pytest.mark.parametrize("form", FORMS)
def test_open_loop_fields_run_on_the_batched_kernel_bit_for_bit(form, tmp_path, monkeypatch):
    spec = _spec(form, tmp_path)
    for name, field in _fields(spec).items():
        fast = run_open_loop(spec, field, 0.12)  # 0.12 s: three rows past the table's end
        with monkeypatch.context() as m:  # the per-rod simulator, as before the batched kernel
            m.setattr(openloop, "uniform_field_simulation",
                      lambda spec, field, clamp=False: build_simulation(spec, field, clamp=clamp))
            single = run_open_loop(spec, field, 0.12)
        assert fast.trajectory.equals(single.trajectory), name
        assert np.array_equal(fast.fields, single.fields), name
        assert all(np.array_equal(a[1], b[1]) and a[0] == b[0]
                   for a, b in zip(fast.shapes, single.shapes, strict=True)), name


def test_fields_and_specs_the_kernel_does_not_model_take_the_per_rod_simulator(tmp_path):
    spec = yao2023_robot(1, "accurate")
    field = RotatingField(4e-3, 1.0)
    assert isinstance(uniform_field_simulation(spec, field), UniformFieldSimulation)
    assert isinstance(uniform_field_simulation(spec, field, clamp=True), RobotSimulation)
    assert isinstance(uniform_field_simulation(spec, PointDipoleField((0.0, 0.05, 0.0), (0.0, 2.5, 0.0))),
                      RobotSimulation)
    (tmp_path / "kv.toml").write_text(SEGMENTS + "[robot.damping]\nkelvin_voigt = 0.1\n")
    viscous = load_robot(tmp_path / "kv.toml")
    assert isinstance(uniform_field_simulation(viscous, ControlledField(4e-3)), RobotSimulation)
    with pytest.raises(ValueError, match="does not model .*kelvin_voigt.*use build_simulation"):
        UniformFieldSimulation(viscous, ControlledField(4e-3))


def test_a_field_function_that_returns_nonsense_is_named_as_the_per_rod_simulator_names_it():
    spec = yao2023_robot(1, "accurate")

    def broken(time):
        return np.array([0.0, np.nan, 0.0]) if time > 0.005 else np.zeros(3)

    messages = []
    for simulation in (UniformFieldSimulation(spec, broken), build_simulation(spec, broken)):
        with pytest.raises(FieldValueError) as caught:
            simulation.step(spec.steps_per_action)
        messages.append(str(caught.value))
    assert messages[0] == messages[1] and "non-finite value" in messages[0], messages


def test_a_divergence_is_worded_as_the_single_robot_simulator_words_it():
    spec = yao2023_robot(1, "accurate")
    held = UniformFieldSimulation(spec, ControlledField(4e-3))
    single = build_simulation(spec, ControlledField(4e-3))
    for simulation in (held, single):
        simulation.rod.velocity_collection[1, 5] = np.nan
    messages = []
    for simulation in (held, single):
        with pytest.raises(SimulationDivergedError) as caught:
            simulation.step(1)
        messages.append(str(caught.value))
    assert messages[0] == messages[1] and "robot 0" not in messages[0], messages


def test_a_batched_robots_field_function_is_checked_and_can_be_removed():
    from elastica_magnetic import BatchedRobots, SpatialFieldNotSupportedError

    robots = BatchedRobots(yao2023_robot(1, "training"), 2)
    with pytest.raises(SpatialFieldNotSupportedError, match="robot 1: a field function is uniform"):
        robots.set_field_function(1, PointDipoleField((0.0, 0.05, 0.0), (0.0, 2.5, 0.0)))
    with pytest.raises(IndexError, match="robot 2: the batch has robots 0 to 1"):
        robots.set_field_function(2, RotatingField(4e-3, 1.0))
    robots.set_field_function(1, ConstantField((0.0, 4e-3, 0.0)))
    robots.step(1)
    assert robots.fields[1].tolist() == [0.0, 4e-3, 0.0] and robots.fields[0].tolist() == [0.0, 0.0, 0.0]
    robots.set_field_function(1, None)
    robots.fields[1] = (1e-3, 0.0, 0.0)
    robots.step(1)
    assert robots.fields[1].tolist() == [1e-3, 0.0, 0.0]  # the row written between steps again
