"""Smoke tests of the RL pipeline through ``msr``: train (2 seeds, 2 worker processes), refine in the
accurate physics, generate, ship, export (TorchScript reloaded with plain torch), figures, demo."""

from __future__ import annotations

import csv
import importlib.metadata
import json
import warnings
from pathlib import Path

import numpy as np
import pytest
import torch
from elastica_magnetic_rl.envs.env import OBSERVATION_LAYOUT, MagneticCrawlerEnv
from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint
from elastica_magnetic_rl.shipping import pipeline, policy_files, policy_runs
from elastica_magnetic_rl.td3.agent import TD3Agent

from elastica_magnetic import read_field_csv
from elastica_magnetic.cli import main as msr
from elastica_magnetic.simulation import TRAJECTORY_COLUMNS

TRAIN_STEPS = 240
SMOKE = ["--learning-starts", "60", "--batch-size", "32", "--hidden", "32,32",
         "--episode-duration", "0.8", "--checkpoint-every", "80", "--eval-every", "120",
         "--no-progress"]


def run_msr(capsys, *argv: str) -> dict:
    capsys.readouterr()
    status = msr([*argv, "--json"])
    out = capsys.readouterr().out
    assert status == 0, out
    return json.loads(out)


@pytest.fixture(scope="module")
def trained(tmp_path_factory) -> Path:
    """``msr train`` smoke run: 2 seeds in 2 processes, training physics, tiny networks."""
    out = tmp_path_factory.mktemp("runs")
    status = msr(["train", "--case", "m1-4mT", "--seeds", "2", "--workers", "2", "--steps",
                  str(TRAIN_STEPS), "--out", str(out), *SMOKE])
    assert status == 0
    return out


@pytest.fixture(scope="module")
def refined(trained) -> Path:
    run = trained / "m1-4mT" / "seed0"
    assert msr(["refine", str(run), "--steps", "3", "--episode-duration", "0.02",
                "--no-progress"]) == 0
    return run / "refined"


def test_train_writes_run_dirs_and_summary(trained):
    case_dir = trained / "m1-4mT"
    for seed in (0, 1):
        run = case_dir / f"seed{seed}"
        assert (run / "checkpoint.pt").is_file() and (run / "episodes.csv").is_file()
        assert list(run.glob("events.out.tfevents.*")), "no TensorBoard scalars"
        meta = json.loads((run / "run.json").read_text())
        assert meta["case"] == "m1-4mT" and meta["seed"] == seed and meta["physics"] == "training"
        assert meta["config"]["target_noise_clip"] == 0.8 and meta["config"]["batch_size"] == 32
        assert meta["versions"]["pyelastica"] == importlib.metadata.version("pyelastica")
        with open(run / "episodes.csv") as f:
            rows = list(csv.DictReader(f))
        assert len(rows) == TRAIN_STEPS // 80 and int(rows[-1]["global_step"]) == TRAIN_STEPS
        assert all(r["truncated"] == "1" and r["terminated"] == "0" for r in rows)
        ckpt = load_checkpoint(run)
        assert ckpt["global_step"] == TRAIN_STEPS and ckpt["metadata"]["case"] == "m1-4mT"
        # evaluations from a zero field, 10 s: at the episode end past 120 steps, and at the end
        with open(run / "evaluations.csv") as f:
            evals = list(csv.DictReader(f))
        assert [int(r["global_step"]) for r in evals] == [160, TRAIN_STEPS]
        assert all(float(r["mean_length"]) == 1000 for r in evals)
        best = load_checkpoint(run / "best.pt")
        assert best["kind"] == "best" and best["global_step"] in (160, TRAIN_STEPS)
        assert best["metadata"]["case"] == "m1-4mT"
    summary = json.loads((case_dir / "summary.json").read_text())
    assert [s["seed"] for s in summary["seeds"]] == [0, 1] and not summary["failed"]
    assert all(np.isfinite(s["final_mean_return"]) for s in summary["seeds"])
    assert all(s["best_eval_step"] in (160, TRAIN_STEPS) for s in summary["seeds"])
    # the two seeds really differ
    a0 = load_checkpoint(case_dir / "seed0")["agent"]["actor"]
    a1 = load_checkpoint(case_dir / "seed1")["agent"]["actor"]
    assert not torch.equal(a0["net.0.weight"], a1["net.0.weight"])


