"""Atomic writes and output-location checks (issue 15, item 4)."""

from __future__ import annotations

import errno
import os

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
)


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
