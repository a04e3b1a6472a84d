"""Measured trajectories: both formats are read, bad ones get a named error before any fitting,
and the simulated points are where the formats say."""

import re

import numpy as np
import pandas as pd
import pytest
from elastica_magnetic_rl.sim2real.tracking import (
    TrajectoryError,
    check_against_robot,
    points_at_rows,
    read_trajectory,
)

from elastica_magnetic.fields import RotatingField
from elastica_magnetic.openloop import run_open_loop, write_trajectory_csv
from elastica_magnetic.presets import robot_by_name

LENGTH = 0.02


def _tracker(tmp_path, rows, header="t_s,x_0_m,y_0_m,x_1_m,y_1_m", name="track.csv"):
    path = tmp_path / name
    path.write_text(header + "\n" + "\n".join(",".join(str(v) for v in row) for row in rows) + "\n")
    return path


def _moving(n=10, dt=1 / 30, speed=0.01):
    return [[k * dt, speed * k * dt, 0.0, 0.02 + speed * k * dt, 0.001] for k in range(n)]


@pytest.fixture(scope="module")
def run():
    robot = robot_by_name("yao2023-m1", "training")
    return run_open_loop(robot, RotatingField(10e-3, -2.0, phase=0.5 * np.pi, ramp_time=0.05), 0.2,
                         n_shapes=21)


def test_reads_msr_trajectory_csv_and_its_points_are_the_markers(tmp_path, run):
    path = write_trajectory_csv(run.trajectory, tmp_path / "trajectory.csv")
    measured = read_trajectory(path)
    assert measured.kind == "trajectory.csv" and measured.points == ("back", "mid", "front")
    assert measured.fractions is None and measured.times.shape == (21,)
    simulated = points_at_rows(measured, run.trajectory, run.shapes)
    np.testing.assert_allclose(simulated, measured.positions, atol=1e-9)  # 9 digits in the file


def test_reads_a_tracker_csv_and_interpolates_along_the_body(tmp_path, run):
    path = _tracker(tmp_path, _moving(), "t_s,x_0.5_m,y_0.5_m,x_0_m,y_0_m,x_1_m,y_1_m,x_0.25_m,y_0.25_m")
    path.write_text("t_s,x_0.5_m,y_0.5_m,x_0_m,y_0_m,x_1_m,y_1_m,x_0.25_m,y_0.25_m\n"
                    + "\n".join(f"{r[0]},{r[1] + 0.01},0,{r[1]},0,{r[3]},0,{r[1] + 0.005},0"
                                for r in _moving()) + "\n")
    measured = read_trajectory(path)
    assert measured.kind == "tracker" and measured.fractions == (0.0, 0.25, 0.5, 1.0)
    assert measured.positions.shape == (10, 4, 2)
    np.testing.assert_allclose(measured.positions[:, 2, 0] - measured.positions[:, 0, 0], 0.01)
    simulated = points_at_rows(measured, run.trajectory, run.shapes)
    nodes = np.stack([pos[:2] for _, pos in run.shapes])  # (rows, 2, 65)
    np.testing.assert_array_equal(simulated[:, 0], nodes[:, :, 0])
    np.testing.assert_array_equal(simulated[:, 3], nodes[:, :, 64])
    np.testing.assert_allclose(simulated[:, 1], nodes[:, :, 16])
    np.testing.assert_allclose(simulated[:, 2], nodes[:, :, 32])


@pytest.mark.parametrize("rows, header, message", [
    (_moving(), "time,x_0_m,y_0_m,x_1_m,y_1_m", "no t_s column"),
    (_moving(), "t_s,a,b,c,d", "no tracked points"),
    (_moving(), "t_s,x_0_m,y_0_m,x_1_m,q", "needs both x_1_m and y_1_m"),
    (_moving(), "t_s,x_0_m,y_0_m,x_2_m,y_2_m", "s = 2: s is a fraction of the body length"),
    (_moving(4), None, "4 frame(s); too short"),
    (_moving(10, dt=0.005), None, "too short to fit, need at least 0.1 s"),
    ([[0.0, 12, 0, 32, 0]] + _moving()[1:], None, "look like millimetres"),
])
def test_bad_files_are_named(tmp_path, rows, header, message):
    path = _tracker(tmp_path, rows, header or "t_s,x_0_m,y_0_m,x_1_m,y_1_m")
    with pytest.raises(TrajectoryError) as info:
        read_trajectory(path)
    assert message in str(info.value) and str(path) in str(info.value)


