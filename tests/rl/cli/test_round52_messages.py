"""Round 52 of held-out tries (issue 48): robustness of a run plays the actor generate plays (S1);
a field CSV's number with an exponent past the decimal module's range (T1); borderline cases."""

from __future__ import annotations

import json

import numpy as np
import pytest

from elastica_magnetic import read_field_csv
from elastica_magnetic.cli import main
from elastica_magnetic.field_csv import FieldCSVError


def run(argv: list[str]) -> int:
    """``msr argv``'s exit status (a parser's refusal exits through SystemExit)."""
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code)


def test_robustness_of_a_run_scores_the_actor_generate_plays_and_names_it(trained, tmp_path, capsys):
    """S1: ``msr real robustness RUN`` played the final actor while ``msr policy generate RUN``
    played the farther one (``best.pt``), and nothing said which."""
    seed = trained / "m1-4mT" / "seed0"
    common = ["--duration", "0.2", "--no-progress"]
    assert run(["policy", "generate", str(seed), "--out", str(tmp_path / "g"), "--no-figures", *common]) == 0
    generated = json.loads((tmp_path / "g" / "generate.json").read_text())
    assert run(["real", "robustness", str(seed), "--vary", "density=0.9:1.1", "--no-corners",
                "--open-loop-only", "--out", str(tmp_path / "r"), *common]) == 0
    capsys.readouterr()
    played = (tmp_path / "r" / "fields.csv").read_bytes()
    assert played == (tmp_path / "g" / "fields.csv").read_bytes()
    report = json.loads((tmp_path / "r" / "robustness.json").read_text())
    actor = report["design"]["actor"]
    assert actor["actor"] == generated["actor_choice"]["actor"], (actor, generated["actor_choice"])
    assert ("best.pt" if actor["actor"] == "best" else "final actor") in report["waveform"]
    for which in ("final", "best"):  # asked: as generate --checkpoint plays it
        assert run(["real", "robustness", str(seed), "--checkpoint", which, "--vary", "density=0.9:1.1",
                    "--no-corners", "--open-loop-only", "--out", str(tmp_path / f"r{which}"), *common]) == 0
        assert run(["policy", "generate", str(seed), "--checkpoint", which, "--out",
                    str(tmp_path / f"g{which}"), "--no-figures", *common]) == 0
        assert ((tmp_path / f"r{which}" / "fields.csv").read_bytes()
                == (tmp_path / f"g{which}" / "fields.csv").read_bytes())
    assert run(["real", "robustness", "m1-4mT", "--checkpoint", "best", "--out", str(tmp_path / "x")]) == 2
    assert "is not a training run" in capsys.readouterr().err


def test_a_number_with_an_exponent_past_any_range_is_read_or_refused_by_name(tmp_path):
    """T1: ``1e-999999999999999999999`` (0.0 to float) passed the finite check, then the decimal
    reader raised InvalidOperation: a traceback in every command that reads a field CSV."""
    tiny = tmp_path / "tiny.csv"
    tiny.write_text("mag_x,mag_y,mag_z\n" + "4,1,1e-999999999999999999999\n" * 3)
    assert np.array_equal(read_field_csv(tiny), np.array([[4e-3, 1e-3, 0.0]] * 3))
    zero = tmp_path / "zero.csv"
    zero.write_text("mag_x,mag_y,mag_z\n" + "4,1,0e9999999999999999999\n" * 3)
    assert np.array_equal(read_field_csv(zero), np.array([[4e-3, 1e-3, 0.0]] * 3))
    huge = tmp_path / "huge.csv"
    huge.write_text("mag_x,mag_y,mag_z\n" + "4,1,1e999999999999999999999\n" * 3)
    with pytest.raises(FieldCSVError, match="huge.csv: line 2, column mag_z: non-finite value"):
        read_field_csv(huge)


def test_a_number_with_an_underscore_is_not_read_as_python_reads_it(tmp_path):
    """Borderline of round 52: ``1_0`` was read as 10 mT (Python's float accepts the separator)."""
    path = tmp_path / "u.csv"
    path.write_text("mag_x,mag_y,mag_z\n4,1_0,0\n")
    with pytest.raises(FieldCSVError, match=r"line 2, column mag_y: '1_0' is not a number \(field in mT\)"):
        read_field_csv(path)


