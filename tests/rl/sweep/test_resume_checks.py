"""``msr train --resume`` (rl/sweep/resume_checks.py, training.py): a resume with nothing to train is
refused and changes no file; episode logs a kill cut short (a truncated last row, a header only, a
half-written header, an empty file) are repaired to their last whole row and block no seed, and a
damaged log of another seed folder never keeps the summary from being written."""

from __future__ import annotations

import csv
import hashlib
import json
import shutil
from pathlib import Path

import pytest
from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint
from elastica_magnetic_rl.runfiles.logs import read_log

from elastica_magnetic.cli import main as msr

#: 0.1 s episodes (10 steps) and evaluations, tiny networks: 20 steps per seed take a second.
TINY = ["--case", "m1-4mT", "--set", "learning_starts=10", "--set", "batch_size=8", "--set", "hidden_sizes=8",
        "--episode-duration", "0.1", "--workers", "1", "--threads", "1", "--set", "eval_every=10",
        "--set", "eval_duration=0.1", "--no-progress"]
HEADER = "episode,global_step,return,length,terminated,truncated,wall_time_s"


@pytest.fixture(scope="module")
def four_seeds(tmp_path_factory) -> Path:
    """4 seeds of 20 steps (2 episodes each), side by side in this process."""
    out = tmp_path_factory.mktemp("runs")
    assert msr(["train", *TINY, "--seeds", "4", "--steps", "20", "--out", str(out)]) == 0
    return out


def _copy(runs: Path, tmp_path: Path) -> Path:
    out = tmp_path / "runs"
    shutil.copytree(runs, out)
    return out


def _hashes(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def test_a_resume_with_nothing_to_train_is_refused_and_changes_no_file(four_seeds, tmp_path, capsys):
    runs = _copy(four_seeds, tmp_path)
    before = _hashes(runs)
    for steps in ("20", "10"):  # at, and below, the steps the runs have done
        capsys.readouterr()
        assert msr(["train", *TINY, "--seeds", "4", "--steps", steps, "--out", str(runs),
                    "--resume"]) == 2
        err = capsys.readouterr().err
        assert "msr train: error: nothing to train: " in err and "Traceback" not in err
        assert f"{runs / 'm1-4mT' / 'seed0'} is already at 20 steps" in err
        assert f"(--steps {steps}); give --steps above 20" in err
        assert _hashes(runs) == before  # summary.json, run.json, best.pt, logs: byte for byte


def test_the_logs_a_kill_cut_short_are_repaired_and_block_no_seed(four_seeds, tmp_path, capsys):
    """Each of four seeds has its episodes.csv damaged as a kill while writing leaves it; the
    resume cuts each back to its last whole row (a note says so) and trains every seed on."""
    runs = _copy(four_seeds, tmp_path)
    case = runs / "m1-4mT"
    log = {k: case / f"seed{k}" / "episodes.csv" for k in range(4)}
    lines = log[0].read_text().splitlines(keepends=True)
    assert lines[0].strip() == HEADER and len(lines) == 3  # 2 episodes
    log[0].write_text(lines[0] + lines[1] + lines[2][:7])  # the last row cut short
    log[1].write_text(lines[0])  # the header only
    log[2].write_text(HEADER[:20])  # a half-written header
    log[3].write_text("")  # empty
    # another seed of the case, not resumed now, whose log a kill also cut: read to its whole rows
    shutil.copytree(case / "seed0", case / "seed7")
    capsys.readouterr()
    assert msr(["train", *TINY, "--seeds", "4", "--steps", "30", "--out", str(runs), "--resume",
                "--json"]) == 0
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    assert summary["failed"] == [] and [s["seed"] for s in summary["seeds"]] == [0, 1, 2, 3, 7]
    assert f"note: {log[0]}: dropped its unfinished last line {lines[2][:7]!r}" in captured.err
    assert f"note: {log[3]}: it was empty" in captured.err
    kept = {0: [lines[1]], 1: [], 2: [], 3: []}  # the whole rows up to the checkpoint (step 20)
    for k in range(4):
        assert load_checkpoint(case / f"seed{k}", with_buffer=False)["global_step"] == 30
        text = log[k].read_text()
        assert text.endswith("\n") and text.splitlines()[0] == HEADER
        rows = list(csv.DictReader(text.splitlines()))
        assert [r["global_step"] for r in rows] == ["10"] * len(kept[k]) + ["30"]
    seed7 = next(s for s in summary["seeds"] if s["seed"] == 7)
    assert seed7["episodes"] == 1 and seed7["global_step"] == 20


def test_a_damaged_log_of_another_seed_is_named_in_the_summary(four_seeds, tmp_path, capsys):
    """A log damaged before its last line (not by a kill: by hand) in a seed folder the sweep does
    not train is named, with the fix, as that seed's error; the seeds trained now are summarized."""
    runs = _copy(four_seeds, tmp_path)
    case = runs / "m1-4mT"
    shutil.copytree(case / "seed0", case / "seed7")
    (case / "seed7" / "episodes.csv").write_text(f"{HEADER}\n0,abc,1,10,0,1,0.1\n")
    capsys.readouterr()
    assert msr(["train", *TINY, "--seeds", "1", "--steps", "30", "--out", str(runs), "--resume",
                "--json"]) == 1  # a seed of the case has an error
    summary = json.loads(capsys.readouterr().out)
    assert summary["failed"] == [7]
    seed0, seed7 = (next(s for s in summary["seeds"] if s["seed"] == k) for k in (0, 7))
    assert seed0["global_step"] == 30 and "error" not in seed0
    assert "seed7/episodes.csv: damaged log: row 2, column 'global_step'" in seed7["error"]
    assert "cut the log back to its last good row" in seed7["error"]
    assert json.loads((case / "summary.json").read_text())["failed"] == [7]


def test_whole_rows_only_reads_a_log_back_to_its_last_line_end(tmp_path):
    path = tmp_path / "episodes.csv"
    path.write_text("global_step,return\r\n10,1.5\r\n20,2")  # the last row cut in "2.5"
    assert read_log(path, ("global_step", "return"), whole_rows_only=True) == [
        {"global_step": "10", "return": "1.5"}]
    path.write_text("global_step,return\r\n10,1.5\r\n20,")
    with pytest.raises(ValueError, match="row 3, column 'return'"):  # without it: named
        read_log(path, ("global_step", "return"))
    for text in ("", "global_st", "global_step,return\r\n"):
        path.write_text(text)
        assert read_log(path, ("global_step", "return"), whole_rows_only=True) == []
    path.write_text("global_step,return\n1x,1\n20,2\n")  # damage before the last line end
    with pytest.raises(ValueError, match="row 2, column 'global_step'"):
        read_log(path, ("global_step", "return"), whole_rows_only=True)
