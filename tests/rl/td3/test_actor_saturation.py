"""The actor's saturation penalty (``TD3Config.actor_saturation_penalty``): it changes nothing
while the actor's pre-``tanh`` outputs stay below 3 in size, and it brings a saturated actor back
to where ``tanh`` passes the critic's gradient, which the plain loss does not."""

from __future__ import annotations

import dataclasses

import numpy as np
import torch
from elastica_magnetic_rl.td3.algorithm import TD3
from elastica_magnetic_rl.td3.config import SATURATION_PREACTIVATION, TD3Config
from elastica_magnetic_rl.td3.replay_buffer import ReplayBuffer
from state_compare import assert_state_equal
from toy_data import random_replay_buffer

torch.set_num_threads(1)
OBS_DIM, ACT_DIM = 4, 2
LOW, HIGH = -np.ones(ACT_DIM), np.ones(ACT_DIM)


def _buffer(seed: int = 0, n: int = 128) -> ReplayBuffer:
    return random_replay_buffer(OBS_DIM, ACT_DIM, n, seed, done_every=11)


def _train(cfg: TD3Config, buf: ReplayBuffer, updates: int, actor_scale: float = 1.0) -> TD3:
    agent = TD3(OBS_DIM, ACT_DIM, LOW, HIGH, [cfg])
    with torch.no_grad():  # scale the output layer: pre-tanh outputs grow by actor_scale
        agent.actor_net.weights[-1].mul_(actor_scale)
        agent.actor_net.biases[-1].mul_(actor_scale)
    for _ in range(updates):
        agent.update([buf.sample(cfg.batch_size, agent.rngs[0])])
    return agent


def _saturated_fraction(agent: TD3, buf: ReplayBuffer) -> float:
    obs = torch.as_tensor(buf.obs[: buf.size]).unsqueeze(0)
    with torch.no_grad():
        pre = agent.actor_net(obs)
    return float((pre.abs() > SATURATION_PREACTIVATION).float().mean())


def test_the_penalty_changes_nothing_below_saturation():
    """A fresh actor's outputs are far below 3 in size: with and without the penalty, the same
    updates give the same networks, bit for bit."""
    buf = _buffer()
    cfg = TD3Config(seed=2, hidden_sizes=(16, 16), batch_size=32)
    plain = _train(cfg, buf, 6)
    penalised = _train(dataclasses.replace(cfg, actor_saturation_penalty=1.0), buf, 6)
    assert _saturated_fraction(plain, buf) == 0.0
    assert_state_equal(plain.seed_state(0), penalised.seed_state(0), "below saturation")


def test_the_penalty_brings_a_saturated_actor_back():
    """An actor whose outputs are scaled into saturation (|u| ~ 9 on average, 3/4 of the states
    beyond 3) stays saturated under the plain loss, whose gradient ``tanh'`` has all but removed;
    with the penalty most states come back below 3 within 500 updates."""
    buf = _buffer(1)
    cfg = TD3Config(seed=5, hidden_sizes=(16, 16), batch_size=32, policy_delay=1)
    assert _saturated_fraction(_train(cfg, buf, 1, actor_scale=50.0), buf) > 0.7
    plain = _train(cfg, buf, 500, actor_scale=50.0)
    penalised = _train(dataclasses.replace(cfg, actor_saturation_penalty=1.0), buf, 500,
                       actor_scale=50.0)
    assert _saturated_fraction(plain, buf) > 0.75
    assert _saturated_fraction(penalised, buf) < 0.25


def test_the_penalty_is_checked():
    for bad in (-1.0, float("nan")):
        try:
            TD3Config(actor_saturation_penalty=bad)
        except ValueError as exc:
            assert "actor_saturation_penalty" in str(exc)
        else:
            raise AssertionError(f"actor_saturation_penalty={bad} was accepted")