def test_train_seeds_sharing_a_simulator_equal_the_separate_runs(trained, tmp_path, capsys):
    """``--seeds-per-simulator 2``: both seeds in one worker and one batched simulator end with the
    same episodes and weights as the 2-process run of the ``trained`` fixture."""
    summary = run_msr(capsys, "train", "--case", "m1-4mT", "--seeds", "2", "--workers", "1",
                      "--threads", "1", "--seeds-per-simulator", "2", "--steps", str(TRAIN_STEPS),
                      "--out", str(tmp_path), *SMOKE)
    assert [s["seed"] for s in summary["seeds"]] == [0, 1] and summary["seeds_per_simulator"] == 2
    for seed in (0, 1):
        shared, alone = tmp_path / "m1-4mT" / f"seed{seed}", trained / "m1-4mT" / f"seed{seed}"
        assert json.loads((shared / "run.json").read_text())["shared_simulator_seeds"] == 2
        rows = [(tuple(r.values())[:-1]) for r in csv.DictReader(open(shared / "episodes.csv"))]
        assert rows == [(tuple(r.values())[:-1]) for r in csv.DictReader(open(alone / "episodes.csv"))]
        assert (_rows_without_wall_time(shared / "evaluations.csv")
                == _rows_without_wall_time(alone / "evaluations.csv"))
        a, b = load_checkpoint(shared)["agent"], load_checkpoint(alone)["agent"]
        for part in ("actor", "critic"):
            for name, tensor in a[part].items():
                assert torch.equal(tensor, b[part][name]), (seed, part, name)
    capsys.readouterr()
    assert msr(["train", "--case", "m1-4mT", "--seeds", "2", "--seeds-per-simulator", "0",
                "--steps", "10", "--out", str(tmp_path / "x"), "--no-progress"]) == 2
    assert "--seeds-per-simulator must be >= 1" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def _rows_without_wall_time(path: Path) -> list[dict[str, str]]:
    with open(path) as f:
        return [{k: v for k, v in r.items() if k != "wall_time_s"} for r in csv.DictReader(f)]


def test_best_actor_generates_but_does_not_refine(trained, tmp_path, capsys):
    best = trained / "m1-4mT" / "seed0" / "best.pt"
    result = run_msr(capsys, "generate", str(best), "--duration", "0.05", "--physics", "training",
                     "--out", str(tmp_path / "gen"), "--no-figures", "--no-progress")
    assert result["case"] == "m1-4mT" and result["policy"] == str(best)
    assert msr(["refine", str(best), "--steps", "2", "--no-progress"]) == 2
    assert "best evaluation" in capsys.readouterr().err


def test_train_refuses_to_overwrite(trained, capsys):
    assert msr(["train", "--case", "m1-4mT", "--seeds", "1", "--steps", "10", "--out",
                str(trained), "--no-progress"]) == 2
    assert "--resume" in capsys.readouterr().err


def test_train_resume_extends_runs(tmp_path, capsys):
    """``--resume`` continues a finished run to a larger step count (one seed, in-process)."""
    args = ["train", "--case", "m2-4mT", "--seeds", "1", "--seed-offset", "3", "--out", str(tmp_path),
            "--learning-starts", "20", "--batch-size", "8", "--hidden", "8", "--episode-duration",
            "0.2", "--no-progress"]
    assert msr([*args, "--steps", "20"]) == 0
    summary = run_msr(capsys, *args, "--steps", "40", "--resume")
    assert summary["seeds"][0]["global_step"] == 40 and summary["seeds"][0]["episodes"] == 2
    run = tmp_path / "m2-4mT" / "seed3"
    meta = json.loads((run / "run.json").read_text())
    assert meta["steps"] == 40 and meta["resumed"] == 1 and meta["seed"] == 3
    assert load_checkpoint(run)["global_step"] == 40
    # another call adding seed 4: the summary covers both seeds of the case
    args[args.index("--seed-offset") + 1] = "4"
    summary = run_msr(capsys, *args, "--steps", "20")
    assert [s["seed"] for s in summary["seeds"]] == [3, 4]
    assert [s["global_step"] for s in summary["seeds"]] == [40, 20]
    assert summary["seeds"][1]["peak_rss_bytes"] > 50e6  # python + torch + numba at least
    assert summary["seeds"][0]["peak_rss_bytes"] > 0  # kept from the earlier call's summary
    on_disk = json.loads((tmp_path / "m2-4mT" / "summary.json").read_text())
    assert [s["seed"] for s in on_disk["seeds"]] == [3, 4]


def test_layer_norm_recipe_trains_ships_and_loads_with_its_critic(tmp_path):
    """``--recipe pink-ln``: the critics get layer norms (checkpoint config), and the run and its
    shipped folder (``critic.pt``, ``policy.json``'s architecture) load back with them."""
    from elastica_magnetic_rl.shipping.pipeline import ship
    from elastica_magnetic_rl.shipping.policy_files import resolve_policy

    assert msr(["train", "--case", "m1-4mT", "--seeds", "1", "--out", str(tmp_path), "--steps", "20",
                "--learning-starts", "10", "--batch-size", "8", "--hidden", "8", "--episode-duration",
                "0.1", "--no-progress", "--recipe", "pink-ln"]) == 0
    run = tmp_path / "m1-4mT" / "seed0"
    config = load_checkpoint(run)["config"]
    assert config["critic_layer_norm"] is True and config["noise_color"] == 1.0
    loaded = resolve_policy(run)
    assert isinstance(loaded.critic.q1_net[1], torch.nn.LayerNorm)
    ship(run, "ln", dest=tmp_path / "shipped", measure=False, progress=False, with_card=False)
    meta = json.loads((tmp_path / "shipped" / "ln" / "policy.json").read_text())
    assert meta["architecture"]["critic_layer_norm"] is True
    again = resolve_policy(tmp_path / "shipped" / "ln")
    for a, b in zip(again.critic.state_dict().values(), loaded.critic.state_dict().values(),
                    strict=True):
        assert torch.equal(a, b)


