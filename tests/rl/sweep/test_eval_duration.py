"""``--set eval_duration=S``: the periodic evaluations run S seconds instead of the case's 10 s,
the summary says so, a resumed run keeps its own, and a ``target`` stop rule (which compares with
the yardstick's 10 s return) is refused with it."""

from __future__ import annotations

import csv
import json
import shutil

import pytest
from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.sweep.stop_settings import case_stop_rule
from elastica_magnetic_rl.td3.config import TD3Config
from smoke import EVAL_DURATION, SMOKE, TRAIN_STEPS

from elastica_magnetic.cli import main as msr


def _lengths(run) -> list[float]:
    with open(run / "evaluations.csv", newline="") as f:
        return [float(row["mean_length"]) for row in csv.DictReader(f)]


def test_the_evaluations_run_the_given_seconds(trained):
    """The shared smoke run evaluates EVAL_DURATION s (80 control steps), not 10 s (1000)."""
    for seed in (0, 1):
        lengths = _lengths(trained / "m1-4mT" / f"seed{seed}")
        assert lengths and all(n == round(EVAL_DURATION / 0.01) for n in lengths), lengths
    summary = json.loads((trained / "m1-4mT" / "summary.json").read_text())
    assert summary["evaluation_duration_s"] == EVAL_DURATION
    assert {s["evaluation_duration_s"] for s in summary["seeds"]} == {EVAL_DURATION}


def test_a_resumed_run_keeps_its_evaluations_length(trained, tmp_path, capsys):
    """Resumed without the setting (the case's 10 s by default) it still evaluates its own
    0.8 s; resumed with another length it is refused before any work, naming both."""
    out = tmp_path / "runs"
    shutil.copytree(trained, out)
    at = SMOKE.index(f"eval_duration={EVAL_DURATION}")
    without = SMOKE[:at - 1] + SMOKE[at + 1:]
    args = ["train", "--case", "m1-4mT", "--seeds", "1", "--workers", "1", "--out", str(out), "--resume"]
    before = (out / "m1-4mT" / "seed0" / "checkpoint.pt").read_bytes()
    assert msr([*args, "--steps", str(TRAIN_STEPS + 80), *without, "--set", "eval_duration=2"]) == 2
    assert "--set eval_duration: the run's 0.8, given 2.0" in capsys.readouterr().err
    assert (out / "m1-4mT" / "seed0" / "checkpoint.pt").read_bytes() == before
    assert msr([*args, "--steps", str(TRAIN_STEPS + 80), *without]) == 0
    lengths = _lengths(out / "m1-4mT" / "seed0")
    assert len(lengths) == 3 and set(lengths) == {80.0}, lengths


def test_a_target_rule_is_refused_with_another_length():
    case = load_case("m1-4mT")
    assert case_stop_rule(case, "target", eval_every=100, eval_duration=0.0).threshold > 0
    assert case_stop_rule(case, "target", eval_every=100, eval_duration=10.0).threshold > 0
    assert case_stop_rule(case, "plateau", eval_every=100, eval_duration=0.8).kind == "plateau"
    with pytest.raises(ValueError, match=r"eval_duration 0.8 s evaluates another length.*--stop-when "
                                         r"plateau or none"):
        case_stop_rule(case, "target", eval_every=100, eval_duration=0.8)


@pytest.mark.parametrize("value", [-1.0, float("nan"), float("inf"), 3601.0, 0.005, 0.001])
def test_an_impossible_length_is_refused(value):
    """Below one 0.01 s control step (round 39 V1: every seed then failed with "duration must be at
    least one 0.01 s step", no setting named)."""
    with pytest.raises(ValueError, match=r"eval_duration must be 0 .* or a number of seconds in "
                                         r"\[0.01, 3600\] \(at least one control step\)"):
        TD3Config(eval_duration=value)


def test_the_recipe_target_rule_is_refused_with_it_on_the_command_line(tmp_path, capsys):
    """The ``fast`` recipe's own target rule: refused before any folder is made."""
    out = tmp_path / "runs"
    assert msr(["train", "--case", "m1-4mT", "--recipe", "fast", "--seeds", "1", "--steps", "200",
                "--set", "eval_every=100", "--set", "eval_duration=1", "--out", str(out),
                "--no-progress"]) == 2
    assert "--stop-when target compares each evaluation" in capsys.readouterr().err
    assert not out.exists()
