"""benchmarks/stop_rule_replay.py: the replay of the ``target`` stop rule on the committed
``pink-ln`` seeds reproduces the numbers quoted in docs/training.md (stopping seeds that have learned)."""

from __future__ import annotations

import pytest
from benchmark_scripts import load_benchmark


@pytest.fixture(scope="module")
def replay():
    return load_benchmark("stop_rule_replay")


def test_the_quoted_fractions_come_from_the_committed_evaluations(replay, capsys):
    quoted = {"m1-4mT": 0.54, "m1-10mT": 0.52, "m2-4mT": 0.54, "m2-10mT": 0.52}
    for case, fraction in quoted.items():
        r = replay.replay(case, "pink-ln", 2, 100_000)
        assert len(r["seeds"]) == 8 and round(r["steps_run_fraction"], 2) == fraction
    k3 = [replay.replay(case, "pink-ln", 3, 100_000)["steps_run_fraction"] for case in quoted]
    assert k3 == pytest.approx([0.58, 0.615, 0.5775, 0.5975])
    assert replay.main(["--consecutive", "2"]) == 0
    assert "m1-10mT" in capsys.readouterr().out


def test_the_rule_fires_at_the_first_step_with_k_evaluations_at_the_threshold(replay):
    from elastica_magnetic_rl.runner.stopping import StopRule

    rows = [{"global_step": str(s), "mean_return": str(r)}
            for s, r in ((5000, 10), (10000, 300), (15000, 100), (20000, 250), (25000, 260))]
    assert replay.stop_step(rows, StopRule("target", threshold=205.0, consecutive=2)) == 25000
    assert replay.stop_step(rows, StopRule("target", threshold=205.0, consecutive=1)) == 10000
    assert replay.stop_step(rows, StopRule("target", threshold=500.0)) is None
