"""A magnet arm's recorded path: read, replayed as the environment played it, and the magnet's moment
identified from a noisy tip path (``msr real identify`` on a magnet-arm case)."""

from __future__ import annotations

import copy
import json
import re

import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import case_from_dict, load_case
from elastica_magnetic_rl.sim2real.identify import load_spec
from elastica_magnetic_rl.sim2real.magnet_path import (
    MagnetDrive,
    MagnetPath,
    read_magnet_path,
    record_steering,
    simulate_tips,
    write_magnet_path,
)
from elastica_magnetic_rl.sim2real.tracking import TrajectoryError, read_trajectory
from spec_texts import quick_catheter

from elastica_magnetic.cli import main
from elastica_magnetic.field_csv import write_field_csv
from elastica_magnetic.specfile import SpecError

TARGET = (0.05, 0.008, -0.006)  # m, inside the shipped case's target box
TRUE_FACTOR = 1.07  # the "real" magnet, 7 % stronger than the spec says
NOISE_M = 5e-5  # the tracker's noise per coordinate: 0.05 mm


@pytest.fixture(scope="module")
def quick_spec() -> dict:
    return quick_catheter("catheter-magnet-reach", "catheter-quick")


@pytest.fixture(scope="module")
def steered(quick_spec):
    """The yardstick steering the quick catheter toward TARGET for 0.6 s: its path and tips."""
    return record_steering(case_from_dict(quick_spec), TARGET, physics="training", duration=0.6)


def test_a_replayed_path_is_the_environment_s_motion(steered, quick_spec):
    """The arm's poses (and the stage) replayed on the batched rod give the tips the environment
    gave while the yardstick steered, bit for bit up to rounding."""
    path, tips = steered
    assert path.insertion is not None and np.ptp(path.insertion) > 1e-4  # the stage moved
    assert np.ptp(path.positions, axis=0).max() > 1e-3  # and the magnet
    replayed = simulate_tips(quick_spec, "training", path)
    np.testing.assert_allclose(replayed, tips, rtol=0, atol=1e-12)
    stronger = copy.deepcopy(quick_spec)
    stronger["actuation"]["moment"] *= 1.05
    assert np.abs(simulate_tips(stronger, "training", path) - tips).max() > NOISE_M  # a 5 % change shows


