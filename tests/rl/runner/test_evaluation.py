"""Evaluation during training (rl/runner/evaluation.py): the best actor kept without changing the
training, exact across a resume, seeds evaluated together as alone."""

from __future__ import annotations

import csv

import numpy as np
import pytest
import torch
from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint
from elastica_magnetic_rl.runner.evaluation import ActorPolicy, evaluate
from elastica_magnetic_rl.runner.loop import train
from elastica_magnetic_rl.td3.agent import TD3Agent
from state_compare import assert_state_equal
from toy_env import Killed, ToyEnv, sync_vector_env, toy_config

torch.set_num_threads(1)


# ----------------------------------------------------------------------------------------------
# evaluation during training: best actor kept, training unchanged, exact across a resume
# ----------------------------------------------------------------------------------------------
def _evaluations(run_dir) -> list[dict[str, float]]:
    with open(run_dir / "evaluations.csv") as f:
        return [{k: float(v) for k, v in r.items() if k != "wall_time_s"} for r in csv.DictReader(f)]


def test_periodic_evaluation_keeps_the_best_and_leaves_training_unchanged(tmp_path):
    steps = 200
    plain = train(ToyEnv, toy_config(seed=7), steps, tmp_path / "plain", progress=False)
    cfg = toy_config(seed=7, eval_every=50, eval_episodes=3)
    agent = train(ToyEnv, cfg, steps, tmp_path / "eval", progress=False, eval_env_fn=ToyEnv)
    assert_state_equal(plain.state_dict(), agent.state_dict())  # evaluation draws no training RNG

    rows = _evaluations(tmp_path / "eval")
    episode_ends = [int(r["global_step"]) for r in csv.DictReader(open(tmp_path / "eval" / "episodes.csv"))]
    expected = [next(g for g in episode_ends if g >= m) for m in (50, 100, 150)]
    assert [int(r["global_step"]) for r in rows] == [*expected, steps]  # + one at the end
    best = np.maximum.accumulate([r["mean_return"] for r in rows])
    assert [r["best_mean_return"] for r in rows] == best.tolist()
    assert len(set(r["mean_return"] for r in rows)) > 1  # the policy did change between them

    ckpt = load_checkpoint(tmp_path / "eval" / "best.pt")
    i_best = int(np.argmax([r["mean_return"] for r in rows]))
    assert ckpt["kind"] == "best" and ckpt["global_step"] == rows[i_best]["global_step"]
    assert ckpt["evaluation"]["mean_return"] == rows[i_best]["mean_return"]
    # the saved networks reproduce the recorded evaluation
    space = ToyEnv().action_space
    replay = ActorPolicy(ckpt["agent"]["actor"], 3, 2, cfg.hidden_sizes, space.low, space.high)
    again = evaluate(replay, ToyEnv, episodes=3, seed=ckpt["evaluation"]["seed"])
    assert again.mean_return == rows[i_best]["mean_return"]
    # networks only: not a starting point for training
    with pytest.raises(ValueError, match="best evaluation"):
        TD3Agent.from_checkpoint(tmp_path / "eval" / "best.pt")
    with pytest.raises(ValueError, match="best evaluation"):
        train(ToyEnv, None, 250, tmp_path / "from_best", progress=False,
              init_from=tmp_path / "eval" / "best.pt")


def test_evaluation_survives_a_kill_and_resume(tmp_path):
    steps, cfg = 200, toy_config(seed=3, eval_every=10)
    train(ToyEnv, cfg, steps, tmp_path / "full", progress=False, eval_env_fn=ToyEnv)

    def kill_late(row):
        if row["global_step"] >= 150:
            raise Killed

    with pytest.raises(Killed):
        train(ToyEnv, cfg, steps, tmp_path / "killed", progress=False, log_fn=kill_late,
              eval_env_fn=ToyEnv)
    # the killed run evaluated after its last checkpoint: the resume must drop those rows
    resumed_from = load_checkpoint(tmp_path / "killed")["global_step"]
    assert _evaluations(tmp_path / "killed")[-1]["global_step"] > resumed_from
    train(ToyEnv, cfg, steps, tmp_path / "killed", resume=True, progress=False, eval_env_fn=ToyEnv)
    assert _evaluations(tmp_path / "full") == _evaluations(tmp_path / "killed")
    a, b = load_checkpoint(tmp_path / "full" / "best.pt"), load_checkpoint(tmp_path / "killed" / "best.pt")
    assert a["global_step"] == b["global_step"]
    assert_state_equal(a["agent"], b["agent"])


def test_resume_may_switch_on_evaluation_but_not_change_hyperparameters(tmp_path):
    """Run settings (checkpoint/log/eval cadence) follow the config passed on resume; the
    hyperparameters stay the checkpoint's; the weights equal an uninterrupted run's."""
    straight = train(ToyEnv, toy_config(seed=5), 200, tmp_path / "straight", progress=False)

    def kill_late(row):
        if row["global_step"] >= 130:
            raise Killed

    with pytest.raises(Killed):  # killed after a checkpoint at an episode boundary
        train(ToyEnv, toy_config(seed=5), 200, tmp_path / "run", progress=False, log_fn=kill_late)
    start = load_checkpoint(tmp_path / "run")["global_step"]
    resumed = train(ToyEnv, toy_config(seed=5, eval_every=40), 200, tmp_path / "run", resume=True,
                    progress=False, eval_env_fn=ToyEnv)
    assert_state_equal(straight.state_dict(), resumed.state_dict())
    steps = [r["global_step"] for r in _evaluations(tmp_path / "run")]
    assert steps and all(start < s <= 200 for s in steps) and steps[-1] == 200
    assert load_checkpoint(tmp_path / "run")["config"]["eval_every"] == 40
    with pytest.warns(UserWarning, match="hyperparameters"):
        again = train(ToyEnv, toy_config(seed=5, tau=0.5), 220, tmp_path / "run", resume=True,
                      progress=False)
    assert again.config.tau == toy_config().tau


def test_seeds_evaluated_together_log_what_each_alone_logs(tmp_path):
    """Evaluations of a group's seeds in one vector environment record the same returns (and keep
    the same best.pt) as each seed evaluated alone in a single environment."""
    from elastica_magnetic_rl.runner.loop import train_seeds

    configs = [toy_config(seed=s, eval_every=40, eval_episodes=2) for s in (2, 5)]
    train_seeds(lambda k: sync_vector_env(ToyEnv, k), configs, 150, [tmp_path / "g2", tmp_path / "g5"],
                progress=False, eval_env_fn=ToyEnv, eval_vec_env_fn=lambda k: sync_vector_env(ToyEnv, k))
    for s in (2, 5):
        train(ToyEnv, toy_config(seed=s, eval_every=40, eval_episodes=2), 150, tmp_path / f"alone{s}",
              progress=False, eval_env_fn=ToyEnv)
        together, alone = _evaluations(tmp_path / f"g{s}"), _evaluations(tmp_path / f"alone{s}")
        assert together == alone and len(alone) >= 3
        a = load_checkpoint(tmp_path / f"g{s}" / "best.pt")
        assert_state_equal(a["agent"], load_checkpoint(tmp_path / f"alone{s}" / "best.pt")["agent"])
