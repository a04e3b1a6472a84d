"""Which actor of a run is used (rl/shipping/policy_runs.py: ``choose_actor``, ``prefer_best``)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
import torch
from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.runfiles.rundir import RunDir
from elastica_magnetic_rl.shipping.policy_runs import choose_actor, evaluate_checkpoint, prefer_best
from smoke import run_msr

from elastica_magnetic.cli import main as msr

DURATION = 0.3  # s of accurate physics per evaluation


def _entry(dx: float, diverged: str | None = None, node: float | None = None) -> dict:
    return {"global_step": 1, "duration_s": 10.0, "physics": "accurate", "initial_field": "zero",
            "mid_dx_m": dx, "node_dx_m": dx if node is None else node, "diverged": diverged}


def test_prefer_best_is_the_farther_that_did_not_diverge():
    crawl = load_case("m1-4mT")
    assert prefer_best(crawl, _entry(0.001), _entry(0.002))
    assert not prefer_best(crawl, _entry(0.002), _entry(0.001))
    assert not prefer_best(crawl, _entry(0.001), None)
    assert not prefer_best(crawl, _entry(0.001), _entry(0.009, diverged="nan"))
    assert prefer_best(crawl, _entry(0.009, diverged="nan"), _entry(-0.001))
    reach = load_case("m1-4mT-reach")  # the closer to the target, not the farther
    target = reach.task.target
    assert prefer_best(reach, _entry(0.0, node=target + 0.004), _entry(0.0, node=target - 0.001))
    assert not prefer_best(reach, _entry(0.0, node=target), _entry(0.0, node=target + 0.003))


@pytest.fixture(scope="module")
def best_is_farther(trained, tmp_path_factory) -> tuple[Path, float, float]:
    """A copy of a trained seed whose ``best.pt`` holds the farther of two trained actors (the
    final ones of seeds 0 and 1: the tiny run's best.pt is its final actor) and ``checkpoint.pt``
    the nearer (in DURATION s, accurate physics, field from zero); with both distances (m),
    measured here."""
    run = tmp_path_factory.mktemp("choice") / "seed0"
    shutil.copytree(trained / "m1-4mT" / "seed0", run)
    files = RunDir(run)
    files.evaluation_json.unlink(missing_ok=True)
    other = RunDir(trained / "m1-4mT" / "seed1").checkpoint
    d_own = evaluate_checkpoint(files.checkpoint, {}, DURATION, False)["mid_dx_m"]
    d_other = evaluate_checkpoint(other, {}, DURATION, False)["mid_dx_m"]
    assert d_own != d_other
    own = torch.load(files.checkpoint, weights_only=True)
    actors = [own["agent"]["actor"], torch.load(other, weights_only=True)["agent"]["actor"]]
    near, far = (actors[0], actors[1]) if d_own < d_other else (actors[1], actors[0])
    best = torch.load(files.best, weights_only=True)
    own["agent"]["actor"], best["agent"]["actor"] = near, far
    torch.save(own, files.checkpoint)
    torch.save(best, files.best)
    return run, min(d_own, d_other), max(d_own, d_other)


def test_generate_uses_the_farther_actor_and_says_so(best_is_farther, tmp_path, capsys):
    run, near, far = best_is_farther
    result = run_msr(capsys, "policy", "generate", str(run), "--duration", str(DURATION), "--out",
                     str(tmp_path / "gen"), "--no-figures", "--no-progress")
    choice = result["actor_choice"]
    assert choice["actor"] == "best" and choice["rule"] == "farther"
    assert result["policy"] == str(RunDir(run).best)
    assert choice["best"]["mid_dx_m"] == pytest.approx(far, rel=1e-9, abs=1e-15)
    assert choice["final"]["mid_dx_m"] == pytest.approx(near, rel=1e-9, abs=1e-15)
    assert result["mid_dx_m"] == pytest.approx(far, rel=1e-9, abs=1e-15)  # the same rollout
    # the text output names the actor, both distances, the physics, duration and initial field
    assert msr(["policy", "generate", str(run), "--duration", str(DURATION), "--out", str(tmp_path / "g2"),
                "--no-figures", "--no-progress"]) == 0
    line = capsys.readouterr().out.splitlines()[0]
    assert line.startswith("actor: best.pt") and "accurate physics" in line and "zero field" in line
    assert f"{1e3 * far:+.3g} mm" in line and f"{1e3 * near:+.3g} mm" in line
    assert f"in {DURATION:g} s" in line


def test_checkpoint_option_chooses_explicitly(best_is_farther, tmp_path, capsys):
    run, _, _ = best_is_farther
    result = run_msr(capsys, "policy", "generate", str(run), "--checkpoint", "final", "--duration", "0.05",
                     "--physics", "training", "--out", str(tmp_path / "gen"), "--no-figures",
                     "--no-progress")
    assert result["policy"] == str(RunDir(run).checkpoint)
    assert result["actor_choice"]["actor"] == "final" and result["actor_choice"]["rule"] == "asked"
    assert choose_actor(run, "best").path == RunDir(run).best
    assert choose_actor(RunDir(run).best, "auto") is None  # a best.pt named directly: used as is
    assert msr(["policy", "generate", str(run), "--checkpoint", str(tmp_path / "nope.pt"), "--out",
                str(tmp_path / "g3"), "--no-progress"]) == 2
    assert "nope.pt" in capsys.readouterr().err


def test_ship_and_export_take_the_checkpoint_option(best_is_farther, tmp_path, capsys):
    import json

    run, _, _ = best_is_farther
    shipped = run_msr(capsys, "policy", "ship", str(run), "--name", "b", "--out", str(tmp_path),
                      "--checkpoint", "best", "--no-measure", "--no-progress")
    assert shipped["actor_choice"]["actor"] == "best"
    meta = json.loads((tmp_path / "b" / "policy.json").read_text())
    assert meta["training"]["best_evaluation"] is True
    # the run's recipe and the precision its updates ran in are recorded, and the card says them
    run_json = json.loads((run / "run.json").read_text())
    recorded = meta["training"]["recipe"], meta["training"]["precision"]
    assert recorded == (run_json["recipe"], run_json["precision"])
    card = (tmp_path / "b" / "MODEL_CARD.md").read_text()
    assert f"- recipe `{run_json['recipe']}`, updates in {run_json['precision']}" in card
    # an existing policy is refused before the actors are evaluated
    assert msr(["policy", "ship", str(run), "--name", "b", "--out", str(tmp_path), "--no-progress"]) == 2
    assert "already holds a policy" in capsys.readouterr().err
    exported = run_msr(capsys, "policy", "export", str(run), "--checkpoint", "final", "--out",
                       str(tmp_path / "exp"))
    assert exported["actor_choice"]["actor"] == "final"


def test_refine_continues_the_farther_actor_and_says_so(best_is_farther, tmp_path, monkeypatch,
                                                        capsys):
    from elastica_magnetic_rl.cli import train_commands

    run, near, far = best_is_farther
    monkeypatch.setattr(train_commands, "REFINE_CHOICE_DURATION", DURATION)  # 10 s in use
    args = ["--steps", "2", "--episode-duration", "0.02", "--no-progress"]
    capsys.readouterr()
    assert msr(["refine", str(run), "--out", str(tmp_path / "r1"), *args]) == 0
    line = capsys.readouterr().out.splitlines()[0]
    assert line.startswith("actor: best.pt") and "accurate physics" in line
    assert f"{1e3 * far:+.3g} mm" in line and f"{1e3 * near:+.3g} mm" in line
    meta = json.loads((tmp_path / "r1" / "run.json").read_text())
    assert meta["refined_actor"] == "best" and meta["refined_from"] == str(RunDir(run).best)
    assert not list((tmp_path / "r1").glob(".refine-start-*"))  # the temporary start is gone
    result = run_msr(capsys, "refine", str(run), "--checkpoint", "final", "--out",
                     str(tmp_path / "r2"), *args)
    assert result["actor"] == "final" and result["actor_choice"]["rule"] == "asked"
    # the output is refused before any evaluation
    assert msr(["refine", str(run), "--out", str(tmp_path / "r2"), *args]) == 2
    assert "already holds a refined checkpoint" in capsys.readouterr().err


def test_an_evaluation_of_a_case_without_a_yardstick_has_no_verdict(monkeypatch):
    """Issue 34: ``evaluation.json`` entries (cached or new) carry no ``meets_target`` for a case
    without a yardstick, also when an older cache stored ``true``; the actor choice ignores it."""
    from types import SimpleNamespace

    from elastica_magnetic_rl.cases.case import case_from_dict
    from elastica_magnetic_rl.shipping import policy_runs

    spec = load_case("m1-4mT").to_dict() | {"name": "nostick"}
    spec["yardstick"] = {"distance_10s": 0.0, "source": ""}
    nostick = case_from_dict(spec, "nostick.toml")
    cases = {"nostick.pt": nostick, "paper.pt": load_case("m1-4mT")}
    monkeypatch.setattr(policy_runs, "resolve_policy", lambda path: SimpleNamespace(
        case=cases[Path(path).name], meta={"global_step": 1}))
    old = _entry(0.03) | {"meets_target": True}  # an older file's verdict: moved, so "met"
    entry = evaluate_checkpoint(Path("nostick.pt"), old, 10.0, False)
    assert "meets_target" not in entry and entry["mid_dx_m"] == 0.03
    assert evaluate_checkpoint(Path("paper.pt"), old, 10.0, False)["meets_target"] is True
    # the farther actor, whatever the stored verdicts say
    assert prefer_best(nostick, _entry(0.01) | {"meets_target": True}, _entry(0.02))
    assert not prefer_best(load_case("m1-4mT"), _entry(0.03), _entry(0.02) | {"meets_target": True})


@pytest.mark.parametrize("log, cause", [
    (None, "the run made no evaluation during training"),
    ("global_step,mean_return\n", "the run made no evaluation during training"),
    ("global_step,mean_return\n200,1.5\n300,-0.2\n",
     "best.pt is missing though the run evaluated 2 times (deleted or moved?)"),
])
def test_checkpoint_best_without_best_pt_says_the_true_cause(tmp_path, log, cause):
    # issue 48 r2: "the run made no evaluation" though evaluations.csv listed evaluations
    files = RunDir(tmp_path / "seed0")
    files.path.mkdir()
    files.checkpoint.write_bytes(b"")  # only its presence makes it a run here
    if log is not None:
        files.evaluations_csv.write_text(log)
    with pytest.raises(FileNotFoundError, match=r"--checkpoint best: .*best\.pt: no such file") as exc:
        choose_actor(files.path, "best", DURATION, False)
    assert cause in str(exc.value)
    if log and log.count("\n") > 1:
        assert "made no evaluation" not in str(exc.value)


@pytest.mark.parametrize("command", [["policy", "ship", "--name", "x", "--no-measure"],
                                     ["policy", "diagnose"], ["policy", "generate"],
                                     ["policy", "export"]])
def test_a_folder_of_seed_runs_given_for_one_run_names_the_seed_to_give(trained, tmp_path, capsys,
                                                                        command):
    """A case folder (OUT/<case>) or a training output (OUT) where one run is expected: the
    message says what the folder is and names a seed's run to give instead."""
    for given, expected in ((trained / "m1-4mT", "it is a folder of seed runs (seed0, seed1)"),
                            (trained, "it is a training output holding the case folders m1-4mT")):
        argv = [*command, str(given)]
        if command[1] != "diagnose":
            argv += ["--out", str(tmp_path / "out")]
        assert msr(argv) == 2
        err = capsys.readouterr().err
        assert expected in err and f"e.g. {trained / 'm1-4mT' / 'seed0'}" in err, err
        assert not (tmp_path / "out").exists()


def test_a_model_card_says_when_the_updates_fell_back_to_fp32():
    """A run that asked bfloat16 updates on a CPU without bfloat16 units trained in fp32: the card
    says both (a seed's result depends on which), and says nothing of it for an older record."""
    from elastica_magnetic_rl.cases.case import load_case
    from elastica_magnetic_rl.shipping.model_card import model_card
    from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR

    case = load_case("m1-4mT")
    info = json.loads((POLICIES_DIR / "m1-4mT" / "policy.json").read_text())
    assert "precision" not in info["training"]  # shipped before the record: no line
    assert "updates in" not in model_card(info, None, case)
    info["training"] = {**info["training"], "recipe": "fast", "precision": "fp32",
                        "config": {**info["training"]["config"], "precision": "bf16"}}
    card = model_card(info, None, case)
    assert "- recipe `fast`, updates in fp32 (bf16 asked; this CPU had no bfloat16 units)" in card
    info["training"]["precision"] = "bf16"
    assert "- recipe `fast`, updates in bf16\n" in model_card(info, None, case)