def test_nan_and_time_order_name_the_line(tmp_path):
    rows = _moving()
    rows[3][2] = "nan"
    with pytest.raises(TrajectoryError, match=r"line 5, column y_0_m: 'nan' is not a finite number"):
        read_trajectory(_tracker(tmp_path, rows))
    rows = _moving()
    rows[6][0] = rows[5][0]
    with pytest.raises(TrajectoryError, match=r"line 8: t_s .* does not increase"):
        read_trajectory(_tracker(tmp_path, rows))
    with pytest.raises(TrajectoryError, match="no such trajectory file"):
        read_trajectory(tmp_path / "missing.csv")
    (tmp_path / "empty.csv").write_text("")
    with pytest.raises(TrajectoryError, match="empty file"):
        read_trajectory(tmp_path / "empty.csv")


def test_checks_against_the_robot_and_the_waveform(tmp_path):
    good = read_trajectory(_tracker(tmp_path, _moving()))
    check_against_robot(good, LENGTH, 1.0)
    with pytest.raises(TrajectoryError, match=r"past the end of the waveform \(0.2 s\)"):
        check_against_robot(good, LENGTH, 0.2)
    still = [[r[0], 1e-6 * r[0], 0, 0.02, 0] for r in _moving()]
    with pytest.raises(TrajectoryError, match="no motion to fit"):
        check_against_robot(read_trajectory(_tracker(tmp_path, still, name="still.csv")), LENGTH, 1.0)
    # millimetres of a robot near the origin: under 10 (m), but the points are 20 "m" apart
    mm = [[r[0], 1e3 * r[1], 0, 1e3 * r[3] / 4, 0] for r in _moving()]
    with pytest.raises(TrajectoryError, match="look like millimetres"):
        check_against_robot(read_trajectory(_tracker(tmp_path, mm, name="mm.csv")), LENGTH, 1.0)
    # one point moving 8 "m" in 0.3 s (millimetres of a point near the origin): 400 body lengths
    path = tmp_path / "one.csv"
    times = [r[0] for r in _moving()]
    pd.DataFrame({"t_s": times, "x_0.5_m": [8.0 * t / times[-1] for t in times],
                  "y_0.5_m": 0.0}).to_csv(path, index=False)
    with pytest.raises(TrajectoryError, match="body lengths: the values look like millimetres or"):
        check_against_robot(read_trajectory(path), LENGTH, 1.0)


def test_centimetres_and_milliseconds_are_named_as_such(tmp_path):
    """Round 4, V7: positions in centimetres were called millimetres, a t_s column in
    milliseconds was "past the end of the waveform"."""
    cm = [[r[0], 100 * r[1], 0, 100 * r[3], 100 * r[4]] for r in _moving()]
    with pytest.raises(TrajectoryError, match=r"\(100 x its length\): the values look like "
                                              r"centimetres; give metres \(divide by 100\)"):
        check_against_robot(read_trajectory(_tracker(tmp_path, cm, name="cm.csv")), LENGTH, 1.0)
    ms = [[1000 * r[0], *r[1:]] for r in _moving()]
    with pytest.raises(TrajectoryError, match=r"the times look like milliseconds; give seconds"):
        check_against_robot(read_trajectory(_tracker(tmp_path, ms, name="ms.csv")), LENGTH, 1.0)
    near = [[1.5 * r[0], *r[1:]] for r in _moving()]  # a little too long: cut, not a unit
    with pytest.raises(TrajectoryError, match=r"past the end of the waveform \(0.3 s\)"):
        check_against_robot(read_trajectory(_tracker(tmp_path, near, name="near.csv")), LENGTH, 0.3)


