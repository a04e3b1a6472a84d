"""benchmarks/robust_selection.py: which seed's waveform is shipped as ``<case>-robust``, and the
study's loop over a case's committed seeds (each seed's scoring, msr real robustness's library, is
replaced by a stand-in here; msr real robustness has its own tests), its choice in selection.json."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from benchmark_scripts import load_benchmark


@pytest.fixture(scope="module")
def selection():
    return load_benchmark("robust_selection")


def test_the_choice_is_the_largest_worst_case_among_seeds_that_reach_the_yardstick(selection):
    rows = [{"seed": 0, "meets_target": True, "worst_m": 0.09},
            {"seed": 1, "meets_target": False, "worst_m": 0.15},  # robust but fails nominally
            {"seed": 2, "meets_target": True, "worst_m": 0.12},
            {"seed": 3, "meets_target": None, "worst_m": 0.20},   # no verdict: not eligible
            {"seed": 4, "meets_target": True, "worst_m": None}]   # every variant diverged
    assert selection.choose_seed(rows)["seed"] == 2
    assert selection.choose_seed([r for r in rows if r["seed"] in (1, 3)]) is None


def test_the_study_scores_a_committed_seed_and_writes_its_choice(selection, tmp_path, monkeypatch):
    calls = []

    def fake_score(folder, out, workers, progress):
        calls.append(Path(folder).name)
        worst = {"seed0": 0.01, "seed1": 0.02}.get(Path(folder).name, 0.0)
        return {"nominal_m": 0.03, "worst_m": worst, "worst_variant": "magnetization x0.85",
                "p10_m": worst, "worst_fraction": None, "p10_fraction": None}

    monkeypatch.setattr(selection, "score_seed", fake_score)
    policies = tmp_path / "policies"
    folder = policies / "m1-4mT" / "seeds" / "robust"
    folder.mkdir(parents=True)
    folder.joinpath("seeds.json").write_text(json.dumps([
        {"seed": 0, "distance_10s_m": 0.021, "actor": "seed0", "meets_target": True},
        {"seed": 1, "distance_10s_m": 0.019, "actor": "seed1", "meets_target": False},
        {"seed": 2, "distance_10s_m": 0.022, "actor": "seed2", "meets_target": True}]))
    out = tmp_path / "out"
    assert selection.main(["--case", "m1-4mT", "--policies", str(policies), "--out", str(out),
                           "--only", "0", "1", "--no-progress"]) == 0
    assert calls == ["seed0", "seed1"]
    result = json.loads((out / "m1-4mT-robust" / "selection.json").read_text())
    assert result["chosen_seed"] == 0 and [r["seed"] for r in result["seeds"]] == [0, 1]
