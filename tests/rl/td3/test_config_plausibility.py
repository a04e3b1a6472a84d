"""A TD3 configuration that could never update a weight is refused (rl/td3/algorithm.py)."""

from __future__ import annotations

import pytest
from elastica_magnetic_rl.td3.config import TD3Config


def test_a_replay_buffer_smaller_than_the_batch_is_refused():
    with pytest.raises(ValueError, match=r"buffer_size \(100\) must be >= batch_size \(256\)"):
        TD3Config(buffer_size=100, batch_size=256)
    assert TD3Config(buffer_size=256, batch_size=256).buffer_size == 256


@pytest.mark.parametrize("hidden", [(), (64, 0)])
def test_hidden_layers_need_units(hidden):
    with pytest.raises(ValueError, match="hidden_sizes must be one or more layers"):
        TD3Config(hidden_sizes=hidden)


def test_updates_per_step_has_an_upper_bound(capsys):
    """``--set updates_per_step=1e9`` was accepted and stalled a run forever (round 4, S8)."""
    from elastica_magnetic_rl.td3.config import MAX_UPDATES_PER_STEP, TD3Config

    from elastica_magnetic.cli import main

    with pytest.raises(ValueError, match=r"updates_per_step must be a finite number in \(0, 64\]"):
        TD3Config(updates_per_step=1e9)
    assert TD3Config(updates_per_step=MAX_UPDATES_PER_STEP).updates_per_step == MAX_UPDATES_PER_STEP
    with pytest.raises(SystemExit) as refused:  # argparse: the value of --set
        main(["train", "--case", "m1-4mT", "--set", "updates_per_step=1e9", "--steps", "10",
              "--out", "/nonexistent-not-written"])
    assert refused.value.code == 2
    assert ("argument --set: updates_per_step=1e9: updates_per_step must be a finite number in "
            "(0, 64]") in capsys.readouterr().err


@pytest.mark.parametrize("rate", [0.0, -1.0, 3.0, float("nan")])
def test_a_learning_rate_that_cannot_learn_is_refused(rate):
    """Round 5, U21/U22: `--set actor_lr=0` trained to the end without changing a weight and
    reported "still improving"; -1 failed in the worker with torch's message."""
    from elastica_magnetic_rl.td3.config import TD3Config

    for name in ("actor_lr", "critic_lr"):
        with pytest.raises(ValueError, match=rf"{name} must be a finite number in \(0, 0.1\]"):
            TD3Config(**{name: rate})
