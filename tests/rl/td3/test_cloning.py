"""Starting TD3 from demonstrations (rl/td3/algorithm.py): the behaviour-cloning step and critic
updates that hold the actor (``TD3Config.yardstick_warmup``)."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from elastica_magnetic_rl.td3.algorithm import TD3
from elastica_magnetic_rl.td3.config import TD3Config
from elastica_magnetic_rl.td3.replay_buffer import Batch

torch.set_num_threads(1)
OBS, ACT = 3, 2


def _learner(seeds=(0,), **kw) -> TD3:
    configs = [TD3Config(seed=s, hidden_sizes=(32, 32), batch_size=64, **kw) for s in seeds]
    return TD3(OBS, ACT, -np.ones(ACT), np.ones(ACT), configs)


def _demonstrations(rng, n=64) -> Batch:
    """States and the actions of a fixed controller ``a = tanh(W s)``."""
    obs = rng.uniform(-1.0, 1.0, (n, OBS)).astype(np.float32)
    w = np.array([[1.5, -0.5, 0.0], [0.0, 1.0, -2.0]])
    actions = np.tanh(obs @ w.T).astype(np.float32)
    return Batch(obs, actions, rng.normal(size=(n, 1)).astype(np.float32), obs[::-1].copy(),
                 np.zeros((n, 1), np.float32))


def _actor_weights(learner: TD3) -> list[torch.Tensor]:
    return [p.detach().clone() for p in learner.actor_net.parameters()]


def test_cloning_brings_the_actor_to_the_actions_shown():
    learner, rng = _learner(), np.random.default_rng(0)
    first = float(learner.clone_step([_demonstrations(rng)])[0])
    for _ in range(400):
        last = float(learner.clone_step([_demonstrations(rng)])[0])
    assert last < 0.05 * first, (first, last)  # measured: 0.32 -> 0.004
    before = [p.detach().clone() for p in learner.critic_net.parameters()]
    assert all(torch.equal(a, b) for a, b in zip(before, learner.critic_net.parameters(), strict=True))


def test_critic_updates_that_hold_the_actor_change_only_the_critics_and_the_targets():
    learner, rng = _learner(), np.random.default_rng(1)
    learner.clone_step([_demonstrations(rng)])
    learner.hold_actor_targets()
    actor = _actor_weights(learner)
    target_actor = [p.detach().clone() for p in learner.actor_target_net.parameters()]
    assert all(torch.equal(a, b) for a, b in zip(actor, target_actor, strict=True))
    critic = [p.detach().clone() for p in learner.critic_net.parameters()]
    critic_target = [p.detach().clone() for p in learner.critic_target_net.parameters()]
    for _ in range(4):  # two policy-delay periods: the targets follow twice
        info = learner.update([_demonstrations(rng)], train_actor=False)
    assert "actor_loss" not in info
    assert all(torch.equal(a, b) for a, b in zip(actor, learner.actor_net.parameters(), strict=True))
    assert all(torch.equal(a, b) for a, b in zip(target_actor, learner.actor_target_net.parameters(),
                                                 strict=True))
    assert not all(torch.equal(a, b) for a, b in zip(critic, learner.critic_net.parameters(), strict=True))
    assert not all(torch.equal(a, b) for a, b in zip(critic_target, learner.critic_target_net.parameters(),
                                                     strict=True))
    # and an ordinary update does move the actor (the flag is what held it)
    for _ in range(2):
        learner.update([_demonstrations(rng)])
    assert not all(torch.equal(a, b) for a, b in zip(actor, learner.actor_net.parameters(), strict=True))


def test_a_seed_clones_the_same_in_a_stack_as_alone():
    alone, stack = _learner((5,)), _learner((4, 5))
    for step in range(30):
        batch = _demonstrations(np.random.default_rng(step))
        other = _demonstrations(np.random.default_rng(100 + step))
        a = alone.clone_step([batch])
        b = stack.clone_step([other, batch])
        assert float(a[0]) == float(b[1])
    for key, value in alone.actor_state(0).items():
        assert torch.equal(value, stack.actor_state(1)[key]), key


def test_a_warm_up_too_short_for_a_minibatch_is_refused():
    with pytest.raises(ValueError, match=r"learning_starts \(100\) must be at least batch_size \(256\)"):
        TD3Config(yardstick_warmup=500, learning_starts=100)
    with pytest.raises(ValueError, match="yardstick_warmup must be >= 0"):
        TD3Config(yardstick_warmup=-1)
    assert TD3Config.parse_setting("yardstick_warmup", "2e3") == 2000
