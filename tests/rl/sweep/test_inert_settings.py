"""Training settings that cannot act (rl/sweep/inert_settings.py), refused before any work: a warm-up
at or beyond the run, a minibatch larger than the run, too few updates per transition, a warm-up
longer than the replay buffer, a stop rule that cannot decide; legitimate settings pass."""

from __future__ import annotations

import pytest
from elastica_magnetic_rl.cases.recipes import crawler_config
from elastica_magnetic_rl.runner.stopping import StopRule
from elastica_magnetic_rl.sweep.inert_settings import (
    SettingSources,
    check_run_learns,
    check_stop_rule_decides,
)

from elastica_magnetic.cli import main as msr


def _train(tmp_path, *argv: str) -> list[str]:
    return ["train", "--case", "m1-4mT", "--seeds", "1", "--out", str(tmp_path / "runs"),
            "--no-progress", *argv]


def test_a_default_warm_up_beyond_the_steps_is_refused_before_any_folder(tmp_path, capsys):
    """The new user's run: --steps 1000 with the default warm-up of 2500 steps trained nothing and
    reported 'still improving'; now refused, naming both numbers and where to change them."""
    assert msr(_train(tmp_path, "--steps", "1000")) == 2
    err = capsys.readouterr().err
    assert "msr train: error: the warm-up is the whole run: learning_starts 2500 (the default; " \
           "--set learning_starts=... or [training.td3] learning_starts sets it) is at or beyond " \
           "--steps 1000" in err
    assert "give --set learning_starts below 1000 or --steps above 2500" in err
    assert "Traceback" not in err and not (tmp_path / "runs").exists()
    assert msr(_train(tmp_path, "--steps", "60", "--set", "learning_starts=60")) == 2  # at: no update
    assert "--set learning_starts=60 is at or beyond --steps 60" in capsys.readouterr().err


def test_a_spec_warm_up_beyond_its_steps_is_refused_naming_the_spec_keys(tmp_path, capsys):
    from elastica_magnetic_rl.cases.case import load_case

    from elastica_magnetic.specfile import dumps

    spec = load_case("m1-4mT").to_dict()
    spec["training"]["steps"] = 300
    spec["training"]["td3"] = {"learning_starts": 500}
    path = tmp_path / "mine.toml"
    path.write_text(dumps(spec))
    assert msr(["train", "--case", str(path), "--seeds", "1", "--out", str(tmp_path / "runs"),
                "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert (f"[training.td3] learning_starts = 500 ({path}) is at or beyond [training] steps = 300 "
            f"({path})") in err


def test_options_that_can_never_update_a_weight_are_refused(tmp_path, capsys):
    base = ("--steps", "1000", "--set", "learning_starts=10")
    assert msr(_train(tmp_path, *base, "--set", "batch_size=2000", "--set", "buffer_size=4000")) == 2
    assert "no minibatch in the whole run: --set batch_size=2000 is larger than --steps 1000" in \
        capsys.readouterr().err
    assert msr(_train(tmp_path, *base, "--set", "batch_size=10", "--set", "updates_per_step=0.001")) == 2
    err = capsys.readouterr().err
    assert "not one update in the whole run: --set updates_per_step=0.001 over the 990 transitions" in err
    assert "--set updates_per_step of at least 0.00101" in err
    assert msr(_train(tmp_path, "--steps", "5000", "--set", "learning_starts=3000", "--set",
        "buffer_size=1000", "--set", "batch_size=100")) == 2
    err = capsys.readouterr().err
    assert ("the warm-up outgrows the replay buffer: --set learning_starts=3000 is above --set "
            "buffer_size=1000") in err and "the first 2000 are overwritten" in err
    assert not (tmp_path / "runs").exists()


def test_a_stop_rule_that_cannot_decide_within_the_run_is_refused(tmp_path, capsys):
    base = ("--steps", "1000", "--set", "learning_starts=10", "--set", "batch_size=8")
    assert msr(_train(tmp_path, *base, "--stop-when", "plateau", "--set", "eval_every=500")) == 2
    err = capsys.readouterr().err
    assert ("--stop-when plateau cannot decide within the run: it needs 7 evaluations, and --steps "
            "1000 with --set eval_every=500 makes at most 2") in err
    # m1-4mT's 20 s episodes: one evaluation per episode end at most (round 25, V1: the advice had
    # been eval_every of at most 166 or --steps of at least 3001, neither of which decides)
    assert ("evaluations come at episode ends, at most one per episode of 20 s (2000 steps), so a shorter "
            "eval_every cannot add enough: give --steps of at least 14000, or --stop-when none") in err
    assert msr(_train(tmp_path, *base, "--stop-when", "target")) == 2  # the default 5000 steps
    assert "eval_every 5000 (the default; --set eval_every=... or [training.td3] eval_every sets it) " \
           "makes at most 1" in capsys.readouterr().err
    assert not (tmp_path / "runs").exists()


@pytest.mark.parametrize(("steps", "overrides"), [
    (240, {"learning_starts": 60, "batch_size": 32, "eval_every": 120}),  # the smoke runs
    (20, {"learning_starts": 10, "batch_size": 8, "updates_per_step": 0.5}),
    (100_000, {}),  # the paper's
    (80, {"learning_starts": 60, "batch_size": 32, "eval_every": 120, "checkpoint_every": 200}),
])
def test_settings_that_act_pass(steps, overrides):
    """An evaluation or checkpoint interval longer than the run still acts (the final evaluation
    and checkpoint of every run): not refused."""
    config = crawler_config(0, "pink-ln", **overrides)
    check_run_learns(config, steps, SettingSources(overrides))
    check_stop_rule_decides(StopRule("target", threshold=1.0), crawler_config(0, eval_every=10),
                            20, 1, SettingSources())


def test_a_resumed_run_is_told_only_to_train_longer():
    config = crawler_config(0, learning_starts=2500)
    with pytest.raises(ValueError, match=r"the run's learning_starts 2500 \(a resumed run keeps it\) "
                                         r"is at or beyond --steps 2000.*give --steps above 2500$"):
        check_run_learns(config, 2000, SettingSources(resumed=True))
