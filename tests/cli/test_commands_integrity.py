"""The writing commands outside the learning package against an existing result (issue 35):
``msr field simulate``, ``msr field replay`` and ``msr validate`` are interrupted (SIGINT, SIGTERM, SIGKILL
after N files opened for writing, or between the swap's renames) or fail (ENOSPC after N bytes)
in a real process; the old result must survive byte for byte and nothing partial be left.

Each case is one ``msr`` process forked from a warm server (``tests/faults.py``: about 1 s, a
0.05 s simulation), so the suite keeps a handful of points here; every point of the mechanism
itself is covered in ``test_results.py``.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
from pathlib import Path

import pytest
from faults import Fault

from elastica_magnetic.cli import main

pytestmark = pytest.mark.skipif(os.name != "posix", reason="signals are POSIX")

SIMULATE = ["field", "simulate", "--duration", "0.05", "--physics", "training", "--amplitude", "0.004"]


def snapshot(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def run_with_fault(server, fault: tuple[str, int, str], argv: list[str]):
    """``msr ARGV`` in a process of its own (``tests/faults.py``) with ``fault``: ``open N SIGNAL``
    sends SIGNAL to itself once the N-th file under a result's temporary folder is opened for
    writing; ``rename N SIGNAL`` right after the N-th rename of the swap; ``enospc N -`` fails
    the writes of the first file there with ENOSPC past N bytes."""
    action, n, sig = fault
    if action == "rename":
        return server.run(argv, Fault("rename", r"/\.sim\.msr-old-", sig, nth=n))
    if action == "enospc":
        return server.run(argv, Fault("enospc", r"\.msr-new-", after=n))
    return server.run(argv, Fault("open", r"\.msr-new-", sig, nth=n))


@pytest.fixture(scope="module")
def old_simulation(tmp_path_factory) -> Path:
    """A finished ``msr field simulate`` result (written once, copied by each test)."""
    out = tmp_path_factory.mktemp("old") / "sim"
    assert main([*SIMULATE, "--frequency", "-2", "--out", str(out)]) == 0
    return out


@pytest.fixture
def existing(old_simulation, tmp_path) -> tuple[Path, dict[str, bytes]]:
    import shutil

    out = tmp_path / "sim"
    shutil.copytree(old_simulation, out)
    return out, snapshot(out)


@pytest.mark.parametrize("fault, status, message", [
    (("open", 1, "SIGINT"), 130, "interrupted (SIGINT)"),
    (("open", 2, "SIGTERM"), 143, "interrupted (SIGTERM)"),
    (("enospc", 300, "-"), 2, "No space left on device"),
], ids=["SIGINT-after-trajectory", "SIGTERM-in-figure", "ENOSPC-300-bytes"])
def test_simulate_interrupted_or_failing_keeps_the_old_result(fault_server, existing, fault, status,
                                                              message):
    out, old = existing
    done = run_with_fault(fault_server, fault, [*SIMULATE, "--out", str(out), "--force"])
    assert done.returncode == status, done.stderr
    assert message in done.stderr and "Traceback" not in done.stderr
    assert f"{out} was left as it was" in done.stderr or f"{out} is left as it was" in done.stderr
    assert snapshot(out) == old
    assert sorted(os.listdir(out.parent)) == ["sim"]  # no temporary folder, no lock


def test_simulate_killed_then_the_next_run_recovers(fault_server, existing, capsys):
    out, old = existing
    for fault in (("open", 2, "SIGKILL"), ("rename", 1, "SIGKILL")):
        done = run_with_fault(fault_server, fault, [*SIMULATE, "--out", str(out), "--force"])
        assert done.returncode == -signal.SIGKILL
        assert any(name.startswith(".sim.msr-") for name in os.listdir(out.parent))
        # The next run, without --force: cleans up (restoring the old result when the kill came
        # between the swap's two renames), then refuses to replace it.
        assert main([*SIMULATE, "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert "note: " in err and "stale lock" in err and "already holds a result" in err
        if fault[0] == "rename":
            assert "restored the previous result" in err
        assert snapshot(out) == old and sorted(os.listdir(out.parent)) == ["sim"]


def test_simulate_replaces_only_with_force_and_never_another_commands_result(existing, capsys):
    out, old = existing
    assert main([*SIMULATE, "--out", str(out)]) == 2
    assert (f"--out {out}: already holds a result of `msr field simulate` for robot yao2023-m1"
            in capsys.readouterr().err)
    marker = json.loads((out / ".msr-result.json").read_text())
    (out / ".msr-result.json").write_text(json.dumps({**marker, "kind": "generate",
                                                      "subject": "case m1-4mT"}))
    assert main([*SIMULATE, "--out", str(out), "--force"]) == 2
    assert "holds a result of `msr policy generate` for case m1-4mT" in capsys.readouterr().err
    (out / ".msr-result.json").write_text(json.dumps(marker))
    assert main([*SIMULATE, "--out", str(out), "--force", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["trajectory_csv"] == str(out / "trajectory.csv")  # the final path, not the temporary
    new = snapshot(out)
    assert new.keys() == old.keys() and new["trajectory.csv"] != old["trajectory.csv"]


def test_replay_over_another_robots_result_is_refused(fault_server, existing, reference_dir, capsys):
    out, old = existing
    field_csv = reference_dir / "magnetic_field.csv"
    replay = ["field", "replay", str(field_csv), "--duration", "0.05", "--physics", "training"]
    assert main([*replay, "--out", str(out), "--force"]) == 2
    assert "holds a result of `msr field simulate`" in capsys.readouterr().err
    replay_out = out.parent / "replay"
    assert main([*replay, "--out", str(replay_out)]) == 0
    assert main([*replay, "--robot", "yao2023-m2", "--out", str(replay_out), "--force"]) == 2
    assert "not for robot yao2023-m2" in capsys.readouterr().err
    replayed = snapshot(replay_out)
    done = run_with_fault(fault_server, ("open", 1, "SIGINT"),
                          [*replay, "--out", str(replay_out), "--force"])
    assert done.returncode == 130 and "left as it was" in done.stderr
    assert snapshot(replay_out) == replayed and snapshot(out) == old
    assert sorted(os.listdir(out.parent)) == ["replay", "sim"]


def test_validate_checks_its_folder_before_running(tmp_path, capsys):
    published = tmp_path / "report"
    published.mkdir()
    (published / "report.md").write_text("# Validation report\n")
    (published / "results.json").write_text("{}\n")
    for force in ([], ["--force"]):  # no record that msr wrote them: never replaced (round 8, D3)
        assert main(["validate", "cantilever", "--quick", "--out", str(published), *force]) == 2
        assert ("holds files named like those `msr validate` writes (report.md, results.json) but "
                "no record that msr wrote them") in capsys.readouterr().err
    mixed = tmp_path / "mixed"
    mixed.mkdir()
    (mixed / "thesis.tex").write_text("mine")
    assert main(["validate", "cantilever", "--quick", "--out", str(mixed), "--force"]) == 2
    assert "holds files that `msr validate` does not write (thesis.tex)" in capsys.readouterr().err
    assert (mixed / "thesis.tex").read_text() == "mine"
    assert (published / "report.md").read_text() == "# Validation report\n"


@pytest.fixture
def small_filesystem(tmp_path):
    """A 100 kB tmpfs (root only; skipped where it cannot be mounted)."""
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    mount = tmp_path / "small"
    mount.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=100k", "tmpfs", str(mount)],
                          capture_output=True, text=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.strip()}")
    try:
        yield mount
    finally:
        subprocess.run(["umount", str(mount)], check=True)


def test_a_full_filesystem_keeps_the_old_result(small_filesystem, old_simulation, capsys):
    """A real ENOSPC: the old result (about 70 kB) fits, the new one beside it does not."""
    import shutil

    out = small_filesystem / "sim"
    shutil.copytree(old_simulation, out)
    old = snapshot(out)
    assert main([*SIMULATE, "--out", str(out), "--force"]) == 2
    err = capsys.readouterr().err
    assert "No space left on device" in err and f"{out} is left as it was" in err
    assert ".msr-new-" not in err  # the message names the user's folder, not the temporary one
    assert snapshot(out) == old and sorted(os.listdir(small_filesystem)) == ["sim"]
