"""One seed's bookkeeping (rl/runner/seed_run.py): its progress line."""

from __future__ import annotations

import torch
from elastica_magnetic_rl.runner.loop import train
from toy_env import ToyEnv, toy_config

torch.set_num_threads(1)


def test_progress_without_a_terminal_is_sparse_and_shows_the_evaluations(tmp_path, capsys):
    cfg = toy_config(eval_every=50, eval_episodes=1)
    train(ToyEnv, cfg, 400, tmp_path, progress=True, progress_desc="toy", eval_env_fn=ToyEnv,
          metadata={"physics": "accurate"})
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert 2 <= len(lines) <= 12, lines  # a line per 10 % at most, not a redraw per step
    last = lines[-1]
    assert last.startswith("toy") and "eval (accurate)" in last and "best" in last
    assert "train ret" in last and "\r" not in "".join(lines)
