"""A residual learner's setting and start (``TD3Config.residual``, rl/td3/algorithm.py): checked as a
weight in range, refused beside a clone of the yardstick, and its actor starts at a zero correction
with every other weight as a plain learner of the same seed draws it."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from elastica_magnetic_rl.td3.algorithm import TD3
from elastica_magnetic_rl.td3.config import MAX_RESIDUAL, TD3Config


@pytest.mark.parametrize("value", [-0.1, MAX_RESIDUAL + 0.5, float("nan")])
def test_a_residual_weight_out_of_range_is_refused_by_name(value):
    with pytest.raises(ValueError, match=r"residual must be a number in \[0, 2\]"):
        TD3Config(residual=value)


def test_a_residual_learner_has_no_clone_to_make():
    with pytest.raises(ValueError, match="residual 0.5 starts the actor at the yardstick.*warmup must be 0"):
        TD3Config(residual=0.5, yardstick_warmup=100, learning_starts=300)


def test_the_setting_reads_from_the_command_line():
    assert TD3Config.parse_setting("residual", "0.5") == 0.5
    with pytest.raises(ValueError, match="residual=3"):
        TD3Config.parse_setting("residual", "3")


def _learner(residual: float, actor_input: str = "observation", obs_dim: int = 12) -> TD3:
    cfg = TD3Config(hidden_sizes=(16, 16), residual=residual, actor_input=actor_input, seed=7)
    return TD3(obs_dim, 3, -np.ones(3), np.ones(3), [cfg])


@pytest.mark.parametrize("actor_input", ["observation", "steering"])
def test_the_actor_starts_at_a_zero_correction_and_the_rest_as_drawn(actor_input):
    residual, plain = _learner(0.5, actor_input), _learner(0.0, actor_input)
    obs = np.random.default_rng(0).normal(size=(1, 5, 12)).astype(np.float32)
    obs[..., -5:-3] = [0.6, 0.8]  # a heading of unit length for the steering actor
    acted = residual.select_actions(obs, explore=False)
    np.testing.assert_array_equal(acted, np.zeros((1, 5, 3), np.float32))
    assert np.abs(plain.select_actions(obs, explore=False)).max() > 0.0
    state, other = residual.actor_state(0), plain.actor_state(0)
    last = max(int(k.split(".")[1]) for k in state if k.startswith("net."))
    for key in state:
        if key.startswith(f"net.{last}."):
            assert not state[key].any(), key
        else:
            assert torch.equal(state[key], other[key]), key
