"""``msr train --stop-when`` (rl/sweep/stop_settings.py): the case's rule, its refusals before any
work, recording it in the run, a resume keeping it, and what summary.json says of each seed. The
stopping itself (a seed leaves its group, the others bit-identical): tests/rl/runner/test_loop.py."""

from __future__ import annotations

import json

import pytest
from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint
from elastica_magnetic_rl.runner.stopping import StopRule
from elastica_magnetic_rl.sweep.stop_settings import (
    case_stop_rule,
    recipe_stop_when,
    seed_state,
    stop_record,
    stop_summary,
)
from smoke import run_msr

from elastica_magnetic.cli import main as msr


def test_the_target_is_the_yardstick_as_an_evaluation_return():
    rule = case_stop_rule(load_case("m1-4mT"), "target", consecutive=3, eval_every=5000)
    # 1/m x m; confirmed in the accurate physics unless asked not to
    assert rule == StopRule("target", threshold=1e4 * 0.0205, consecutive=3, confirm="accurate")
    unconfirmed = case_stop_rule(load_case("m1-4mT"), "target", confirm="none", eval_every=5000)
    assert unconfirmed == StopRule("target", threshold=1e4 * 0.0205)
    assert "confirm" not in unconfirmed.to_dict()
    with pytest.raises(ValueError, match="--stop-confirm is for --stop-when target"):
        case_stop_rule(load_case("m1-4mT"), "plateau", confirm="accurate")
    with pytest.raises(ValueError, match="--stop-confirm needs --stop-when"):
        case_stop_rule(load_case("m1-4mT"), None, confirm="accurate")
    assert case_stop_rule(load_case("m1-4mT"), None) is None
    with pytest.raises(ValueError, match="'m1-4mT-reach' has no target return.*'reach'"):
        case_stop_rule(load_case("m1-4mT-reach"), "target")
    no_stick = load_case("m1-4mT").to_dict() | {"name": "no-stick"}
    no_stick["yardstick"] = {"distance_10s": 0.0, "source": ""}
    with pytest.raises(ValueError, match="'no-stick' has no target return.*distance_10s = 0 m"):
        case_stop_rule(load_case(no_stick), "target")
    # hu2018-crawl's yardstick: the rotating field's +25.3 mm (docs/training.md)
    assert case_stop_rule(load_case("hu2018-crawl"), "target", confirm="none").threshold == \
        pytest.approx(1e4 * 0.0253)
    with pytest.raises(ValueError, match="needs --set eval_every > 0"):
        case_stop_rule(load_case("m1-4mT"), "plateau", eval_every=0)
    with pytest.raises(ValueError, match="--stop-consecutive is for --stop-when target"):
        case_stop_rule(load_case("m1-4mT"), "plateau", consecutive=2)
    with pytest.raises(ValueError, match="--stop-patience needs --stop-when"):
        case_stop_rule(load_case("m1-4mT"), None, patience=2)
    assert recipe_stop_when(None, "pink-ln") is None and recipe_stop_when("none", "pink-ln") is None


def test_stop_when_is_refused_before_any_run_folder_is_made(tmp_path, capsys):
    base = ["train", "--seeds", "1", "--steps", "20", "--out", str(tmp_path), "--no-progress"]
    assert msr([*base, "--case", "m1-4mT-reach", "--stop-when", "target"]) == 2
    assert "has no target return" in capsys.readouterr().err
    assert msr([*base, "--case", "m1-4mT", "--stop-when", "target", "--set", "eval_every=0"]) == 2
    assert "--set eval_every > 0" in capsys.readouterr().err
    with pytest.raises(SystemExit) as refused:  # argparse: the option's range
        msr([*base, "--case", "m1-4mT", "--stop-when", "plateau", "--stop-tolerance", "-1"])
    assert refused.value.code == 2
    assert "--stop-tolerance: expected a fraction of the best return in [0, 1), got -1" in (
        capsys.readouterr().err)
    assert not any(tmp_path.iterdir())


