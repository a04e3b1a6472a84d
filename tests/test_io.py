"""Atomic writes and output-location checks (issue 15, item 4)."""

from __future__ import annotations

import errno
import os
import subprocess

import numpy as np
import pytest

from elastica_magnetic import write_field_csv
from elastica_magnetic.io import (
    OutputPathError,
    atomic_save,
    atomic_write,
    atomic_write_text,
    prepare_output_dir,
    prepare_output_file,
    unwritable_reason,
)
from elastica_magnetic.results import result_folder


def test_failed_write_keeps_the_old_file_and_leaves_no_temporary(tmp_path):
    path = atomic_write_text(tmp_path / "result.json", "old\n")
    with pytest.raises(RuntimeError), atomic_write(path) as handle:
        handle.write("half a fi")
        raise RuntimeError("killed")
    assert path.read_text() == "old\n" and os.listdir(tmp_path) == ["result.json"]


def test_full_disk_is_named(tmp_path):
    path = atomic_write_text(tmp_path / "fig.png", "old")

    def full(tmp):
        tmp.write_text("partial")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    with pytest.raises(OutputPathError, match=r"fig\.png: cannot write: No space left on device"):
        atomic_save(path, full)
    assert path.read_text() == "old" and os.listdir(tmp_path) == ["fig.png"]


def test_field_csv_written_atomically_over_an_existing_file(tmp_path):
    path = write_field_csv(tmp_path / "f.csv", np.zeros((2, 3)))
    write_field_csv(path, np.ones((3, 3)) * 1e-3)
    assert path.read_text().count("\n") == 4 and os.listdir(tmp_path) == ["f.csv"]


def test_output_folder_checks(tmp_path):
    afile = tmp_path / "afile"
    afile.write_text("keep")
    with pytest.raises(OutputPathError, match=r"--out .*afile: .*afile is a file, not a folder"):
        prepare_output_dir(afile)
    with pytest.raises(OutputPathError, match=r"--out .*sub: .*afile is a file, not a folder"):
        prepare_output_dir(afile / "sub")
    with pytest.raises(OutputPathError, match=r"--out .*: is a folder, expected a file name"):
        prepare_output_file(tmp_path)
    assert prepare_output_dir(tmp_path / "a" / "b").is_dir()
    assert afile.read_text() == "keep"


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root ignores permissions")
def test_read_only_folder_is_named(tmp_path):
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o500)
    try:
        with pytest.raises(OutputPathError, match=r"--out .*ro: cannot write in .*ro: Permission denied"):
            prepare_output_dir(folder)
    finally:
        folder.chmod(0o700)


def test_a_read_only_file_system_is_named_as_such_not_as_permission_denied(tmp_path, monkeypatch):
    """A read-only mount refuses writes to root as well; "Permission denied" there sent users to
    chmod. The reason comes from the file system's flags."""
    class Flags:
        f_flag = os.ST_RDONLY

    monkeypatch.setattr(os, "access", lambda *args, **kwargs: False)
    monkeypatch.setattr(os, "statvfs", lambda path: Flags())
    assert unwritable_reason(tmp_path) == "the file system is mounted read-only"
    Flags.f_flag = 0
    assert unwritable_reason(tmp_path).startswith("Permission denied")
    monkeypatch.undo()
    assert unwritable_reason(tmp_path) is None


@pytest.mark.skipif(os.name != "posix" or os.geteuid() != 0, reason="mounting needs root")
def test_a_read_only_mount_is_named_by_every_kind_of_writer(tmp_path):
    mount = tmp_path / "ro"
    mount.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k,ro", "tmpfs", str(mount)],
                      capture_output=True).returncode != 0:
        pytest.skip("this machine does not allow mounting a tmpfs")
    try:
        with pytest.raises(OutputPathError, match="(?i)read-only") as refused:
            with result_folder(mount / "x", kind="export", force=False):
                pass
        assert "Permission denied" not in str(refused.value)
        with pytest.raises(OutputPathError, match="y: cannot write in .*: Read-only file system"):
            prepare_output_dir(mount / "y")
    finally:
        subprocess.run(["umount", str(mount)], check=True)
