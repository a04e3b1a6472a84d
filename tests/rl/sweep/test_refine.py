"""``msr refine`` (rl/sweep/refine.py): a trained run continued in the accurate physics, its agent and
replay buffer kept (the ``trained`` and ``refined`` runs: tests/rl/conftest.py)."""

from __future__ import annotations

import json

import torch
from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint
from smoke import TRAIN_STEPS


def test_refine_continues_agent_and_buffer_in_accurate_physics(trained, refined):
    source = load_checkpoint(trained / "m1-4mT" / "seed0")
    ckpt = load_checkpoint(refined)
    assert ckpt["global_step"] == TRAIN_STEPS + 3
    assert ckpt["buffer"]["size"] == TRAIN_STEPS + 3  # the training transitions are kept
    assert torch.equal(ckpt["buffer"]["obs"][:TRAIN_STEPS], source["buffer"]["obs"])
    # learning happened (past the warm-up): more critic updates, different weights
    assert ckpt["agent"]["num_updates"] == source["agent"]["num_updates"] + 3
    assert not torch.equal(ckpt["agent"]["critic"]["q1_net.0.weight"],
                           source["agent"]["critic"]["q1_net.0.weight"])
    meta = ckpt["metadata"]
    assert meta["physics"] == "accurate" and meta["command"] == "refine"
    assert meta["refine_steps"] == 3 and meta["training_steps"] == TRAIN_STEPS
    assert json.loads((refined / "run.json").read_text())["physics"] == "accurate"
