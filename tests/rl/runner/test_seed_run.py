"""One seed's bookkeeping (rl/runner/seed_run.py): its progress line, its resume."""

from __future__ import annotations

import dataclasses

import pytest
import torch
from elastica_magnetic_rl.runfiles.rundir import RunDir
from elastica_magnetic_rl.runner.loop import train
from elastica_magnetic_rl.runner.seed_run import starting_point
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


def test_a_resume_with_other_hyperparameters_names_each_one_it_does_not_take(tmp_path):
    """The library (the command line refuses these by option name before): the warning says
    which hyperparameters of the call were replaced by the run's, and by what."""
    cfg = toy_config(eval_every=50, eval_episodes=1)
    train(ToyEnv, cfg, 120, tmp_path, progress=False)
    other = dataclasses.replace(cfg, batch_size=cfg.batch_size * 2, gamma=0.5, eval_every=60)
    with pytest.warns(UserWarning) as caught:
        _, resumed, config, _ = starting_point(RunDir(tmp_path).checkpoint, True, None, other, None)
    message = str(caught[0].message)
    assert resumed and config.batch_size == cfg.batch_size and config.eval_every == 60
    assert f"batch_size (the run's {cfg.batch_size}, passed {2 * cfg.batch_size})" in message
    assert "gamma (the run's 0.99, passed 0.5)" in message and "eval_every" not in message
