"""The replay buffer (rl/td3/replay_buffer.py): a ring of float32 transitions whose state round-trips."""

from __future__ import annotations

import numpy as np
import torch
from elastica_magnetic_rl.td3.replay_buffer import ReplayBuffer

torch.set_num_threads(1)


def test_replay_buffer_ring_dtype_and_state_roundtrip():
    buf = ReplayBuffer(4, obs_dim=2, act_dim=1)
    assert buf.obs.dtype == np.float32 and buf.obs.nbytes == 4 * 2 * 4
    for i in range(6):
        buf.add(np.full(2, i, np.float64), np.array([i / 10]), float(i), np.full(2, i + 1),
                terminated=(i == 5))
    assert len(buf) == 4 and buf.ptr == 2
    assert sorted(buf.rewards.tolist()) == [2.0, 3.0, 4.0, 5.0]
    assert buf.obs.dtype == np.float32 and buf.terminated[1] == 1.0  # i=5 went to slot 1
    batch = buf.sample(64, np.random.default_rng(0))
    np.testing.assert_array_equal(batch.next_obs[:, 0], batch.obs[:, 0] + 1)
    np.testing.assert_array_equal(batch.terminated, (batch.rewards == 5.0).astype(np.float32))

    same = ReplayBuffer(4, 2, 1)
    same.load_state_dict(buf.state_dict())
    assert (same.ptr, same.size) == (buf.ptr, buf.size)
    np.testing.assert_array_equal(same.obs, buf.obs)
    bigger = ReplayBuffer(10, 2, 1)  # into another capacity: chronological, oldest first
    bigger.load_state_dict(buf.state_dict())
    assert bigger.rewards[:4].tolist() == [2.0, 3.0, 4.0, 5.0] and bigger.ptr == 4
    smaller = ReplayBuffer(3, 2, 1)  # keeps the newest
    smaller.load_state_dict(buf.state_dict())
    assert smaller.rewards.tolist() == [3.0, 4.0, 5.0] and smaller.ptr == 0
