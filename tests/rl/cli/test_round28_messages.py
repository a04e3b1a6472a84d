"""Round 28 of held-out tries (issue 48), the findings of the commands: each test fails without its
fix (docs/errors.md, "A twenty-eighth round of tries")."""

from __future__ import annotations

import json
import shutil

import pytest
from elastica_magnetic_rl.shipping import shipped
from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR

from elastica_magnetic.cli import main as msr


@pytest.mark.parametrize("drop", ["evaluation", "duration_s", "tip_reach"])
def test_a_catheter_policy_json_without_its_targets_is_a_failing_verdict(tmp_path, monkeypatch, drop):
    """Round 28 T1: ``msr validate shipped`` of a tip-reach policy whose policy.json lacks
    ``evaluation`` (or its ``duration_s`` or ``tip_reach``) ended in a KeyError; now a failing verdict
    naming the file and keys, as for a crawler."""
    folder = tmp_path / "catheter-magnet-reach"
    shutil.copytree(POLICIES_DIR / "catheter-magnet-reach", folder)
    info = json.loads((folder / "policy.json").read_text())
    if drop == "evaluation":
        del info["evaluation"]
    else:
        del info["evaluation"][drop]
    (folder / "policy.json").write_text(json.dumps(info))
    judged = {"duration_s": 0.05, "policy": {"successes": 0, "targets_m": [[0.05, 0, 0]] * 20,
                                             "final_distance_m": [0.01] * 20, "ended_by": ["time"] * 20}}
    monkeypatch.setattr("elastica_magnetic_rl.shipping.tip_reach.judge_held_out", lambda *a, **k: judged)
    result = shipped.verify_shipped("catheter-magnet-reach", duration=0.05, policies_dir=tmp_path, quick=True)
    assert result["passed"] is False
    assert ("policy.json: no evaluation with duration_s and tip_reach.policy" in result["problem"]
            or "policy.json: evaluation.duration_s is not recorded" in result["problem"]), result["problem"]


def _files(folder):
    return sorted(p.relative_to(folder) for p in folder.rglob("*") if p.is_file())


def test_figures_of_another_case_stay_out_of_a_policy_s_seeds(tmp_path, capsys):
    """S1: ``msr policy seeds --figure`` and ``msr policy figures --out`` wrote case m1-4mT's figures
    into the catheter policy's seeds/ (every other writer refuses another case's results there). Now
    both are refused naming both cases; the policy's own case's figures still go there."""
    catheter = tmp_path / "pc"
    shutil.copytree(POLICIES_DIR / "catheter-magnet-reach", catheter)
    crawler = tmp_path / "pm"
    shutil.copytree(POLICIES_DIR / "m1-4mT", crawler, ignore=shutil.ignore_patterns("seed[1-9]"))
    before = _files(catheter)
    seed = crawler / "seeds" / "fast" / "seed0"
    seeds = catheter / "seeds"
    for argv, option in ((["policy", "seeds", "m1-4mT", "--figure", str(seeds)], "--figure"),
                         (["policy", "figures", str(seed), "--out", str(seeds / "figs")], "--out")):
        assert msr(argv) == 2
        err = capsys.readouterr().err
        assert (f"{option} " in err and "lies in the shipped policy" in err and "of case "
                "'catheter-magnet-reach', and these figures are of case 'm1-4mT'" in err), err
    assert _files(catheter) == before
    assert msr(["policy", "figures", str(seed), "--out", str(crawler / "seeds" / "figs")]) == 0
    assert (crawler / "seeds" / "figs" / "learning_curves_fast.png").is_file()


def test_a_yardstick_spec_of_another_case_stays_out_of_a_policy_s_seeds(tmp_path, capsys):
    """S1: ``msr field baseline --set-yardstick`` into the catheter policy's seeds/ passed its check and
    wrote case m1-4mT's spec there after the sweep; now refused before the sweep."""
    catheter = tmp_path / "pc"
    shutil.copytree(POLICIES_DIR / "catheter-magnet-reach", catheter)
    out = tmp_path / "sweep"
    spec = catheter / "seeds" / "ys.toml"
    assert msr(["field", "baseline", "--case", "m1-4mT", "--set-yardstick", str(spec),
                "--periods", "0.5", "--out", str(out), "--no-figures", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "--set-yardstick" in err and "and this spec is of case 'm1-4mT'" in err, err
    assert not out.exists() and not spec.exists()


@pytest.mark.parametrize("given", ["missing", "mine", "campaign", "card"])
def test_notes_from_a_file_in_the_policy_s_folder_say_what_it_is(tmp_path, capsys, given):
    """V1: ``msr policy notes --file`` called any path in the policy's folder the policy's own file that
    ship wrote: a missing file, the user's notes, a seed campaign's seeds.json. Now a missing file is
    "no such file", a file ship wrote is named so, any other is said to lie in the policy's folder."""
    policy = tmp_path / "pm"
    shutil.copytree(POLICIES_DIR / "m1-4mT", policy, ignore=shutil.ignore_patterns("seed[1-9]"))
    (policy / "seeds" / "mynotes.md").write_text("# my notes\n")
    path, said = {"missing": (policy / "nonexist.md", "no such file"),
                  "mine": (policy / "seeds" / "mynotes.md", "lies in the shipped policy"),
                  "campaign": (policy / "seeds" / "fast" / "seeds.json", "lies in the shipped policy"),
                  "card": (policy / "MODEL_CARD.md", "is the policy's own MODEL_CARD.md (msr policy ship "
                                                     "wrote it")}[given]
    card = (policy / "MODEL_CARD.md").read_text()
    assert msr(["policy", "notes", str(policy), "--file", str(path)]) == 2
    err = capsys.readouterr().err
    assert said in err, err
    assert given == "card" or "msr policy ship wrote" not in err, err
    assert (policy / "MODEL_CARD.md").read_text() == card
