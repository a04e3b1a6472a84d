"""A TD3 configuration that could never update a weight is refused (rl/td3/algorithm.py)."""

from __future__ import annotations

import pytest
from elastica_magnetic_rl.td3.algorithm import TD3Config


def test_a_replay_buffer_smaller_than_the_batch_is_refused():
    with pytest.raises(ValueError, match=r"buffer_size \(100\) must be >= batch_size \(256\)"):
        TD3Config(buffer_size=100, batch_size=256)
    assert TD3Config(buffer_size=256, batch_size=256).buffer_size == 256


@pytest.mark.parametrize("hidden", [(), (64, 0)])
def test_hidden_layers_need_units(hidden):
    with pytest.raises(ValueError, match="hidden_sizes must be one or more layers"):
        TD3Config(hidden_sizes=hidden)