def test_recipe_is_recorded_and_a_resume_keeps_the_runs_settings(tmp_path, capsys):
    """``--recipe pink`` trains with pink exploration noise (run.json, the checkpoint's config);
    a resume that changes the recipe or the episode length is refused before anything is touched."""
    args = ["train", "--case", "m1-4mT", "--seeds", "1", "--out", str(tmp_path), "--learning-starts",
            "10", "--batch-size", "8", "--hidden", "8", "--episode-duration", "0.1", "--no-progress"]
    assert msr([*args, "--steps", "20", "--recipe", "pink"]) == 0
    run = tmp_path / "m1-4mT" / "seed0"
    assert json.loads((run / "run.json").read_text())["recipe"] == "pink"
    assert load_checkpoint(run)["config"]["noise_color"] == 1.0
    before = (run / "episodes.csv").read_text()
    capsys.readouterr()
    assert msr([*args, "--steps", "30", "--resume"]) == 2  # the case's recipe: pink-ln
    assert "--recipe pink-ln differs from the run's pink" in capsys.readouterr().err
    args[args.index("--episode-duration") + 1] = "0.2"
    assert msr([*args, "--steps", "30", "--resume", "--recipe", "pink"]) == 2
    assert "--episode-duration 0.2 differs from the run's 0.1" in capsys.readouterr().err
    assert (run / "episodes.csv").read_text() == before
    assert json.loads((run / "run.json").read_text())["steps"] == 20
    # a resume of a seed that has no checkpoint is refused too, naming the file
    assert msr([*args, "--steps", "30", "--resume", "--seed-offset", "5"]) == 2
    assert "seed5/checkpoint.pt" in capsys.readouterr().err
    # a run started when the case's default recipe was another one resumes with its own recipe
    record = json.loads((run / "run.json").read_text())
    record["case_spec"]["training"]["recipe"] = "pink-ln-unsat"
    (run / "run.json").write_text(json.dumps(record))
    args[args.index("--episode-duration") + 1] = "0.1"
    assert msr([*args, "--steps", "30", "--resume", "--recipe", "pink"]) == 0
    assert load_checkpoint(run)["global_step"] == 30


def test_refine_continues_agent_and_buffer_in_accurate_physics(trained, refined):
    source = load_checkpoint(trained / "m1-4mT" / "seed0")
    ckpt = load_checkpoint(refined)
    assert ckpt["global_step"] == TRAIN_STEPS + 3
    assert ckpt["buffer"]["size"] == TRAIN_STEPS + 3  # the training transitions are kept
    assert torch.equal(ckpt["buffer"]["obs"][:TRAIN_STEPS], source["buffer"]["obs"])
    # learning happened (past the warm-up): more critic updates, different weights
    assert ckpt["agent"]["num_updates"] == source["agent"]["num_updates"] + 3
    assert not torch.equal(ckpt["agent"]["critic"]["q1_net.0.weight"],
                           source["agent"]["critic"]["q1_net.0.weight"])
    meta = ckpt["metadata"]
    assert meta["physics"] == "accurate" and meta["command"] == "refine"
    assert meta["refine_steps"] == 3 and meta["training_steps"] == TRAIN_STEPS
    assert json.loads((refined / "run.json").read_text())["physics"] == "accurate"


def test_generate_json_and_files(refined, tmp_path, capsys):
    out = tmp_path / "gen"
    result = run_msr(capsys, "generate", str(refined), "--duration", "0.2", "--out", str(out),
                     "--no-progress")
    for key in ("mid_dx_m", "fields_csv", "trajectory_csv"):
        assert key in result
    assert np.isfinite(result["mid_dx_m"]) and result["physics"] == "accurate"
    assert not result["diverged"]
    header = Path(result["fields_csv"]).read_text().splitlines()[0]
    assert header == ",mag_x,mag_y,mag_z"
    fields = read_field_csv(result["fields_csv"])
    assert fields.shape == (20, 3)
    assert np.all(np.abs(fields[0, :2]) <= 0.3e-3 + 1e-12)  # from zero, one increment
    assert np.all(np.abs(np.diff(fields[:, :2], axis=0)) <= 0.3e-3 + 1e-12)
    with open(result["trajectory_csv"]) as f:
        rows = list(csv.reader(f))
    assert tuple(rows[0]) == TRAJECTORY_COLUMNS and len(rows) == 22 and float(rows[1][0]) == 0.0
    assert float(rows[-1][0]) == pytest.approx(0.2)
    figures = result["figures"]
    for name in ("positions_velocities", "field_waveforms", "field_polar", "height_span_contact",
                 "q_values", "filmstrip", "gait_gif"):
        assert Path(figures[name]).stat().st_size > 1000, name
    assert Path(figures["gait_gif"]).read_bytes()[:3] == b"GIF"
    with open(result["gait_csv"]) as f:
        gait = list(csv.DictReader(f))
    assert len(gait) == 21 and float(gait[0]["contact_back"]) == 1.0


