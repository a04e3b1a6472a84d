"""benchmarks/recipe_campaign.py: which seeds it trains, resumes, skips and exports."""

from __future__ import annotations

import json

import pytest
from benchmark_scripts import load_benchmark


@pytest.fixture(scope="module")
def campaign():
    return load_benchmark("recipe_campaign")


def test_the_plan_trains_what_is_missing_and_resumes_what_was_started(campaign, tmp_path,
                                                                      monkeypatch, capsys):
    policies, runs = tmp_path / "policies", tmp_path / "runs"
    exported = policies / "m1-4mT" / "seeds" / "pink" / "seeds.json"
    exported.parent.mkdir(parents=True)
    exported.write_text(json.dumps([{"seed": s, "distance_10s_m": 0.02, "actor": f"seed{s}"}
                                    for s in (0, 1, 5)]))
    states = {("pink", 2): "partial", ("pink", 3): "partial", ("pink", 4): "done",
              ("paper", 0): "partial"}

    def fake_state(run_dir, steps):
        assert steps == 100_000
        return states.get((run_dir.parent.parent.name, int(run_dir.name[4:])), "none")

    monkeypatch.setattr(campaign, "run_state", fake_state)
    batches, exports = campaign.plan({"m1-4mT": 100_000}, ["paper", "pink"], 8, runs, policies)
    assert [b.describe() for b in batches] == [
        "m1-4mT paper: resume seed 0", "m1-4mT paper: train seeds 1-7",
        "m1-4mT pink: resume seeds 2-3", "m1-4mT pink: train seeds 6-7"]
    assert exports == [("m1-4mT", "paper"), ("m1-4mT", "pink")]  # pink's seed 4: exported only
    # all eight exported: nothing to do
    exported.write_text(json.dumps([{"seed": s, "distance_10s_m": 0.02, "actor": f"seed{s}"}
                                    for s in range(8)]))
    assert campaign.plan({"m1-4mT": 100_000}, ["pink"], 8, runs, policies) == ([], [])
    # the dry run prints the plan and trains nothing; an unknown case fails before anything
    assert campaign.main(["--cases", "m1-4mT", "--recipes", "pink", "--policies", str(policies),
                          "--runs", str(runs), "--dry-run"]) == 0
    assert "0 training calls, 0 exports" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        campaign.main(["--cases", "no-such-case", "--dry-run"])
    assert "unknown case 'no-such-case'" in capsys.readouterr().err


def test_a_screen_trains_only_the_seeds_it_names(campaign, tmp_path, monkeypatch, capsys):
    """``--only 2 3 7``: those seeds and no other (seed 3 already exported: skipped)."""
    policies, runs = tmp_path / "policies", tmp_path / "runs"
    exported = policies / "m1-10mT" / "seeds" / "pink-ln" / "seeds.json"
    exported.parent.mkdir(parents=True)
    exported.write_text(json.dumps([{"seed": 3, "distance_10s_m": 0.2, "actor": "seed3"}]))
    monkeypatch.setattr(campaign, "run_state", lambda run_dir, steps: "none")
    batches, exports = campaign.plan({"m1-10mT": 100_000}, ["pink-ln"], [2, 3, 7], runs,
                                     policies)
    assert [b.describe() for b in batches] == ["m1-10mT pink-ln: train seed 2",
                                               "m1-10mT pink-ln: train seed 7"]
    assert exports == [("m1-10mT", "pink-ln")]
    assert campaign.main(["--cases", "m1-10mT", "--recipes", "pink-ln", "--only", "2", "3",
                          "--policies", str(policies), "--runs", str(runs), "--dry-run"]) == 0
    assert "m1-10mT pink-ln: train seed 2\n" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        campaign.main(["--cases", "m1-10mT", "--only", "-1", "--dry-run"])
    assert "--only takes seeds >= 0" in capsys.readouterr().err


def test_each_pair_is_exported_as_soon_as_its_last_seed_is_trained(campaign):
    """A campaign cut short has exported every (case, recipe) it finished; a pair with nothing
    left to train is exported first."""
    Batch = campaign.Batch
    batches = [Batch("m2-4mT", "pink-ln", 6, 2, True), Batch("m2-10mT", "pink-ln", 0, 4, False),
               Batch("m2-10mT", "pink-ln", 4, 4, True)]
    exports = [("m1-4mT", "paper"), ("m2-4mT", "pink-ln"), ("m2-10mT", "pink-ln")]
    assert campaign.schedule(batches, exports) == [
        ("m1-4mT", "paper"), batches[0], ("m2-4mT", "pink-ln"), batches[1], batches[2],
        ("m2-10mT", "pink-ln")]
    assert campaign.schedule([], []) == []
