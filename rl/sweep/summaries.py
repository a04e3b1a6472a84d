"""The summaries of a sweep: one run's episodes and evaluations (:func:`summarize_run`), and each
case's ``summary.json`` over every seed folder of the case (:func:`case_summary`), written by ``msr
train`` (:func:`elastica_magnetic_rl.sweep.training.train_cases`) and read by ``msr policy ship``
and the reports."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from elastica_magnetic.io import atomic_write_json

from ..cases.case import Case
from ..runfiles.locking import briefly_locked
from ..runfiles.logs import read_log
from ..runfiles.rundir import CaseDir, RunDir
from .stop_settings import stop_summary

__all__ = ["case_summary", "failed_group_results", "summarize_run"]


def summarize_run(run_dir: str | Path, last: int = 5, reward_scale: float = 1e4,
                  travels: bool = True) -> dict[str, Any]:
    """Episodes, steps and the mean return of the last ``last`` episodes of a run (``nan`` if it has no
    finished episode). ``final_mean_distance_m`` is that return / ``reward_scale`` (the task's, per m;
    for crawling: m per episode); ``None`` for a robot that does not travel (``travels`` false: a
    catheter clamped at its base, whose return sums its tip's approaches and penalties). With
    evaluations during training: ``best_eval_step`` and ``best_eval_return`` (the evaluation that
    ``best.pt`` holds; for crawling its return / ``reward_scale`` is the 10 s distance from a zero
    field, m), else ``None``. A log's row cut short by a kill is left out (its whole rows are read; a
    resume repairs the file); other damage raises ``ValueError`` naming the file and row."""

    run = RunDir(run_dir)
    rows, evals = [], []
    if run.episodes_csv.is_file():
        rows = read_log(run.episodes_csv, ("global_step", "return", "terminated"), whole_rows_only=True)
    if run.evaluations_csv.is_file():
        evals = read_log(run.evaluations_csv, ("global_step", "mean_return"), whole_rows_only=True)
    best_eval = max(evals, key=lambda r: float(r["mean_return"])) if evals else None
    returns = [float(r["return"]) for r in rows]
    tail = returns[-last:]
    mean = float(np.mean(tail)) if tail else float("nan")
    return {
        "run_dir": str(run.path),
        "episodes": len(rows),
        "global_step": _checkpoint_step(run, rows),
        "final_mean_return": mean,
        "final_mean_distance_m": mean / reward_scale if travels else None,
        "best_return": max(returns) if returns else float("nan"),
        "terminated_episodes": sum(int(r["terminated"]) for r in rows),
        # blown up on the first step: a time step too coarse for the robot, not a learned failure
        "diverged_at_first_step": sum(int(r["terminated"]) and int(float(r.get("length") or 0)) <= 1
                                      for r in rows),
        "best_eval_step": int(best_eval["global_step"]) if best_eval else None,
        "best_eval_return": float(best_eval["mean_return"]) if best_eval else None,
    }


def failed_group_results(configs: Any, run_dirs: Any, error: str) -> list[dict[str, Any]]:
    """One result per seed of a group whose worker failed (``configs``: the seeds' TD3
    configurations as dicts, ``run_dirs`` their folders): what each folder holds
    (:func:`summarize_run`, when it has episodes) with the seed and the ``error``."""
    results = []
    for config, run_dir in zip(configs, run_dirs, strict=True):
        entry = _readable_summary(run_dir) if RunDir(run_dir).has_episodes() else {}
        damaged = entry.pop("error", None)  # its log, besides the worker's error
        results.append({**entry, "seed": config["seed"],
                        "error": error if damaged is None else f"{error}; {damaged}"})
    return results


def _readable_summary(run_dir: str | Path, **kwargs: Any) -> dict[str, Any]:
    """:func:`summarize_run`, or, for a folder whose log is damaged (not just cut by a kill),
    ``run_dir`` and an ``error`` naming the file, the row and the fix: one damaged seed folder
    never keeps the summary of the others from being written."""
    try:
        return summarize_run(run_dir, **kwargs)
    except ValueError as err:
        return {"run_dir": str(run_dir), "error": str(err)}


def _checkpoint_step(run: RunDir, rows: list[dict[str, str]]) -> int:
    """The step a run has reached: its checkpoint's (episodes cut by the last checkpoint are not in
    ``episodes.csv``), else the last logged episode's, else 0."""
    from ..runfiles.checkpoint import load_checkpoint

    if run.checkpoint.is_file():
        try:
            return int(load_checkpoint(run.checkpoint, with_buffer=False)["global_step"])
        except (ValueError, KeyError, TypeError):
            pass  # an unreadable checkpoint: what the log says
    return int(float(rows[-1]["global_step"])) if rows else 0


