"""``msr policy export``, ``msr policy export-seeds --out`` and ``msr policy ship --force`` killed
(SIGKILL) at several points over an existing result, each in a real process (issue 35;
``tests/faults.py``): the old content survives byte for byte and nothing partial is left once the
next command recovered the folder. ``ship`` killed between the moves of its new files (the new
``actor.pt`` in place, the old ``policy.json`` still there) is recovered by the next command that
reads the policy: it finishes the replacement, so the policy loads whole."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest
from elastica_magnetic_rl.shipping.policy_files import resolve_policy, weights_sha256
from faults import Fault

pytestmark = pytest.mark.skipif(os.name != "posix", reason="fork and signals are POSIX")


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (relative path -> bytes)."""
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def beside(folder: Path) -> list[str]:
    """What the mechanism leaves beside ``folder`` (temporary folders, asides, its lock)."""
    return sorted(p.name for p in folder.parent.iterdir() if p.name.startswith(f".{folder.name}."))


def atomic_temporary(folder_pattern: str, name: str) -> str:
    """The path pattern of the temporary file an atomic write of ``name`` (``policy.json``) opens
    inside a temporary folder matching ``folder_pattern``."""
    stem, suffix = os.path.splitext(name)
    return rf"{folder_pattern}[^/]*/(.*/)?\.{stem}\.tmp\d+{suffix}$"


def earlier_export(out: Path) -> dict[str, bytes]:
    """An earlier ``msr policy export`` result of case m1-4mT in ``out`` (written by the mechanism, with
    stand-in bytes: a real export costs seconds of torch.export, and only its bytes matter)."""
    from elastica_magnetic.results import result_folder

    with result_folder(out, kind="export", subject="case m1-4mT") as folder:
        for name in ("policy.ts.pt", "policy.pt2", "policy.json"):
            (folder.path / name).write_bytes(f"earlier {name}\n".encode() * 100)
    return snapshot(out)


def test_export_killed_while_building_and_between_the_renames(fault_server, trained, tmp_path):
    run = trained / "m1-4mT" / "seed0"
    out = tmp_path / "export"
    old = earlier_export(out)
    export = ["policy", "export", run, "--out", out, "--checkpoint", "final"]

    # killed once the TorchScript file is in the new folder (before torch.export)
    done = fault_server.run([*export, "--force"],
                            Fault("rename", r"/\.export\.msr-new-[^/]*/policy\.ts\.pt$", "SIGKILL"))
    assert done.returncode == -9
    assert snapshot(out) == old  # killed while building beside it: untouched
    assert [n.split("-")[0] for n in beside(out)] == [".export.msr", ".export.msr"]  # new, lock

    # killed between the swap's two renames, all the work done: the old one is aside
    done = fault_server.run([*export, "--force"], Fault("rename", r"/\.export\.msr-old-", "SIGKILL"))
    assert done.returncode == -9 and not out.exists()

    done = fault_server.run(export)  # the next export recovers, then refuses (no --force)
    assert done.returncode == 2
    assert "restored the previous result" in done.stderr and "stale lock" in done.stderr
    assert "already holds a result of `msr policy export` for case m1-4mT" in done.stderr
    assert snapshot(out) == old and beside(out) == []


def test_export_seeds_killed_while_building_and_between_the_renames(fault_server, trained,
                                                                    tmp_path):
    runs = tmp_path / "runs"
    shutil.copytree(trained / "m1-4mT", runs / "m1-4mT")  # export-seeds caches evaluations there
    dest = tmp_path / "seeds"
    export = ["policy", "export-seeds", runs / "m1-4mT", "--out", dest, "--duration", "0.05",
              "--no-progress", "--workers", "1"]
    assert fault_server.run(export).returncode == 0
    old = snapshot(dest)
    assert {"seed0/policy.json", "seed1/policy.json", "seed1/episodes.csv"} <= set(old)

    # killed while the second seed's policy.json is written into the new folder
    done = fault_server.run([*export, "--force"],
                            Fault("open", atomic_temporary(r"\.seeds\.msr-new-", "policy.json"),
                                  "SIGKILL", nth=2))
    assert done.returncode == -9
    assert snapshot(dest) == old and len(beside(dest)) == 2  # the unfinished folder, the lock

    done = fault_server.run([*export, "--force"], Fault("rename", r"/\.seeds\.msr-old-", "SIGKILL"))
    assert done.returncode == -9 and not dest.exists()

    done = fault_server.run(export)
    assert done.returncode == 2
    assert "restored the previous result" in done.stderr
    assert "already holds seeds 0, 1 of case m1-4mT" in done.stderr
    assert snapshot(dest) == old and beside(dest) == []


def test_ship_killed_mid_swap_is_finished_by_the_next_reader(fault_server, trained, tmp_path):
    dest = tmp_path / "policies"
    policy = dest / "p"
    ship = ["policy", "ship", "--name", "p", "--out", dest, "--no-measure"]
    seed0, seed1 = (trained / "m1-4mT" / f"seed{k}" for k in (0, 1))
    assert fault_server.run([*ship[:2], seed0, *ship[2:]]).returncode == 0
    old = snapshot(policy)

    # killed while writing the new files (in a temporary folder inside the policy's)
    done = fault_server.run([*ship[:2], seed1, *ship[2:], "--force"],
                            Fault("open", atomic_temporary(r"/p/\.msr-files-", "policy.json"),
                                  "SIGKILL"))
    assert done.returncode == -9
    assert {k: v for k, v in snapshot(policy).items() if ".msr-files-" not in k} == old
    done = fault_server.run(["policy", "notes", policy])  # a reader: the unfinished files are dropped
    assert done.returncode == 0, done.stderr
    assert "left by a run that was killed" in done.stderr and done.stdout == "(no notes)\n"
    assert snapshot(policy) == old and beside(policy) == []

    # killed between the moves: the new actor.pt is in, the old policy.json still there
    done = fault_server.run([*ship[:2], seed1, *ship[2:], "--force"],
                            Fault("rename", r"/p/actor\.pt$", "SIGKILL"))
    assert done.returncode == -9
    mixed = snapshot(policy)
    assert mixed["actor.pt"] != old["actor.pt"] and mixed["policy.json"] == old["policy.json"]

    done = fault_server.run(["policy", "notes", policy, "--json"])  # the next reader finishes the swap
    assert done.returncode == 0, done.stderr
    assert "finished moving" in done.stderr and json.loads(done.stdout)["notes"] is None
    new = snapshot(policy)
    assert beside(policy) == [] and not any(".msr-files-" in k for k in new)
    info = json.loads(new["policy.json"])
    assert info["training"]["seed"] == 1 and info["training"]["source"] == "m1-4mT/seed1/checkpoint.pt"
    loaded = resolve_policy(policy)  # whole: the actor is the one policy.json describes
    assert weights_sha256(loaded.actor.state_dict()) == info["actor_sha256"]
    assert set(new) == set(old) and all(new[k] != old[k] for k in ("actor.pt", "critic.pt"))