def test_a_folder_a_design_writes_is_not_told_to_wait_for_a_checkpoint(tmp_path, monkeypatch):
    """V2: ``msr policy export D6`` while ``msr design`` wrote D6 said to wait for the run's first
    checkpoint, which a design never writes."""
    from elastica_magnetic_rl.runfiles.rundir import being_written_hint

    import elastica_magnetic.locks as locks

    owner = {"pid": 1, "host": "elsewhere", "command": "msr design small.toml --out D6 --quick",
             "started_utc": "2026-12-05T17:00:00Z"}
    monkeypatch.setattr(locks, "live_owner", lambda path: owner)
    hint = being_written_hint(tmp_path)
    assert "a `msr design` result, not a training run: it will hold no policy checkpoint" in hint, hint
    owner["command"] = "msr train --case m1-4mT --out runs"
    assert "wait for it" in being_written_hint(tmp_path)


def test_inputs_through_a_missing_folder_name_it_for_every_kind_of_file(tmp_path, monkeypatch, capsys):
    """V1: round 51's hint reached field CSVs and specs only; calibrations, notes, references,
    trajectories and policies said a bare "no such file"."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "n1.md").write_text("notes\n")
    (tmp_path / "f.csv").write_text("mag_x,mag_y,mag_z\n1,0,0\n")
    hint = "(the folder missing does not exist; a path is followed folder by folder"
    for argv in (["policy", "generate", "missing/../m1-4mT", "--out", "g"],
                 ["real", "firmware", "f.csv", "--calibration", "missing/../cal.json", "--out", "fw"],
                 ["field", "replay", "f.csv", "--reference", "missing/../t.csv", "--out", "r"]):
        assert run(argv) == 2, argv
        assert hint in capsys.readouterr().err, argv


def test_a_file_force_would_not_replace_is_refused_for_that_reason_at_once(tmp_path):
    """V4: "already exists; pass --force to replace it", then --force refused the file as the
    user's (calibrate --out on a notes file, stream --log on a file that is no log)."""
    from elastica_magnetic.result_file import ResultExistsError, check_result_file

    mine = tmp_path / "notes.txt"
    mine.write_text("mine\n")
    for force in (False, True):
        with pytest.raises(ResultExistsError) as refused:
            check_result_file(mine, force=force)
        assert "was not written by msr" in str(refused.value) and "pass --force" not in str(refused.value)
    assert mine.read_text() == "mine\n"


def test_a_generate_result_given_as_a_policy_is_named_for_what_it_is(tmp_path, capsys):
    """V3: a ``msr policy generate`` result given as a policy was "a shipped-policy folder ... without
    actor.pt and policy.json (deleted or not copied? ship it again)"."""
    out = tmp_path / "gen1"
    assert run(["policy", "generate", "m1-4mT", "--duration", "0.05", "--out", str(out), "--no-figures",
                "--no-progress"]) == 0
    capsys.readouterr()
    assert run(["policy", "notes", str(out)]) == 2
    err = capsys.readouterr().err
    assert "holds a result of `msr policy generate` for case m1-4mT" in err, err
    assert "ship it again" not in err
    assert f"its waveform, where a field CSV goes, is {out / 'fields.csv'}" in err


def test_a_column_far_below_a_unit_mistake_is_not_called_one(tmp_path):
    """Borderline of round 52: a 1e-315 mT column beside 3 mT was "about 1000 times less: in T?"."""
    import warnings

    from elastica_magnetic.field_csv import _check_column_units

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        _check_column_units(tmp_path / "x.csv", np.array([[3e-3, 0.0, 3e-6]]))
        _check_column_units(tmp_path / "x.csv", np.array([[3e-3, 0.0, 1e-318]]))
    unit, stray = (str(w.message) for w in caught if "times less" in str(w.message))
    assert "about 1000 times less: mag_z in T where the file is in mT?" in unit
    assert "more than 1e308 times less: a column of round-off or stray values?" in stray


def test_a_waveform_shorter_than_the_study_is_told_the_duration_to_give(tmp_path, capsys):
    """Borderline of round 52: a 0.3 s waveform under the default 10 s study was refused without
    saying to give --duration 0.3."""
    from elastica_magnetic import write_field_csv

    short = write_field_csv(tmp_path / "short.csv", np.zeros((30, 3)))
    assert run(["real", "robustness", "m1-4mT", "--fields", str(short), "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert "the default 10 s is past the end of the waveform" in err, err
    assert "give --duration 0.3 or less, or a longer waveform with --fields" in err
