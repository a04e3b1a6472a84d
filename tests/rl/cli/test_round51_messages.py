"""Round 51 of held-out tries (issue 48): the waveform ``msr policy generate`` writes replays its
own trajectory to the last bit (S1: the CSV's mT round trip had changed one value in ~50 by one
ulp, which the accurate physics' contact amplified to 5.6e-8 m in 0.2 s)."""

from __future__ import annotations

import numpy as np
import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from elastica_magnetic import read_field_csv, write_field_csv
from elastica_magnetic.cli import main
from elastica_magnetic.field_csv import millitesla_text_to_tesla, tesla_to_millitesla_text


def run(argv: list[str]) -> int:
    """``msr argv``'s exit status (a parser's refusal exits through SystemExit)."""
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code)


finite_fields = arrays(np.float64, st.tuples(st.integers(1, 40), st.just(3)),
                       elements=st.floats(-1e300, 1e300, allow_nan=False, width=64))  # T; mT stays finite


@settings(max_examples=200, deadline=None)
@given(field=finite_fields)
def test_a_field_written_and_read_is_the_same_float_to_the_last_bit(tmp_path_factory, field):
    path = write_field_csv(tmp_path_factory.mktemp("csv") / "f.csv", field)
    back = read_field_csv(path)
    assert np.array_equal(back.view(np.int64), field.view(np.int64))  # -0.0 kept too


def test_fields_made_by_increments_come_back_where_the_old_round_trip_moved_some():
    """A policy's fields (float32 actions times 0.3 mT, summed and clipped): the old reading of
    the old writing (``float(repr(B / 1e-3)) * 1e-3``) moved some of them by one ulp."""
    rng = np.random.default_rng(51)
    increments = 0.3e-3 * rng.uniform(-1, 1, size=(2000, 3)).astype(np.float32).astype(np.float64)
    field = np.clip(np.cumsum(increments, axis=0), -4e-3, 4e-3)
    moved = [v for v in field.ravel().tolist() if float(repr(v / 1e-3)) * 1e-3 != v]
    assert moved  # values the old round trip did change
    assert all(millitesla_text_to_tesla(tesla_to_millitesla_text(v)) == v for v in moved)


def test_a_hand_written_millitesla_reads_as_the_nearest_double():
    assert millitesla_text_to_tesla("3.9876") == float("3.9876e-3")
    assert millitesla_text_to_tesla(" -0.3 ") == -3e-4


def test_generate_and_the_replay_of_its_fields_csv_give_one_trajectory(tmp_path, capsys):
    """S1: 0.136395 against 0.136445 mm in 0.2 s of the accurate physics."""
    spec = tmp_path / "m1.toml"
    assert run(["case", "show", "m1-4mT", "--toml"]) == 0
    spec.write_text(capsys.readouterr().out)
    assert run(["policy", "generate", "m1-4mT", "--duration", "0.3", "--physics", "accurate",
                "--out", str(tmp_path / "pg"), "--no-figures", "--no-progress"]) == 0
    assert run(["field", "replay", str(tmp_path / "pg" / "fields.csv"), "--robot", str(spec),
                "--physics", "accurate", "--out", str(tmp_path / "rp"), "--no-progress"]) == 0
    played = pd.read_csv(tmp_path / "pg" / "trajectory.csv")
    replayed = pd.read_csv(tmp_path / "rp" / "trajectory.csv")
    assert played.shape == replayed.shape
    assert (played.to_numpy() == replayed.to_numpy()).all()


def test_a_shipped_policys_policy_json_is_told_to_give_its_folder(capsys):
    """Borderline of round 51: "policy.json: cannot be read as a checkpoint: is a text file"."""
    from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR

    folder = POLICIES_DIR / "m1-4mT"
    assert run(["policy", "notes", str(folder / "policy.json")]) == 2
    assert f"a file of the shipped policy {folder}, not a policy: give its folder" in capsys.readouterr().err


def test_notes_of_a_run_folder_call_it_a_run_and_best_pt_is_told_its_name(trained, tmp_path, monkeypatch,
                                                                          capsys):
    """Borderline of round 51: a run's folder was "a checkpoint, not a shipped policy"; ``--checkpoint
    best.pt`` (read from the current folder) was "no such checkpoint file (or auto, final, best)"."""
    run_dir = trained / "m1-4mT" / "seed0"
    assert run(["policy", "notes", str(run_dir)]) == 2
    assert "a training run's folder, not a shipped policy" in capsys.readouterr().err
    monkeypatch.chdir(tmp_path)
    assert run(["policy", "export", str(run_dir), "--checkpoint", "best.pt", "--out", "ex"]) == 2
    assert "the run's own best.pt is --checkpoint best" in capsys.readouterr().err


def test_ship_refuses_an_empty_notes_file_as_notes_does(trained, tmp_path, capsys):
    """Borderline of round 51: ``ship --notes empty.md`` shipped ``notes = ""`` without a word."""
    empty = tmp_path / "empty.md"
    empty.write_text("\n")
    assert run(["policy", "ship", str(trained / "m1-4mT" / "seed0"), "--name", "p1", "--out",
                str(tmp_path / "pols"), "--notes", str(empty)]) == 2
    assert f"--notes {empty}: is empty" in capsys.readouterr().err
    assert not (tmp_path / "pols" / "p1").exists()


def test_an_input_through_a_missing_folder_names_the_folder(tmp_path, monkeypatch, capsys):
    """Borderline of round 51: ``--robot ./missing/../small.toml`` was "no such spec file" beside an
    existing small.toml (the system follows ``..`` after the missing folder, and fails)."""
    monkeypatch.chdir(tmp_path)
    assert run(["case", "show", "m1-4mT", "--toml"]) == 0
    (tmp_path / "small.toml").write_text(capsys.readouterr().out)
    write_field_csv(tmp_path / "f.csv", np.zeros((5, 3)))
    assert run(["field", "replay", "f.csv", "--robot", "./missing/../small.toml", "--out", "r"]) == 2
    assert ("no such spec file (the folder missing does not exist; a path is followed folder by folder"
            in capsys.readouterr().err)
    assert run(["field", "replay", "./gone/../f.csv", "--robot", "small.toml", "--out", "r"]) == 2
    assert "no such field CSV file (the folder gone does not exist" in capsys.readouterr().err
