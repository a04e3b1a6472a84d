"""Round 36 of held-out tries (issue 48): what they found, each fixed with the message it gives."""

from __future__ import annotations

import numpy as np
import pytest
from elastica_magnetic_rl.sim2real.tracking import TrajectoryError, check_against_robot, read_trajectory

from elastica_magnetic.cli import main as msr
from elastica_magnetic.field_csv import FieldCSVError, read_field_csv
from elastica_magnetic.hardware.coil_currents import CoilCurrentsError, read_coil_currents

LENGTH = 0.02  # m, the robot the trajectories below are on


def _trajectory_csv(path, columns: dict[str, np.ndarray]) -> None:
    """A CSV of ``columns`` over 30 frames 0.01 s apart (the robot straight along x, moving)."""
    t = 0.01 * np.arange(30)
    table = {"t_s": t, **columns}
    lines = [",".join(table)] + [",".join(f"{table[c][k]:.6g}" for c in table) for k in range(len(t))]
    path.write_text("\n".join(lines) + "\n")


def _markers(names=("back", "mid", "front")) -> dict[str, np.ndarray]:
    t = 0.01 * np.arange(30)
    at = {"back": 0.0, "mid": 0.5, "front": 1.0}
    out = {}
    for name in names:
        out[f"{name}_x_m"] = at[name] * LENGTH + 0.05 * t
        out[f"{name}_y_m"] = np.full_like(t, 0.0003)
    return out


@pytest.mark.parametrize("dropped", ["mid_y_m", "front_y_m", "back_x_m"])
def test_a_marker_with_one_coordinate_is_named(tmp_path, dropped):
    """S1/V1: a trajectory.csv marker with one of its two columns was dropped without a word (a
    missing ``front_y_m`` then read as "another robot, or not in metres"): the column is named."""
    columns = _markers()
    del columns[dropped]
    _trajectory_csv(tmp_path / "t.csv", columns)
    kept = dropped.replace("_y_", "_x_") if "_y_" in dropped else dropped.replace("_x_", "_y_")
    with pytest.raises(TrajectoryError, match=f"{kept} without {dropped}: the {dropped.split('_')[0]} "
                                              "marker needs both"):
        read_trajectory(tmp_path / "t.csv")


def test_tracker_columns_beside_markers_are_refused(tmp_path):
    """S1: ``mid_x_m, mid_y_m`` beside ``x_0_m, y_0_m, x_1_m, y_1_m``: the fit used ``mid`` alone,
    the tracker's two points ignored without a word."""
    columns = _markers(("mid",))
    t = 0.01 * np.arange(30)
    columns.update({"x_0_m": 0.05 * t, "y_0_m": 0 * t, "x_1_m": LENGTH + 0.05 * t, "y_1_m": 0 * t})
    _trajectory_csv(tmp_path / "t.csv", columns)
    with pytest.raises(TrajectoryError, match=r"holds msr's trajectory.csv markers \(mid_x_m, mid_y_m\) "
                                              r"and a tracker's columns \(x_0_m, y_0_m, x_1_m, y_1_m\)"):
        read_trajectory(tmp_path / "t.csv")


def test_the_span_check_knows_which_markers_a_file_has(tmp_path):
    """V1: back and mid alone (10 mm apart on a 20 mm robot) are where they should be: the first
    frame's span is judged against their half body length, not the whole."""
    _trajectory_csv(tmp_path / "t.csv", _markers(("back", "mid")))
    measured = read_trajectory(tmp_path / "t.csv")
    assert measured.points == ("back", "mid")
    check_against_robot(measured, LENGTH, 1.0)
    with pytest.raises(TrajectoryError, match="outermost tracked points are 10 mm apart"):
        check_against_robot(measured, 3 * LENGTH, 1.0)  # a robot three times as long: refused


def _field_lines(n: int) -> list[str]:
    return [f"{0.1 * k:.3f},{0.2:.3f},0.000" for k in range(n)]


@pytest.mark.parametrize("header", ["mag_x,mag_y,mag_z", ",mag_x,mag_y,mag_z"])
def test_a_field_row_of_empty_cells_is_named(tmp_path, header):
    """S2: a row ``,,`` between samples was dropped and every later row played 0.01 s early."""
    indexed = header.startswith(",")
    rows = [f"{k},{r}" if indexed else r for k, r in enumerate(_field_lines(40))]
    gap = ",,," if indexed else ",,"
    (tmp_path / "gap.csv").write_text("\n".join([header, *rows[:20], gap, *rows[20:]]) + "\n")
    with pytest.raises(FieldCSVError, match=r"gap.csv: line 22: a row of empty cells between rows of values"):
        read_field_csv(tmp_path / "gap.csv")
    assert msr(["field", "replay", str(tmp_path / "gap.csv"), "--physics", "training", "--out",
                str(tmp_path / "r"), "--no-progress"]) == 2
    assert not (tmp_path / "r").exists()


