"""Fault injection for the writers that need a training run or a policy (issue 48; the registry
of every writing command is ``tests/cli/test_fault_coverage.py``): ``msr refine`` killed while it
writes its checkpoint, ``msr policy notes`` killed while it replaces a policy's notes (``msr policy diagnose
--figure``: ``tests/rl/reports/test_diagnostics.py``). Each runs in a real process (``tests/faults.py``)."""

from __future__ import annotations

import json
import os
import shutil
import signal
from pathlib import Path

import pytest
from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR, resolve_policy
from faults import Fault

from elastica_magnetic.cli import main as msr

pytestmark = pytest.mark.skipif(os.name != "posix", reason="fork and signals are POSIX")


def snapshot(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def test_refine_killed_mid_checkpoint_resumes(fault_server, trained, tmp_path, capsys):
    run = tmp_path / "seed0"
    shutil.copytree(trained / "m1-4mT" / "seed0", run)
    out = tmp_path / "refined"
    argv = ["refine", str(run), "--checkpoint", "final", "--steps", "3", "--episode-duration",
            "0.02", "--out", str(out), "--no-progress"]
    done = fault_server.run(argv, Fault("open", r"/refined/checkpoint\.pt\.tmp$", "SIGKILL", nth=1))
    assert done.returncode == -signal.SIGKILL
    assert not (out / "checkpoint.pt").exists()  # never half a checkpoint under its name
    # the next run cleans up the killed writer's lock and temporary file, and refines
    assert msr([*argv, "--json"]) == 0, capsys.readouterr().err
    assert json.loads(capsys.readouterr().out)["steps"] == 3
    assert not [p.name for p in out.iterdir() if p.name.endswith(".tmp")]


def test_notes_interrupted_leave_the_policy_whole(fault_server, tmp_path, capsys):
    policy = tmp_path / "m1-4mT"
    shutil.copytree(POLICIES_DIR / "m1-4mT", policy, ignore=shutil.ignore_patterns("seeds"))
    before = snapshot(policy)
    notes = tmp_path / "new.md"
    notes.write_text("New notes of the lab.\n")
    done = fault_server.run(["policy", "notes", str(policy), "--file", str(notes)],
                            Fault("open", r"\.msr-files-", "SIGKILL", nth=1))
    assert done.returncode == -signal.SIGKILL
    resolve_policy(str(policy))  # a reader recovers the folder first: the policy loads whole
    after = snapshot(policy)
    # the policy's files whole (msr's own dot files, its record included, are not the policy)
    assert {k: v for k, v in after.items() if not k.startswith(".")} == \
        {k: v for k, v in before.items() if not k.startswith(".")}
    assert msr(["policy", "notes", str(policy), "--file", str(notes)]) == 0
    assert "New notes of the lab." in (policy / "MODEL_CARD.md").read_text()
