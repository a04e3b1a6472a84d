"""``msr policy export-seeds`` (rl/shipping/seed_export.py): every seed as a generate-ready folder with
seeds.json, seeds of several runs collected, mixed ones refused."""

from __future__ import annotations

import json

from smoke import run_msr

from elastica_magnetic.cli import main as msr


def test_export_seeds_writes_generate_ready_folders_and_seeds_json(trained, tmp_path, capsys):
    dest = tmp_path / "seeds" / "paper"
    result = run_msr(capsys, "policy", "export-seeds", str(trained / "m1-4mT"), "--out", str(dest),
                     "--duration", "0.05", "--no-progress", "--workers", "2")  # one process a seed
    entries = json.loads((dest / "seeds.json").read_text())
    assert [e["seed"] for e in entries] == [0, 1] and result["total"] == 2
    for e in entries:
        # evaluated for 0.05 s: the distance is labelled with its duration, not stored as 10 s's
        assert set(e) >= {"seed", "steps", "distance_m", "duration_s", "actor", "checkpoint"}
        assert "distance_10s_m" not in e and e["duration_s"] == 0.05
        evaluation = json.loads((trained / "m1-4mT" / f"seed{e['seed']}" / "evaluation.json").read_text())
        chosen = evaluation if e["checkpoint"] == "final" else evaluation["best"]
        assert e["distance_m"] == chosen["mid_dx_m"] and e["steps"] == chosen["global_step"]
        other = evaluation["best"] if e["checkpoint"] == "final" else evaluation
        assert other is None or e["distance_m"] >= other["mid_dx_m"]  # the farther actor
        folder = dest / e["actor"]
        assert sorted(p.name for p in folder.iterdir()) == ["actor.pt", "episodes.csv",
                                                            "evaluations.csv", "policy.json"]
        run_dir = trained / "m1-4mT" / f"seed{e['seed']}"
        assert (folder / "episodes.csv").read_text() == (run_dir / "episodes.csv").read_text()
    out = run_msr(capsys, "policy", "generate", str(dest / "seed0"), "--duration", "0.05", "--out",
                  str(tmp_path / "gen"), "--no-figures", "--no-progress")
    assert out["case"] == "m1-4mT"


