"""The smoke settings of the learning package's ``msr`` tests, and running ``msr`` for its JSON."""

from __future__ import annotations

import json

from elastica_magnetic.cli import main as msr

#: Steps per seed of the shared training run (tests/rl/conftest.py's ``trained``).
TRAIN_STEPS = 240
#: s: the smoke runs' evaluations (the case's 10 s would be most of a smoke run's time).
EVAL_DURATION = 0.8
#: Tiny networks, short episodes and evaluations: a training run of seconds.
SMOKE = ["--set", "learning_starts=60", "--set", "batch_size=32", "--set", "hidden_sizes=32,32",
         "--episode-duration", "0.8", "--set", "checkpoint_every=80", "--set", "eval_every=120",
         "--set", f"eval_duration={EVAL_DURATION}", "--set", "eval_episodes=1", "--set", "critic_warmup=0",
         "--no-progress"]
#: The smallest training that updates its networks: a 10-step warm-up, batches of 8, one hidden
#: layer of 8, evaluations of 0.1 s (the case's 10 s evaluation would be most of such a run's time).
#: A clone of the yardstick (``--set yardstick_warmup=N``) on a case whose ``[training.td3]`` trains a
#: residual learner (the shipped goto and catheter cases): no correction, no penalty on one.
NOT_RESIDUAL = ["--set", "residual=0", "--set", "correction_penalty=0"]
TINY = ["--set", "learning_starts=10", "--set", "batch_size=8", "--set", "hidden_sizes=8",
        "--set", "eval_duration=0.1"]


def run_msr(capsys, *argv: str) -> dict:
    """``msr ARGV --json``, which must succeed; its printed JSON."""
    capsys.readouterr()
    status = msr([*argv, "--json"])
    out = capsys.readouterr().out
    assert status == 0, out
    return json.loads(out)