def test_the_path_file_round_trips(steered, tmp_path):
    path, _ = steered
    back = read_magnet_path(write_magnet_path(tmp_path / "magnet.csv", path))
    np.testing.assert_allclose(back.positions, path.positions, rtol=1e-8)
    np.testing.assert_allclose(back.directions, path.directions, rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(back.insertion, path.insertion, rtol=1e-8, atol=1e-12)


def _write(path, header, rows):
    path.write_text(header + "\n" + "\n".join(",".join(str(v) for v in row) for row in rows) + "\n")
    return path


HEADER = "t_s,magnet_x_m,magnet_y_m,magnet_z_m,direction_x,direction_y,direction_z"


@pytest.mark.parametrize("rows, header, match", [
    ([(0, 0.09, 0, 0, 1, 0, 0), (0.01, 0.09, 0, 0, 1, 0, 0)], "t_s,magnet_x_m,magnet_y_m,direction_x",
     "no column magnet_z_m"),
    ([(0, 0.09, 0, 0, 1, 0, 0), (0.02, 0.09, 0, 0, 1, 0, 0)], HEADER, "line 3: t_s 0.02 s, expected 0.01 s"),
    ([(0, 90, 0, 0, 1, 0, 0), (0.01, 90, 0, 0, 1, 0, 0)], HEADER, "look like millimetres"),
    ([(0, 0.09, 0, 0, 1, 0, 0), (0.01, 0.09, 0, 0, 0, 0, 0)], HEADER, "line 3: direction"),
    ([(0, 0.09, 0, 0, 1, 0, 0), (0.01, "nan", 0, 0, 1, 0, 0)], HEADER, "line 3, column magnet_x_m"),
    ([(0, 0.09, 0, 0, 1, 0, 0)], HEADER, "two or more"),
])
def test_a_bad_path_is_named(tmp_path, rows, header, match):
    with pytest.raises(TrajectoryError, match=match):
        read_magnet_path(_write(tmp_path / "magnet.csv", header, rows))


def test_a_path_that_does_not_fit_the_case_is_named(tmp_path, quick_spec):
    rows = [(0.01 * k, 0.09, 0, 0, 1, 0, 0) for k in range(5)]
    no_stage = MagnetDrive(read_magnet_path(_write(tmp_path / "a.csv", HEADER, rows)))
    with pytest.raises(TrajectoryError, match="no insertion_m column"):
        no_stage.check_spec(quick_spec)
    staged = [(*row, 0.02 * k) for k, row in enumerate(rows)]
    beyond = MagnetDrive(read_magnet_path(_write(tmp_path / "b.csv", HEADER + ",insertion_m", staged)))
    with pytest.raises(TrajectoryError, match=r"line 3: insertion_m 0.02 m is beyond the stage's travel"):
        beyond.check_spec(quick_spec)
    late = [(*row, 0.001) for row in rows]
    moved = MagnetDrive(read_magnet_path(_write(tmp_path / "c.csv", HEADER + ",insertion_m", late)))
    with pytest.raises(TrajectoryError, match="the rod starts where it is built"):
        moved.check_spec(quick_spec)
    without = copy.deepcopy(quick_spec)
    del without["actuation"]["insertion"], without["actuation"]["insertion_speed"]
    with pytest.raises(TrajectoryError, match="the case has no insertion stage"):
        beyond.check_spec(without)
    with pytest.raises(SpecError, match="a magnet path drives a case steered by a magnet on an arm"):
        load_spec("m1-4mT", steered_by="magnet-pose")
    with pytest.raises(SpecError, match="a magnet arm's recorded path"):
        load_spec("catheter-magnet-reach")


def _measured_files(tmp_path, steered, quick_spec):
    """The magnet path, and the tip path of a magnet TRUE_FACTOR x the spec's with NOISE_M noise
    (at 50 frames per second), as a lab would record them."""
    path, _ = steered
    truth = copy.deepcopy(quick_spec)
    truth["actuation"]["moment"] *= TRUE_FACTOR
    tips = simulate_tips(truth, "training", path)[::2]
    noisy = tips + np.random.default_rng(7).normal(0.0, NOISE_M, tips.shape)
    lines = ["t_s,tip_x_m,tip_y_m,tip_z_m"] + [f"{t:.2f},{x:.9g},{y:.9g},{z:.9g}"
                                               for t, (x, y, z) in zip(path.times[::2], noisy, strict=True)]
    (tmp_path / "tip.csv").write_text("\n".join(lines) + "\n")
    spec_file = tmp_path / "catheter.toml"
    spec_file.write_text(case_from_dict(quick_spec).toml(with_name=True))
    return write_magnet_path(tmp_path / "magnet.csv", path), tmp_path / "tip.csv", spec_file


@pytest.mark.slow
def test_identify_recovers_the_magnet_s_moment(tmp_path, steered, quick_spec, capsys):
    """From a 0.05 mm-noisy tip path of a magnet 7 % stronger than the spec's, ``msr real identify``
    recovers the moment within 3 %, its interval holding the truth."""
    magnet, tip, spec_file = _measured_files(tmp_path, steered, quick_spec)
    assert read_trajectory(tip).positions.shape[1:] == (1, 3)
    assert main(["real", "identify", str(magnet), str(tip), "--robot", str(spec_file), "--fit", "magnet",
                 "--out", str(tmp_path / "id"), "--starts", "1", "--max-evaluations", "40",
                 "--noise-m", str(NOISE_M), "--no-confirm", "--no-progress", "--json"]) == 0
    report = json.loads((tmp_path / "id" / "identify.json").read_text())
    fitted = report["fitted"]["magnet"]
    assert fitted["keys"] == ["actuation.moment"]
    assert abs(fitted["factor"] / TRUE_FACTOR - 1.0) < 0.03, fitted["factor"]
    assert fitted["identifiable"] and fitted["interval"][0] <= TRUE_FACTOR <= fitted["interval"][1]
    assert report["residual_vs_noise"] < 1.5
    assert report["magnet_path"] == str(magnet)
    assert "moment = " in (tmp_path / "id" / "identified.toml").read_text()
    capsys.readouterr()


def test_identify_pairs_the_files_by_kind(tmp_path, steered, quick_spec, capsys):
    magnet, tip, spec_file = _measured_files(tmp_path, steered, quick_spec)
    fields = tmp_path / "fields.csv"
    write_field_csv(fields, np.tile([1e-3, 0.0, 0.0], (20, 1)))
    crawl = tmp_path / "trajectory.csv"
    crawl.write_text("t_s,x_0.5_m,y_0.5_m\n" + "".join(f"{0.01 * k:.2f},{0.001 * k},0\n" for k in range(20)))
    base = ["real", "identify", "--robot", str(spec_file), "--fit", "magnet", "--no-progress"]
    assert main([*base, str(magnet), str(crawl), "--out", str(tmp_path / "a")]) == 2
    assert "give the tip's path" in capsys.readouterr().err
    assert main([*base, str(fields), str(tip), "--out", str(tmp_path / "b")]) == 2
    assert "goes with the magnet arm's recorded path" in capsys.readouterr().err
    assert main([*base[:3], "m1-4mT", *base[4:], str(magnet), str(tip), "--out", str(tmp_path / "c")]) == 2
    assert "a magnet path drives a case steered by a magnet on an arm" in capsys.readouterr().err
    assert not any((tmp_path / name).exists() for name in "abc")


def test_a_path_of_its_own_form(tmp_path):
    """A path written by hand (no stage in the case, a turning magnet) replays on a spec without
    an insertion stage."""
    spec = copy.deepcopy(load_case("catheter-magnet-reach").to_dict())
    del spec["actuation"]["insertion"], spec["actuation"]["insertion_speed"]
    spec["robot"]["n_elements"] = 6
    spec["physics"]["training"]["dt"] = 4e-5
    times = np.arange(21) * 0.01
    angle = np.linspace(0.0, 0.6, times.size)
    path = MagnetPath("hand", times, np.tile([0.09, 0.0, 0.0], (times.size, 1)),
                      np.stack([np.cos(angle), np.sin(angle), np.zeros_like(angle)], axis=1))
    MagnetDrive(path).check_spec(spec)
    tips = simulate_tips(spec, "training", path)
    # the field on the dipole's axis behind it, (2 cos a, -sin a, 0): the tip bends toward -y
    assert tips[-1, 1] < tips[0, 1] - 1e-4 and abs(tips[-1, 2]) < 1e-9


def test_sigterm_stops_identify_as_ctrl_c_does(tmp_path, steered, quick_spec):
    """Round 17 V: `msr real identify` killed by SIGTERM died by the default action: no line, and
    its output folder's lock left beside it."""
    import os
    import signal
    import subprocess
    import sys
    import time

    magnet, tip, spec_file = _measured_files(tmp_path, steered, quick_spec)
    out = tmp_path / "id"
    proc = subprocess.Popen([sys.executable, "-m", "elastica_magnetic.cli", "real", "identify", str(magnet),
                             str(tip), "--robot", str(spec_file), "--fit", "magnet", "--out", str(out),
                             "--no-progress"], stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "MPLBACKEND": "Agg"})
    deadline = time.time() + 300  # into the fit: its output's lock is taken (slow on a loaded machine)
    while not list(tmp_path.glob(".id.msr-*")) and proc.poll() is None and time.time() < deadline:
        time.sleep(0.1)
    time.sleep(1.0)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, err
    assert "interrupted (SIGTERM)" in err, err
    assert not out.exists() and not list(tmp_path.glob(".id.msr-*")), list(tmp_path.iterdir())


