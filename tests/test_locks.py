"""Folder locks between real processes (issue 35, mechanism 2): a second writer is refused
naming the first; the lock of a process that died is taken over and reported; a lock naming
another host is left to the user."""

from __future__ import annotations

import json
import os

import pytest
from lock_holder import start_holder

from elastica_magnetic.locks import FolderLock, FolderLockedError, lock_path
from elastica_magnetic.results import result_folder

pytestmark = pytest.mark.skipif(os.name != "posix", reason="flock and signals are POSIX")


def test_a_second_process_is_refused_and_a_dead_ones_lock_taken_over(tmp_path):
    folder = tmp_path / "seed0"
    holder = start_holder(folder)
    try:
        owner = json.loads(lock_path(folder).read_text())
        assert owner["pid"] == holder.pid and owner["host"]
        with pytest.raises(FolderLockedError, match=rf"--out .*seed0: being written by pid "
                                                    rf"{holder.pid} on .*; wait for it to finish"):
            FolderLock(folder).acquire()
        # A result folder there is refused as well, before anything is written.
        with pytest.raises(FolderLockedError, match=f"pid {holder.pid}"):
            with result_folder(folder, kind="demo"):
                pytest.fail("the block must not run")
        assert not folder.exists()
        holder.kill()  # SIGKILL: the lock file stays, naming a process that is gone
        holder.wait()
        assert lock_path(folder).exists()
        with FolderLock(folder) as lock:
            assert lock.notes and f"stale lock of pid {holder.pid}" in lock.notes[0]
            assert json.loads(lock_path(folder).read_text())["pid"] == os.getpid()
        assert not lock_path(folder).exists()
    finally:
        holder.kill()
        holder.wait()


def test_a_released_lock_is_free_and_another_hosts_lock_is_not_taken(tmp_path):
    folder = tmp_path / "seed1"
    holder = start_holder(folder)
    holder.communicate("\n", timeout=30)  # released normally: no file left
    assert holder.returncode == 0 and not lock_path(folder).exists()
    FolderLock(folder).acquire().release()
    lock_path(folder).write_text(json.dumps({"pid": 1, "host": "elsewhere", "command": "msr train",
                                             "started_utc": "2026-01-01T00:00:00Z"}))
    with pytest.raises(FolderLockedError, match=r"pid 1 on elsewhere \(`msr train`.*another host.*"
                                                r"if it does not, remove .*\.seed1\.msr-lock"):
        FolderLock(folder).acquire()


def test_an_unreadable_lock_file_is_taken_over_and_said(tmp_path):
    """Round 12 (an observation): a lock file holding garbage was taken over in silence, unlike a
    stale lock of a dead pid."""
    from elastica_magnetic.locks import FolderLock, lock_path

    folder = tmp_path / "fs1"
    lock_path(folder).write_text("garbage")
    with FolderLock(folder) as lock:
        assert any("whose content is not an msr lock's" in note for note in lock.notes), lock.notes
    with FolderLock(folder) as lock:
        assert lock.notes == []


def test_a_symbolic_link_at_the_lock_files_name_is_refused_and_its_target_left_alone(tmp_path):
    """Round 13 D1: the lock file was opened through a link planted at its name, and the file the
    link points to overwritten with the lock's JSON."""
    from elastica_magnetic.io import OutputPathError

    precious = tmp_path / "precious.txt"
    precious.write_text("precious data")
    folder = tmp_path / "out"
    lock_path(folder).symlink_to(precious.name)
    with pytest.raises(OutputPathError, match=r"is a symbolic link \(to precious.txt\), not msr's lock file"):
        FolderLock(folder).acquire()
    assert precious.read_text() == "precious data" and lock_path(folder).is_symlink()
    assert not folder.exists()


def test_a_hard_link_at_the_lock_files_name_is_refused_and_its_file_left_alone(tmp_path):
    """Round 13 D1 (its other half): a hard link at the lock's name shares the user's file."""
    from elastica_magnetic.io import OutputPathError

    precious = tmp_path / "precious.txt"
    precious.write_text("precious data")
    folder = tmp_path / "out"
    os.link(precious, lock_path(folder))
    with pytest.raises(OutputPathError, match=r"has other names \(hard links\)"):
        FolderLock(folder).acquire()
    assert precious.read_text() == "precious data" and lock_path(folder).exists()


def test_a_fifo_at_the_lock_files_name_is_refused_at_once(tmp_path):
    """Round 14 V6: a FIFO (named pipe) at the lock file's name made a writing command wait
    forever in open(); it is refused by name like a symbolic link, and left as it is."""
    import signal
    import stat

    from elastica_magnetic.io import OutputPathError
    from elastica_magnetic.locks import read_lock

    def waited(signum, frame):
        raise TimeoutError("waited on the FIFO at the lock file's name")

    folder = tmp_path / "l3"
    os.mkfifo(lock_path(folder))
    previous = signal.signal(signal.SIGALRM, waited)
    signal.alarm(20)  # without the fix open() or read() waits forever: fail instead
    try:
        with pytest.raises(OutputPathError, match=r"\.l3\.msr-lock is a FIFO \(named pipe\), not msr's "
                                                  r"lock file: msr does not open it; remove it"):
            FolderLock(folder).acquire()
        assert read_lock(folder) == {}  # read without waiting for a writer
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    assert stat.S_ISFIFO(os.lstat(lock_path(folder)).st_mode) and not folder.exists()


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="Linux's /proc tells an unreaped process")
def test_a_killed_writer_left_unreaped_counts_as_dead(tmp_path):
    """Round 51 borderline: a writer killed with SIGKILL whose parent does not reap it (a
    container's PID 1) stayed a zombie, and its lock and temporaries counted as a live writer's."""
    import subprocess
    import time

    from elastica_magnetic.locks import _pid_alive

    child = subprocess.Popen(["sleep", "30"])
    try:
        assert _pid_alive(child.pid)
        child.kill()
        deadline = time.monotonic() + 10
        while _pid_alive(child.pid) and time.monotonic() < deadline:  # ended, not reaped: a zombie
            time.sleep(0.05)
        assert not _pid_alive(child.pid)
        assert os.path.exists(f"/proc/{child.pid}")  # still there, unreaped
    finally:
        child.wait()
