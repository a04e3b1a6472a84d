"""Shared pieces of the learning package's tests.

The helper modules beside this file (``benchmark_scripts``, ``smoke``, ``spec_matrix``, ``state_compare``,
``toy_data``, ``toy_env``) are imported by name from the test folders below it: pytest puts this
folder on ``sys.path`` because it holds a ``conftest.py``.

The training runs that many tests read are made here, once per test session (``trained``: ``msr
train`` of 2 seeds; ``refined``: ``msr refine`` of its seed 0; ``catheter_run``: a smoke training of a
catheter case), whichever test modules use them.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from smoke import NOT_RESIDUAL, SMOKE, TRAIN_STEPS

from elastica_magnetic.cli import main as msr


@pytest.fixture(scope="session")
def trained(tmp_path_factory) -> Path:
    """``msr train`` smoke run: 2 seeds in 2 processes, training physics, tiny networks."""
    out = tmp_path_factory.mktemp("runs")
    status = msr(["train", "--case", "m1-4mT", "--seeds", "2", "--workers", "2", "--steps",
                  str(TRAIN_STEPS), "--out", str(out), *SMOKE])
    assert status == 0
    return out


@pytest.fixture(scope="session")
def refined(trained) -> Path:
    """``msr refine`` of ``trained``'s seed 0 (3 steps in the accurate physics)."""
    run = trained / "m1-4mT" / "seed0"
    assert msr(["refine", str(run), "--checkpoint", "final", "--steps", "3",
                "--episode-duration", "0.02", "--no-progress"]) == 0
    return run / "refined"


@pytest.fixture(scope="session")
def catheter_run(tmp_path_factory) -> Path:
    """A smoke training of the shipped magnet-arm catheter case (seconds; an untrained actor):
    its seed 0's run folder."""
    out = tmp_path_factory.mktemp("catheter_runs")
    assert msr(["train", "--case", "catheter-magnet-reach", "--seeds", "1", "--workers", "1", "--steps",
                "160", "--out", str(out), *SMOKE, *NOT_RESIDUAL, "--set", "yardstick_warmup=20"]) == 0
    return out / "catheter-magnet-reach" / "seed0"
