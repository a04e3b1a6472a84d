"""``msr train --backend ray``: a sweep of 2 seeds as Ray tasks on a local Ray instance (2 CPUs),
checked against the process-pool backend (same run directories and summary, same episodes and
same final weights: the work is deterministic on CPU with one torch thread per seed), then resumed.

Ray is kept local and quiet: a private instance (``address="local"``), no dashboard, no usage
statistics (nothing leaves the machine). The first sweep starts and ends its own instance; the
later ones run on one instance the module holds (a sweep that finds Ray running uses it and leaves
it running), so Ray starts twice, not once per sweep: most of the time is Ray's start and the
workers importing torch."""

from __future__ import annotations

import csv
import json
import logging
import os
import signal
from pathlib import Path

import pytest
import torch
from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint
from elastica_magnetic_rl.sweep import training
from elastica_magnetic_rl.sweep.backends import LOCAL_OBJECT_STORE_BYTES

from elastica_magnetic.cli import main as msr

STEPS = 200
TINY = ["--case", "m1-4mT", "--seeds", "2", "--workers", "2", "--threads", "1",
        "--set", "learning_starts=100", "--set", "batch_size=32", "--set", "hidden_sizes=32,32",
        "--set", "eval_duration=0.5", "--episode-duration", "0.5", "--no-progress", "--json"]
#: summary.json entries that may differ between two runs of the same seeds
RUN_SPECIFIC = {"wall_s", "backend", "summary_json"}


@pytest.fixture(scope="module", autouse=True)
def quiet_local_ray():
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("RAY_USAGE_STATS_ENABLED", "0")  # no usage report (no network)
        mp.delenv("RAY_ADDRESS", raising=False)  # never join a cluster found in the environment
        mp.setenv("RAY_DEDUP_LOGS", "0")
        yield


def _train(capsys, out: Path, *extra: str) -> dict:
    capsys.readouterr()
    status = msr(["train", *TINY, "--out", str(out), *extra])
    captured = capsys.readouterr()
    assert status == 0, captured.out + captured.err
    return json.loads(captured.out)


def _episodes(run: Path) -> list[dict]:
    with open(run / "episodes.csv", newline="") as f:
        return [{k: v for k, v in row.items() if k != "wall_time_s"} for row in csv.DictReader(f)]


@pytest.fixture(scope="module")
def sweeps(tmp_path_factory):
    """The same 2-seed sweep with each backend (relative --out, as a user would type it)."""
    root = tmp_path_factory.mktemp("sweeps")
    cwd = os.getcwd()
    os.chdir(root)
    try:
        import ray

        handlers = {n: signal.getsignal(n) for n in (signal.SIGTERM, signal.SIGINT)}
        results = {}
        for backend in ("ray", "process"):
            argv = ["train", *TINY, "--out", backend, "--steps", str(STEPS), "--backend", backend]
            status = msr(argv)
            assert status == 0
            results[backend] = json.loads((root / backend / "m1-4mT" / "summary.json").read_text())
            if backend == "ray":
                assert not ray.is_initialized(), "the local Ray instance was left running"
                # ray.init installs its own SIGTERM handler: the sweep puts the one it found back
                assert {n: signal.getsignal(n) for n in handlers} == handlers
    finally:
        os.chdir(cwd)
    return root, results


@pytest.fixture(scope="module")
def held_ray(sweeps):
    """One local Ray instance for the sweeps after the first (which ended its own)."""
    import ray

    handlers = {n: signal.getsignal(n) for n in (signal.SIGTERM, signal.SIGINT)}
    ray.init(address="local", num_cpus=2, include_dashboard=False, log_to_driver=False,
             logging_level=logging.ERROR, object_store_memory=LOCAL_OBJECT_STORE_BYTES)
    yield ray
    ray.shutdown()
    for number, handler in handlers.items():  # ray.init's handlers go with its instance
        signal.signal(number, handler)


@pytest.mark.slow
def test_ray_sweep_writes_run_dirs_and_summary(sweeps):
    root, results = sweeps
    summary = results["ray"]
    assert summary["backend"] == "ray" and not summary["failed"]
    assert [s["seed"] for s in summary["seeds"]] == [0, 1]
    for seed in (0, 1):
        run = root / "ray" / "m1-4mT" / f"seed{seed}"
        assert {"checkpoint.pt", "episodes.csv", "run.json"} <= {p.name for p in run.iterdir()}
        assert list(run.glob("events.out.tfevents.*")), "no TensorBoard scalars"
        # --out is made absolute where it is parsed (the one path rule): the summary names it so
        assert summary["seeds"][seed]["run_dir"] == str(root.resolve() / "ray" / "m1-4mT" /
                                                        f"seed{seed}")
        assert summary["seeds"][seed]["global_step"] == STEPS
        meta = json.loads((run / "run.json").read_text())
        assert meta["seed"] == seed and meta["torch_threads"] == 1
        assert load_checkpoint(run)["global_step"] == STEPS


