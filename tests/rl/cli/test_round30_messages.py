"""Round 30 of held-out tries (issue 48), the findings of the commands: each test fails without its
fix (docs/errors.md, "A thirtieth round of tries")."""

from __future__ import annotations

import json
import shutil

import pytest
from elastica_magnetic_rl.shipping import shipped
from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR
from smoke import NOT_RESIDUAL

from elastica_magnetic.cli import main as msr
from elastica_magnetic.result_markers import mark_folder


def _tree(folder):
    return sorted((p.relative_to(folder).as_posix(), p.stat().st_size if p.is_file() else -1)
                  for p in folder.rglob("*"))


def test_a_refinement_is_not_written_into_a_committed_seed_campaign(tmp_path, trained, capsys):
    """D1: ``msr refine --out POLICY/seeds/fast/ref`` wrote a refinement into a seed campaign committed
    with a shipped policy (it has no marker file, only its seeds.json); replacing the campaign would
    take the refinement with it. Now refused before any work, naming the campaign."""
    policy = tmp_path / "pm"
    shutil.copytree(POLICIES_DIR / "m1-4mT", policy)
    campaign = policy / "seeds" / "fast"
    before = _tree(policy)
    run = trained / "m1-4mT" / "seed0"
    assert msr(["refine", str(run), "--checkpoint", "final", "--steps", "3", "--episode-duration", "0.02",
                "--out", str(campaign / "ref"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "export-seeds" in err and "choose another --out" in err, err
    assert _tree(policy) == before


def test_ship_does_not_put_a_policy_among_another_result_or_a_training(tmp_path, trained, capsys):
    """D2, D3: ``msr policy ship --out DIR --name NAME`` where DIR/NAME is another command's result
    (a simulation's folder) or a training's case folder put the policy's files among that result's
    or that training's runs. Now each is refused before any measuring, nothing there changed."""
    run = trained / "m1-4mT" / "seed0"
    other = tmp_path / "res" / "sim"
    other.mkdir(parents=True)
    (other / "tip.csv").write_text("t_s,x_m\n0,0\n")
    mark_folder(other, kind="simulate", subject="case m1-4mT")
    before_other, before_runs = _tree(other), _tree(trained)
    for dest, name, said in ((other.parent, "sim", "a result of `msr field simulate`"),
                             (trained, "m1-4mT", "holds the runs of a training")):
        assert msr(["policy", "ship", str(run), "--out", str(dest), "--name", name, "--no-measure",
                    "--force", "--no-progress"]) == 2
        err = capsys.readouterr().err
        assert said in err and "choose another --out/--name" in err, err
    assert _tree(other) == before_other
    assert _tree(trained) == before_runs


@pytest.mark.parametrize(("where", "value", "said"), [
    ("final_distance_m", [0.01] * 19 + [float("nan")], "final_distance_m[19] is nan (float)"),
    ("successes", "19", "successes is '19' (str): expected a count"),
    ("successes", 19.0, "successes is 19.0 (float): expected a count"),
    ("duration_s", True, "evaluation.duration_s is True (bool): expected a duration")])
def test_a_damaged_tip_reach_record_is_named_by_key_and_value(tmp_path, monkeypatch, where, value, said):
    """V2, V3: a NaN among the recorded final distances was reported as "holds 20 entries ...
    expected 20"; ``successes`` "19" or 19.0 and ``duration_s`` true as "not recorded". Now the key,
    the value and its type are named."""
    folder = tmp_path / "catheter-magnet-reach"
    shutil.copytree(POLICIES_DIR / "catheter-magnet-reach", folder)
    info = json.loads((folder / "policy.json").read_text())
    table = info["evaluation"] if where == "duration_s" else info["evaluation"]["tip_reach"]["policy"]
    table[where] = value
    (folder / "policy.json").write_text(json.dumps(info))
    judged = {"duration_s": 10.0, "policy": {"successes": 0, "targets_m": [[0.05, 0, 0]] * 20,
                                              "final_distance_m": [0.01] * 20, "ended_by": ["time"] * 20}}
    monkeypatch.setattr("elastica_magnetic_rl.shipping.tip_reach.judge_held_out", lambda *a, **k: judged)
    result = shipped.verify_shipped("catheter-magnet-reach", duration=10.0, policies_dir=tmp_path)
    assert result["passed"] is False
    assert said in result["problem"], result["problem"]


def test_a_regularized_run_is_not_advised_fewer_steps_than_its_warm_up(tmp_path, capsys):
    """V6: a regularized run whose buffer (1000) holds fewer than its steps was advised "--steps of at
    most 1000", which its warm-up (learning_starts 2000) refuses. That advice is given only where a
    run that short still learns."""
    common = ["train", "--case", "m1-4mT-goto", "--seeds", "1", "--steps", "3000", "--set",
              "yardstick_regularization=0.4", "--set", "yardstick_warmup=50", "--set", "eval_every=0",
              *NOT_RESIDUAL]
    assert msr([*common, "--set", "buffer_size=1000", "--set", "learning_starts=2000",
                "--out", str(tmp_path / "a")]) == 2
    err = capsys.readouterr().err
    assert "--set buffer_size of at least 3000" in err and "--steps of at most" not in err, err
    assert msr([*common, "--set", "buffer_size=1000", "--set", "learning_starts=500",
                "--out", str(tmp_path / "b")]) == 2
    assert "or --steps of at most 1000" in capsys.readouterr().err
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


def test_a_result_inside_a_campaign_s_seed_names_the_campaign(tmp_path, capsys):
    """V1: ``--out POLICY/seeds/fast/seed0/x`` was refused as lying in "a shipped policy" (the seed's
    policy.json) with the advice "a result goes beside it", inside the campaign, refused too. Now
    the seed campaign is named, the result that holds the seed."""
    from elastica_magnetic.io import OutputPathError
    from elastica_magnetic.results import check_result_folder

    policy = tmp_path / "pm"
    shutil.copytree(POLICIES_DIR / "m1-4mT", policy)
    with pytest.raises(OutputPathError, match=r"lies in .*seeds/fast, which holds a result of `msr policy "
                                              r"export-seeds`") as refused:
        check_result_folder(policy / "seeds" / "fast" / "seed0" / "x", kind="export", subject="case m1-4mT")
    assert "beside it" not in str(refused.value)


def test_a_refused_ship_into_a_policy_shows_the_path_as_given(tmp_path, trained, capsys, monkeypatch):
    """V5: ship refused ``--out POLICY/sub`` naming the policy by its absolute path; paths are shown
    relative to the current folder where they lie in it, as every other message does."""
    policy = tmp_path / "pm"
    shutil.copytree(POLICIES_DIR / "m1-4mT", policy, ignore=shutil.ignore_patterns("seeds"))
    monkeypatch.chdir(tmp_path)
    assert msr(["policy", "ship", str(trained / "m1-4mT" / "seed0"), "--out", "pm/sub", "--name", "y",
                "--no-measure", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "--out pm/sub: pm is a shipped policy" in err and str(tmp_path) not in err, err


def test_an_interaction_cutoff_is_advised_beyond_an_element(tmp_path):
    """V8: on a rod whose four radii are shorter than an element, a cutoff below an element was refused
    advising "leave cutoff out for four radii", shorter still (and the default then ran into NaN).
    Now a cutoff of four elements is advised, and a table without cutoff on such a rod is refused."""
    from elastica_magnetic_rl.cases.case import load_case

    from elastica_magnetic.specfile import SpecError

    base = load_case("catheter-magnet-reach").toml().replace('name = "catheter-magnet-reach"', 'name = "cut"')
    spec = tmp_path / "cut.toml"
    spec.write_text(base + "\n[robot.interaction]\ncutoff = 0.001\n")
    with pytest.raises(SpecError, match=r"cutoff: 0.001 m is at or below one element's length") as refused:
        load_case(spec)
    assert "leave cutoff out" not in str(refused.value) and "4 elements" in str(refused.value)
    spec.write_text(base + "\n[robot.interaction]\nband_source = true\n")
    with pytest.raises(SpecError, match=r"cutoff: absent: the default of 4 radii"):
        load_case(spec)


def test_a_yardstick_warm_up_on_a_reach_case_is_not_sent_to_a_crawl(tmp_path, capsys):
    """V9: ``--set yardstick_warmup`` on a reach case without ``[yardstick] period`` was told to train
    "a crawl on the spec msr field baseline writes"; a reach case's baseline spec records it alike."""
    assert msr(["train", "--case", "m1-4mT-reach", "--seeds", "1", "--steps", "300", "--set",
                "yardstick_warmup=50", "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert "train m1-4mT-reach on the spec msr field baseline" in err and "a crawl on" not in err, err
