"""A command's pre-check takes its output's lock and keeps it until the write (issue 48, round 5
X06/X07/X09): a second writer of the same ``--out`` is refused at its own pre-check, before its
long work (a fit, a rollout, a sweep), instead of after it. The lock is re-entrant within one
process, so the command's own write under the claim goes through, and the lock file goes when
the write is done or the command ends."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from lock_holder import held_elsewhere

from elastica_magnetic.filesets import check_files, replace_files
from elastica_magnetic.locks import FolderLockedError, lock_path, release_claims
from elastica_magnetic.result_file import check_result_file, result_file
from elastica_magnetic.results import check_result_folder, result_folder

pytestmark = pytest.mark.skipif(os.name != "posix", reason="flock is POSIX")

TRY_LOCK = ("import sys\nfrom elastica_magnetic.locks import FolderLock, FolderLockedError\n"
            "try:\n    FolderLock(sys.argv[1]).acquire()\nexcept FolderLockedError as e:\n"
            "    print(e); sys.exit(3)\n")


def _other_process_can_lock(path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", TRY_LOCK, str(path)], capture_output=True,
                          text=True, timeout=120)


def test_a_checked_result_folder_is_locked_until_its_write(tmp_path):
    out = tmp_path / "result"
    check_result_folder(out, kind="demo")
    assert lock_path(out).exists()
    other = _other_process_can_lock(out)
    assert other.returncode == 3 and f"being written by pid {os.getpid()}" in other.stdout
    with result_folder(out, kind="demo") as folder:  # the same process: shares its claim
        (folder.path / "a.txt").write_text("a")
    assert (out / "a.txt").read_text() == "a"
    assert not lock_path(out).exists()
    assert _other_process_can_lock(out).returncode == 0


def test_a_refused_pre_check_keeps_no_lock(tmp_path):
    out = tmp_path / "result"
    with result_folder(out, kind="demo") as folder:
        (folder.path / "a.txt").write_text("a")
    with pytest.raises(OSError, match="already holds"):
        check_result_folder(out, kind="demo")
    assert not lock_path(out).exists()


def test_a_live_writer_is_refused_at_the_pre_check(tmp_path):
    out = tmp_path / "result"
    (tmp_path / "file.json").write_text("{}")
    with held_elsewhere(out) as pid:
        with pytest.raises(FolderLockedError, match=f"being written by pid {pid}"):
            check_result_folder(out, kind="demo")
    with held_elsewhere(tmp_path / "file.json") as pid:
        with pytest.raises(FolderLockedError, match=f"being written by pid {pid}"):
            check_result_file(tmp_path / "file.json", force=True)
    with held_elsewhere(tmp_path) as pid:
        with pytest.raises(FolderLockedError, match=f"being written by pid {pid}"):
            check_files(tmp_path, ["b.txt"])


def test_checked_files_are_locked_until_written(tmp_path):
    target = tmp_path / "calibration.json"
    check_result_file(target)
    assert _other_process_can_lock(target).returncode == 3
    with result_file(target) as handle:
        handle.path.write_text("{}")
    assert not lock_path(target).exists() and target.read_text() == "{}"
    check_files(tmp_path, ["b.txt"])
    assert _other_process_can_lock(tmp_path).returncode == 3
    with replace_files(tmp_path, ["b.txt"]) as files:
        (files.path / "b.txt").write_text("b")
    assert not lock_path(tmp_path).exists()


def test_claims_of_a_command_that_stopped_early_are_released(tmp_path):
    out = tmp_path / "result"
    check_result_folder(out, kind="demo")  # then the command fails before writing
    release_claims()  # what the command line does when a command ends
    assert not lock_path(out).exists()
    assert _other_process_can_lock(out).returncode == 0


def test_a_second_baseline_on_a_live_writers_out_is_refused_before_its_sweep(tmp_path,
                                                                              monkeypatch):
    from elastica_magnetic_rl.shipping import baseline_sweep

    def no_sweep(job):
        raise AssertionError("the sweep ran before the output was checked")

    monkeypatch.setattr(baseline_sweep, "_run_one", no_sweep)
    out = tmp_path / "baseline"
    with held_elsewhere(out) as pid:
        with pytest.raises(FolderLockedError, match=f"being written by pid {pid}"):
            baseline_sweep.sweep_baseline("m1-4mT", periods=(1.0,), duration=1.0, out=out,
                                          workers=1, physics="training")
