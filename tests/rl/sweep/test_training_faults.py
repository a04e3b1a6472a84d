"""``msr train`` when a checkpoint write fails or the process is killed in the middle of one, in
real processes (issue 35; ``tests/faults.py``): the last good ``checkpoint.pt`` survives byte for
byte, the failure is named, nothing temporary is left once the next run took over, and
``--resume`` continues from that checkpoint."""

from __future__ import annotations

import os

import pytest
from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint
from faults import Fault

from elastica_magnetic.locks import host_name, lock_path

pytestmark = pytest.mark.skipif(os.name != "posix", reason="fork and signals are POSIX")

TINY = ["train", "--case", "m1-4mT", "--set", "learning_starts=10", "--set", "batch_size=8",
    "--set", "hidden_sizes=8",
        "--episode-duration", "0.1", "--no-progress", "--seeds", "1", "--workers", "1",
        "--threads", "1", "--set", "checkpoint_every=10", "--set", "eval_every=0"]
CHECKPOINT_TMP = r"checkpoint\.pt\.tmp$"


def temporaries(run) -> list[str]:
    return sorted(p.name for p in run.iterdir() if ".tmp" in p.name)


def test_a_full_disk_then_a_kill_mid_checkpoint_keep_the_last_good_one(fault_server, tmp_path):
    out = tmp_path / "runs"
    train = [*TINY, "--out", out]
    run = out / "m1-4mT" / "seed0"
    ckpt = run / "checkpoint.pt"

    # The disk fills up 1000 bytes into the second checkpoint (step 20).
    done = fault_server.run([*train, "--steps", "30"], Fault("enospc", CHECKPOINT_TMP, nth=2,
                                                             after=1000))
    assert done.returncode == 1, done.stderr
    assert (f"seed0: OutputPathError: {ckpt}: cannot write the checkpoint: No space left on device "
            "(the previous checkpoint is kept; --resume continues from it)") in done.stdout
    assert "Traceback" not in done.stderr + done.stdout
    assert load_checkpoint(ckpt)["global_step"] == 10  # with its replay rows: resumable
    assert temporaries(run) == [] and not lock_path(run).exists()
    good = ckpt.read_bytes()

    # Resumed, then killed 1000 bytes into its first checkpoint.
    done = fault_server.run([*train, "--steps", "40", "--resume"],
                            Fault("write", CHECKPOINT_TMP, "SIGKILL", nth=1, after=1000))
    assert done.returncode == -9
    assert ckpt.read_bytes() == good  # the last good checkpoint, byte for byte
    assert (run / "checkpoint.pt.tmp").stat().st_size == 1000  # what a kill leaves
    assert lock_path(run).exists()

    # The next run reports what it cleans up, and resumes from the good checkpoint.
    done = fault_server.run([*train, "--steps", "40", "--resume"])
    assert done.returncode == 0, done.stderr
    notes = [line for line in done.stderr.splitlines() if line.startswith("note: ")]
    assert any(f"{run}: took over the stale lock of pid " in n and f" on {host_name()} (`msr train"
               in n and "which is no longer running" in n for n in notes), done.stderr
    assert (f"note: {run}: removed checkpoint.pt.tmp, the unfinished file of a run that was killed "
            "while writing it (the previous complete file is kept)") in notes
    resumed = load_checkpoint(ckpt)
    assert resumed["global_step"] == 40 and int(resumed["buffer"]["rows"]) == 40
    assert temporaries(run) == [] and not lock_path(run).exists()
