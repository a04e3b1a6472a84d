"""``msr train`` (rl/sweep/training.py, summaries.py, run_records.py): run folders and summaries, seeds
sharing a simulator equal to separate runs, resume, recipes, interruptions (Ctrl-C, SIGINT, SIGKILL), a
failing worker. Refinement: test_refine.py."""

from __future__ import annotations

import csv
import importlib.metadata
import json
from pathlib import Path

import numpy as np
import pytest
import torch
from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint
from elastica_magnetic_rl.sweep.run_records import record_hash
from smoke import EVAL_DURATION, SMOKE, TINY, TRAIN_STEPS, run_msr

from elastica_magnetic.cli import main as msr


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
        # evaluations from a zero field, the smoke runs' eval_duration: at the episode end past
        # 120 steps, and at the end
        with open(run / "evaluations.csv") as f:
            evals = list(csv.DictReader(f))
        assert [int(r["global_step"]) for r in evals] == [160, TRAIN_STEPS]
        assert all(float(r["mean_length"]) == round(EVAL_DURATION / 0.01) for r in evals)
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


def test_train_refuses_to_overwrite(trained, capsys):
    assert msr(["train", "--case", "m1-4mT", "--seeds", "1", "--steps", "10", "--out",
                str(trained), "--no-progress"]) == 2
    assert "--resume" in capsys.readouterr().err


def test_train_resume_extends_runs(tmp_path, capsys):
    """``--resume`` continues a finished run to a larger step count (one seed, in-process)."""
    args = ["train", "--case", "m2-4mT", "--seeds", "1", "--seed-offset", "3", "--out", str(tmp_path),
            *TINY,
                "--episode-duration",
            "0.2", "--no-progress"]  # a warm-up below --steps 20: a run of its warm-up is refused
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


def test_recipe_is_recorded_and_a_resume_keeps_the_runs_settings(tmp_path, capsys):
    """``--recipe pink`` trains with pink exploration noise (run.json, the checkpoint's config);
    a resume that changes the recipe or the episode length is refused before anything is touched."""
    args = ["train", "--case", "m1-4mT", "--seeds", "1", "--out", str(tmp_path), *TINY,
        "--episode-duration", "0.1", "--no-progress"]
    assert msr([*args, "--steps", "20", "--recipe", "pink"]) == 0
    run = tmp_path / "m1-4mT" / "seed0"
    assert json.loads((run / "run.json").read_text())["recipe"] == "pink"
    assert load_checkpoint(run)["config"]["noise_color"] == 1.0
    before = (run / "episodes.csv").read_text()
    capsys.readouterr()
    assert msr([*args, "--steps", "30", "--resume", "--recipe", "pink-ln"]) == 2
    assert ("--recipe pink-ln differs from the run's pink (" in (err := capsys.readouterr().err)
            and "(give --recipe pink, or leave the option out)" in err)
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
    record["record_sha256"] = record_hash(record)  # as msr wrote it for such a run
    (run / "run.json").write_text(json.dumps(record))
    args[args.index("--episode-duration") + 1] = "0.1"
    assert msr([*args, "--steps", "30", "--resume", "--recipe", "pink"]) == 0
    assert load_checkpoint(run)["global_step"] == 30


def test_resume_from_a_corrupted_checkpoint_is_refused_and_keeps_the_results(tmp_path, capsys):
    args = ["train", "--case", "m1-4mT", "--seeds", "1", "--out", str(tmp_path), *TINY,
        "--episode-duration", "0.1", "--no-progress"]
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


@pytest.mark.slow
def test_ctrl_c_stops_cleanly_and_the_run_resumes(tmp_path):
    """SIGINT to a real 2-worker training: exit 130, no traceback, the message names the folders;
    the checkpoints it left resume."""
    import os
    import signal
    import subprocess
    import sys
    import time

    args = [sys.executable, "-m", "elastica_magnetic.cli", "train", "--case", "m1-4mT", "--seeds", "2",
            "--out", str(tmp_path), *TINY,
            "--episode-duration", "0.1", "--set", "checkpoint_every=10", "--no-progress"]
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


@pytest.mark.slow
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
            "--set", "checkpoint_every=10")]
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
    return ["train", "--case", "m1-4mT", "--out", str(out), *TINY, "--episode-duration", "0.1",
        "--no-progress", *extra]


def test_train_output_that_is_a_file_is_refused_before_any_work(tmp_path, capsys):
    (tmp_path / "taken").write_text("a file")
    capsys.readouterr()
    assert msr(_tiny_train(tmp_path / "taken", "--seeds", "1", "--steps", "20")) == 2
    err = capsys.readouterr().err
    assert f"--out {tmp_path / 'taken'}" in err and "is a file" in err and "Traceback" not in err
    assert (tmp_path / "taken").read_text() == "a file"


def test_a_failing_worker_is_reported_and_the_other_seeds_finish(tmp_path, capsys):
    """Two seeds in two worker processes; on resume seed 1's checkpoint lacks its critic (a damage
    only loading the networks finds: a missing replay file is refused before any work), so its
    worker raises: exit status 1, ``failed`` names it, seed 0 finishes, seed 1 keeps its earlier
    numbers."""
    import torch

    assert msr(_tiny_train(tmp_path, "--seeds", "2", "--steps", "20")) == 0
    checkpoint = tmp_path / "m1-4mT" / "seed1" / "checkpoint.pt"
    data = torch.load(checkpoint, weights_only=True)
    del data["agent"]["critic"]
    torch.save(data, checkpoint)
    capsys.readouterr()
    assert msr([*_tiny_train(tmp_path, "--seeds", "2", "--steps", "40", "--resume"), "--json"]) == 1
    summary = json.loads(capsys.readouterr().out)
    assert summary["failed"] == [1]
    seed0, seed1 = summary["seeds"]
    assert seed0["global_step"] == 40 and "error" not in seed0
    assert "critic" in seed1["error"] and seed1["global_step"] == 20
    assert load_checkpoint(tmp_path / "m1-4mT" / "seed0")["global_step"] == 40
    # for people: the failed seeds by folder name (round 5: "failed: 0" read as "none failed")
    assert msr(_tiny_train(tmp_path, "--seeds", "2", "--steps", "60", "--resume")) == 1
    assert "failed seeds: seed1" in capsys.readouterr().out.splitlines()


@pytest.mark.slow
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
            "--seeds", "1", "--set", "checkpoint_every=10", "--threads", "1"]
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
                               *_tiny_train(tmp_path / "straight"), "--seeds", "1", "--set",
                               "checkpoint_every=10", "--threads", "1", "--steps", str(target)],
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


def test_a_resume_that_leaves_options_out_keeps_the_runs_recipe_and_episode_length(tmp_path, capsys):
    """Round 13 V1: ``--resume`` without ``--recipe`` and ``--episode-duration`` was refused as if
    the defaults had been given; it now keeps the run's recorded values."""
    args = ["train", "--case", "m1-4mT", "--seeds", "1", "--out", str(tmp_path), *TINY, "--no-progress"]
    assert msr([*args, "--steps", "20", "--recipe", "pink", "--episode-duration", "0.1"]) == 0
    capsys.readouterr()
    assert msr([*args, "--steps", "30", "--resume"]) == 0
    record = json.loads((tmp_path / "m1-4mT" / "seed0" / "run.json").read_text())
    assert record["recipe"] == "pink" and record["episode_duration_s"] == 0.1 and record["steps"] == 30
