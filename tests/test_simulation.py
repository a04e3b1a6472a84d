"""Presets, the simulation builder, open-loop replay against the published run, and `msr`."""

import json
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from elastica_magnetic import (
    ConstantField,
    RobotSpec,
    SimulationDivergedError,
    TabulatedField,
    build_simulation,
    hu2018_robot,
    run_open_loop,
    yao2023_robot,
)
from elastica_magnetic.cli import main
from elastica_magnetic.cli.commands import compare_trajectories
from elastica_magnetic.forcing import (
    LegacyInternalDamping,
    MagneticTorques,
    RelativeVelocityDamping,
)
from elastica_magnetic.ground import FrictionalGroundContact


def test_paper_preset_values():
    accurate = yao2023_robot(1, "accurate")
    training = yao2023_robot(2, "training")
    assert accurate.radius == pytest.approx(0.8e-3 / np.sqrt(3))
    assert accurate.steps_per_action == 1250 and training.steps_per_action == 100
    assert training.effective_density == pytest.approx(1860 * 1000 / 95)
    assert training.effective_gravity * training.effective_density == pytest.approx(
        accurate.effective_gravity * accurate.effective_density
    )
    assert accurate.shear_modulus == pytest.approx(84.5e3 / 1.48)  # the authors' effective G
    np.testing.assert_allclose(training.magnetization[:, 0], [0, -61.3e3, 0])


def test_forcing_is_registered_in_the_paper_order():
    sim = build_simulation(yao2023_robot(1, "training"), ConstantField([0, 0, 0]))
    forcing = [type(op).__name__ for op in _operators(sim.simulator)]
    order = [
        MagneticTorques.__name__,
        RelativeVelocityDamping.__name__,
        LegacyInternalDamping.__name__,
        "GravityForces",
        FrictionalGroundContact.__name__,
    ]
    assert [name for name in forcing if name in order] == order


def _operators(simulator):
    """Forcing and contact objects in the order PyElastica runs them (its synchronize group)."""
    owners = []
    for call in simulator._feature_group_synchronize:
        owner = call.func.__self__
        if owner not in owners:
            owners.append(owner)
    return owners


def test_divergence_names_time_and_element():
    spec = replace(yao2023_robot(1, "accurate"), dt=2e-3)  # far beyond the stable step
    sim = build_simulation(spec, ConstantField([0, 4e-3, 0]))
    with pytest.raises(SimulationDivergedError, match=r"at t = [0-9.]+ s: .* at node \d+ \(element \d+\)"):
        sim.advance(2.0)


def test_spec_rejects_bad_values():
    with pytest.raises(ValueError, match=r"magnetization must have shape \(3, 64\)"):
        replace(yao2023_robot(), magnetization=np.zeros((3, 10)))
    with pytest.raises(ValueError, match="youngs_modulus must be positive"):
        replace(yao2023_robot(), youngs_modulus=-5.0)
    with pytest.raises(ValueError, match="density must be positive"):
        replace(yao2023_robot(), density=float("nan"))
    with pytest.raises(ValueError, match="physics must be"):
        yao2023_robot(1, "fast")
    assert isinstance(hu2018_robot(), RobotSpec)


def test_straight_robot_rests_without_field():
    result = run_open_loop(yao2023_robot(1, "training"), ConstantField([0, 0, 0]), 0.3)
    # gravity presses it onto the ground; nothing should move it along x
    assert abs(result.mid_dx) < 1e-7
    assert result.max_height < 1e-5


def test_replay_reproduces_published_start(reference_dir):
    """0.5 s of the accurate replay against the published trajectory (full 10 s: msr validate)."""
    field = TabulatedField.from_csv(reference_dir / "magnetic_field.csv")
    result = run_open_loop(yao2023_robot(1, "accurate"), field, 0.5)
    reference = pd.read_csv(reference_dir / "trajectory.csv")
    diff = compare_trajectories(result.trajectory, reference)
    assert diff["max_abs_diff_mid_x_m"] < 0.02e-3
    assert diff["max_abs_diff_height_max_m"] < 0.05e-3
    assert result.max_height > 1e-3  # the robot arched up: the comparison is not trivial


def test_msr_replay_json(tmp_path, reference_dir, capsys):
    status = main(["field", "replay", str(reference_dir / "magnetic_field.csv"), "--robot", "yao2023-m1",
        "--physics", "training", "--duration", "0.2", "--out", str(tmp_path), "--json",
        "--reference", str(reference_dir / "trajectory.csv"),
    ])
    assert status == 0
    result = json.loads(capsys.readouterr().out)
    for key in ("mid_dx_m", "max_height_m", "duration_s", "trajectory_csv", "wall_s"):
        assert key in result
    assert result["duration_s"] == pytest.approx(0.2)
    trajectory = pd.read_csv(result["trajectory_csv"])
    reference_columns = pd.read_csv(reference_dir / "trajectory.csv", nrows=1).columns
    # the published reference's columns, in its order, then the sideways markers (planar: 0)
    assert list(trajectory.columns) == [*reference_columns, "mid_z_m", "back_z_m", "front_z_m"]
    assert (trajectory[["mid_z_m", "back_z_m", "front_z_m"]] == 0.0).all().all()
    assert len(trajectory) == 21 and trajectory.t_s.iloc[0] == 0.0
    assert np.allclose(np.diff(trajectory.t_s), 0.01)
    assert (tmp_path / "replay.png").stat().st_size > 10_000


def test_msr_replay_bad_csv_is_one_clear_line(tmp_path, capsys):
    bad = tmp_path / "field.csv"
    bad.write_text(",mag_x,mag_y,mag_z\n0,1,2,3\n1,1,x,3\n")
    assert main(["field", "replay", str(bad), "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "field.csv: line 3, column mag_y: 'x' is not a number" in err


def test_msr_simulate_main_job(tmp_path, capsys):
    status = main(["field", "simulate", "--duration", "0.2", "--physics", "training", "--out", str(tmp_path),
                   "--json"])
    assert status == 0
    result = json.loads(capsys.readouterr().out)
    trajectory = pd.read_csv(result["trajectory_csv"])
    assert len(trajectory) == 21
    assert result["max_height_m"] > 1e-4  # the rotating field lifts the robot
    assert (tmp_path / "shapes.png").stat().st_size > 10_000
