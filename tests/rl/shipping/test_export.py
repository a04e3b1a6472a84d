"""``msr policy export`` (rl/shipping/export.py): TorchScript and torch.export reloaded with plain torch."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import torch
from elastica_magnetic_rl.envs.env import OBSERVATION_LAYOUT, MagneticCrawlerEnv
from elastica_magnetic_rl.td3.agent import TD3Agent
from smoke import run_msr


def test_export_torchscript_matches_agent(trained, tmp_path, capsys):
    run = trained / "m1-4mT" / "seed1"
    result = run_msr(capsys, "policy", "export", str(run), "--checkpoint", "final", "--out",
                     str(tmp_path / "export"))  # checkpoint.pt's actor, compared below
    assert result["actor_choice"]["actor"] == "final"
    assert result["max_abs_diff"] < 1e-6 and result["max_abs_diff_pt2"] < 1e-6
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # torch.jit is deprecated in 2.13
        module = torch.jit.load(result["torchscript"])  # plain torch, no package code
    program = torch.export.load(result["torch_export"]).module()
    layout = json.loads(Path(result["json"]).read_text())
    assert layout["observation"]["size"] == 260
    assert layout["action"]["field_increment_T_per_unit"] == 3e-4
    agent = TD3Agent.from_checkpoint(run / "checkpoint.pt")
    env = MagneticCrawlerEnv(duration=0.05)
    obs, _ = env.reset(seed=5)
    obs, *_ = env.step(np.array([0.5, -0.5], np.float32))
    with torch.no_grad():
        exported = module(torch.from_numpy(obs[None]))[0].numpy()
        exported_pt2 = program(torch.from_numpy(obs[None]))[0].numpy()
    np.testing.assert_allclose(exported, agent.act(obs), atol=1e-6)
    np.testing.assert_allclose(exported_pt2, agent.act(obs), atol=1e-6)
    assert obs[OBSERVATION_LAYOUT["field_amplitude"]][0] > 0
