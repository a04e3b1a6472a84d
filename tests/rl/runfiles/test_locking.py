"""Run folders' locks (rl/runfiles/locking.py; issue 35): the pre-check of ``msr train``'s seed
folders reports a stale lock it takes over, and the lock's holder removes what a writer killed
mid-write left behind (the unfinished ``checkpoint.pt.tmp``), keeping the previous checkpoint."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
from elastica_magnetic_rl.runfiles.locking import check_unlocked, held_run_folders
from elastica_magnetic_rl.runfiles.rundir import RunDir
from lock_holder import held_elsewhere

from elastica_magnetic.locks import FolderLockedError, host_name, lock_path

pytestmark = pytest.mark.skipif(os.name != "posix", reason="flock is POSIX")


def dead_pid() -> int:
    """The pid of a process that has ended."""
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_the_pre_check_reports_a_stale_lock_it_takes_over(tmp_path, capsys):
    seed = tmp_path / "m1-4mT" / "seed0"
    seed.mkdir(parents=True)
    pid = dead_pid()
    lock_path(seed).write_text(json.dumps({"pid": pid, "host": host_name(), "command": "msr train",
                                           "started_utc": "2026-01-01T00:00:00Z"}))
    notes = check_unlocked([seed, tmp_path / "m1-4mT" / "seed1"])
    assert len(notes) == 1
    expected = (f"{seed}: took over the stale lock of pid {pid} on {host_name()} (`msr train`, since "
                "2026-01-01T00:00:00Z), which is no longer running")
    assert notes == [expected]
    assert capsys.readouterr().err == f"note: {expected}\n"
    assert not lock_path(seed).exists()  # taken over and released
    assert check_unlocked([seed]) == [] and capsys.readouterr().err == ""

    with held_elsewhere(seed) as pid:  # a live owner is refused, named
        with pytest.raises(FolderLockedError, match=rf"--out {seed}: being written by pid "
                                                    rf"{pid} on {host_name()}"):
            check_unlocked([seed])


def test_the_holder_removes_what_a_killed_writer_left_and_keeps_the_checkpoint(tmp_path):
    run = RunDir(tmp_path / "seed0")
    run.path.mkdir()
    run.checkpoint.write_bytes(b"complete checkpoint")
    leftovers = [run.path / "checkpoint.pt.tmp", run.path / "best.pt.tmp",
                 run.path / "episodes.csv.tmp", run.path / ".run.tmp4242.json"]
    for path in leftovers:
        path.write_bytes(b"half")
    mine = [run.path / "notes.tmp", run.path / ".run.tmpx.json"]  # not a run file's temporary
    for path in mine:
        path.write_bytes(b"keep")
    with held_run_folders([run.path]) as notes:
        assert sorted(notes) == sorted(
            f"{run.path}: removed {p.name}, the unfinished file of a run that was killed while "
            "writing it (the previous complete file is kept)" for p in leftovers)
    assert not any(p.exists() for p in leftovers) and all(p.exists() for p in mine)
    assert run.checkpoint.read_bytes() == b"complete checkpoint"


def test_round12_v4_a_seed_being_trained_is_named_by_its_readers(tmp_path, capsys):
    """Round 12, V4: a seed folder being trained before its first checkpoint was "no checkpoint" to
    --resume (whose advice, train without --resume, was then refused), refine and generate."""
    from lock_holder import held_elsewhere

    from elastica_magnetic.cli import main

    seed = tmp_path / "trc" / "m1-4mT" / "seed0"
    seed.mkdir(parents=True)
    with held_elsewhere(seed) as pid:
        commands = (
            ["train", "--case", "m1-4mT", "--seeds", "1", "--steps", "60", "--out", str(tmp_path / "trc"),
             "--resume", "--no-progress"],
            ["refine", str(seed), "--steps", "5", "--out", str(tmp_path / "rf"), "--no-progress"],
            ["policy", "generate", str(seed), "--no-figures", "--no-gif", "--duration", "0.1",
             "--out", str(tmp_path / "g"), "--no-progress"],
            # round 13 V3: export-seeds said only "no seed<k>/checkpoint.pt to evaluate"
            ["policy", "export-seeds", str(seed.parent), "--out", str(tmp_path / "es"), "--no-progress"],
        )
        for argv in commands:
            assert main(argv) != 0, argv
            err = capsys.readouterr().err
            assert f"being written by another msr command, pid {pid} on" in err, (argv, err)
    assert not any((tmp_path / name).exists() for name in ("rf", "g", "es"))
