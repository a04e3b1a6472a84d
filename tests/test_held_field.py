"""One robot under a held field on the batched kernel (``elastica_magnetic.held_field``): the
environments' simulator and ``run_open_loop``'s for a 100 Hz table. Its trajectory is the per-rod
simulator's to the last bit, for robots of every form a spec takes."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from spec_texts import CATHETER, CATHETER_ON_GROUND, SMALL_BAND

from elastica_magnetic import (
    MM_MG_S,
    ControlledField,
    HeldFieldSimulation,
    RobotSimulation,
    SimulationDivergedError,
    TabulatedField,
    build_simulation,
    held_field_simulation,
    load_robot,
    run_open_loop,
    yao2023_robot,
)
from elastica_magnetic.openloop import _held_rows

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
    single, held = build_simulation(spec, single_field), HeldFieldSimulation(spec, held_field)
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


@pytest.mark.parametrize("form", FORMS)
def test_open_loop_tables_run_on_the_batched_kernel_bit_for_bit(form, tmp_path):
    spec = _spec(form, tmp_path)
    rows = np.random.default_rng(1).uniform(-4e-3, 4e-3, (9, 3)) * _tesla(spec)
    table = TabulatedField(rows, after_end="zero")  # 0.12 s: three rows past its end
    assert _held_rows(spec, table, clamp=False) is not None

    def per_rod(time: float):  # any callable takes the per-rod simulator
        return table(time)

    held, single = run_open_loop(spec, table, 0.12), run_open_loop(spec, per_rod, 0.12)
    assert held.trajectory.equals(single.trajectory)
    assert np.array_equal(held.fields, single.fields)
    assert all(np.array_equal(a[1], b[1]) and a[0] == b[0] for a, b in zip(held.shapes, single.shapes,
                                                                          strict=True))


def test_fields_and_specs_the_kernel_cannot_hold_take_the_per_rod_simulator(tmp_path):
    spec = yao2023_robot(1, "accurate")
    table = TabulatedField(np.zeros((5, 3)))
    assert _held_rows(spec, table, clamp=True) is None  # a clamped base
    assert _held_rows(spec, TabulatedField(np.zeros((5, 3)), rate=50.0), clamp=False) is None
    # a spec built in code may step 0.01 s unevenly (spec files refuse it): 333 steps of 9.99 ms
    assert _held_rows(replace(spec, dt=3e-5), table, clamp=False) is None
    (tmp_path / "kv.toml").write_text(SEGMENTS + "[robot.damping]\nkelvin_voigt = 0.1\n")
    viscous = load_robot(tmp_path / "kv.toml")
    assert _held_rows(viscous, table, clamp=False) is None
    assert isinstance(held_field_simulation(viscous, ControlledField(4e-3)), RobotSimulation)
    assert isinstance(held_field_simulation(spec, ControlledField(4e-3)), HeldFieldSimulation)
    with pytest.raises(ValueError, match="does not model .*kelvin_voigt.*use build_simulation"):
        HeldFieldSimulation(viscous, ControlledField(4e-3))


def test_a_divergence_is_worded_as_the_single_robot_simulator_words_it():
    spec = yao2023_robot(1, "accurate")
    held = HeldFieldSimulation(spec, ControlledField(4e-3))
    single = build_simulation(spec, ControlledField(4e-3))
    for simulation in (held, single):
        simulation.rod.velocity_collection[1, 5] = np.nan
    messages = []
    for simulation in (held, single):
        with pytest.raises(SimulationDivergedError) as caught:
            simulation.step(1)
        messages.append(str(caught.value))
    assert messages[0] == messages[1] and "robot 0" not in messages[0], messages
