"""``msr train --randomize`` / recipe ``robust`` / ``[training.randomize]``: which robots a sweep
trains on, recorded in each run's case (run.json, checkpoint), kept by a resume. The draws
themselves: tests/rl/envs/test_randomization.py."""

from __future__ import annotations

import json

import pytest
from elastica_magnetic_rl.cases.case import case_from_dict, load_case
from elastica_magnetic_rl.cases.variations import DEFAULT_RANGES
from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint
from elastica_magnetic_rl.sweep.randomize_settings import randomized_cases
from smoke import run_msr

from elastica_magnetic.cli import main as msr


def _own_table_case():
    spec = load_case("m1-4mT").to_dict()
    spec["training"]["randomize"] = {"magnetization": "0.9:1.1"}
    return case_from_dict(spec, "own.toml")


def test_which_robots_a_sweep_trains_on():
    plain, own = load_case("m1-4mT"), _own_table_case()
    cases = {"m1-4mT": plain, "own": own}

    def names(out):
        return {name: [(v.name, v.low, v.high) for v in c.training.randomize] for name, c in out.items()}

    default = [(name, low, high) for name, (low, high) in DEFAULT_RANGES.items()]
    # no option: the spec's own table; the plain case follows its recipe (pink-ln: nominal)
    own_table = [("magnetization", 0.9, 1.1)]
    assert names(randomized_cases(cases, None, "pink-ln")) == {"m1-4mT": [], "own": own_table}
    # recipe robust: the default set where the spec has no table of its own
    assert names(randomized_cases(cases, None, "robust")) == {"m1-4mT": default, "own": own_table}
    # --randomize default / none override both
    assert names(randomized_cases(cases, "default", "pink-ln")) == {"m1-4mT": default, "own": default}
    assert names(randomized_cases(cases, "none", "robust")) == {"m1-4mT": [], "own": []}
    with pytest.raises(ValueError, match="--randomize must be default or none"):
        randomized_cases(cases, "magnetization", "robust")


def test_the_robust_recipe_records_its_ranges_in_the_run_and_a_resume_keeps_them(tmp_path, capsys):
    args = ["train", "--case", "m1-4mT", "--seeds", "1", "--out", str(tmp_path), "--set",
        "learning_starts=10", "--set", "batch_size=8", "--set", "hidden_sizes=8",
        "--episode-duration", "0.05", "--set", "eval_every=0", "--no-progress", "--recipe", "robust"]
    run_msr(capsys, *args, "--steps", "20")
    run = tmp_path / "m1-4mT" / "seed0"
    expected = {name: f"{low!r}:{high!r}" for name, (low, high) in DEFAULT_RANGES.items()}
    record = json.loads((run / "run.json").read_text())
    assert record["case_spec"]["training"]["randomize"] == expected
    assert load_checkpoint(run)["metadata"]["case_spec"]["training"]["randomize"] == expected
    # a resume that would train on other robots is refused, naming the table
    assert msr([*args, "--steps", "30", "--resume", "--randomize", "none"]) == 2
    assert "[training] randomize" in capsys.readouterr().err
    run_msr(capsys, *args, "--steps", "30", "--resume")
    assert load_checkpoint(run)["global_step"] == 30
