"""Round 38 of held-out tries (issue 48): what they found, each fixed with the message it gives."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from elastica_magnetic.cli import main as msr

REPO = Path(__file__).resolve().parents[3]
TINY = ["--seeds", "1", "--steps", "80", "--episode-duration", "0.5", "--set", "learning_starts=60",
        "--set", "batch_size=32", "--set", "hidden_sizes=32,32", "--no-progress"]


@pytest.mark.parametrize("setting", ["eval_duration=0.3", "eval_episodes=4"])
def test_an_evaluation_setting_without_evaluations_is_refused(tmp_path, capsys, setting):
    """S1: ``--set eval_duration=0.3`` (or ``eval_episodes``) with ``eval_every=0`` was recorded, and
    summary.json reported an evaluation length where none ran."""
    out = tmp_path / "tr"
    assert msr(["train", "--case", "m1-4mT", *TINY, "--set", "eval_every=0", "--set", setting,
                "--out", str(out)]) == 2
    key = setting.split("=")[0]
    assert (f"--set {setting} sets the periodic evaluations, and --set eval_every=0 makes none" in
            capsys.readouterr().err)
    assert not out.exists(), key


def test_evaluations_a_spec_sets_are_refused_only_where_the_spec_turns_them_off():
    """A case whose ``[training.td3]`` evaluates several episodes (the shipped goto cases:
    ``eval_episodes = 4``) trained with ``--set eval_every=0``: the option turns its evaluations off,
    and was refused for the spec's own ``eval_episodes``; a spec that sets both is refused."""
    from elastica_magnetic_rl.sweep.inert_settings import SettingSources, check_evaluations_made
    from elastica_magnetic_rl.td3.config import TD3Config

    config = TD3Config(eval_every=0, eval_episodes=4)
    check_evaluations_made(config, SettingSources(given={"eval_every": 0}, spec_td3={"eval_episodes": 4},
                                                  source="goto.toml"))
    with pytest.raises(ValueError, match=r"\[training.td3\] eval_episodes = 4 \(goto.toml\) sets the "
                                         r"periodic evaluations, and \[training.td3\] eval_every = 0"):
        check_evaluations_made(config, SettingSources(spec_td3={"eval_episodes": 4, "eval_every": 0},
                                                      source="goto.toml"))


def test_a_run_without_evaluations_reports_no_evaluation_length(tmp_path, capsys):
    out = tmp_path / "tr"
    assert msr(["train", "--case", "m1-4mT", *TINY, "--set", "eval_every=0", "--out", str(out)]) == 0
    summary = json.loads((out / "m1-4mT" / "summary.json").read_text())
    assert summary["evaluation_duration_s"] is None
    assert [s["evaluation_duration_s"] for s in summary["seeds"]] == [None]


def test_calibrate_with_a_folder_for_out_is_told_so(tmp_path, capsys):
    """V1: ``msr real calibrate cal/m.csv --out cal --force``: "cal replaces whole, the input would be
    deleted", and its advice (copy the input elsewhere) refused next: "--out cal: is a folder". It
    replaces one file: a folder is said first."""
    cal = tmp_path / "cal"
    cal.mkdir()
    measurements = cal / "m.csv"
    measurements.write_text("current_x_A,current_y_A,current_z_A,field_x_mT,field_y_mT,field_z_mT\n"
                            + "".join(f"{i},{j},{k},{2 * i},{3 * j},{4 * k}\n"
                                      for i, j, k in [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (0, 1, 1),
                                                      (1, 0, 1)]))
    assert msr(["real", "calibrate", str(measurements), "--out", str(cal), "--force"]) == 2
    err = capsys.readouterr().err
    assert f"--out {cal}: is a folder, expected a file name" in err and "lies in" not in err, err
    # the file itself as --out is still refused as the input it is
    shutil.copy(REPO / "stm32" / "calibration" / "default.json", cal / "c.json")
    assert msr(["real", "calibrate", str(measurements), "--base", str(cal / "c.json"), "--out",
                str(cal / "c.json"), "--force"]) == 2
    assert f"--base {cal / 'c.json'}: lies in --out {cal / 'c.json'}" in capsys.readouterr().err