def test_micrometres_and_frame_numbers_are_named(tmp_path):
    """Round 5, I07/I08: micrometres were called millimetres (dividing by 1000 was refused
    again); frame numbers in t_s were only "past the end of the waveform"."""
    um = [[r[0], 1e6 * r[1], 0, 1e6 * r[3], 1e6 * r[4]] for r in _moving()]
    with pytest.raises(TrajectoryError, match="look like micrometres: give metres"):
        read_trajectory(_tracker(tmp_path, um, name="um.csv"))
    frames = [[float(k), *r[1:]] for k, r in enumerate(_moving())]
    with pytest.raises(TrajectoryError, match="t_s holds whole numbers 0, 1, 2...: frame numbers"):
        check_against_robot(read_trajectory(_tracker(tmp_path, frames, name="f.csv")), LENGTH, 1.0)


def test_a_trajectory_naming_a_column_twice_is_refused(tmp_path):
    """Round 18 S151: a crawler trajectory with ``front_x_m`` twice was fitted, one copy dropped."""
    rows = [[0.0, 0.0, 0.0, 5.0], [0.1, 0.001, 0.0, 5.0], [0.2, 0.002, 0.0, 5.0]]
    path = _tracker(tmp_path, rows, header="t_s,front_x_m,front_y_m,front_x_m")
    with pytest.raises(TrajectoryError, match=r"its header names front_x_m twice \(columns 2 and 4\)"):
        read_trajectory(path)


@pytest.mark.parametrize("offset", [5.0, 1764892800.0])
def test_a_tracker_clock_that_does_not_start_with_the_waveform_is_named(tmp_path, offset):
    """Round 34, V2: frames from t_s = 5 s (or Unix time) were told to "cut the trajectory to the
    waveform" (leaving no frame) or to "divide t_s by 1000" (refused again); now the clock is named
    with the shift that mends it."""
    late = [[offset + r[0], *r[1:]] for r in _moving()]
    first = re.escape(f"{offset:g}")
    with pytest.raises(TrajectoryError, match=rf"its frames run from t_s = {first} s .* subtract the "
                                              r"tracker's time of the waveform's start from t_s"):
        check_against_robot(read_trajectory(_tracker(tmp_path, late, name="late.csv")), LENGTH, 1.0)


@pytest.mark.parametrize("columns", ["x_1_mm,y_1_mm", "X_1_m,Y_1_m", "x_-0.5_m,y_-0.5_m"])
def test_a_tracked_point_spelled_otherwise_is_named_not_dropped(tmp_path, columns):
    """Round 35, S1: ``x_1_mm``, ``X_1_m`` or ``x_-0.5_m`` beside well-named points were dropped
    without a word (the fit ran on the other points). Now named, with the spelling expected."""
    path = tmp_path / "tk.csv"
    rows = "".join(f"{k / 30:.4f},{1e-4 * k},0,{0.02 + 1e-4 * k},0\n" for k in range(12))
    path.write_text(f"t_s,x_0_m,y_0_m,{columns}\n" + rows)
    named = re.escape(columns.replace(",", ", "))
    with pytest.raises(TrajectoryError, match=rf"column\(s\) {named} look like "
                                              r"a tracked point's but are not x_<s>_m / y_<s>_m"):
        read_trajectory(path)


def test_a_tracked_point_s_sideways_column_is_said_unused(tmp_path):
    """Round 35: ``z_0_m`` of a tracked point had been dropped without a word (``mid_z_m`` of
    msr's trajectory.csv was said unused); now both are."""
    path = tmp_path / "tk.csv"
    path.write_text("t_s,x_0_m,y_0_m,z_0_m,x_1_m,y_1_m\n" + "".join(
        f"{k / 30:.4f},{1e-4 * k},0,0,{0.02 + 1e-4 * k},0\n" for k in range(12)))
    with pytest.warns(Warning, match=r"columns z_0_m are not used"):
        read_trajectory(path)