def test_ship_evaluates_every_seed_and_caches(refined, tmp_path, monkeypatch):
    """``evaluate_all_seeds``: each seed's final checkpoint is rolled out (accurate physics, zero
    field); the card lists them with the notes; a second ship reuses the per-seed cache."""
    info = pipeline.ship(refined, "m1-4mT", dest=tmp_path, measure=False, duration=0.05,
                         progress=False, evaluate_all_seeds=True, notes="Trained by a *test*.")
    meta = json.loads((tmp_path / "m1-4mT" / "policy.json").read_text())
    evaluations = meta["seeds"]["evaluations"]
    assert [e["seed"] for e in evaluations] == [0, 1] and info["evaluation"] is None
    assert all(e["global_step"] == TRAIN_STEPS and e["duration_s"] == 0.05 for e in evaluations)
    assert all(e["meets_target"] is None for e in evaluations)  # 0.05 s: not the 10 s criterion
    assert evaluations[0]["mid_dx_m"] != evaluations[1]["mid_dx_m"]  # two different actors
    for e in evaluations:  # and each seed's best.pt, with its own step
        best = load_checkpoint(refined.parent.parent / f"seed{e['seed']}" / "best.pt")
        assert e["best"]["global_step"] == best["global_step"]
        assert e["best"]["duration_s"] == 0.05 and e["best"]["meets_target"] is None
    card = (tmp_path / "m1-4mT" / "MODEL_CARD.md").read_text()
    assert "| 0 | 240 |" in card and "| 1 | 240 |" in card and "best.pt" in card
    assert "## Notes" in card and "Trained by a *test*." in card
    cache = refined.parent / "evaluation.json"  # seed0/evaluation.json
    assert json.loads(cache.read_text())["mid_dx_m"] == evaluations[0]["mid_dx_m"]

    def no_rollout(*args, **kwargs):
        raise AssertionError("the cached evaluation should have been reused")

    monkeypatch.setattr(policy_runs, "run_policy", no_rollout)
    again = policy_runs.evaluate_seeds(refined.parent.parent, duration=0.05, progress=False)
    assert again == evaluations
    # shipping the best actor of a seed says so on the card
    pipeline.ship(refined.parent / "best.pt", "m1-4mT-best", dest=tmp_path, measure=False)
    card = (tmp_path / "m1-4mT-best" / "MODEL_CARD.md").read_text()
    assert "best.pt" in card and "the best of the evaluations during training" in card


def test_ship_over_a_policy_keeps_it_when_the_measurement_fails(refined, tmp_path, monkeypatch):
    """``ship --force`` computes everything before it writes: a measurement that fails (or is
    interrupted) leaves the policy it was to replace byte for byte as it was; one that succeeds
    replaces it, and the old waveform does not outlive its actor."""
    dest = tmp_path / "policies"
    pipeline.ship(refined, "m1-4mT", dest=dest, measure=True, duration=0.03, progress=False)
    folder = dest / "m1-4mT"
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    assert "fields.csv" in before

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(pipeline, "run_policy", interrupted)
    best = refined.parent / "best.pt"  # another actor
    with pytest.raises(KeyboardInterrupt):
        pipeline.ship(best, "m1-4mT", dest=dest, overwrite=True, progress=False)
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before
    # replaced without a measurement: the replaced policy's fields.csv goes with it
    pipeline.ship(best, "m1-4mT", dest=dest, overwrite=True, measure=False, progress=False)
    assert not (folder / "fields.csv").exists()
    assert json.loads((folder / "policy.json").read_text())["training"]["best_evaluation"]
    assert policy_files.resolve_policy(folder).kind == "shipped"  # the new files belong together


def test_export_seeds_writes_generate_ready_folders_and_seeds_json(trained, tmp_path, capsys):
    dest = tmp_path / "seeds" / "paper"
    result = run_msr(capsys, "export-seeds", str(trained / "m1-4mT"), "--dest", str(dest),
                     "--duration", "0.05", "--no-progress", "--workers", "2")  # one process a seed
    entries = json.loads((dest / "seeds.json").read_text())
    assert [e["seed"] for e in entries] == [0, 1] and result["total"] == 2
    for e in entries:
        assert set(e) >= {"seed", "steps", "distance_10s_m", "actor", "checkpoint"}
        evaluation = json.loads((trained / "m1-4mT" / f"seed{e['seed']}" / "evaluation.json").read_text())
        chosen = evaluation if e["checkpoint"] == "final" else evaluation["best"]
        assert e["distance_10s_m"] == chosen["mid_dx_m"] and e["steps"] == chosen["global_step"]
        other = evaluation["best"] if e["checkpoint"] == "final" else evaluation
        assert other is None or e["distance_10s_m"] >= other["mid_dx_m"]  # the farther actor
        folder = dest / e["actor"]
        assert sorted(p.name for p in folder.iterdir()) == ["actor.pt", "episodes.csv",
                                                            "evaluations.csv", "policy.json"]
        run_dir = trained / "m1-4mT" / f"seed{e['seed']}"
        assert (folder / "episodes.csv").read_text() == (run_dir / "episodes.csv").read_text()
    out = run_msr(capsys, "generate", str(dest / "seed0"), "--duration", "0.05", "--out",
                  str(tmp_path / "gen"), "--no-figures", "--no-progress")
    assert out["case"] == "m1-4mT"


