"""msr real identify: recovers the values of a perturbed robot from its synthetic trajectory, writes
the identified spec, and refuses bad input before any fitting. The recovery of three values at once
(the moduli among them, 3 minutes) is a case of benchmarks/identify_recovery.py."""

import json

import numpy as np
import pytest
from elastica_magnetic_rl.cases.variations import apply_values
from elastica_magnetic_rl.sim2real.identify import load_spec

from elastica_magnetic.cli import main
from elastica_magnetic.field_csv import read_field_csv, write_field_csv
from elastica_magnetic.openloop import run_open_loop, write_trajectory_csv
from elastica_magnetic.specfile import describe_robot, load_robot

CASE = "m1-4mT"


def rotating_field(path, amplitude=10e-3, frequency=-2.0, duration=1.0, ramp=0.1):
    """A field turning in the x-y plane (T, 100 rows/s), written as a field CSV and read back
    (so that the simulated truth sees the file's rounding)."""
    t = np.arange(int(round(100 * duration))) / 100
    a = amplitude * np.minimum(t / ramp, 1.0)
    phase = 2 * np.pi * frequency * t + np.pi / 2
    write_field_csv(path, np.stack([a * np.cos(phase), a * np.sin(phase), 0 * t], axis=1))
    return read_field_csv(path)


@pytest.fixture(scope="module")
def spec():
    return load_spec(CASE)


def test_one_value_from_msr_trajectory_csv_through_the_command(tmp_path, spec, capsys):
    fields = rotating_field(tmp_path / "fields.csv", duration=0.3)
    truth = apply_values(spec, {"robot.magnetization.magnitude": 0.9 * 61300.0})
    from elastica_magnetic.fields import TabulatedField

    run = run_open_loop(describe_robot(truth).robot("training"), TabulatedField(fields), 0.3)
    write_trajectory_csv(run.trajectory, tmp_path / "trajectory.csv")
    out = tmp_path / "id"
    assert main(["real", "identify", str(tmp_path / "fields.csv"), str(tmp_path / "trajectory.csv"),
                 "--robot", CASE, "--fit", "magnetization", "--out", str(out), "--no-progress",
                 "--starts", "1", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    fitted = report["fitted"]["magnetization"]
    assert fitted["factor"] == pytest.approx(0.9, rel=2e-3)  # the file's 9 digits: not exact
    assert report["residual_m"]["rms"] < 0.05 * report["residual_m"]["nominal_rms"]
    assert report["confirm"]["physics"] == "accurate" and np.isfinite(report["confirm"]["rms_m"])
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == [
        "identified.toml", "identify.json", "identify.png"]
    robot = load_robot(out / "identified.toml", "training")
    assert robot.magnetization.max() == pytest.approx(fitted["values"]["robot.magnetization.magnitude"])
    assert json.loads((out / "identify.json").read_text())["fitted"] == report["fitted"]


def test_bad_input_is_named_before_any_fitting(tmp_path, spec, capsys):
    rotating_field(tmp_path / "fields.csv", duration=0.5)
    track = tmp_path / "track.csv"
    rows = [f"{k / 30:.4f},{0.001 * k:.6f},0,{0.02 + 0.001 * k:.6f},0" for k in range(12)]
    track.write_text("t_s,x_0_m,y_0_m,x_1_m,y_1_m\n" + "\n".join(rows) + "\n")
    base = ["real", "identify", str(tmp_path / "fields.csv"), str(track), "--robot", CASE,
            "--out", str(tmp_path / "id")]
    assert main([*base, "--fit", "robot.magnetisation.magnitude"]) == 2
    assert "did you mean robot.magnetization.magnitude" in capsys.readouterr().err
    assert main([*base, "--fit", "magnetization,"]) == 2
    assert "expected KEY[,KEY...]" in capsys.readouterr().err
    millimetres = tmp_path / "mm.csv"
    millimetres.write_text("t_s,x_0_m,y_0_m,x_1_m,y_1_m\n" + "\n".join(
        f"{k / 30:.4f},{k:.3f},0,{20 + k:.3f},0" for k in range(12)) + "\n")
    assert main([*base[:3], str(millimetres), *base[4:], "--fit", "magnetization"]) == 2
    assert "look like millimetres" in capsys.readouterr().err
    long = tmp_path / "long.csv"
    long.write_text("t_s,x_0_m,y_0_m,x_1_m,y_1_m\n" + "\n".join(
        f"{k / 10:.4f},{0.001 * k:.6f},0,{0.02 + 0.001 * k:.6f},0" for k in range(12)) + "\n")
    assert main([*base[:3], str(long), *base[4:], "--fit", "magnetization"]) == 2
    assert "past the end of the waveform (0.5 s)" in capsys.readouterr().err
    assert main([*base[:5], "nope.toml", *base[6:], "--fit", "magnetization"]) == 2
    assert "nope.toml: no such spec file" in capsys.readouterr().err
    assert not (tmp_path / "id").exists()
