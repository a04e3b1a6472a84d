"""Holding the actor near the yardstick's warm-up for the whole run
(``TD3Config.yardstick_regularization``, rl/td3/algorithm.py): the TD3+BC actor loss, what it holds
against a critic that pulls elsewhere, and the settings refused."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from elastica_magnetic_rl.td3.algorithm import TD3
from elastica_magnetic_rl.td3.config import MAX_YARDSTICK_REGULARIZATION, TD3Config
from elastica_magnetic_rl.td3.replay_buffer import Batch, ReplayBuffer

torch.set_num_threads(1)
OBS, ACT = 3, 2
W = np.array([[1.5, -0.5, 0.0], [0.0, 1.0, -2.0]])


def _learner(beta: float, seed: int = 0, **kw) -> TD3:
    config = TD3Config(seed=seed, hidden_sizes=(32, 32), batch_size=64, yardstick_warmup=100,
                       learning_starts=64, yardstick_regularization=beta, **kw)
    return TD3(OBS, ACT, -np.ones(ACT), np.ones(ACT), [config])


def _shown(rng, n=64) -> Batch:
    """The warm-up: states and a fixed controller's actions ``a = tanh(W s) / 2``."""
    obs = rng.uniform(-1.0, 1.0, (n, OBS)).astype(np.float32)
    actions = (0.5 * np.tanh(obs @ W.T)).astype(np.float32)
    return Batch(obs, actions, np.zeros((n, 1), np.float32), obs.copy(), np.zeros((n, 1), np.float32))


def _pulling(rng, n=64) -> Batch:
    """Transitions whose reward is the sum of the actions: a critic that learns them values every
    action nearer +1, away from the controller's."""
    obs = rng.uniform(-1.0, 1.0, (n, OBS)).astype(np.float32)
    actions = rng.uniform(-1.0, 1.0, (n, ACT)).astype(np.float32)
    rewards = actions.sum(axis=1, keepdims=True)
    return Batch(obs, actions, rewards, obs.copy(), np.ones((n, 1), np.float32))


def _distance(learner: TD3, batch: Batch) -> float:
    with torch.no_grad():
        mu = torch.tanh(learner.actor_net(torch.as_tensor(batch.obs)[None], learner.compute_dtype))[0]
    return float(((mu - torch.as_tensor(batch.actions)) ** 2).mean())


def _cloned_then_trained(beta: float, updates: int) -> tuple[float, float]:
    """The actor's distance to the controller after cloning it, and after ``updates`` TD3 updates
    on transitions that reward leaving it."""
    learner, rng = _learner(beta), np.random.default_rng(0)
    for _ in range(300):
        learner.clone_step([_shown(rng)])
    learner.hold_actor_targets()
    test = _shown(np.random.default_rng(99), 512)
    cloned = _distance(learner, test)
    for _ in range(updates):
        learner.update([_pulling(rng)], warmup_batches=lambda: [_shown(rng)])
    return cloned, _distance(learner, test)


def test_the_hold_is_a_trade_that_beta_sets():
    """Against a critic that truly values other actions, the actor leaves the clone by an offset
    that shrinks as ``beta`` grows (each action's balance: ``2 beta offset / act_dim = 1 / mean|Q|``);
    plain TD3 walks it all the way. Measured: distance 1.13 plain, 0.92 at 0.4, 0.46 at 1, 0.12 at 4."""
    distances = {}
    for beta in (0.0, 0.4, 1.0, 4.0):
        cloned, distances[beta] = _cloned_then_trained(beta, 600)
        assert cloned < 0.01
    assert distances[0.0] > 0.3  # the critic's pull: every action toward +1
    assert distances[0.0] > distances[0.4] > distances[1.0] > distances[4.0]
    assert distances[4.0] < 0.15 * distances[0.0], distances


def test_the_actor_loss_is_td3_bc_s():
    """``actor_loss = -mean Q1(s, mu(s)) / mean|Q1(s, mu(s))| + beta * mean ||mu(s_w) - a_w||^2``
    with the critic of the same update's critic step, and ``warmup_distance`` the distance; checked
    against a twin learner that makes the same critic step with its actor held."""
    beta = 0.4
    learner, twin = _learner(beta, seed=3, policy_delay=1), _learner(beta, seed=3, policy_delay=1)
    rng = np.random.default_rng(3)
    batch, shown = _pulling(rng), _shown(rng)
    info = learner.update([batch], warmup_batches=lambda: [shown])
    twin.update([batch], train_actor=False)  # the same critic step; the actor as it was
    obs = torch.as_tensor(batch.obs)[None]
    with torch.no_grad():
        mu = torch.tanh(twin.actor_net(obs, twin.compute_dtype))
        q1 = twin.critic_net(torch.cat([obs, mu], dim=-1), twin.compute_dtype, members=slice(0, 1))
    distance = _distance(twin, shown)
    expected = -q1.mean() / q1.abs().mean() + beta * distance
    assert float(info["actor_loss"][0]) == pytest.approx(float(expected), rel=1e-5)
    assert float(info["warmup_distance"][0]) == pytest.approx(distance, rel=1e-5)
    assert _distance(learner, shown) != distance  # the step moved the actor


def test_settings_that_cannot_hold_are_refused():
    with pytest.raises(ValueError, match="set yardstick_warmup too"):
        TD3Config(yardstick_regularization=0.4)
    with pytest.raises(ValueError, match="yardstick_regularization must be a finite number >= 0"):
        TD3Config(yardstick_warmup=100, learning_starts=256, yardstick_regularization=-0.1)
    with pytest.raises(ValueError, match=f"at most {MAX_YARDSTICK_REGULARIZATION:g}"):
        TD3Config(yardstick_warmup=100, learning_starts=256, yardstick_regularization=50)
    learner = _learner(0.4)
    with pytest.raises(ValueError, match="needs warmup_batches"):
        for _ in range(2):  # the second is the actor's step
            learner.update([_pulling(np.random.default_rng(0))])


def test_the_warm_up_rows_are_sampled_only_while_the_ring_keeps_them():
    buffer, rng = ReplayBuffer(8, 1, 1), np.random.default_rng(0)
    for i in range(6):
        buffer.add(np.array([i]), np.array([0.0]), 0.0, np.array([i]), False)
    assert set(buffer.sample_first(3, 200, rng).obs[:, 0]) == {0.0, 1.0, 2.0}
    for i in range(6, 9):
        buffer.add(np.array([i]), np.array([0.0]), 0.0, np.array([i]), False)
    with pytest.raises(ValueError, match="the first 3 transitions were overwritten"):
        buffer.sample_first(3, 1, rng)


def test_a_setting_alone_is_checked_beside_the_warm_up_it_needs():
    """``--set yardstick_regularization=0.4`` is read on its own (the spec may give the warm-up);
    the whole config without a warm-up is refused."""
    assert TD3Config.parse_setting("yardstick_regularization", "0.4") == 0.4
    with pytest.raises(ValueError, match="regularization=20: yardstick_regularization must be at most"):
        TD3Config.parse_setting("yardstick_regularization", "20")
