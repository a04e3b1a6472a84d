"""``msr real robustness`` of a tip-reach policy (issue 53, "the rest of the loop knows space"): the
policy and the case's steering yardstick steer every varied catheter to the held-out targets; the
magnet's moment is among the default variations of a magnet arm."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import case_from_dict, load_case
from elastica_magnetic_rl.cases.variations import DEFAULT_RANGES, SOURCE_RANGES, default_variations
from elastica_magnetic_rl.shipping.policy_files import resolve_policy
from elastica_magnetic_rl.shipping.policy_runs import choose_tip_reach_actor
from elastica_magnetic_rl.shipping.tip_reach import (
    actor_controller,
    held_out_targets,
    run_targets,
    steering_controller,
)

from elastica_magnetic.cli import main as msr

DURATION = 0.1  # s: a few control steps of each target's run


@pytest.fixture(scope="module")
def study(catheter_run, tmp_path_factory):
    out = tmp_path_factory.mktemp("tip_robustness") / "rob"
    assert msr(["real", "robustness", str(catheter_run), "--vary", "magnet=0.8:1.25", "--no-corners",
                "--duration", str(DURATION), "--workers", "1", "--no-progress", "--out", str(out)]) == 0
    return out, json.loads((out / "robustness.json").read_text())


def test_the_default_set_varies_a_steering_source_only_where_there_is_one():
    def names(case):
        return [v.name for v in default_variations(load_case(case).to_dict())]

    assert names("catheter-magnet-reach") == ["magnetization", "modulus", "density", "magnet"]
    assert names("catheter-coils-reach") == ["magnetization", "modulus", "density", "coils"]
    assert names("m1-4mT") == list(DEFAULT_RANGES) and set(SOURCE_RANGES) == {"magnet", "coils"}


def test_each_variant_is_what_the_policy_and_the_yardstick_do_on_that_catheter(catheter_run, study):
    """The report's final distances are those of independent runs of the actor and of the steering
    law on the varied spec (the magnet x1.25), to the held-out targets."""
    out, report = study
    case = load_case("catheter-magnet-reach")
    targets = held_out_targets(case)
    np.testing.assert_allclose(np.loadtxt(out / "targets.csv", delimiter=",", skiprows=1), targets)
    assert report["targets_m"] == targets.tolist() and report["kind"] == "tip_reach_policy"
    labels = [v["label"] for v in report["variants"]]
    assert labels == ["nominal", "magnet x0.8", "magnet x1.25"]
    stronger = report["variants"][2]
    assert stronger["values"] == {"actuation.moment": pytest.approx(1.25)}
    data = copy.deepcopy(case.to_dict())
    data["actuation"]["moment"] = 1.25
    varied = case_from_dict(data, "varied")
    chosen = choose_tip_reach_actor(catheter_run)  # as msr policy generate plays the run: best.pt
    assert report["design"]["actor"]["checkpoint"] == str(chosen.path)
    actor = resolve_policy(str(chosen.path)).actor
    for mode, controller in (("policy", actor_controller(actor)), ("yardstick", steering_controller)):
        expected = run_targets(varied, targets, controller, "training", DURATION)
        assert stronger[mode]["final_distance_m"] == pytest.approx(expected["final_distance_m"], abs=1e-12)
        assert stronger[mode]["successes"] == expected["successes"]
    # a weaker magnet steers the yardstick's tip less far from the straight one than a stronger one
    weaker = report["variants"][1]["yardstick"]["final_distance_m"]
    assert weaker != stronger["yardstick"]["final_distance_m"]
    assert (out / "robustness.png").stat().st_size > 10_000 and not (out / "fields.csv").exists()


def test_the_summary_counts_where_the_policy_keeps_up_with_the_yardstick(study):
    """Round 21 S F5: an untrained policy reaching no target and ending farther than the yardstick
    on every variant was counted as keeping up on all of them (a tie at 0 reached): as many targets
    now count only with a median final distance no larger."""
    out, report = study
    both = report["variants"]
    expected = sum(1 for v in both if (v["policy"]["successes"], -v["policy"]["median_m"])
                   >= (v["yardstick"]["successes"], -v["yardstick"]["median_m"]))
    assert report["policy_at_least_yardstick"] == expected and report["variants_compared"] == 3
    if not report["any_reached"]:  # the smoke run's untrained actor, at 0.1 s: nothing reached
        assert all(v[m]["successes"] == 0 for v in both for m in ("policy", "yardstick"))
        assert all(v["policy"]["median_m"] > v["yardstick"]["median_m"] for v in both)
        assert report["policy_at_least_yardstick"] == 0
    worst = report["summary"]["yardstick"]
    fewest = min(v["yardstick"]["successes"] for v in both)
    assert worst["worst_successes"] == fewest
    assert worst["nominal_successes"] == both[0]["yardstick"]["successes"]


@pytest.mark.parametrize("extra, message", [
    (["--fields", "f.csv"], "--fields: {run} is a policy of the tip-reach case 'catheter-magnet-reach': it "
                            "plays no waveform"),
    (["--open-loop-only"], "its study is closed loop only"),
    (["--duration", "5"], "--duration 5 s: longer than case 'catheter-magnet-reach''s episode (3 s)"),
])
def test_options_a_tip_reach_study_cannot_use_are_refused_before_any_run(catheter_run, tmp_path, capsys,
                                                                         extra, message):
    out = tmp_path / "rob"
    assert msr(["real", "robustness", str(catheter_run), "--out", str(out), "--no-progress", *extra]) != 0
    assert message.format(run=catheter_run) in capsys.readouterr().err
    assert not out.exists()
