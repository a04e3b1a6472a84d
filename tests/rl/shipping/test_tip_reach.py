"""Judging tip-reach cases (issue 53): held-out targets and a controller's result on them."""

from __future__ import annotations

import tomllib
import warnings

import numpy as np
from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.shipping.tip_reach import (
    HELD_OUT_SEED,
    held_out_targets,
    run_targets,
    steering_controller,
)
from spec_texts import CATHETER_MAGNET_REACH


def case():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_case({**tomllib.loads(CATHETER_MAGNET_REACH), "name": "catheter"})


def test_held_out_targets_lie_in_the_box_and_are_not_a_training_draw():
    c = case()
    targets = held_out_targets(c)
    low, high = np.asarray(c.task.target_box)
    assert targets.shape == (20, 3) and np.all((targets >= low) & (targets <= high))
    assert np.array_equal(targets, held_out_targets(c))
    training_draw = np.random.default_rng(0).uniform(low, high, size=(20, 3))
    assert not np.allclose(targets, training_draw) and HELD_OUT_SEED > 10**6


def test_a_controller_that_does_nothing_ends_where_the_straight_tip_is():
    c = case()
    targets = np.array([[0.042, 0.01, 0.0], [0.045, 0.0, 0.005]])
    result = run_targets(c, targets, lambda env: lambda env, obs: np.zeros((2, 5)), physics="training",
                         duration=0.05)
    straight = np.linalg.norm(targets - [0.05, 0.0, 0.0], axis=1)
    # the magnet 40 mm beyond the tip pulls it a few um along the axis; nothing bends it
    np.testing.assert_allclose(result["final_distance_m"], straight, atol=1e-5)
    assert result["ended_by"] == ["time", "time"] and result["successes"] == 0


def test_the_steering_yardstick_closes_the_distance():
    c = case()
    targets = np.array([[0.044, 0.012, 0.0], [0.045, 0.0, -0.01]])
    result = run_targets(c, targets, steering_controller, physics="training", duration=1.0)
    straight = np.linalg.norm(targets - [0.05, 0.0, 0.0], axis=1)
    assert np.all(np.asarray(result["closest_distance_m"]) < 0.75 * straight)
    assert result["duration_s"] == 1.0 and len(result["success"]) == 2


def test_with_an_insertion_stage_the_yardstick_reaches_targets_inside_the_sheet():
    """The bearing law plus the stage pushed until the tip is as far from the base's start as the
    target: targets inside the sheet a fixed-length catheter bends over come within 1 mm."""
    data = tomllib.loads(CATHETER_MAGNET_REACH)
    data["name"] = "catheter"
    data["actuation"].update(insertion=[-0.01, 0.01], insertion_speed=0.01)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        c = load_case(data)
    targets = np.array([[0.041, 0.011, 0.0086], [0.0444, 0.0017, -0.0032]])  # 6 and 5.4 mm inside
    result = run_targets(c, targets, steering_controller, physics="training", duration=2.0)
    assert max(result["closest_distance_m"]) < 1e-3


def test_the_coils_yardstick_closes_the_distance():
    """Fixed coils (the shipped coil case): the bearing law picks the field's direction at the tip
    and the least-norm currents make it; the stage brings the tip to the target's distance."""
    c = load_case("catheter-coils-reach")
    target = held_out_targets(c)[:1]
    straight = float(np.linalg.norm(target - [0.05, 0.0, 0.0]))
    result = run_targets(c, target, steering_controller, physics="training", duration=0.6)
    assert result["closest_distance_m"][0] < 0.75 * straight and result["ended_by"] == ["time"]
