"""A resume keeps the run's settings, read from its run.json: without it the resume is refused
(round 4, S7: it ran with today's options, 20 s episodes for a 0.5 s run, and rewrote the record)."""

from __future__ import annotations

import json
import shutil

from smoke import SMOKE, TRAIN_STEPS

from elastica_magnetic.cli import main as msr


def test_a_resume_without_run_json_is_refused(trained, tmp_path, capsys):
    out = tmp_path / "runs"
    shutil.copytree(trained / "m1-4mT", out / "m1-4mT")
    (out / "m1-4mT" / "seed0" / "run.json").unlink()
    before = sorted(p.name for p in (out / "m1-4mT" / "seed0").iterdir())
    assert msr(["train", "--case", "m1-4mT", "--seeds", "2", "--workers", "1", "--steps",
                str(TRAIN_STEPS + 40), "--out", str(out), "--resume", *SMOKE]) == 2
    err = capsys.readouterr().err
    assert "seed0: its run.json" in err and "is missing, so the resume cannot keep the run's " \
                                            "settings" in err, err
    assert sorted(p.name for p in (out / "m1-4mT" / "seed0").iterdir()) == before


def test_a_string_in_run_json_is_named_not_compared_as_a_different_setting(trained, tmp_path,
                                                                           capsys):
    """Round 4, V5: "--episode-duration 0.8 differs from the run's 0.8" for a record holding the
    string "0.8": the record's kind is named, and nothing of the run is touched."""
    out = tmp_path / "runs"
    shutil.copytree(trained / "m1-4mT", out / "m1-4mT")
    record = out / "m1-4mT" / "seed0" / "run.json"
    data = json.loads(record.read_text())
    data["episode_duration_s"] = str(data["episode_duration_s"])
    record.write_text(json.dumps(data))
    before = {p.name: p.read_bytes() for p in record.parent.iterdir() if p.is_file()}
    assert msr(["train", "--case", "m1-4mT", "--seeds", "1", "--workers", "1", "--steps",
                str(TRAIN_STEPS + 40), "--out", str(out), "--resume", *SMOKE]) == 2
    err = capsys.readouterr().err
    assert f"{record}: episode_duration_s is '0.8' (a string), expected a number such as 0.8" in err
    assert {p.name: p.read_bytes() for p in record.parent.iterdir() if p.is_file()} == before
    data["episode_duration_s"] = float("nan")  # round 5, W02: "--episode-duration 0.8 differs from nan"
    record.write_text(json.dumps(data))
    assert msr(["train", "--case", "m1-4mT", "--seeds", "1", "--workers", "1", "--steps",
                str(TRAIN_STEPS + 40), "--out", str(out), "--resume", *SMOKE]) == 2
    assert f"{record}: episode_duration_s is nan, not a finite number" in capsys.readouterr().err


def test_a_resume_without_the_td3_options_prints_no_python_warning(trained, tmp_path):
    """Round 5, K07: every resume given fewer options than the run was trained with printed
    `loop.py:229: UserWarning: resuming: using the checkpoint's hyperparameters ...` with a source
    line, for values the user never gave (the recipe's defaults). The run keeps its own: no word."""
    import subprocess
    import sys

    out = tmp_path / "runs"
    shutil.copytree(trained / "m1-4mT", out / "m1-4mT")
    done = subprocess.run([sys.executable, "-m", "elastica_magnetic.cli", "train", "--case", "m1-4mT",
                           "--seeds", "1", "--workers", "1", "--steps", str(TRAIN_STEPS + 40),
                           "--out", str(out), "--resume", "--episode-duration", "0.8",
                           "--no-progress"], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert "Warning" not in done.stderr and "resuming: using" not in done.stderr, done.stderr
    assert json.loads((out / "m1-4mT" / "seed0" / "run.json").read_text())["config"][
        "batch_size"] == 32  # the run's own, not the default 256