def test_export_seeds_collects_seeds_of_several_runs_and_refuses_mixed_ones(trained, tmp_path, capsys):
    """Seeds trained in two runs collect in one folder (the second export keeps the first's seeds it
    does not replace); a folder of seeds trained with other hyperparameters is refused, unchanged."""
    dest = tmp_path / "seeds" / "paper"
    second_run = tmp_path / "second" / "m1-4mT"
    second_run.mkdir(parents=True)
    (second_run / "seed1").symlink_to(trained / "m1-4mT" / "seed1", target_is_directory=True)
    only_seed0 = tmp_path / "first" / "m1-4mT"
    only_seed0.mkdir(parents=True)
    (only_seed0 / "seed0").symlink_to(trained / "m1-4mT" / "seed0", target_is_directory=True)
    run_msr(capsys, "policy", "export-seeds", str(only_seed0), "--out", str(dest), "--duration", "0.05",
            "--no-progress")
    result = run_msr(capsys, "policy", "export-seeds", str(second_run), "--out", str(dest), "--duration",
                     "0.05", "--no-progress")
    entries = json.loads((dest / "seeds.json").read_text())
    assert [e["seed"] for e in entries] == [0, 1] and result["total"] == 2
    assert {"actor.pt", "policy.json"} <= {p.name for p in (dest / "seed0").iterdir()}
    # seed 0's actor now claims another batch size: a mixed folder is refused before anything changes
    policy_json = dest / "seed0" / "policy.json"
    meta = json.loads(policy_json.read_text())
    meta["training"]["config"]["batch_size"] = 64
    policy_json.write_text(json.dumps(meta))
    before = (dest / "seeds.json").read_bytes()
    capsys.readouterr()
    assert msr(["policy", "export-seeds", str(second_run), "--out", str(dest), "--duration", "0.05",
                "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "seed 0" in err and "batch_size" in err and "another folder" in err
    assert (dest / "seeds.json").read_bytes() == before
    # a spec whose default recipe changed since is the same robot and task: kept; another robot is not
    meta["training"]["config"]["batch_size"] = json.loads(
        (dest / "seed1" / "policy.json").read_text())["training"]["config"]["batch_size"]
    meta["case_spec"]["training"]["recipe"] = "pink-ln"
    policy_json.write_text(json.dumps(meta))
    run_msr(capsys, "policy", "export-seeds", str(second_run), "--out", str(dest), "--duration", "0.05",
            "--no-progress", "--force")  # seed 1 is there already: replaced only when asked
    assert [e["seed"] for e in json.loads((dest / "seeds.json").read_text())] == [0, 1]
    meta["case_spec"]["robot"]["youngs_modulus"] *= 2
    policy_json.write_text(json.dumps(meta))
    before = (dest / "seeds.json").read_bytes()
    assert msr(["policy", "export-seeds", str(second_run), "--out", str(dest), "--duration", "0.05",
                "--no-progress", "--force"]) == 2
    err = capsys.readouterr().err
    assert "seed 0" in err and "another spec of case" in err and (dest / "seeds.json").read_bytes() == before
    assert "(they differ at [robot] youngs_modulus)" in err


def test_export_seeds_of_a_case_without_a_yardstick_writes_no_verdict(tmp_path, monkeypatch):
    """Issue 34: seeds.json of a case without a yardstick holds no ``meets_target`` (an earlier
    export's ``true`` is dropped) and the result's ``meeting_target`` is None, not a count of the
    seeds that moved; ``msr policy seeds`` then reports them as not applicable."""
    from pathlib import Path
    from types import SimpleNamespace

    from elastica_magnetic_rl.cases.case import case_from_dict, load_case
    from elastica_magnetic_rl.shipping import seed_export
    from elastica_magnetic_rl.shipping.seed_report import case_seeds

    spec = load_case("m1-4mT").to_dict() | {"name": "nostick"}
    spec["yardstick"] = {"distance_10s": 0.0, "source": ""}
    case = case_from_dict(spec, "nostick.toml")
    meta = {"config": {}, "case_spec": case.to_dict(), "case": "nostick"}
    runs = tmp_path / "runs" / "nostick"
    for seed in (0, 1):
        (runs / f"seed{seed}").mkdir(parents=True)
    dest = tmp_path / "policies" / "nostick" / "seeds" / "paper"
    (dest / "seed5").mkdir(parents=True)  # an earlier export, when no yardstick meant "moved"
    (dest / "seed5" / "policy.json").write_text(json.dumps({"case": "nostick", **meta,
                                                           "training": {"config": {}}}))
    (dest / "seeds.json").write_text(json.dumps([{"seed": 5, "steps": 10, "distance_10s_m": 0.002,
                                                  "actor": "seed5", "checkpoint": "final",
                                                  "meets_target": True}]))

    def evaluation(dx):  # evaluate_checkpoint's entry: no verdict for this case
        return {"global_step": 10, "duration_s": 10.0, "physics": "accurate", "initial_field": "zero",
                "mid_dx_m": dx, "node_dx_m": dx, "diverged": None}

    def fake_ship(source, folder, dest, **kwargs):
        (Path(dest) / folder).mkdir(parents=True, exist_ok=True)
        (Path(dest) / folder / "policy.json").write_text(json.dumps(meta))
        (Path(dest) / folder / "actor.pt").write_bytes(b"")

    monkeypatch.setattr(seed_export, "seed_run_dirs", lambda d: [(0, runs / "seed0"), (1, runs / "seed1")])
    monkeypatch.setattr(seed_export, "resolve_policy", lambda p: SimpleNamespace(case=case, meta=meta))
    monkeypatch.setattr(seed_export, "evaluate_seeds", lambda *a: [
        {"seed": 0, **evaluation(0.03), "best": None}, {"seed": 1, **evaluation(0.001), "best": None}])
    monkeypatch.setattr(seed_export, "ship", fake_ship)
    result = seed_export.export_seeds(runs, dest, progress=False)
    entries = json.loads((dest / "seeds.json").read_text())
    assert [e["seed"] for e in entries] == [0, 1, 5] and result["total"] == 3
    assert all("meets_target" not in e for e in entries) and result["meeting_target"] is None
    (group,) = case_seeds(case, tmp_path / "policies")
    assert group.count is None and group.summary == "n/a (3 seeds)"


def test_a_damaged_summary_json_is_named_with_its_file(trained, tmp_path, capsys):
    import shutil

    case_dir = tmp_path / "m1-4mT"
    shutil.copytree(trained / "m1-4mT", case_dir)
    summary = case_dir / "summary.json"
    summary.write_text(summary.read_text()[:40])  # a copy cut short
    dest = tmp_path / "seeds"
    assert msr(["policy", "export-seeds", str(case_dir), "--out", str(dest), "--duration", "0.05",
                "--no-progress", "--workers", "1"]) == 2
    err = capsys.readouterr().err
    assert "summary.json: not readable as JSON (line 3" in err and "restore it" in err, err
    assert not dest.exists()


def test_a_hand_edited_seed_number_is_named_before_any_evaluation(trained, tmp_path, capsys):
    dest = tmp_path / "seeds"
    dest.mkdir()
    (dest / "seeds.json").write_text(json.dumps([{"seed": "zero", "actor": "seed0"}]))
    before = (dest / "seeds.json").read_bytes()
    assert msr(["policy", "export-seeds", str(trained / "m1-4mT"), "--out", str(dest), "--duration",
                "0.05", "--no-progress", "--workers", "1", "--force"]) == 2
    err = capsys.readouterr().err
    assert "seeds.json: entry 0: seed = 'zero', expected a seed number" in err, err
    assert (dest / "seeds.json").read_bytes() == before
