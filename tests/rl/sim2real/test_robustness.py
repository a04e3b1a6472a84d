"""msr real robustness: the nominal variant is a plain replay, a stronger magnetization goes farther,
the closed loop is the policy's rollout, the output folder is written whole, bad input is named."""

import json
import shutil

import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.cases.variations import parse_variation
from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR, resolve_policy
from elastica_magnetic_rl.shipping.policy_runs import run_policy
from elastica_magnetic_rl.sim2real.report import robustness_table
from elastica_magnetic_rl.sim2real.robustness import plan_robustness, run_robustness

from elastica_magnetic.cli import main
from elastica_magnetic.fields import TabulatedField
from elastica_magnetic.openloop import run_open_loop
from elastica_magnetic.specfile import SpecError

FIELDS_10MT = POLICIES_DIR / "m1-10mT" / "fields.csv"
DURATION = 0.3


def _distances(report, mode="open_loop"):
    return {v["label"]: v[mode]["distance_m"] for v in report["variants"]}


def test_nominal_is_a_plain_replay_and_stronger_magnetization_goes_farther():
    plan = plan_robustness(FIELDS_10MT, case="m1-10mT", duration=DURATION, corners=False,
                           variations=[parse_variation("magnetization=0.5:1.5")])
    report = run_robustness(plan, workers=1, progress=False)
    distances = _distances(report)
    replay = run_open_loop(load_case("m1-10mT").robot_spec("training"),
                           TabulatedField.from_csv(FIELDS_10MT), DURATION)
    assert distances["nominal"] == replay.mid_dx  # exactly: the same robot, the same field
    assert distances["magnetization x1.5"] > distances["nominal"] + 2e-4
    assert distances["nominal"] > distances["magnetization x0.5"] + 2e-4
    summary = report["summary"]["open_loop"]
    assert summary["worst_variant"] == "magnetization x0.5"
    assert summary["worst_m"] == distances["magnetization x0.5"]
    # a short run of the training physics is not comparable with the yardstick (10 s, accurate):
    # no percentage of it; the worst as a fraction of the nominal robot in the same physics
    assert report["yardstick_comparable"] is False and summary["nominal_fraction"] is None
    assert summary["worst_of_nominal"] == pytest.approx(distances["magnetization x0.5"]
                                                        / distances["nominal"])
    assert "not comparable with" in robustness_table(report)
    assert "closed_loop" not in report["summary"]  # a field CSV has no policy


def test_closed_loop_is_the_policy_on_the_varied_robot():
    plan = plan_robustness("m1-4mT", duration=DURATION, corners=False,
                           variations=[parse_variation("robot.ground.kinetic_mu=abs:0.3:0.6")])
    report = run_robustness(plan, workers=1, progress=False)
    closed = _distances(report, "closed_loop")
    policy = resolve_policy("m1-4mT")
    assert closed["nominal"] == run_policy(policy, DURATION, "training", progress=False).mid_dx
    assert plan.waveform == "fields.csv of the shipped-format policy m1-4mT"
    # the high end is the nominal 0.6: listed once
    assert [v["label"] for v in report["variants"]] == ["nominal", "robot.ground.kinetic_mu = 0.3"]


def test_worker_processes_give_the_same_distances():
    kwargs = dict(case="m1-10mT", duration=0.1, corners=False,
                  variations=[parse_variation("density=0.9:1.1")])
    one = run_robustness(plan_robustness(FIELDS_10MT, **kwargs), workers=1, progress=False)
    two = run_robustness(plan_robustness(FIELDS_10MT, **kwargs), workers=2, progress=False)
    assert _distances(one) == _distances(two)
    assert two["workers"] == 2


def test_command_writes_the_folder_whole_and_refuses_an_existing_one(tmp_path, capsys):
    out = tmp_path / "rb"
    argv = ["real", "robustness", str(FIELDS_10MT), "--case", "m1-10mT", "--duration", "0.1",
            "--vary", "friction=0.75:1.25", "--samples", "2", "--out", str(out), "--json",
            "--no-progress", "--workers", "1"]
    assert main(argv) == 0
    printed = json.loads(capsys.readouterr().out)
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == [
        "fields.csv", "robustness.json", "robustness.png"]
    report = json.loads((out / "robustness.json").read_text())
    assert [v["kind"] for v in report["variants"]] == ["nominal", "one-at-a-time", "one-at-a-time",
                                                       "sample", "sample"]
    assert printed["summary"] == report["summary"]
    values = report["variants"][1]["values"]
    assert values == {"robot.ground.static_mu": 0.8 * 0.75, "robot.ground.kinetic_mu": 0.6 * 0.75}
    assert main(argv) == 2
    assert "already holds a result of `msr real robustness`" in capsys.readouterr().err
    (out / "stale.txt").write_text("old")  # a file msr did not write: never replaced, even with --force
    assert main([*argv, "--force", "--samples", "0"]) == 2
    assert "stale.txt" in capsys.readouterr().err and (out / "stale.txt").read_text() == "old"
    (out / "stale.txt").unlink()
    assert main([*argv, "--force", "--samples", "0"]) == 0
    capsys.readouterr()
    assert len(json.loads((out / "robustness.json").read_text())["variants"]) == 3
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary left


def test_bad_input_is_named_before_any_simulation(tmp_path, capsys):
    out = tmp_path / "rb"
    # an invalid variant: the spec parser's own error, naming the variant and the key
    named = r"variant 'robot.ground.kinetic_mu = -0.1'.*kinetic_mu: must be >= 0"
    with pytest.raises(SpecError, match=named):
        plan_robustness(FIELDS_10MT, case="m1-10mT",
                        variations=[parse_variation("robot.ground.kinetic_mu=abs:-0.1:0.5")])
    assert main(["real", "robustness", str(FIELDS_10MT), "--case", "m1-10mT", "--duration", "20",
                 "--out", str(out)]) == 2
    assert "past the end of the waveform" in capsys.readouterr().err
    assert main(["real", "robustness", "m1-4mT", "--vary", "robot.magnetisation.magnitude=0.9:1.1",
                 "--out", str(out)]) == 2
    assert "did you mean robot.magnetization.magnitude" in capsys.readouterr().err
    assert main(["real", "robustness", "no-such-policy", "--out", str(out)]) == 2
    assert "not a run directory" in capsys.readouterr().err
    assert main(["real", "robustness", "m1-4mT", "--case", "m1-4mT", "--out", str(out)]) == 2
    assert "--case is for a field CSV" in capsys.readouterr().err
    assert not out.exists()
    with pytest.raises(SystemExit):
        main(["real", "robustness", "m1-4mT", "--vary", "friction=0:1"])
    assert "relative factors must be > 0" in capsys.readouterr().err


def test_a_policy_without_a_waveform_gets_one_generated(tmp_path):
    folder = tmp_path / "policy"
    folder.mkdir()
    for name in ("actor.pt", "policy.json"):
        shutil.copy(POLICIES_DIR / "m1-4mT" / name, folder / name)
    plan = plan_robustness(folder, duration=0.05, corners=False, progress=False,
                           variations=[parse_variation("density=0.9:1.1")])
    generated = run_policy(resolve_policy(folder), 0.05, "accurate", progress=False).fields
    np.testing.assert_array_equal(plan.fields, generated)
    assert plan.waveform.startswith("generated")