def _write(path, columns: dict) -> None:
    import numpy as np

    t = 0.01 * np.arange(30)
    table = {"t_s": t, **{k: v(t) for k, v in columns.items()}}
    path.write_text("\n".join([",".join(table)] + [",".join(f"{table[c][k]:.6g}" for c in table)
                                                   for k in range(len(t))]) + "\n")


@pytest.mark.parametrize("extra", [("head_x_m", "head_y_m"), ("x_mid_m", "y_mid_m"),
                                   ("center_x_m", "center_y_m"), ("x_nan_m", "y_nan_m"),
                                   ("x_inf_m", "y_inf_m")])
def test_a_point_the_fit_cannot_read_is_named(tmp_path, extra):
    """S2: ``head_x_m``, ``x_mid_m``, ``center_x_m``, ``x_nan_m`` beside the points the fit reads were
    dropped without a word (the fit ran on the others)."""
    from elastica_magnetic_rl.sim2real.tracking import TrajectoryError, read_trajectory

    columns = {"x_0_m": lambda t: 0.05 * t, "y_0_m": lambda t: 0 * t, "x_1_m": lambda t: 0.02 + 0.05 * t,
               "y_1_m": lambda t: 0 * t, extra[0]: lambda t: 0.01 + 0.05 * t, extra[1]: lambda t: 0 * t}
    _write(tmp_path / "t.csv", columns)
    named = f"column\\(s\\) {extra[0]}, {extra[1]} look like a tracked point's but are not one the fit reads"
    with pytest.raises(TrajectoryError, match=named):
        read_trajectory(tmp_path / "t.csv")


def test_other_unused_columns_are_said_and_msr_s_own_extras_are_not(tmp_path):
    from elastica_magnetic_rl.sim2real.tracking import read_trajectory

    from elastica_magnetic.plausibility import ImplausibleValueWarning

    columns = {"x_0_m": lambda t: 0.05 * t, "y_0_m": lambda t: 0 * t, "x_1_m": lambda t: 0.02 + 0.05 * t,
               "y_1_m": lambda t: 0 * t, "frame": lambda t: 100 * t, "likelihood": lambda t: 0 * t + 0.9,
               "height_max_m": lambda t: 0 * t, "span_m": lambda t: 0 * t + 0.02}
    _write(tmp_path / "t.csv", columns)
    with pytest.warns(ImplausibleValueWarning, match=r"column\(s\) frame, likelihood are not used") as seen:
        assert read_trajectory(tmp_path / "t.csv").points == ("s=0", "s=1")
    assert not any("height_max_m" in str(w.message) for w in seen)


FIELD_CSV = REPO / "elastica_magnetic" / "data" / "yao2023" / "magnetization1_4mT" / "magnetic_field.csv"
CALIBRATION = REPO / "stm32" / "calibration" / "default.json"


def test_firmware_lists_an_unread_column_among_its_warnings(tmp_path, capsys):
    """V2: ``msr real firmware`` warned "column(s) '', 'note' are not read" and then printed
    "warnings: none" (``--json``: ``[]``); the pandas index column '' was called unread though it is
    checked as the row index."""
    lines = FIELD_CSV.read_text().splitlines()[:51]
    assert lines[0] == ",mag_x,mag_y,mag_z"  # the index column pandas writes
    rows = [f"{lines[0]},note"] + [f"{line},x" for line in lines[1:]]
    (tmp_path / "extra.csv").write_text("\n".join(rows) + "\n")
    assert msr(["real", "firmware", str(tmp_path / "extra.csv"), "--calibration", str(CALIBRATION),
                "--out", str(tmp_path / "fw"), "--json"]) == 0
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    assert len(summary["warnings"]) == 1 and "column(s) 'note' are not read" in summary["warnings"][0]
    assert captured.err.count("are not read") == 1


def test_an_unnamed_index_column_beside_other_columns_is_checked(tmp_path):
    from elastica_magnetic.field_csv import FieldCSVError, read_field_csv

    (tmp_path / "f.csv").write_text(",mag_x,mag_y,mag_z,note\n0,1,0,0,a\n2,1,0,0,b\n")
    with pytest.raises(FieldCSVError, match="line 3: index '2' out of sequence, expected 1"):
        read_field_csv(tmp_path / "f.csv")