def _earlier_seeds(case_dir: Path, exclude: list[int], reward_scale: float,
                   travels: bool = True) -> list[dict[str, Any]]:
    """Seeds of ``case_dir`` trained by earlier ``msr train`` calls (``--seed-offset``), so that
    ``summary.json`` covers every seed of the case. Their entries from the previous summary are
    kept (wall time, memory) and their episode statistics re-read from ``episodes.csv``."""
    previous: dict[int, dict[str, Any]] = {}
    summary_json = CaseDir(case_dir).summary_json
    if summary_json.is_file():
        try:
            old = json.loads(summary_json.read_text())
            previous = {int(r["seed"]): r for r in old.get("seeds", []) if "seed" in r}
        except (ValueError, KeyError, TypeError):
            previous = {}  # an unreadable summary is rebuilt from the run folders
    found = []
    for seed, run in CaseDir(case_dir).seeds():
        if seed in exclude or not run.has_episodes():
            continue
        entry = {k: v for k, v in previous.get(seed, {}).items() if k != "succeeded"}
        found.append({**entry, "seed": seed, **_readable_summary(run.path, reward_scale=reward_scale,
                                                                      travels=travels),
                      "run_dir": str(run.path)})
    return found


def _evaluation_duration(mine: list[dict[str, Any]], spec: Case) -> float | None:
    """The periodic evaluations' episode of this call's seeds, s (their ``eval_duration``; ``None``
    for seeds that made none), else the case's."""
    durations = {r["evaluation_duration_s"] for r in mine if "evaluation_duration_s" in r}
    return durations.pop() if len(durations) == 1 else spec.evaluation_duration


def case_summary(case_dir: CaseDir, spec: Case, mine: list[dict[str, Any]], seed_list: list[int],
                  success_fraction: float, sweep: dict[str, Any], wall: float) -> dict[str, Any]:
    """A case's ``summary.json`` (written, and returned with its path): every seed folder of the
    case, this call's and earlier ones', the succeeded ones counted against the threshold.

    A seed counts as *succeeded* when its final mean episode return reaches ``success_fraction``
    of the yardstick's distance rate (its 10 s distance, scaled to the episode length, x the
    reward scale): a heuristic to count working seeds, reported with its threshold (crawling cases
    with a yardstick distance only; the seeds' real test is ``msr policy export-seeds``)."""
    for r in mine:
        if "run_dir" in r:
            r["run_dir"] = str(case_dir.seed(r["seed"]).path)
    threshold = None
    if spec.task.kind == "crawl" and spec.yardstick.distance_10s > 0.0:
        threshold = (success_fraction * spec.yardstick.distance_10s
                     * (sweep["episode_duration_s"] / 10.0) * spec.task.reward_scale)
    with briefly_locked(case_dir.path):  # read-modify-write: processes training other seeds
        return _writecase_summary(case_dir, spec, mine, seed_list, threshold, sweep, wall)


def _writecase_summary(case_dir: CaseDir, spec: Case, mine: list[dict[str, Any]],
                        seed_list: list[int], threshold: float | None, sweep: dict[str, Any],
                        wall: float) -> dict[str, Any]:
    earlier = _earlier_seeds(case_dir.path, seed_list, spec.task.reward_scale, spec.field_actuated)
    per_seed = sorted(mine + earlier, key=lambda r: r["seed"])
    for r in per_seed:
        if "error" not in r and threshold is not None:
            r["succeeded"] = bool(r["final_mean_return"] >= threshold)
    ok = [r for r in per_seed if "error" not in r and math.isfinite(r["final_mean_return"])]
    best = max(ok, key=lambda r: r["final_mean_return"]) if ok else None
    summary = {
        "case": spec.name,
        "task": spec.task.kind,
        **{k: sweep[k] for k in ("steps", "physics", "episode_duration_s", "workers", "backend",
                                 "envs_per_seed", "seeds_per_simulator", "torch_threads_per_worker",
                                 "layout", "recipe", "precision", "device")},
        **({"precision_asked": sweep["precision_asked"]} if "precision_asked" in sweep else {}),
        "success_threshold_return": threshold,
        "succeeded": None if threshold is None else sum(bool(r.get("succeeded")) for r in per_seed),
        "best_seed": best["seed"] if best else None,
        "best_run_dir": best["run_dir"] if best else None,
        "wall_s": wall,
        "seeds": per_seed,
        "failed": [r["seed"] for r in per_seed if "error" in r],
        **stop_summary(per_seed, sweep["steps"], sweep["stop_rules"].get(spec.name),
                       _evaluation_duration(mine, spec)),
    }
    case_dir.path.mkdir(parents=True, exist_ok=True)
    atomic_write_json(case_dir.summary_json, summary)
    summary["summary_json"] = str(case_dir.summary_json)
    return summary