def test_ship_then_generate_by_folder_and_name(refined, tmp_path, monkeypatch, capsys):
    dest = tmp_path / "policies"
    info = pipeline.ship(refined, "m1-4mT", dest=dest, measure=True, duration=0.05, progress=False)
    folder = dest / "m1-4mT"
    assert {"actor.pt", "critic.pt", "policy.json", "MODEL_CARD.md", "fields.csv"} <= set(info["files"])
    meta = json.loads((folder / "policy.json").read_text())
    assert meta["case"] == "m1-4mT" and meta["architecture"]["hidden_sizes"] == [32, 32]
    actor_state = torch.load(folder / "actor.pt", weights_only=True)
    assert meta["actor_sha256"] == policy_files.weights_sha256(actor_state)
    assert meta["training"]["refine_steps"] == 3 and meta["seeds"]["total"] == 2
    card = (folder / "MODEL_CARD.md").read_text()
    assert "m1-4mT" in card and "refinement steps" in card and "seeds that succeeded" in card
    # the shipped actor acts exactly as the checkpoint's
    obs = np.random.default_rng(1).normal(size=260).astype(np.float32)
    shipped = policy_files.resolve_policy(folder)
    original = policy_files.resolve_policy(refined)
    np.testing.assert_array_equal(shipped.act(obs), original.act(obs))
    # by name, from the (patched) package folder of shipped policies

    monkeypatch.setattr(policy_files, "POLICIES_DIR", dest)
    result = run_msr(capsys, "generate", "m1-4mT", "--duration", "0.03", "--out",
                     str(tmp_path / "gen"), "--no-progress", "--no-gif")
    assert result["policy"] == str(folder) and "q_values" in result["figures"]
    with pytest.raises(FileExistsError):
        pipeline.ship(refined, "m1-4mT", dest=dest, measure=False)


def test_export_torchscript_matches_agent(trained, tmp_path, capsys):
    run = trained / "m1-4mT" / "seed1"
    result = run_msr(capsys, "export", str(run), "--out", str(tmp_path / "export"))
    assert result["max_abs_diff"] < 1e-6 and result["max_abs_diff_pt2"] < 1e-6
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # torch.jit is deprecated in 2.13
        module = torch.jit.load(result["torchscript"])  # plain torch, no package code
    program = torch.export.load(result["torch_export"]).module()
    layout = json.loads(Path(result["json"]).read_text())
    assert layout["observation"]["size"] == 260
    assert layout["action"]["field_increment_T_per_unit"] == 3e-4
    agent = TD3Agent.from_checkpoint(run / "checkpoint.pt")
    env = MagneticCrawlerEnv(duration=0.05)
    obs, _ = env.reset(seed=5)
    obs, *_ = env.step(np.array([0.5, -0.5], np.float32))
    with torch.no_grad():
        exported = module(torch.from_numpy(obs[None]))[0].numpy()
        exported_pt2 = program(torch.from_numpy(obs[None]))[0].numpy()
    np.testing.assert_allclose(exported, agent.act(obs), atol=1e-6)
    np.testing.assert_allclose(exported_pt2, agent.act(obs), atol=1e-6)
    assert obs[OBSERVATION_LAYOUT["field_amplitude"]][0] > 0


def test_figures_from_training_runs(trained, tmp_path, capsys):
    result = run_msr(capsys, "figures", str(trained), "--out", str(tmp_path))
    assert Path(result["learning_curves_m1-4mT"]).stat().st_size > 1000


