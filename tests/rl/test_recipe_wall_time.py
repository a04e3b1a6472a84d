"""benchmarks/recipe_wall_time.py: the reference wall time runs the named recipe without its stop
rule, and refuses a run of nothing."""

from __future__ import annotations

import pytest
from benchmark_scripts import load_benchmark


@pytest.fixture(scope="module")
def wall_time():
    return load_benchmark("recipe_wall_time")


class _Captured(Exception):
    pass


def test_the_runs_train_the_named_recipe_with_no_stop_rule(wall_time, monkeypatch):
    """Both runs of the projection (warm-up, then the resumed window) get the recipe and
    ``stop_when="none"``: a ``fast`` reference whose seeds stopped would time less than 1e5 steps."""
    import elastica_magnetic_rl.sweep.training as training

    calls = []

    def fake_train_case(case, seeds, **kwargs):
        calls.append({"case": case, "seeds": seeds, **kwargs})
        raise _Captured

    monkeypatch.setattr(training, "train_case", fake_train_case)
    with pytest.raises(_Captured):
        wall_time.main(["--case", "m1-4mT", "--recipe", "fast", "--seeds", "3"])
    (call,) = calls
    assert call["case"] == "m1-4mT" and call["seeds"] == 3
    assert call["recipe"] == "fast" and call["stop_when"] == "none"
    assert "precision" not in call["config_overrides"]  # the recipe's bfloat16, not overridden
    assert call["steps"] == 2500  # the recipe's warm-up (learning_starts)


def test_a_run_of_nothing_is_refused_before_any_training(wall_time, capsys):
    with pytest.raises(SystemExit) as stop:
        wall_time.main(["--seeds", "0"])
    assert stop.value.code == 2 and "--seeds and --window must be >= 1" in capsys.readouterr().err
