"""An idle worker takes over seeds of a busy one (rl/sweep/rebalance.py): the split, the pool's
requests and merges (with a stand-in for the training, tests/rl/toy_jobs.py), and a real
training whose group hands its seeds back and ends bit-identical to one that never moved."""

from __future__ import annotations

import json
from dataclasses import replace

import pytest
from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint
from elastica_magnetic_rl.sweep import training
from elastica_magnetic_rl.sweep.backends import run_in_processes
from elastica_magnetic_rl.sweep.jobs import GroupJob
from elastica_magnetic_rl.sweep.rebalance import GroupRebalancing, split_evenly
from smoke import SMOKE
from state_compare import assert_state_equal
from toy_jobs import fake_group

from elastica_magnetic.cli import main as msr
from elastica_magnetic.cli.app import build_parser


def test_split_evenly_keeps_order_and_sizes_within_one():
    assert split_evenly([1, 2, 3], 2) == [[1, 2], [3]]
    assert split_evenly([1, 2, 3, 4, 5], 2) == [[1, 2, 3], [4, 5]]
    assert split_evenly([1, 2], 5) == [[1], [2]]
    assert split_evenly([1, 2, 3], 1) == [[1, 2, 3]]
    assert split_evenly([], 2) == []


def _job(case: str, seeds: list[int], tmp_path) -> GroupJob:
    return GroupJob(case=case, case_spec={}, physics="training", duration=1.0, steps=10,
                    resume=False, progress=False, position=seeds[0], threads=1, envs=1,
                    recipe="fast", configs=tuple({"seed": s} for s in seeds),
                    run_dirs=tuple(str(tmp_path / f"seed{s}") for s in seeds))


@pytest.mark.parametrize("case", ["ok", "fail-3"])
def test_an_idle_worker_asks_the_busy_group_and_takes_half_its_seeds(tmp_path, case):
    """Group [0] ends at once; the idle worker's request makes group [1, 2, 3] hand its seeds
    back; they go on as [1, 2] and [3] on the two workers, their results merged into the busy
    group's; a continuation that fails is reported per seed with its error."""
    with GroupRebalancing() as rebalancing:
        jobs = rebalancing.askable([_job(case, [0], tmp_path), _job(case, [1, 2, 3], tmp_path)])
        results = run_in_processes(fake_group, jobs, 2, on_error=lambda k, exc: {"error": str(exc)},
                                   rebalancing=rebalancing.protocol())
        folder = rebalancing.folder
    assert not folder.exists()  # the request files are gone
    assert results[0] == {"group": [{"seed": 0, "ran_in": [0]}]}
    by_seed = {r["seed"]: r for r in results[1]["group"]}
    assert sorted(by_seed) == [1, 2, 3]
    assert by_seed[1]["ran_in"] == by_seed[2]["ran_in"] == [1, 2]
    if case == "ok":
        assert by_seed[3]["ran_in"] == [3]
    else:
        assert by_seed[3]["error"] == "RuntimeError: seed 3's worker failed"


def test_a_group_handed_back_and_resumed_apart_equals_one_never_moved(tmp_path, monkeypatch, capsys):
    """``msr train`` of 2 seeds whose group is asked at once to hand them back (as an idle worker
    would): each seed goes on in a group of its own, ends bit-identical to the group that never
    moved, and its ``run.json`` counts no resume."""
    def moved_at_once(jobs, workers, backend, address, progress, rebalance=False):
        with GroupRebalancing() as rebalancing:
            results = []
            for job in rebalancing.askable(jobs):
                rebalancing.request(job)  # asked before its first step
                result = training._train_group(job)
                assert sorted(result["handed_back"]) == sorted(job.run_dirs)
                for more in rebalancing.split(job, result, 2):
                    result = rebalancing.merge(result, more, training._train_group(more))
                results += [(job.case, r) for r in result["group"]]
            return results

    common = ["train", "--case", "m1-4mT", "--seeds", "2", "--workers", "1", "--threads", "1",
              "--steps", "120", *SMOKE, "--json"]
    assert msr([*common, "--out", str(tmp_path / "ref")]) == 0
    monkeypatch.setattr(training, "_run_groups", moved_at_once)
    capsys.readouterr()
    assert msr([*common, "--out", str(tmp_path / "moved")]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert [s["group_seeds"] for s in summary["seeds"]] == [[0], [1]]
    for s in (0, 1):
        a = load_checkpoint(tmp_path / "moved" / "m1-4mT" / f"seed{s}")
        b = load_checkpoint(tmp_path / "ref" / "m1-4mT" / f"seed{s}")
        assert a["global_step"] == b["global_step"] == 120
        for key in ("agent", "buffer", "episode", "evaluation"):
            assert_state_equal(a[key], b[key], key)
        run = json.loads((tmp_path / "moved" / "m1-4mT" / f"seed{s}" / "run.json").read_text())
        assert run["resumed"] == 0 and run["shared_simulator_seeds"] == 1


def test_seeds_move_by_default_and_only_on_one_thread_per_worker(tmp_path, monkeypatch):
    """By default (``--rebalance``, ``train_cases(rebalance=True)``) the pool gets its rebalancing
    and each group a request file; with ``--no-rebalance``, or two threads per worker, neither."""
    seen = []

    def fake_run_jobs(fn, jobs, workers, backend, address, progress, rebalancing=None):
        seen.append((rebalancing is not None, [j.hand_back_file is not None for j in jobs]))
        return [{"group": []} for _ in jobs]

    monkeypatch.setattr(training, "run_jobs", fake_run_jobs)
    jobs = [_job("ok", [0, 1], tmp_path), _job("ok", [2, 3], tmp_path)]
    training._run_groups(jobs, 2, "process", None, False, rebalance=False)
    training._run_groups(jobs, 2, "process", None, False)
    two_threads = [replace(j, threads=2) for j in jobs]
    training._run_groups(two_threads, 2, "process", None, False)
    assert seen == [(False, [False, False]), (True, [True, True]), (False, [False, False])]
    options = build_parser().parse_args(["train", "--case", "m1-4mT"])
    assert options.rebalance is True
    assert build_parser().parse_args(["train", "--case", "m1-4mT", "--no-rebalance"]).rebalance is False
