"""The checkpoint format (rl/runfiles/checkpoint.py): checkpoints append only the new transitions to
replay.bin."""

from __future__ import annotations

import numpy as np
import torch
from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint
from elastica_magnetic_rl.runner.loop import train
from toy_env import ToyEnv, toy_config

torch.set_num_threads(1)


def test_checkpoints_append_only_the_new_transitions(tmp_path):
    """The replay buffer goes to replay.bin, each checkpoint appending the rows since the last."""
    train(ToyEnv, toy_config(seed=1), 100, tmp_path, progress=False)
    ckpt = torch.load(tmp_path / "checkpoint.pt", weights_only=True)
    assert ckpt["buffer"]["file"] == "replay.bin" and "obs" not in ckpt["buffer"]
    width = 2 * 3 + 2 + 2
    assert (tmp_path / "replay.bin").stat().st_size == ckpt["buffer"]["rows"] * width * 4
    assert ckpt["buffer"]["rows"] == ckpt["buffer"]["size"] == 100
    first = load_checkpoint(tmp_path)["buffer"]
    # stray rows of a run killed between an append and its checkpoint are cut on resume
    with open(tmp_path / "replay.bin", "ab") as f:
        f.write(np.ones(width * 3, np.float32).tobytes())
    train(ToyEnv, toy_config(seed=1), 120, tmp_path, resume=True, progress=False)
    full = load_checkpoint(tmp_path)
    assert full["buffer"]["size"] == 120
    assert (tmp_path / "replay.bin").stat().st_size == 120 * width * 4
    for key in ("obs", "actions", "rewards", "next_obs", "terminated"):
        torch.testing.assert_close(full["buffer"][key][:100], first[key], rtol=0, atol=0)