def _scaled_copy(src, dst, columns, factor):
    """``src`` CSV with ``columns`` multiplied by ``factor`` (a unit mistake), written to ``dst``."""
    import pandas as pd

    table = pd.read_csv(src)
    for column in columns:
        table[column] *= factor
    table.to_csv(dst, index=False)
    return dst


@pytest.mark.parametrize(("which", "match"), [
    ("tip", r"tip_cm.csv: line 2: the tip starts at .* from the straight 50 mm catheter's tip"),
    ("magnet", r"magnet.csv: line 2: the magnet is 9 m from the rod's base, beyond any arm"),
    ("through", r"magnet.csv: line 2: the magnet starts 0 mm from the straight rod, nearer than the arm's "
                r"min_clearance"),
])
def test_paths_in_another_unit_or_through_the_rod_are_refused_before_the_fit(
        tmp_path, steered, quick_spec, capsys, which, match):
    """Round 18 S18, S20, V21: a tip path in cm (the tip 5 m from the base), a magnet path in cm
    (the magnet 9 m away: a field of nothing) were fitted and written as identified; a magnet path
    through the catheter failed in the simulation with a message naming neither file nor line."""
    magnet, tip, spec_file = _measured_files(tmp_path, steered, quick_spec)
    if which == "tip":
        tip = _scaled_copy(tip, tmp_path / "tip_cm.csv", ["tip_x_m", "tip_y_m", "tip_z_m"], 100.0)
    elif which == "magnet":
        _scaled_copy(magnet, magnet, ["magnet_x_m", "magnet_y_m", "magnet_z_m"], 100.0)
    else:
        _scaled_copy(magnet, magnet, ["magnet_x_m", "magnet_y_m", "magnet_z_m"], 0.0)  # at the base
    capsys.readouterr()
    assert main(["real", "identify", str(magnet), str(tip), "--robot", str(spec_file), "--fit", "magnet",
                 "--out", str(tmp_path / "id"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert re.search(match, err), err
    assert not (tmp_path / "id").exists()


def test_a_magnet_path_that_runs_into_the_rod_names_its_line(quick_spec):
    """Round 18 V21: the magnet reaching the rod mid-path named neither the file nor the line."""
    from elastica_magnetic_rl.sim2real.magnet_path import MagnetPath

    times = np.arange(4) * 0.01
    positions = np.array([[0.09, 0.0, 0.0], [0.07, 0.0, 0.0], [0.04, 0.0, 0.0], [1.0 / 3 * 0.05, 0.0, 0.0]])
    path = MagnetPath("arm.csv", times, positions, np.tile([1.0, 0.0, 0.0], (4, 1)), None)
    with pytest.raises(TrajectoryError, match=r"arm.csv: line 4 \(t_s 0.02 s\): the magnet is [\d.]+ mm from "
                                              r"the rod, nearer than the arm's min_clearance \(10 mm\)"):
        simulate_tips(quick_spec, "training", path)


@pytest.mark.parametrize("which", ["magnet", "tip"])
def test_a_path_with_a_column_twice_is_refused(tmp_path, steered, quick_spec, capsys, which):
    """Round 18 S148, S149: a magnet or tip path naming a column twice was fitted with one copy
    dropped in silence."""
    magnet, tip, spec_file = _measured_files(tmp_path, steered, quick_spec)
    path, column = (magnet, "magnet_x_m") if which == "magnet" else (tip, "tip_x_m")
    lines = path.read_text().splitlines()
    path.write_text("\n".join([lines[0] + f",{column}"] + [line + ",0.5" for line in lines[1:]]) + "\n")
    capsys.readouterr()
    assert main(["real", "identify", str(magnet), str(tip), "--robot", str(spec_file), "--fit", "magnet",
                 "--out", str(tmp_path / "id"), "--no-progress"]) == 2
    assert f"names {column} twice" in capsys.readouterr().err


def test_a_magnet_path_the_arm_cannot_have_followed_is_named(tmp_path, quick_spec):
    """Round 19 S11: a path jumping 60 mm in one 0.01 s row (6 m/s), one faster than the arm's
    max_speed (0.1 m/s) and one leaving its workspace were fitted without a word."""
    def drive(name, positions):
        rows = [(0.01 * k, *p, 1, 0, 0, 0.0) for k, p in enumerate(positions)]
        return MagnetDrive(read_magnet_path(_write(tmp_path / name, HEADER + ",insertion_m", rows)))

    jump = drive("jump.csv", [(0.09, 0, 0)] * 3 + [(0.15, 0, 0)] * 2)
    with pytest.raises(TrajectoryError, match=r"jump.csv: line 5: the magnet moves 60 mm in 10 ms \(6 m/s\), "
                                              r"faster than any arm \(5 m/s\)"):
        jump.check_spec(quick_spec)
    fast = drive("fast.csv", [(0.09 + 0.002 * k, 0, 0) for k in range(5)])  # 0.2 m/s
    with pytest.warns(UserWarning, match=r"fast.csv: line 3: the magnet moves at 0.2 m/s, faster than the "
                                         r"arm's max_speed \(0.1 m/s\)"):
        fast.check_spec(quick_spec)
    away = drive("away.csv", [(0.09, 0.099 + 0.0008 * k, 0) for k in range(5)])  # y past 0.1 m + 1 mm
    with pytest.warns(UserWarning, match=r"away.csv: line 5: the magnet at .* is outside the arm's "
                                         r"workspace"):
        away.check_spec(quick_spec)