def test_demo_names_the_missing_policy(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(pipeline, "POLICIES_DIR", tmp_path / "none")
    assert msr(["demo", "--out", str(tmp_path / "demo"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "m1-4mT" in err and "actor.pt" in err and "msr ship" in err


def test_unknown_policy_is_a_clear_error(tmp_path):
    with pytest.raises(policy_files.PolicyNotFoundError, match="shipped"):
        policy_files.resolve_policy(tmp_path / "nothing-here")


#: Whether each shipped policy reaches the authors' 10 s distance, as rl/policies/README.md and
#: the docs state it (a policy re-shipped with another result must update them, and this).
SHIPPED = ("hu2018-crawl", "m1-10mT", "m1-4mT", "m1-4mT-reach", "m2-10mT", "m2-4mT")


def test_every_shipped_policy_is_tested():
    from elastica_magnetic_rl.shipping.shipped import shipped_names

    assert shipped_names() == list(SHIPPED)


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_policy_generates_and_exports(name, tmp_path, capsys):
    """A policy shipped in the package: generate a short run by name, export it, reload it; its
    card and policy.json agree with the case and report a 10 s distance that reaches the authors'
    (as the README states for every shipped policy), or its target for cases beyond the paper."""
    import json

    import torch

    assert msr(["generate", name, "--duration", "0.05", "--out", str(tmp_path / "gen"),
                "--no-gif", "--no-figures", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    fields = np.loadtxt(result["fields_csv"], delimiter=",", skiprows=1)
    assert fields.shape == (5, 4)
    assert np.all(np.abs(fields[:, 1:3]) <= 5 * 0.3 + 1e-9)  # mT: from zero, +-0.3 mT per step
    assert msr(["export", name, "--out", str(tmp_path / "exp")]) == 0
    policy = policy_files.resolve_policy(name)
    assert policy.case.name == name
    obs = np.zeros(policy.case.obs_dim, dtype=np.float32)
    module = torch.jit.load(str(next((tmp_path / "exp").glob("*.ts.pt"))))
    action = module(torch.from_numpy(obs)[None]).detach().numpy()[0]
    np.testing.assert_allclose(action, policy.act(obs), atol=1e-6)
    info = json.loads((policy_files.POLICIES_DIR / name / "policy.json").read_text())
    assert info["case"] == name and info["evaluation"]["duration_s"] == 10.0
    ev = info["evaluation"]
    assert policy.case.meets_yardstick(ev["mid_dx_m"], ev.get("node_dx_m", ev["mid_dx_m"]),
                                       ev["duration_s"], ev["diverged"])
    if name in ("m1-10mT", "m1-4mT", "m2-10mT", "m2-4mT"):
        assert ev["mid_dx_m"] >= info["authors_mid_dx_10s_m"]
    card = (policy_files.POLICIES_DIR / name / "MODEL_CARD.md").read_text()
    assert "meets the target" in card
    shipped_fields = np.loadtxt(policy_files.POLICIES_DIR / name / "fields.csv", delimiter=",", skiprows=1)
    assert shipped_fields.shape == (1000, 4)  # the 10 s waveform, 100 rows/s


def test_one_shipped_distance_is_re_run_in_full():
    """The whole 10 s accurate rollout of one shipped policy (a different one each day, in turn;
    ``msr validate shipped`` runs all four; ``--quick``, in the validation tests, their first 0.3 s)
    reproduces policy.json's distance to 1e-3 relative and reaches the authors' distance, and the
    shipped waveform row by row on the machine that recorded it (elsewhere round-off, amplified
    by contact switches, parts the waveforms; see elastica_magnetic_rl.shipping.shipped)."""
    import datetime

    from elastica_magnetic_rl.shipping.shipped import verify_shipped

    name = SHIPPED[datetime.date.today().toordinal() % len(SHIPPED)]
    result = verify_shipped(name)
    assert result["rows_compared"] == 1000
    assert result["relative_diff"] <= result["distance_rtol"] == 1e-3, result
    assert result["meets_authors"] and result["passed"], result
    if result["waveform_check"] == "exact":
        assert result["max_field_diff_mT"] <= 1e-6


def test_a_policy_rollout_is_deterministic_on_one_machine():
    """The claim behind the shipped waveforms: on one machine, two rollouts of a policy give the
    same waveform and trajectory bit for bit."""
    from elastica_magnetic_rl.shipping.policy_runs import resolve_policy, run_policy

    policy = resolve_policy("m2-4mT")
    first, second = (run_policy(policy, 0.3, "accurate", "zero", False) for _ in range(2))
    assert np.array_equal(first.fields, second.fields)
    assert np.array_equal(first.positions, second.positions)


def test_resume_from_a_corrupted_checkpoint_is_refused_and_keeps_the_results(tmp_path, capsys):
    args = ["train", "--case", "m1-4mT", "--seeds", "1", "--out", str(tmp_path), "--learning-starts",
            "10", "--batch-size", "8", "--hidden", "8", "--episode-duration", "0.1", "--no-progress"]
    assert msr([*args, "--steps", "20"]) == 0
    run = tmp_path / "m1-4mT" / "seed0"
    ckpt = run / "checkpoint.pt"
    ckpt.write_bytes(ckpt.read_bytes()[:100])  # truncated
    kept = {p: p.read_bytes() for p in (tmp_path / "m1-4mT" / "summary.json", run / "run.json",
                                        run / "episodes.csv", ckpt)}
    capsys.readouterr()
    assert msr([*args, "--steps", "40", "--resume"]) == 2
    err = capsys.readouterr().err
    assert f"{ckpt}: cannot be read as a checkpoint" in err and "Traceback" not in err
    assert all(p.read_bytes() == data for p, data in kept.items())


def test_ctrl_c_stops_cleanly_and_the_run_resumes(tmp_path):
    """SIGINT to a real 2-worker training: exit 130, no traceback, the message names the folders;
    the checkpoints it left resume."""
    import os
    import signal
    import subprocess
    import sys
    import time

    args = [sys.executable, "-m", "elastica_magnetic.cli", "train", "--case", "m1-4mT", "--seeds", "2",
            "--out", str(tmp_path), "--learning-starts", "10", "--batch-size", "8", "--hidden", "8",
            "--episode-duration", "0.1", "--checkpoint-every", "10", "--no-progress"]
    # as from a terminal: SIGINT delivered, also when the suite itself was started in the
    # background (a shell starts background jobs with SIGINT ignored, and children inherit that)
    proc = subprocess.Popen([*args, "--steps", "100000"], stderr=subprocess.PIPE, text=True,
                            start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    ckpts = [tmp_path / "m1-4mT" / f"seed{s}" / "checkpoint.pt" for s in (0, 1)]
    # generous: on a loaded machine starting two workers (imports, numba JIT) takes minutes
    deadline = time.time() + 600
    while not all(p.exists() for p in ckpts) and time.time() < deadline and proc.poll() is None:
        time.sleep(0.2)
    try:
        assert all(p.exists() for p in ckpts), "the training wrote no checkpoints to interrupt"
        time.sleep(1.0)
        os.killpg(proc.pid, signal.SIGINT)  # as Ctrl-C does: the whole foreground process group
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:  # never leave a training running behind a failed test
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130, err
    assert "interrupted" in err and "--resume" in err and "Traceback" not in err
    steps = [load_checkpoint(p, with_buffer=False)["global_step"] for p in ckpts]
    target = str(max(steps) + 20)
    done = subprocess.run([*args, "--steps", target, "--resume"], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    assert all(load_checkpoint(p)["global_step"] == int(target) for p in ckpts)


def test_sigint_to_the_main_process_alone_ends_the_workers(tmp_path):
    """``kill -INT`` of the main process only (not its group): the workers do not get it, so the
    main process ends them after its grace period instead of waiting on the whole training; exit
    130, and the checkpoints they left resume."""
    import os
    import signal
    import subprocess
    import sys
    import time

    from elastica_magnetic_rl.sweep.backends import STOP_GRACE_S

    args = [sys.executable, "-m", "elastica_magnetic.cli", *_tiny_train(tmp_path, "--seeds", "2",
            "--checkpoint-every", "10")]
    proc = subprocess.Popen([*args, "--steps", "100000"], stderr=subprocess.PIPE, text=True,
                            start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    ckpts = [tmp_path / "m1-4mT" / f"seed{s}" / "checkpoint.pt" for s in (0, 1)]
    deadline = time.time() + 600
    while not all(p.exists() for p in ckpts) and time.time() < deadline and proc.poll() is None:
        time.sleep(0.2)
    try:
        assert all(p.exists() for p in ckpts), "the training wrote no checkpoints to interrupt"
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=STOP_GRACE_S + 120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130, err
    assert "interrupted" in err and "--resume" in err and "Traceback" not in err
    steps = [load_checkpoint(p, with_buffer=False)["global_step"] for p in ckpts]
    target = str(max(steps) + 20)
    done = subprocess.run([*args, "--steps", target, "--resume"], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr


def _tiny_train(out, *extra):
    return ["train", "--case", "m1-4mT", "--out", str(out), "--learning-starts", "10", "--batch-size",
            "8", "--hidden", "8", "--episode-duration", "0.1", "--no-progress", *extra]


def test_train_output_that_is_a_file_is_refused_before_any_work(tmp_path, capsys):
    (tmp_path / "taken").write_text("a file")
    capsys.readouterr()
    assert msr(_tiny_train(tmp_path / "taken", "--seeds", "1", "--steps", "20")) == 2
    err = capsys.readouterr().err
    assert f"--out {tmp_path / 'taken'}" in err and "is a file" in err and "Traceback" not in err
    assert (tmp_path / "taken").read_text() == "a file"


def test_a_failing_worker_is_reported_and_the_other_seeds_finish(tmp_path, capsys):
    """Two seeds in two worker processes; on resume seed 1's replay file is gone, so its worker
    raises: exit status 1, ``failed`` names it, seed 0 finishes, seed 1 keeps its earlier numbers."""
    assert msr(_tiny_train(tmp_path, "--seeds", "2", "--steps", "20")) == 0
    (tmp_path / "m1-4mT" / "seed1" / "replay.bin").unlink()
    capsys.readouterr()
    assert msr([*_tiny_train(tmp_path, "--seeds", "2", "--steps", "40", "--resume"), "--json"]) == 1
    summary = json.loads(capsys.readouterr().out)
    assert summary["failed"] == [1]
    seed0, seed1 = summary["seeds"]
    assert seed0["global_step"] == 40 and "error" not in seed0
    assert "replay.bin is missing" in seed1["error"] and seed1["global_step"] == 20
    assert load_checkpoint(tmp_path / "m1-4mT" / "seed0")["global_step"] == 40


def test_sigkill_then_resume_equals_an_uninterrupted_run(tmp_path):
    """A real training process killed with SIGKILL (here after its first checkpoints, with what a
    kill inside a checkpoint write leaves: a partial ``checkpoint.pt.tmp`` and stray rows in
    ``replay.bin``) resumes to the same weights as a run never interrupted."""
    import os
    import signal
    import subprocess
    import sys
    import time

    base = [sys.executable, "-m", "elastica_magnetic.cli", *_tiny_train(tmp_path / "killed"),
            "--seeds", "1", "--checkpoint-every", "10", "--threads", "1"]
    proc = subprocess.Popen([*base, "--steps", "100000"], start_new_session=True,
                            stderr=subprocess.DEVNULL)
    ckpt = tmp_path / "killed" / "m1-4mT" / "seed0" / "checkpoint.pt"
    deadline = time.time() + 120
    while time.time() < deadline and proc.poll() is None and (
            not ckpt.exists() or load_checkpoint(ckpt, with_buffer=False)["global_step"] < 30):
        time.sleep(0.2)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(timeout=60)
    assert proc.returncode == -signal.SIGKILL
    run = ckpt.parent
    (run / "checkpoint.pt.tmp").write_bytes(ckpt.read_bytes()[:64])
    with open(run / "replay.bin", "ab") as f:
        f.write(b"\0" * 1000)
    target = load_checkpoint(ckpt, with_buffer=False)["global_step"] + 30
    done = subprocess.run([*base, "--steps", str(target), "--resume"], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    straight = subprocess.run([sys.executable, "-m", "elastica_magnetic.cli",
                               *_tiny_train(tmp_path / "straight"), "--seeds", "1", "--checkpoint-every",
                               "10", "--threads", "1", "--steps", str(target)],
                              capture_output=True, text=True, timeout=300)
    assert straight.returncode == 0, straight.stderr
    a = load_checkpoint(ckpt)
    b = load_checkpoint(tmp_path / "straight" / "m1-4mT" / "seed0")
    assert a["global_step"] == b["global_step"] == target
    for part in ("actor", "critic"):
        for key, value in a["agent"][part].items():
            assert torch.equal(value, b["agent"][part][key]), (part, key)
    for key in ("obs", "actions", "rewards"):
        assert torch.equal(a["buffer"][key], b["buffer"][key])


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
    run_msr(capsys, "export-seeds", str(only_seed0), "--dest", str(dest), "--duration", "0.05",
            "--no-progress")
    result = run_msr(capsys, "export-seeds", str(second_run), "--dest", str(dest), "--duration",
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
    assert msr(["export-seeds", str(second_run), "--dest", str(dest), "--duration", "0.05",
                "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "seed 0" in err and "batch_size" in err and "another folder" in err
    assert (dest / "seeds.json").read_bytes() == before
    # a spec whose default recipe changed since is the same robot and task: kept; another robot is not
    meta["training"]["config"]["batch_size"] = json.loads(
        (dest / "seed1" / "policy.json").read_text())["training"]["config"]["batch_size"]
    meta["case_spec"]["training"]["recipe"] = "pink-ln"
    policy_json.write_text(json.dumps(meta))
    run_msr(capsys, "export-seeds", str(second_run), "--dest", str(dest), "--duration", "0.05",
            "--no-progress")
    assert [e["seed"] for e in json.loads((dest / "seeds.json").read_text())] == [0, 1]
    meta["case_spec"]["robot"]["youngs_modulus"] *= 2
    policy_json.write_text(json.dumps(meta))
    before = (dest / "seeds.json").read_bytes()
    assert msr(["export-seeds", str(second_run), "--dest", str(dest), "--duration", "0.05",
                "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "seed 0" in err and "another case spec" in err and (dest / "seeds.json").read_bytes() == before


def test_train_help_describes_every_recipe(capsys, monkeypatch):
    """``msr train --help`` names each recipe with its one-line summary (one home: recipes.py)."""
    from elastica_magnetic_rl.cases.recipes import RECIPE_SUMMARIES, RECIPES

    monkeypatch.setenv("COLUMNS", "1000")  # argparse wraps at hyphens: one line per option

    assert set(RECIPE_SUMMARIES) == set(RECIPES)
    with pytest.raises(SystemExit):
        msr(["train", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for name, line in RECIPE_SUMMARIES.items():
        assert f"{name}: {line}" in text


def test_notes_have_one_home_and_a_re_ship_keeps_the_seeds_table(refined, tmp_path, capsys):
    """A policy's notes live in policy.json and the card's Notes section is rendered from them:
    ``msr notes`` changes both together and nothing else; ``ship --force`` keeps the table of
    the case's committed seeds (``msr seeds --card``) in the new card."""
    from elastica_magnetic_rl.shipping.model_card import NOTES_SECTION, card_section
    from elastica_magnetic_rl.shipping.seed_report import CARD_SECTION

    dest = tmp_path / "policies"
    pipeline.ship(refined, "m1-4mT", dest=dest, measure=False, progress=False, notes="First.")
    folder = dest / "m1-4mT"
    seeds = folder / "seeds" / "paper" / "seeds.json"
    seeds.parent.mkdir(parents=True)
    seeds.write_text(json.dumps([{"seed": 0, "steps": 240, "distance_10s_m": 0.0221, "actor": "seed0"},
                                 {"seed": 1, "steps": 240, "distance_10s_m": 0.0018, "actor": "seed1"}]))
    pipeline.ship(refined.parent / "best.pt", "m1-4mT", dest=dest, overwrite=True, measure=False,
                  progress=False, notes="Second.")
    card = (folder / "MODEL_CARD.md").read_text()
    assert "| `paper` | 1 of 2 |" in card and card.index(CARD_SECTION) < card.index("## Evaluation")
    assert card_section(card, NOTES_SECTION) == "Second."

    actor = (folder / "actor.pt").read_bytes()
    new_notes = tmp_path / "notes.md"
    new_notes.write_text("- Third, *edited*.\n\n")
    assert msr(["notes", str(folder), "--file", str(new_notes)]) == 0
    info = json.loads((folder / "policy.json").read_text())
    card = (folder / "MODEL_CARD.md").read_text()
    assert info["notes"] == card_section(card, NOTES_SECTION) == "- Third, *edited*."
    assert card.count(NOTES_SECTION) == 1 and card.index(NOTES_SECTION) < card.index("## Limitations")
    assert "| `paper` | 1 of 2 |" in card and (folder / "actor.pt").read_bytes() == actor
    assert policy_files.resolve_policy(folder).kind == "shipped"
    capsys.readouterr()
    assert msr(["notes", str(folder)]) == 0 and capsys.readouterr().out.strip() == "- Third, *edited*."
    new_notes.write_text("\n")  # an empty file removes them, from both
    assert msr(["notes", str(folder), "--file", str(new_notes)]) == 0
    assert json.loads((folder / "policy.json").read_text())["notes"] is None
    assert NOTES_SECTION not in (folder / "MODEL_CARD.md").read_text()
    capsys.readouterr()
    before = {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}
    assert msr(["notes", str(refined), "--file", str(new_notes)]) == 2  # a run has no notes
    assert "shipped policy" in capsys.readouterr().err
    assert msr(["notes", str(folder), "--file", str(tmp_path / "missing.md")]) == 2
    assert "missing.md: no such file" in capsys.readouterr().err
    assert {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()} == before
