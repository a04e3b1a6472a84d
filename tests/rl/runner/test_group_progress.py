"""The group's rate and ETA (rl/runner/progress.py): evaluations counted from the schedule and
timed apart from training."""

from __future__ import annotations

import math

import pytest
from elastica_magnetic_rl.runner.progress import GroupProgress, evaluations_left, format_duration


def test_evaluations_left_follow_the_schedule():
    assert evaluations_left(0, 100_000, 5000, -1) == 20  # 5000 .. 100000, the last one at the end
    assert evaluations_left(6000, 100_000, 5000, 6000) == 19  # the first fell at 6000
    assert evaluations_left(0, 1050, 100, -1) == 11  # 100 .. 1000, and the final one at 1050
    assert evaluations_left(0, 1000, 0, -1) == 0 and evaluations_left(1000, 1000, 100, 1000) == 0


def test_no_evaluation_is_counted_in_a_warm_up_the_yardstick_plays():
    # the m1-4mT-goto schedule: a 36000-step warm-up, evaluations every 2000 steps, 42100 steps:
    # the clone's at 36000, then 38000, 40000, 42000 and the last at 42100 (not 21 rounds)
    assert evaluations_left(0, 42_100, 2000, -1, warmup_end=36_000) == 5
    assert evaluations_left(36_000, 42_100, 2000, 36_000, warmup_end=36_000) == 4
    assert evaluations_left(0, 42_100, 2000, -1) == 22  # without a warm-up: every multiple of 2000


def test_the_eta_counts_training_at_its_rate_and_each_evaluation_at_its_cost():
    timing = {"act": 0.0, "env": 0.0, "update": 0.0, "evaluation": 0.0}
    progress = GroupProgress(timing, start_step=0)
    first = progress.estimate(timing, 0, 1000, 2, 100, -1)
    assert math.isnan(first["rate"]) and math.isnan(first["eta_s"])
    # 200 steps of each of 2 seeds in 4 s of training, and 2 evaluation rounds of 3 s each
    timing = {"act": 1.0, "env": 1.0, "update": 2.0, "evaluation": 6.0}
    progress.evaluated()
    progress.evaluated()
    est = progress.estimate(timing, 200, 1000, 2, 100, 200)
    assert est["rate"] == pytest.approx(100.0)  # 400 transitions / 4 s
    assert est["evals_left"] == 8 and est["eval_s"] == pytest.approx(3.0)
    assert est["eta_s"] == pytest.approx(1600 / 100 + 8 * 3)
    line = GroupProgress.describe(est)
    assert line == "group 100 steps/s, ETA 0:40 (8 evaluations, 3 s each)"
    assert format_duration(3725) == "1:02:05" and format_duration(math.nan) == "?"
