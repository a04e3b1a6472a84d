"""Round 29 of held-out tries (issue 48), the findings of the commands: each test fails without its
fix (docs/errors.md, "A twenty-ninth round of tries"). S1 and S2 (identify) are tested in
tests/rl/sim2real/test_coil_path.py."""

from __future__ import annotations

import json
import shutil

import pytest
from elastica_magnetic_rl.shipping import shipped
from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR

from elastica_magnetic.cli import main as msr


def _catheter_with(tmp_path, monkeypatch, distances):
    folder = tmp_path / "catheter-magnet-reach"
    shutil.copytree(POLICIES_DIR / "catheter-magnet-reach", folder)
    info = json.loads((folder / "policy.json").read_text())
    info["evaluation"]["tip_reach"]["policy"]["final_distance_m"] = distances
    (folder / "policy.json").write_text(json.dumps(info))
    judged = {"duration_s": float(info["evaluation"]["duration_s"]),
              "policy": {"successes": 0, "targets_m": [[0.05, 0, 0]] * 20,
                         "final_distance_m": [0.01] * 20, "ended_by": ["time"] * 20}}
    monkeypatch.setattr("elastica_magnetic_rl.shipping.tip_reach.judge_held_out", lambda *a, **k: judged)
    return shipped.verify_shipped("catheter-magnet-reach", duration=judged["duration_s"],
                                  policies_dir=tmp_path)


@pytest.mark.parametrize(("distances", "said"), [(["0.001"] * 20, "[0] is '0.001' (str)"),
                                                 ([0.001] * 5, " holds 5 entries"), ([], " holds 0 entries"),
                                                 ("far", " is str")])
def test_recorded_final_distances_of_another_form_are_a_failing_verdict(tmp_path, monkeypatch, distances,
                                                                        said):
    """T1, V2: a catheter policy.json whose final_distance_m held strings ended in a numpy traceback,
    one of another length in "operands could not be broadcast"; now a failing verdict naming the key,
    what it holds and the 20 distances expected."""
    result = _catheter_with(tmp_path, monkeypatch, distances)
    assert result["passed"] is False
    assert f"evaluation.tip_reach.policy.final_distance_m{said}" in result["problem"], result["problem"]
    assert ("expected 20 distances (m, numbers >= 0)" in result["problem"]
            or "expected a distance (m, a finite number >= 0)" in result["problem"]), result["problem"]


def test_a_result_of_no_case_is_not_sent_to_the_seeds_folder_that_refuses_it(tmp_path):
    """V4: a calibration refused in a policy's folder was told to go "(or in POLICY/seeds/)", where it
    is refused as a result of no case; V3: a robustness study or a design there was called "of no
    case". Now a result of no case is sent beside the policy only, told it is none of the seeds/'s."""
    from elastica_magnetic.hardware.calibration import CALIBRATION_FILE
    from elastica_magnetic.io import OutputPathError
    from elastica_magnetic.result_file import check_result_file
    from elastica_magnetic.results import check_result_folder

    policy = tmp_path / "pm"
    shutil.copytree(POLICIES_DIR / "m1-4mT", policy, ignore=shutil.ignore_patterns("seed[1-9]"))
    with pytest.raises(OutputPathError, match="a result goes beside it; choose another --out") as refused:
        check_result_file(policy / "cal.json", kind=CALIBRATION_FILE)
    assert "seeds/" not in str(refused.value)
    with pytest.raises(OutputPathError, match=r"a result goes beside it \(or in .*seeds/\)"):
        check_result_folder(policy / "exp", kind="export", subject="case m1-4mT")  # a case's result
    with pytest.raises(OutputPathError, match=r"this result is none of them \(a study, a design, a "
                                              r"calibration or a hardware file\): it goes beside"):
        check_result_folder(policy / "seeds" / "rob", kind="robustness")


@pytest.fixture(scope="module")
def m1_run(tmp_path_factory):
    """A tiny training run of case m1-4mT (its checkpoint), to ship, refine and train beside."""
    import torch

    out = tmp_path_factory.mktemp("m1run")
    torch.set_num_threads(1)
    assert msr(["train", "--case", "m1-4mT", "--seeds", "1", "--workers", "1", "--steps", "80",
                "--episode-duration", "0.5", "--set", "learning_starts=60", "--set", "batch_size=32",
                "--set", "hidden_sizes=32,32", "--set", "eval_every=0", "--out", str(out / "runs"),
                "--no-progress"]) == 0
    return out / "runs" / "m1-4mT" / "seed0"


def test_runs_and_policies_of_another_case_stay_out_of_a_policy_s_seeds(tmp_path, m1_run, capsys):
    """D1, D2: ``msr policy ship --out POLICY/seeds``, ``msr refine --out`` and ``msr train --out``
    put a policy or runs of case m1-4mT into the catheter policy's seeds/ (every other writer refuses
    another case's results there). Now each is refused before any work, naming both cases."""
    catheter = tmp_path / "pc"
    shutil.copytree(POLICIES_DIR / "catheter-magnet-reach", catheter)
    before = sorted(p for p in catheter.rglob("*"))
    seeds = catheter / "seeds"
    for argv in (["policy", "ship", str(m1_run), "--out", str(seeds), "--name", "y", "--no-measure"],
                 ["refine", str(m1_run), "--steps", "5", "--physics", "training", "--out", str(seeds / "ref"),
                  "--checkpoint", "final"],
                 ["train", "--case", "m1-4mT", "--seeds", "1", "--steps", "80", "--episode-duration", "0.5",
                  "--set", "learning_starts=60", "--out", str(seeds)]):
        assert msr([*argv, "--no-progress"]) == 2, argv
        err = capsys.readouterr().err
        assert ("lies in the shipped policy" in err and "of case 'catheter-magnet-reach'" in err
                and "of case 'm1-4mT'" in err), err
    assert sorted(p for p in catheter.rglob("*")) == before