def test_empty_rows_around_the_values_are_still_skipped(tmp_path):
    """What a spreadsheet writes around a table (blank lines, rows of empty cells before the header
    and after the last sample) shifts nothing: read as before."""
    rows = _field_lines(30)
    (tmp_path / "f.csv").write_text("\n".join([",,", "mag_x,mag_y,mag_z", *rows, "", ",,", ",,"]) + "\n")
    field = read_field_csv(tmp_path / "f.csv")
    assert field.shape == (30, 3) and field[29, 0] == pytest.approx(2.9e-3)


def test_a_coil_current_row_of_empty_cells_is_named(tmp_path):
    rows = [f"{0.1 * k:.3f},{-0.1 * k:.3f}" for k in range(20)]
    (tmp_path / "c.csv").write_text("\n".join(["current_0_A,current_1_A", *rows[:5], ",", *rows[5:]]) + "\n")
    with pytest.raises(CoilCurrentsError, match=r"c.csv: line 7: a row of empty cells"):
        read_coil_currents(tmp_path / "c.csv")


def test_residual_variance_is_the_stated_noise_where_larger():
    from elastica_magnetic_rl.sim2real.identifiability import residual_variance

    residual = np.full(101, 1e-6)
    assert residual_variance(residual, 1) == (pytest.approx(101e-12 / 100), "residual")
    assert residual_variance(residual, 1, 5e-5) == (pytest.approx(2.5e-9), "noise")
    assert residual_variance(residual, 1, 1e-7) == (pytest.approx(101e-12 / 100), "residual")


def test_identify_measures_its_intervals_in_the_stated_noise(tmp_path, capsys):
    """S3: on a noise-free trajectory (a replay) the intervals came from the fit's own residual
    (1e-12 m): kinetic friction "identifiable within 1 %" where a value 16 % away fits 8 times below
    the 0.05 mm noise the user stated. Measured in that noise, it is not identifiable."""
    import json

    spec, fields = tmp_path / "m1.toml", tmp_path / "bl" / "fields.csv"
    assert msr(["case", "show", "m1-4mT", "--toml"]) == 0
    spec.write_text(capsys.readouterr().out)
    assert msr(["field", "baseline", "--case", "m1-4mT", "--period", "0.25", "--duration", "0.5",
                "--physics", "training", "--out", str(tmp_path / "bl"), "--no-figures", "--no-progress"]) == 0
    assert msr(["field", "replay", str(fields), "--robot", str(spec), "--physics", "training", "--out",
                str(tmp_path / "rp"), "--no-progress"]) == 0
    capsys.readouterr()
    assert msr(["real", "identify", str(fields), str(tmp_path / "rp" / "trajectory.csv"), "--robot",
                str(spec), "--fit", "robot.ground.kinetic_mu", "--max-evaluations", "12", "--starts", "1",
                "--no-confirm", "--no-progress", "--out", str(tmp_path / "id"), "--noise-m", "5e-5"]) == 0
    assert "intervals measured in the stated noise (0.05 mm)" in capsys.readouterr().out
    report = json.loads((tmp_path / "id" / "identify.json").read_text())
    assert report["identifiability"]["variance_from"] == "noise"
    assert report["identifiability"]["variance_m2"] == pytest.approx(2.5e-9)
    assert report["fitted"]["robot.ground.kinetic_mu"]["identifiable"] is False


@pytest.mark.parametrize("kind", ["tracker", "markers"])
def test_ends_swapped_are_named(tmp_path, kind):
    """V2: a tracker's s = 1 at the back (or trajectory.csv's back and front swapped) was fitted, and
    the residual blamed on a value missing from --fit."""
    t = 0.01 * np.arange(30)
    back, front = 0.05 * t, LENGTH + 0.05 * t
    if kind == "tracker":
        columns = {"x_1_m": back, "y_1_m": 0 * t, "x_0_m": front, "y_0_m": 0 * t}
        named = "s=1 lies 20 mm behind s=0"
    else:
        columns = {"back_x_m": front, "back_y_m": 0 * t, "front_x_m": back, "front_y_m": 0 * t}
        named = "front lies 20 mm behind back"
    _trajectory_csv(tmp_path / "t.csv", columns)
    with pytest.raises(TrajectoryError, match=f"the point {named} along x.*ends swapped"):
        check_against_robot(read_trajectory(tmp_path / "t.csv"), LENGTH, 1.0)
