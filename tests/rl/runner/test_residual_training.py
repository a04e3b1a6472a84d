"""Residual learning in the training loop (``TD3Config.residual``): the learner corrects a weak
yardstick of the toy task and ends with more return than the yardstick alone; its first evaluation
is the yardstick's; a residual config on environments that do not play corrections, or the
reverse, is refused before any step."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from elastica_magnetic_rl.envs.residual import ResidualController, ResidualEnv, ResidualVectorEnv
from elastica_magnetic_rl.runner.evaluation import evaluate
from elastica_magnetic_rl.runner.loop import train, train_vector
from toy_env import ToyEnv, sync_vector_env, toy_config

torch.set_num_threads(1)


class SlowTeacher:
    """A weak controller of the toy task: a tenth of the way to the target per step, and the second
    action at its low end (the task wants its middle)."""

    obs_dim, act_dim = 3, 2

    def reset(self) -> None:
        pass

    def state(self) -> None:
        return None

    def set_state(self, state) -> None:
        pass

    def act(self, obs: np.ndarray) -> np.ndarray:
        return np.array([np.clip(obs[1] - obs[0], -1.0, 1.0), -1.0])


def _fixed() -> ToyEnv:
    return ToyEnv(p_terminate=0.0)


def _mean_return(policy, episodes: int = 20) -> float:
    return evaluate(policy, _fixed, episodes, seed=100).mean_return


class _Played:
    """A normalised-action controller as the agent ``evaluate`` expects (the toy's action box)."""

    def __init__(self, act):
        self.act_normalised = act

    def act(self, obs):
        a = np.asarray(self.act_normalised(obs), dtype=np.float64)
        return np.array([a[0], 1.0 + a[1]], dtype=np.float32)  # [-1, 1] x [0, 2]


def test_the_residual_learner_improves_on_a_weak_yardstick(tmp_path):
    cfg = toy_config(residual=1.0, learning_starts=200, batch_size=64, hidden_sizes=(32, 32),
                     exploration_noise=0.2, seed=1)
    agent = train(lambda: ResidualEnv(_fixed(), SlowTeacher, 1.0), cfg, 3000, tmp_path / "residual",
                  progress=False)

    def correction(rows):
        with torch.no_grad():
            return agent.actor(torch.as_tensor(np.asarray(rows, np.float32))).numpy()

    yardstick = _mean_return(_Played(SlowTeacher().act))
    corrected = _mean_return(_Played(ResidualController(correction, SlowTeacher, 1.0).act))
    # the yardstick pays 0.01 a step for its second action and closes a tenth of the gap a step
    # (measured: -1.53 corrected, -2.15 the yardstick)
    assert corrected > yardstick + 0.1, (corrected, yardstick)


def test_the_first_evaluation_is_the_yardstick_s(tmp_path):
    cfg = toy_config(residual=0.5, learning_starts=40, eval_every=40, eval_episodes=3, seed=2)
    train(lambda: ResidualEnv(_fixed(), SlowTeacher, 0.5), cfg, 40, tmp_path / "r", progress=False,
          eval_env_fn=lambda: ResidualEnv(_fixed(), SlowTeacher, 0.5))
    import pandas as pd
    from elastica_magnetic_rl.runner.evaluation import EVAL_SEED

    recorded = pd.read_csv(tmp_path / "r" / "evaluations.csv")["mean_return"].iloc[0]
    expected = evaluate(_Played(SlowTeacher().act), _fixed, 3, EVAL_SEED).mean_return
    assert recorded == pytest.approx(expected, rel=1e-12)


def test_a_residual_config_on_plain_environments_is_refused_and_the_reverse(tmp_path):
    with pytest.raises(ValueError, match="residual 0.5: the actor learns a correction.*as they are"):
        train(_fixed, toy_config(residual=0.5), 10, tmp_path / "a", progress=False)
    with pytest.raises(ValueError, match="play corrections of the yardstick \\(residual 0.5\\).*set"):
        train_vector(lambda: ResidualVectorEnv(sync_vector_env(_fixed, 2), SlowTeacher, 0.5), toy_config(),
                     10, tmp_path / "b", progress=False)


def test_the_critic_warmup_holds_the_actor_and_then_lets_it_learn(tmp_path):
    """``critic_warmup``: the first N updates learn the critics only; the actor (a residual learner's
    zero correction) moves once they are done."""
    def run(warmup: int, name: str):
        cfg = toy_config(residual=1.0, learning_starts=40, critic_warmup=warmup, seed=4)
        return train(lambda: ResidualEnv(_fixed(), SlowTeacher, 1.0), cfg, 140, tmp_path / name,
                     progress=False)

    held, moved = run(100, "held"), run(60, "moved")  # 100 updates in all
    assert held.num_updates == moved.num_updates == 100
    last = [p for name, p in held.actor.named_parameters() if name.startswith("net.")][-2:]
    assert all(not p.any() for p in last)  # still the zero correction: the yardstick
    assert any(p.any() for name, p in moved.actor.named_parameters() if name.startswith("net.") and
               p.shape == last[0].shape)
    with pytest.raises(ValueError, match="critic_warmup must be >= 0"):
        toy_config(critic_warmup=-1)


def test_the_correction_penalty_holds_the_correction_near_zero(tmp_path):
    """``correction_penalty``: TD3+BC's term on a zero correction. The same run (same seed, the same
    updates) learns a smaller correction of the weak yardstick with it than without it, and reports
    the size it descends; it needs a residual learner."""
    def run(penalty: float, name: str):
        cfg = toy_config(residual=1.0, learning_starts=40, correction_penalty=penalty, seed=4)
        return train(lambda: ResidualEnv(_fixed(), SlowTeacher, 1.0), cfg, 240, tmp_path / name,
                     progress=False)

    def mean_size(agent) -> float:
        obs = np.random.default_rng(0).uniform(-1.0, 1.0, size=(256, 3)).astype(np.float32)
        with torch.no_grad():
            return float((agent.actor(torch.as_tensor(obs)) ** 2).sum(dim=-1).mean())

    free, held = mean_size(run(0.0, "free")), mean_size(run(10.0, "held"))
    assert held < 0.25 * free, (held, free)
    with pytest.raises(ValueError, match="correction_penalty 0.4 holds a residual learner's correction"):
        toy_config(correction_penalty=0.4)