def test_the_rule_is_recorded_and_a_resume_keeps_it(tmp_path, capsys):
    args = ["train", "--case", "m1-4mT", "--seeds", "1", "--out", str(tmp_path), "--set",
        "learning_starts=10", "--set", "batch_size=8", "--set", "hidden_sizes=8",
        "--episode-duration", "0.1", "--set", "eval_every=10", "--no-progress"]
    summary = run_msr(capsys, *args, "--steps", "20", "--stop-when", "target")
    run = tmp_path / "m1-4mT" / "seed0"
    rule = StopRule("target", threshold=205.0, confirm="accurate").to_dict()
    assert json.loads((run / "run.json").read_text())["stop_rule"] == rule
    assert load_checkpoint(run)["stop_rule"] == rule
    seed = summary["seeds"][0]  # an untrained crawler is nowhere near 20.5 mm: it runs on
    assert (seed["stopped_early"], seed["stop_reason"], seed["stop_step"], seed["steps_saved"]) == (
        False, None, None, 0)
    assert seed["state"] in ("still improving", "plateaued")
    assert summary["stop_rule"] == rule and summary["stopped_early"] == []
    assert summary["steps_run_fraction"] == 1.0
    assert msr([*args, "--steps", "30", "--resume", "--stop-when", "plateau"]) == 2
    err = capsys.readouterr().err
    assert "stop rule is target" in err and "not plateau" in err
    assert msr([*args, "--steps", "30", "--resume", "--stop-when", "none"]) == 2
    assert "not none" in capsys.readouterr().err
    summary = run_msr(capsys, *args, "--steps", "30", "--resume")  # keeps the run's rule
    assert summary["stop_rule"] == rule and load_checkpoint(run)["global_step"] == 30


def test_summary_entries_of_a_stopped_seed(tmp_path):
    ckpt = {"stopped": {"step": 40000, "reason": "target: ...", "rule": {}}}
    record = stop_record(ckpt, 100_000)
    assert record == {"stopped_early": True, "stop_reason": "target: ...", "stop_step": 40000,
                      "steps_saved": 60000}
    assert seed_state(tmp_path, record, 205.0) == "stopped"
    (tmp_path / "evaluations.csv").write_text("global_step,mean_return\n5000,10\n10000,210\n")
    assert seed_state(tmp_path, stop_record({}, 10), 205.0) == "learned"
    assert seed_state(tmp_path, stop_record({}, 10), None) == "still improving"
    summary = stop_summary([{"seed": 0, **record}, {"seed": 1, **stop_record({}, 100_000)}], 100_000,
                           None)
    assert summary["stopped_early"] == [0] and summary["steps_run_fraction"] == pytest.approx(0.7)


def test_the_fast_recipe_carries_the_target_rule_and_none_turns_it_off():
    from elastica_magnetic_rl.cases.recipes import crawler_config

    assert recipe_stop_when(None, "fast") == "target"
    assert recipe_stop_when("none", "fast") is None
    assert recipe_stop_when("plateau", "fast") == "plateau"
    cfg = crawler_config(0, "fast")
    assert cfg.hidden_sizes == (256, 256) and cfg.actor_widths == (256, 256)
    assert cfg.critic_layer_norm and cfg.noise_color == 1.0
    assert cfg.batch_size == 128 and cfg.precision == "bf16"


def test_every_recipe_runs_the_cases_steps_unless_steps_are_given():
    """A run takes the case's steps per seed (a ``fast`` seed may stop before them); given
    steps win."""
    from elastica_magnetic_rl.cases.case import load_case
    from elastica_magnetic_rl.sweep.sweep_plan import case_defaults as _case_defaults

    case = load_case("m1-4mT")
    assert case.training.steps == 100_000
    loaded = {case.name: case}
    assert _case_defaults(loaded, None, None, "fast")[0] == 100_000
    assert _case_defaults(loaded, 30_000, None, "fast")[0] == 30_000
    assert _case_defaults(loaded, None, None, None) == (100_000, case.task.episode_duration, "pink-ln")


def test_the_fast_recipes_target_rule_is_off_with_a_warning_for_a_case_without_a_target(
        tmp_path, capsys):
    """``msr train --case m1-4mT-goto --recipe fast``: the recipe's default stop rule cannot act on
    a goto case (no target return); the seeds train their full steps, and the run says so. (The
    case's spec with 2 s episodes instead of 30, so that its one evaluation, a whole episode, is
    short.)"""
    from elastica_magnetic_rl.cases.case import SPECS_DIR

    text = (SPECS_DIR / "m1-4mT-goto.toml").read_text()
    assert text.count("episode_duration = 30.0") == 1
    spec = tmp_path / "spec" / "m1-4mT-goto.toml"
    spec.parent.mkdir()
    spec.write_text(text.replace("episode_duration = 30.0", "episode_duration = 2.0"))
    args = ["train", "--case", str(spec), "--recipe", "fast", "--seeds", "1", "--steps", "20",
            "--out", str(tmp_path), "--set", "learning_starts=10", "--set", "batch_size=8",
            "--set", "hidden_sizes=8", "--episode-duration", "0.1", "--no-progress"]
    assert msr(args) == 0
    err = capsys.readouterr().err
    assert ("warning: case 'm1-4mT-goto' has no target return (task 'goto', judged on its targets, "
            "not on one evaluation's return): the recipe's target stop rule is off for it") in err
    summary = json.loads((tmp_path / "m1-4mT-goto" / "summary.json").read_text())
    assert summary["stop_rule"] is None and summary["steps_run_fraction"] == 1.0
    assert summary["evaluation_duration_s"] == 2.0  # a goto evaluation runs the whole episode