def test_ray_and_process_backends_agree(sweeps):
    root, results = sweeps
    ray_summary, proc_summary = results["ray"], results["process"]
    assert proc_summary["backend"] == "process"

    def comparable(summary: dict, out: str) -> dict:
        seeds = [{k: v for k, v in s.items() if k not in {"wall_s", "peak_rss_bytes", "group_timing_s"}}
                 | {"run_dir": s["run_dir"].replace(out, "")}
                 for s in summary["seeds"]]
        rest = {k: v for k, v in summary.items() if k not in RUN_SPECIFIC | {"seeds", "best_run_dir"}}
        return rest | {"seeds": seeds}

    assert comparable(ray_summary, "ray") == comparable(proc_summary, "process")
    for seed in (0, 1):
        a, b = (root / backend / "m1-4mT" / f"seed{seed}" for backend in ("ray", "process"))
        assert _episodes(a) == _episodes(b) and len(_episodes(a)) == STEPS // 50
        ca, cb = load_checkpoint(a), load_checkpoint(b)
        for net in ("actor", "critic", "actor_target", "critic_target"):
            if net in ca["agent"]:
                for name, tensor in ca["agent"][net].items():
                    assert torch.equal(tensor, cb["agent"][net][name]), (seed, net, name)
        assert torch.equal(ca["buffer"]["obs"], cb["buffer"]["obs"])
    # the two seeds differ
    w0 = load_checkpoint(root / "ray" / "m1-4mT" / "seed0")["agent"]["actor"]["net.0.weight"]
    w1 = load_checkpoint(root / "ray" / "m1-4mT" / "seed1")["agent"]["actor"]["net.0.weight"]
    assert not torch.equal(w0, w1)


def test_ray_resume_extends_runs(sweeps, held_ray, capsys):
    """``--resume`` through Ray: the same per-seed code continues the runs from their checkpoints
    (on the Ray instance it found running, which it leaves running)."""
    root, _ = sweeps
    summary = _train(capsys, root / "ray", "--steps", str(STEPS + 50), "--backend", "ray", "--resume")
    assert held_ray.is_initialized(), "the sweep ended a Ray instance it did not start"
    assert [s["global_step"] for s in summary["seeds"]] == [STEPS + 50] * 2 and not summary["failed"]
    for seed in (0, 1):
        run = root / "ray" / "m1-4mT" / f"seed{seed}"
        meta = json.loads((run / "run.json").read_text())
        assert meta["resumed"] == 1 and meta["steps"] == STEPS + 50
        assert load_checkpoint(run)["global_step"] == STEPS + 50
        assert len(_episodes(run)) == (STEPS + 50) // 50


def test_address_needs_the_ray_backend(tmp_path, capsys):
    assert msr(["train", *TINY, "--steps", "10", "--out", str(tmp_path), "--address", "auto"]) == 2
    assert "--backend ray" in capsys.readouterr().err
    with pytest.raises(ValueError, match="backend"):
        training.train_case("m1-4mT", seeds=1, steps=1, out=tmp_path, backend="dask")


def test_ray_sweep_over_two_cases(held_ray, tmp_path, capsys):
    """Cases and seeds in one sweep: ``--case m1-4mT m2-10mT`` makes 2 x 1 Ray tasks; each case gets
    its own folder and summary, and the pattern and field limit of each run are its case's."""
    argv = [a for a in TINY if a not in {"m1-4mT"}]
    argv[argv.index("--case") + 1:argv.index("--case") + 1] = ["m1-4mT", "m2-10mT"]
    argv[argv.index("--seeds") + 1] = "1"
    # below --steps 100: a run of its warm-up is refused
    argv[argv.index("learning_starts=100")] = "learning_starts=50"
    capsys.readouterr()
    status = msr(["train", *argv, "--steps", "100", "--out", str(tmp_path), "--backend", "ray"])
    captured = capsys.readouterr()
    assert status == 0, captured.out + captured.err
    summaries = json.loads(captured.out)
    assert set(summaries) == {"m1-4mT", "m2-10mT"}
    for case, (pattern, limit) in {"m1-4mT": (1, 4e-3), "m2-10mT": (2, 10e-3)}.items():
        summary = json.loads((tmp_path / case / "summary.json").read_text())
        assert summary["case"] == case and [s["seed"] for s in summary["seeds"]] == [0]
        assert summary["seeds"][0]["global_step"] == 100 and not summary["failed"]  # 2 episodes
        meta = json.loads((tmp_path / case / "seed0" / "run.json").read_text())
        assert (meta["case"], meta["field_limit_T"]) == (case, limit)
        assert meta["case_spec"]["robot"]["magnetization"]["kind"] == f"yao2023-pattern{pattern}"
