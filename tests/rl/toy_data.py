"""Toy training data for the rl tests that exercise TD3 updates without a simulator."""

from __future__ import annotations

import numpy as np
from elastica_magnetic_rl.td3.replay_buffer import ReplayBuffer


def random_replay_buffer(obs_dim: int, act_dim: int, n: int, seed: int = 0,
                         done_every: int = 9, capacity: int | None = None) -> ReplayBuffer:
    """A replay buffer (``capacity``, default ``n``) holding ``n`` random transitions: observations
    and rewards standard normal, actions uniform in [-1, 1], every ``done_every``-th one terminal."""
    rng = np.random.default_rng(seed)
    buf = ReplayBuffer(capacity or n, obs_dim, act_dim)
    for i in range(n):
        buf.add(rng.normal(size=obs_dim), rng.uniform(-1, 1, act_dim), rng.normal(),
                rng.normal(size=obs_dim), i % done_every == 0)
    return buf
