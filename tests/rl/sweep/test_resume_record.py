"""A resume keeps the run's settings, read from its run.json: without it the resume is refused
(round 4, S7: it ran with today's options, 20 s episodes for a 0.5 s run, and rewrote the record)."""

from __future__ import annotations

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
