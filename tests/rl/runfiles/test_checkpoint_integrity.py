"""A checkpoint write that fails (a full disk) keeps the last good checkpoint and its replay rows
(rl/runfiles/checkpoint.py; issue 35); a damaged CSV log is named (rl/runfiles/logs.py)."""

from __future__ import annotations

import errno
import os
import shutil

import pytest
import torch
from elastica_magnetic_rl.runfiles import checkpoint as checkpoint_module
from elastica_magnetic_rl.runfiles.checkpoint import ReplayFile, load_checkpoint, save_checkpoint
from elastica_magnetic_rl.runfiles.logs import read_log

from elastica_magnetic.io import OutputPathError


def test_a_full_disk_keeps_the_previous_checkpoint(trained, tmp_path, monkeypatch):
    run = tmp_path / "seed0"
    shutil.copytree(trained / "m1-4mT" / "seed0", run)
    path = run / "checkpoint.pt"
    before = path.read_bytes()
    ckpt = load_checkpoint(run)

    def full_disk(obj, f):
        f.write(b"\x00" * 1000)  # part of the new checkpoint, then the disk is full
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(checkpoint_module.torch, "save", full_disk)
    with pytest.raises(OutputPathError, match="No space left on device.*previous checkpoint is kept"):
        save_checkpoint(path, {**ckpt, "global_step": ckpt["global_step"] + 80})
    monkeypatch.undo()
    assert path.read_bytes() == before and not (run / "checkpoint.pt.tmp").exists()
    assert load_checkpoint(run)["global_step"] == ckpt["global_step"]  # --resume can continue
    # round 5, D08: the first checkpoint of a run fails: nothing to resume, and the message says so
    monkeypatch.setattr(checkpoint_module.torch, "save", full_disk)
    first = tmp_path / "new" / "checkpoint.pt"
    first.parent.mkdir()
    with pytest.raises(OutputPathError) as refused:
        save_checkpoint(first, ckpt)
    message = str(refused.value)
    assert "no checkpoint was written yet, so there is nothing to resume" in message, message
    assert "--resume continues" not in message and os.listdir(first.parent) == []


def test_a_failed_replay_append_leaves_the_rows_the_checkpoint_needs(tmp_path, monkeypatch):
    from elastica_magnetic_rl.td3.replay_buffer import ReplayBuffer

    buffer = ReplayBuffer(100, 3, 2)
    for _ in range(10):
        buffer.add(torch.zeros(3).numpy(), torch.zeros(2).numpy(), 1.0, torch.ones(3).numpy(), False)
    replay = ReplayFile(tmp_path)
    replay.state(buffer)
    size = replay.path.stat().st_size
    for _ in range(5):
        buffer.add(torch.zeros(3).numpy(), torch.zeros(2).numpy(), 1.0, torch.ones(3).numpy(), False)
    real_fsync = os.fsync

    def full_disk(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(checkpoint_module.os, "fsync", full_disk)
    with pytest.raises(OSError):
        replay.state(buffer)
    monkeypatch.setattr(checkpoint_module.os, "fsync", real_fsync)
    assert replay.path.stat().st_size == size and replay.rows == 10


def test_a_damaged_log_is_named_with_its_row_and_column(tmp_path):
    log = tmp_path / "episodes.csv"
    log.write_text("episode,global_step,return\n0,10,1.5\n1,20,abc\n")
    with pytest.raises(ValueError, match=r"episodes.csv: damaged log: row 3, column 'return': 'abc'"):
        read_log(log, ("global_step", "return"))
    log.write_text("episode,return\n0,1.5\n")
    with pytest.raises(ValueError, match="the header lacks global_step"):
        read_log(log, ("global_step", "return"))
    log.write_bytes(b"episode,global_step,return\n0,10,\xff\n")
    with pytest.raises(ValueError, match="not UTF-8"):
        read_log(log, ("global_step", "return"))
    log.write_text("episode,global_step,return\n0,10,1.5\n")
    assert read_log(log, ("global_step", "return")) == [
        {"episode": "0", "global_step": "10", "return": "1.5"}]


@pytest.mark.parametrize(("content", "expected"), [
    (b"", "is empty (0 bytes)"),
    (b"t_s,mag_x,mag_y,mag_z\n0,1,0,0\n", "is a text file (it begins 't_s,mag_x,mag_y,mag_z')"),
    (b"\x80\x04K\x01.", "is a bare Python pickle"),
    (b"\x00\x01\x02binary", "is not a torch file"),
    ("truncated", "is a damaged or truncated torch file (RuntimeError"),
    ("objects", "holds Python objects other than tensors"),
])
def test_a_file_that_is_not_a_checkpoint_says_what_it_is(tmp_path, content, expected):
    """torch's own message for these advises weights_only=False (running the file's code) or
    is a KeyError of a byte; the reason says what the file is instead."""
    path = tmp_path / "checkpoint.pt"
    if content == "truncated":
        torch.save({"w": torch.zeros(1000)}, path)
        path.write_bytes(path.read_bytes()[:2000])
    elif content == "objects":
        torch.save({"where": tmp_path}, path)  # a PosixPath: not loadable with weights_only
    else:
        path.write_bytes(content)
    with pytest.raises(ValueError) as refused:
        load_checkpoint(path)
    message = str(refused.value)
    assert message.startswith(f"{path}: cannot be read as a checkpoint: {expected}"), message
    assert "weights_only` set to `False" not in message
