"""Training and refinement of crawling policies (``msr train``, ``msr refine``): seeds in groups
that train side by side (:func:`elastica_magnetic_rl.runner.loop.train_seeds`), groups in worker
processes or Ray tasks (:mod:`elastica_magnetic_rl.sweep.backends`), one summary per case.

Each seed writes ``OUT/<case>/seed<k>/`` (``episodes.csv``, TensorBoard scalars, ``checkpoint.pt``
and ``replay.bin``, ``evaluations.csv`` and ``best.pt``, ``run.json``); ``OUT/<case>/summary.json``
collects every seed of the case.
"""

from __future__ import annotations

import functools
import json
import math
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from elastica_magnetic.io import atomic_write_json

from ..cases.case import EVAL_DURATION, Case, case_from_dict, case_from_metadata, load_case
from ..cases.recipes import crawler_config
from ..envs.env import make_env
from ..runfiles.checkpoint import checkpoint_metadata
from ..runfiles.locking import (
    briefly_locked,
    check_unlocked,
    held_run_folders,
    mark_run_folder,
)
from ..runfiles.logs import read_log
from ..runfiles.provenance import versions
from ..runfiles.rundir import CaseDir, RunDir
from .backends import BACKENDS, run_jobs
from .jobs import GroupJob
from .refine_start import (
    check_refine_output,
    default_refine_output,
    refine_source,
    starting_file,
)
from .resume_checks import check_resumed_checkpoints
from .stop_settings import (
    case_stop_rule,
    check_resumed_stop_rules,
    recipe_stop_when,
    resumed_stop_rule,
    seed_state,
    stop_record,
    stop_summary,
    target_return,
)

__all__ = ["default_layout", "refine", "summarize_run", "train_case", "train_cases"]


def summarize_run(run_dir: str | Path, last: int = 5, reward_scale: float = 1e4) -> dict[str, Any]:
    """Episodes, steps and the mean return of the last ``last`` episodes of a run (``nan`` if it has
    no finished episode). ``final_mean_distance_m`` is that return / ``reward_scale`` (the task's,
    per m; for crawling: m per episode). With evaluations during training: ``best_eval_step`` and
    ``best_eval_return`` (the evaluation that ``best.pt`` holds; for crawling its return /
    ``reward_scale`` is the 10 s distance from a zero field, m), else ``None``."""

    run = RunDir(run_dir)
    rows, evals = [], []
    if run.episodes_csv.is_file():
        rows = read_log(run.episodes_csv, ("global_step", "return", "terminated"))
    if run.evaluations_csv.is_file():
        evals = read_log(run.evaluations_csv, ("global_step", "mean_return"))
    best_eval = max(evals, key=lambda r: float(r["mean_return"])) if evals else None
    returns = [float(r["return"]) for r in rows]
    tail = returns[-last:]
    mean = float(np.mean(tail)) if tail else float("nan")
    return {
        "run_dir": str(run.path),
        "episodes": len(rows),
        "global_step": _checkpoint_step(run, rows),
        "final_mean_return": mean,
        "final_mean_distance_m": mean / reward_scale,
        "best_return": max(returns) if returns else float("nan"),
        "terminated_episodes": sum(int(r["terminated"]) for r in rows),
        "best_eval_step": int(best_eval["global_step"]) if best_eval else None,
        "best_eval_return": float(best_eval["mean_return"]) if best_eval else None,
    }


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


def _run_metadata(case: Case, physics: str, duration: float, seed: int, **extra: Any) -> dict:
    """A run's record: the case by name and complete (``case_spec``: what ``msr generate``,
    ``refine``, ``ship`` and ``export`` rebuild it from, without the spec file), its settings."""
    return {"case": case.name, "field_limit_T": case.field_limit, "task": case.task.kind,
            "physics": physics, "episode_duration_s": duration, "seed": int(seed), **extra,
            "case_spec": case.to_dict()}


#: Settings of a run that a resume must not change (they are the run's, in ``run.json``).
_RUN_SETTINGS = ("case", "case_spec", "physics", "episode_duration_s", "recipe", "stop_rule")


def _check_resume_settings(run_dir: Path, metadata: dict[str, Any]) -> None:
    """A resumed run keeps its case, physics and episode length: refuse other values, naming the
    option and the run's value."""
    run_json = RunDir(run_dir).run_json
    if not run_json.is_file():
        return
    try:
        record = json.loads(run_json.read_text())
    except ValueError as err:
        raise ValueError(f"{run_json}: not readable JSON ({err})") from None
    options = {"case": "--case", "physics": "--physics", "episode_duration_s": "--episode-duration",
               "recipe": "--recipe", "stop_rule": "--stop-when"}
    for key in _RUN_SETTINGS:
        if key == "case_spec" and key in record:
            run_spec, spec = _without_default_recipe(record[key]), _without_default_recipe(metadata[key])
            if run_spec != spec:
                raise ValueError(f"the spec of case {metadata['case']!r} differs from the run's at "
                                 f"{_first_difference(run_spec, spec)} ({run_json}): a resumed run "
                                 "keeps its case")
        elif key in record and key in metadata and record[key] != metadata[key]:
            raise ValueError(f"{options[key]} {metadata[key]} differs from the run's {record[key]} "
                             f"({run_json}): a resumed run keeps its settings")


def _without_default_recipe(spec: Any) -> Any:
    """A case spec without its ``[training] recipe``: the recipe a run really used is its own
    setting (``recipe``, compared on its own), so a spec whose default recipe changed since the
    run started still resumes it."""
    if not isinstance(spec, dict) or not isinstance(spec.get("training"), dict):
        return spec
    return {**spec, "training": {k: v for k, v in spec["training"].items() if k != "recipe"}}


def _first_difference(a: Any, b: Any, path: str = "") -> str:
    """The first key (``[table] key``) where two spec dicts differ."""
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b)):
            if a.get(key) != b.get(key):
                return _first_difference(a.get(key), b.get(key), f"{path}.{key}" if path else key)
    if "." in path:
        table, key = path.rsplit(".", 1)
        return f"[{table}] {key}"
    return path or "the top level"


def _write_run_json(run_dir: Path, config, metadata: dict[str, Any], steps: int, threads: int,
                    resumed_now: bool) -> None:
    """``run.json``: the run's settings, the steps it has reached and how often it was resumed
    (written when a new run starts, with 0 steps, and when a training call has finished)."""
    record = {}
    run_json = RunDir(run_dir).run_json
    if run_json.is_file():
        record = json.loads(run_json.read_text())
    atomic_write_json(run_json, {
        **record, **metadata, "steps": int(steps), "config": config.to_dict(),
        "torch_threads": int(threads), "versions": versions(),
        "resumed": int(record.get("resumed", 0)) + int(resumed_now)})


def _train_group(job: GroupJob) -> dict[str, Any]:
    """:func:`_train_group_unlocked` holding each seed's folder (a second process on one of them
    is refused, naming this one) and marking it as a training run's."""
    with held_run_folders(job.run_dirs) as notes:
        for note in notes:  # a stale lock of a killed run taken over
            print(f"note: {note}", file=sys.stderr)
        for run_dir in job.run_dirs:
            mark_run_folder(run_dir, "train", job.case)
        result = _train_group_unlocked(job)
        for run_dir in job.run_dirs:
            mark_run_folder(run_dir, "train", job.case)
    return result


def _train_group_unlocked(job: GroupJob) -> dict[str, Any]:
    """Train a group of seeds of one case side by side in one worker process: their crawlers in
    one batched simulator (``job.envs`` each), their networks updated as one computation
    (:func:`~elastica_magnetic_rl.runner.loop.train_seeds`). Returns ``{"group": [one result per
    seed]}``."""
    import torch

    from ..envs.vector_env import make_vector_env
    from ..runfiles.checkpoint import load_checkpoint
    from ..runner.loop import train_seeds
    from ..runner.stopping import StopRule
    from ..td3.algorithm import TD3Config, resolve_precision

    torch.set_num_threads(int(job.threads))
    configs = [TD3Config.from_dict(c) for c in job.configs]
    run_dirs = [Path(d) for d in job.run_dirs]
    case = case_from_dict(job.case_spec, job.case)
    metadata = [_run_metadata(case, job.physics, job.duration, c.seed, command="train",
                              envs=job.envs, shared_simulator_seeds=len(configs),
                              precision=resolve_precision(c.precision, c.device), recipe=job.recipe,
                              stop_rule=job.stop_rule)
                for c in configs]
    for config, run_dir, meta in zip(configs, run_dirs, metadata, strict=True):
        if not job.resume:
            run_dir.mkdir(parents=True, exist_ok=True)
            RunDir(run_dir).run_json.unlink(missing_ok=True)  # a stale record of a run without checkpoint
            _write_run_json(run_dir, config, meta, 0, job.threads, resumed_now=False)
    start = time.perf_counter()
    train_seeds(functools.partial(make_vector_env, case, physics=job.physics,
                                  initial_field="random", duration=job.duration),
                configs, job.steps, run_dirs, envs_per_seed=job.envs, resume=job.resume,
                progress=job.progress, metadata=metadata,
                eval_env_fn=functools.partial(make_env, case, job.physics, "zero", EVAL_DURATION),
                eval_vec_env_fn=functools.partial(make_vector_env, case, physics=job.physics,
                                                  initial_field="zero", duration=EVAL_DURATION),
                progress_position=job.position, progress_desc=job.case,
                stop_rules=[None if job.stop_rule is None else StopRule.from_dict(job.stop_rule)]
                * len(configs))
    wall, peak = time.perf_counter() - start, _peak_rss_bytes()
    results = []
    for run_dir, meta in zip(run_dirs, metadata, strict=True):
        ckpt = load_checkpoint(run_dir)  # what was actually done, with the settings actually used
        _write_run_json(run_dir, TD3Config.from_dict(ckpt["config"]), meta,
                        int(ckpt["global_step"]), job.threads, resumed_now=job.resume)
        record = stop_record(ckpt, job.steps)
        results.append({"seed": int(ckpt["config"]["seed"]),
                        **summarize_run(run_dir, reward_scale=case.task.reward_scale), **record,
                        "state": seed_state(run_dir, record, target_return(case)),
                        "wall_s": wall, "peak_rss_bytes": peak,
                        "group_seeds": [c.seed for c in configs],
                        "group_timing_s": ckpt.get("timing")})
    return {"group": results}


def default_layout(seeds: int, cases: int = 1, cpus: int | None = None) -> dict[str, int]:
    """The fastest layout known for ``seeds`` seeds of each of ``cases`` cases on ``cpus`` cores:
    one worker process per core, each training its share of a case's seeds side by side (one
    batched simulator, one stacked update; measured in ``docs/performance.md``), one torch thread
    each. Returns ``workers``, ``seeds_per_simulator`` and ``threads``."""
    cpus = max(1, cpus if cpus is not None else (os.cpu_count() or 1))
    workers_per_case = max(1, cpus // max(1, cases))
    per_group = -(-seeds // min(seeds, workers_per_case))
    groups = -(-seeds // per_group) * cases
    workers = min(cpus, groups)
    return {"workers": workers, "seeds_per_simulator": per_group,
            "threads": max(1, cpus // workers)}


def _peak_rss_bytes() -> int | None:
    """Peak resident memory of this process so far (bytes; ``None`` where unavailable)."""
    try:
        import resource
    except ImportError:  # not on Windows
        return None
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return int(peak if sys.platform == "darwin" else peak * 1024)  # macOS: bytes; Linux: KiB


def _earlier_seeds(case_dir: Path, exclude: list[int], reward_scale: float) -> list[dict[str, Any]]:
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
        found.append({**entry, "seed": seed, **summarize_run(run.path, reward_scale=reward_scale),
                      "run_dir": str(run.path)})
    return found


def train_case(case: str | Path | Case, seeds: int = 8, **kwargs: Any) -> dict[str, Any]:
    """Train seeds of one case: :func:`train_cases` with ``[case]``; returns its summary."""
    return train_cases([case], seeds, **kwargs)[load_case(case).name]


def train_cases(
    cases: Sequence[str | Path | Case],
    seeds: int = 8,
    steps: int | None = None,
    workers: int | None = None,
    out: str | Path = "runs",
    resume: bool = False,
    seed_offset: int = 0,
    config_overrides: dict[str, Any] | None = None,
    physics: str = "training",
    episode_duration: float | None = None,
    progress: bool = True,
    threads: int | None = None,
    success_fraction: float = 0.5,
    envs: int = 1,
    backend: str = "process",
    address: str | None = None,
    seeds_per_simulator: int | None = None,
    recipe: str | None = None,
    stop_when: str | None = None,
    stop_options: dict[str, Any] | None = None,
) -> dict[str, dict[str, Any]]:
    """Train seeds ``seed_offset .. seed_offset + seeds - 1`` of every case in ``cases`` for
    ``steps`` environment steps each, in groups of seeds of one case that train side by side in
    one worker (:func:`_train_group`), ``workers`` groups at a time in separate processes
    (``spawn``, one progress bar per seed) or Ray tasks.

    The layout (``workers``, ``seeds_per_simulator``, ``threads``) defaults to
    :func:`default_layout`, the fastest one known for this machine; the results do not depend on
    it (a seed trained in a group is bit-identical to the same seed trained alone).

    Writes ``out/<case>/seed<k>/`` per seed and ``out/<case>/summary.json`` per case; returns the
    summaries by case. A summary covers every seed folder of its case, also those of earlier calls
    (trained with another ``seed_offset``), so success counts and the best seed are over all of
    them. A seed counts as *succeeded* when its final mean episode return reaches
    ``success_fraction`` of the yardstick's distance rate (its 10 s distance, scaled to the episode
    length, x the reward scale): a heuristic to count working seeds, reported with its threshold
    (crawling cases with a yardstick distance only; the seeds' real test is ``msr export-seeds``).

    ``cases`` are shipped names or spec files (or :class:`~elastica_magnetic_rl.cases.case.Case`); the
    folders are named after the cases. ``steps``, ``episode_duration`` and ``recipe`` default to
    each case's ``[training]`` / ``[task]`` values (so to one value when the cases agree), and
    ``config_overrides`` go on top of the case's ``[training.td3]``.

    Args:
        config_overrides: :class:`~elastica_magnetic_rl.td3.algorithm.TD3Config` fields on top of
            :func:`crawler_config` (e.g. ``precision="bf16"``, ``device="cuda"``).
        workers: groups trained at a time (processes or Ray tasks in flight).
        threads: torch threads per worker. Exact resume needs the same thread count.
        envs: crawlers per seed (``envs`` transitions and updates per vector step); resume with
            the same value.
        backend: ``"process"`` (default: worker processes on this machine) or ``"ray"`` (one Ray
            task per group; see :mod:`elastica_magnetic_rl.sweep.backends`). Same run directories and
            summaries.
        address: Ray cluster to run on (``backend="ray"`` only; default: a local Ray instance with
            ``workers x threads`` CPUs, started and shut down here). The output folder must then be
            on a filesystem every node sees at the same path.
        seeds_per_simulator: seeds of a case per group (one batched simulator, one stacked
            update).
        recipe: the training recipe (:data:`RECIPES`), recorded in ``run.json`` and the summary.
        stop_when: stop a seed that has learned (``"target"``, ``"plateau"``; ``"none"``: off;
            default: the recipe's run setting, else off): see
            :mod:`elastica_magnetic_rl.sweep.stop_settings`. Recorded in each run; a resume keeps it.
        stop_options: ``consecutive``, ``patience``, ``tolerance`` of the rule.
    """
    loaded = _load_cases(cases)
    cases = list(loaded)  # names, in order, once each
    steps, episode_duration, recipe = _case_defaults(loaded, steps, episode_duration, recipe)
    _check_sweep_options(seeds=seeds, steps=steps, envs=envs, workers=workers,
                         seeds_per_simulator=seeds_per_simulator, threads=threads,
                         seed_offset=seed_offset, backend=backend, address=address)
    layout = _sweep_layout(seeds, len(cases), workers, seeds_per_simulator, threads, address)
    seed_list = [seed_offset + k for k in range(seeds)]
    per_group = layout["seeds_per_simulator"]
    groups = [seed_list[i:i + per_group] for i in range(0, seeds, per_group)]
    workers = min(layout["workers"], len(groups) * len(cases))
    if threads is None:  # on a Ray cluster this machine's CPU count says nothing: one per worker
        threads = 1 if address else max(1, (os.cpu_count() or 1) // workers)
    configs = _seed_configs(loaded, seed_list, recipe, config_overrides)
    keep_stop_rules = resume and stop_when is None and not stop_options
    if not keep_stop_rules:
        stop_rules = _stop_rules(loaded, recipe_stop_when(stop_when, recipe), stop_options,
                                 configs[seed_list[0]].eval_every)
    _check_run_folders(out, loaded, seed_list, resume, physics, episode_duration, recipe)
    if resume:  # the checkpoints are these cases', and no hyperparameter given differs
        check_resumed_checkpoints([(c, CaseDir.of(out, c).seed(s)) for c in loaded
                                   for s in seed_list], config_overrides)
    if resume:  # a resumed run keeps its stop rule: the runs' own, or the same one given
        folders = {case: [CaseDir.of(out, case).seed(s).path for s in seed_list] for case in loaded}
        if keep_stop_rules:
            stop_rules = {case: resumed_stop_rule(dirs) for case, dirs in folders.items()}
            if any(stop_rules.values()) and configs[seed_list[0]].eval_every <= 0:
                raise ValueError("the runs stop by a rule decided at their evaluations: resume them "
                                 "with --eval-every > 0")
        for case, dirs in folders.items():
            check_resumed_stop_rules(dirs, stop_rules[case])
    jobs = _group_jobs(out, loaded, groups, configs, backend, physics=physics,
                       duration=float(episode_duration), steps=int(steps), resume=resume,
                       progress=progress, threads=threads, envs=int(envs), recipe=recipe,
                       stop_rules=stop_rules)
    start = time.perf_counter()
    results = _run_groups(jobs, workers, backend, address, progress)
    sweep = {"steps": int(steps), "physics": physics, "episode_duration_s": float(episode_duration),
             "workers": workers, "backend": backend, "envs_per_seed": int(envs),
             "seeds_per_simulator": int(per_group), "torch_threads_per_worker": threads,
             "layout": layout["layout"], "recipe": recipe,
             "precision": configs[seed_list[0]].precision, "device": configs[seed_list[0]].device,
             "stop_rules": stop_rules}
    wall = time.perf_counter() - start
    return {case: _case_summary(CaseDir.of(out, case), loaded[case],
                                [r for c, r in results if c == case], seed_list, success_fraction,
                                sweep, wall)
            for case in cases}


def _stop_rules(loaded: dict[str, Case], kind: str | None, options: dict[str, Any] | None,
                eval_every: int) -> dict[str, Any]:
    """Each case's stop rule (``None``: off), checked before any work."""
    return {name: case_stop_rule(case, kind, eval_every=eval_every, **(options or {}))
            for name, case in loaded.items()}


def _load_cases(cases: Sequence[str | Path | Case]) -> dict[str, Case]:
    """The cases by name, every spec checked before any work (two different specs may not share
    a name)."""
    loaded: dict[str, Case] = {}
    for case in cases:
        c = load_case(case)
        loaded.setdefault(c.name, c)
        if loaded[c.name].to_dict() != c.to_dict():
            raise ValueError(f"two different cases are named {c.name!r}: rename one spec file")
    if not loaded:
        raise ValueError("no case to train")
    return loaded


def _case_defaults(loaded: dict[str, Case], steps: int | None, episode_duration: float | None,
                   recipe: str | None) -> tuple[int, float, str]:
    """``steps``, ``episode_duration`` (s) and ``recipe``, each the cases' own value when not
    given (they must then agree)."""
    for key, value in (("steps", steps), ("episode_duration", episode_duration), ("recipe", recipe)):
        defaults = {c.name: {"steps": c.training.steps, "episode_duration": c.task.episode_duration,
                             "recipe": c.training.recipe}[key] for c in loaded.values()}
        if value is None and len(set(defaults.values())) > 1:
            raise ValueError(f"the cases' specs give different {key} ({defaults}): set it")
    first = next(iter(loaded.values()))
    return (first.training.steps if steps is None else steps,
            first.task.episode_duration if episode_duration is None else episode_duration,
            first.training.recipe if recipe is None else recipe)


def _check_sweep_options(*, seeds: int, steps: int, envs: int, workers: int | None,
                         seeds_per_simulator: int | None, threads: int | None, seed_offset: int,
                         backend: str, address: str | None) -> None:
    """Refuse a bad option, naming it, before any work."""
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; choose one of {', '.join(BACKENDS)}")
    if address is not None and backend != "ray":
        raise ValueError("--address is for the ray backend (--backend ray)")
    for name, value in (("seeds", seeds), ("steps", steps), ("envs", envs), ("workers", workers),
                        ("seeds_per_simulator", seeds_per_simulator), ("threads", threads)):
        if value is not None and value < 1:
            raise ValueError(f"{name} must be >= 1, got {value}")
    if seed_offset < 0:
        raise ValueError(f"seed_offset must be >= 0, got {seed_offset}")


def _sweep_layout(seeds: int, cases: int, workers: int | None, seeds_per_simulator: int | None,
                  threads: int | None, address: str | None) -> dict[str, Any]:
    """``workers`` and ``seeds_per_simulator``: the ones given, else :func:`default_layout`'s;
    ``layout`` says which of them (and ``threads``) were given."""
    # --workers W alone: the fastest layout for W workers (a case's seeds split among them), so
    # that e.g. --workers 1 trains all seeds of a case side by side instead of group after group
    cpus = workers if workers is not None else (None if not address else seeds * cases)
    layout = default_layout(seeds, cases, cpus)
    manual = {k for k, v in (("workers", workers), ("seeds_per_simulator", seeds_per_simulator),
                             ("threads", threads)) if v is not None}
    return {"workers": workers or layout["workers"],
            "seeds_per_simulator": min(seeds, seeds_per_simulator or layout["seeds_per_simulator"]),
            "layout": "default" if not manual else f"set: {', '.join(sorted(manual))}"}


def _seed_configs(loaded: dict[str, Case], seed_list: list[int], recipe: str,
                  config_overrides: dict[str, Any] | None) -> dict[int, Any]:
    """Each seed's TD3 configuration: the recipe, the cases' ``[training.td3]``, the overrides."""
    td3_settings = [dict(c.training.td3) for c in loaded.values()]
    if any(t != td3_settings[0] for t in td3_settings):
        raise ValueError("the cases' specs give different [training.td3] settings: train them apart")
    return {s: crawler_config(s, recipe, **{**td3_settings[0], **(config_overrides or {})})
            for s in seed_list}


def _check_run_folders(out: str | Path, loaded: dict[str, Case], seed_list: list[int], resume: bool,
                       physics: str, episode_duration: float, recipe: str) -> None:
    """Before any work: no run is overwritten; a resumed run exists, can continue and keeps its
    settings; every seed's folder can be written."""
    from elastica_magnetic.io import prepare_output_dir

    from ..runfiles.checkpoint import load_checkpoint, refuse_networks_only

    runs = [(case, s, CaseDir.of(out, case).seed(s)) for case in loaded for s in seed_list]
    if not resume:
        existing = [str(run.path) for _, _, run in runs if run.checkpoint.exists()]
        if existing:
            raise FileExistsError(f"runs already exist: {', '.join(existing)} (use --resume, another "
                                  "--out, or --seed-offset)")
    else:
        missing = [str(run.checkpoint) for _, _, run in runs if not run.checkpoint.exists()]
        if missing:
            raise FileNotFoundError(f"cannot resume: no checkpoint {', '.join(missing)} (train those "
                                    "seeds without --resume, or choose --seeds/--seed-offset)")
        for case, _, run in runs:  # a resumed run keeps its settings: checked before any work
            if run.episodes_csv.is_file():  # a damaged log is named before any work
                read_log(run.episodes_csv, ("global_step", "return"))
            refuse_networks_only(load_checkpoint(run.checkpoint, with_buffer=False), run.checkpoint)
            _check_resume_settings(run.path, {
                "case": case, "case_spec": loaded[case].to_dict(), "physics": physics,
                "episode_duration_s": float(episode_duration), "recipe": recipe})
    for _, _, run in runs:  # every seed's folder can be written, before any work
        prepare_output_dir(run.path, "--out")
    check_unlocked(run.path for _, _, run in runs)  # no other process trains one of them now


def _group_jobs(out: str | Path, loaded: dict[str, Case], groups: list[list[int]],
                configs: dict[int, Any], backend: str, stop_rules: dict[str, Any] | None = None,
                **settings: Any) -> list[GroupJob]:
    """One job per case and group of seeds, progress bars numbered across them."""

    def run_dir(case: str, seed: int) -> str:
        # Ray workers may run elsewhere (another cwd, another node): give them absolute paths
        path = CaseDir.of(out, case).seed(seed).path
        return str(path.resolve() if backend == "ray" else path)

    jobs, position = [], 0
    for case, spec in loaded.items():
        for group in groups:
            jobs.append(GroupJob(case=case, case_spec=spec.to_dict(), position=position,
                                 configs=tuple(configs[s].to_dict() for s in group),
                                 run_dirs=tuple(run_dir(case, s) for s in group),
                                 stop_rule=_rule_dict((stop_rules or {}).get(case)), **settings))
            position += len(group)
    return jobs


def _rule_dict(rule: Any) -> dict[str, Any] | None:
    return None if rule is None else rule.to_dict()


def _run_groups(jobs: list[GroupJob], workers: int, backend: str, address: str | None,
                progress: bool) -> list[tuple[str, dict[str, Any]]]:
    """``(case, result)`` of every seed; a failed group reports what its folders hold."""
    results = []
    for job, result in zip(jobs, run_jobs(_train_group, jobs, workers, backend=backend,
                                          address=address, progress=progress), strict=True):
        if "group" in result:
            results += [(job.case, r) for r in result["group"]]
        else:  # the whole group failed: what its folders hold is still reported
            for c, d in zip(job.configs, job.run_dirs, strict=True):
                entry = summarize_run(d) if RunDir(d).has_episodes() else {}
                results.append((job.case, {**entry, "seed": c["seed"], "error": result["error"]}))
    return results


def _case_summary(case_dir: CaseDir, spec: Case, mine: list[dict[str, Any]], seed_list: list[int],
                  success_fraction: float, sweep: dict[str, Any], wall: float) -> dict[str, Any]:
    """A case's ``summary.json`` (written, and returned with its path): every seed folder of the
    case, this call's and earlier ones', the succeeded ones counted against the threshold."""
    for r in mine:
        if "run_dir" in r:
            r["run_dir"] = str(case_dir.seed(r["seed"]).path)
    threshold = None
    if spec.task.kind == "crawl" and spec.yardstick.distance_10s > 0.0:
        threshold = (success_fraction * spec.yardstick.distance_10s
                     * (sweep["episode_duration_s"] / 10.0) * spec.task.reward_scale)
    with briefly_locked(case_dir.path):  # read-modify-write: processes training other seeds
        return _write_case_summary(case_dir, spec, mine, seed_list, threshold, sweep, wall)


def _write_case_summary(case_dir: CaseDir, spec: Case, mine: list[dict[str, Any]],
                        seed_list: list[int], threshold: float | None, sweep: dict[str, Any],
                        wall: float) -> dict[str, Any]:
    per_seed = sorted(mine + _earlier_seeds(case_dir.path, seed_list, spec.task.reward_scale),
                      key=lambda r: r["seed"])
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
        "success_threshold_return": threshold,
        "succeeded": None if threshold is None else sum(bool(r.get("succeeded")) for r in per_seed),
        "best_seed": best["seed"] if best else None,
        "best_run_dir": best["run_dir"] if best else None,
        "wall_s": wall,
        "seeds": per_seed,
        "failed": [r["seed"] for r in per_seed if "error" in r],
        **stop_summary(per_seed, sweep["steps"], sweep["stop_rules"].get(spec.name)),
    }
    case_dir.path.mkdir(parents=True, exist_ok=True)
    atomic_write_json(case_dir.summary_json, summary)
    summary["summary_json"] = str(case_dir.summary_json)
    return summary


def refine(
    run: str | Path,
    steps: int = 1000,
    out: str | Path | None = None,
    resume: bool = False,
    progress: bool = True,
    episode_duration: float = 20.0,
    physics: str = "accurate",
    device: str | None = None,
) -> dict[str, Any]:
    """Continue training a run for ``steps`` more environment steps in the accurate physics
    (on ``device``, default the run's).

    ``run``: a run folder or its ``checkpoint.pt``, whose final actor is refined, or its ``best.pt``
    (:func:`~elastica_magnetic_rl.sweep.refine_start.refine_source`: best.pt's networks, the rest of
    the run's training state; which actor to refine is the command line's choice, the rule of
    ``msr generate``). The agent (networks, targets, optimisers), its replay buffer, RNG states and
    counters come from the run's checkpoint (``init_from``), so learning continues at once (the
    counters are past the warm-up) with the training-physics transitions still in the buffer,
    gradually displaced by accurate ones. Episodes keep the training setting (random initial
    field, 20 s). The refined run goes to ``out`` (default ``RUN/refined``) with its own
    ``episodes.csv``, TensorBoard scalars, ``checkpoint.pt`` and ``run.json``; ``resume``
    continues an interrupted refinement.

    Cost: one accurate step is 1250 substeps (~0.1 s here), 12.5x a training step.
    """
    from ..envs.vector_env import make_vector_env
    from ..runner.loop import train_seeds
    from ..td3.algorithm import TD3Config

    if steps < 1:
        raise ValueError("steps must be >= 1")
    source = RunDir.checkpoint_of(run)
    ckpt, start = refine_source(source)
    meta = checkpoint_metadata(ckpt, start["state_from"])
    case = case_from_metadata(meta, str(source))
    out = RunDir(out if out is not None else default_refine_output(source))
    start_step = int(ckpt["global_step"])
    total = start_step + int(steps)
    config = TD3Config.from_dict(ckpt["config"])
    if device is not None:
        config.device = device
    metadata = _run_metadata(
        case, physics, episode_duration, config.seed, command="refine",
        refined_from=str(source), refine_start_step=start_step, refine_steps=int(steps),
        training_steps=int(meta.get("training_steps", start_step)), refined_actor=start["actor"],
        refined_actor_step=start["actor_step"],
    )
    check_refine_output(out.path, resume)
    begin = time.perf_counter()
    with held_run_folders([out.path]):
        mark_run_folder(out.path, "refine", case.name)
        atomic_write_json(out.run_json, {**metadata, "steps": total, "config": config.to_dict(),
                                         "versions": versions()})
        with starting_file(ckpt, start, out.path) as init_from:
            train_seeds(functools.partial(make_vector_env, case, physics=physics,
                                          initial_field="random", duration=episode_duration),
                        [config], total, [out.path], resume=resume, progress=progress,
                        init_from=[init_from], metadata=[metadata],
                        progress_desc=f"refine {case.name} {CaseDir.seed_name(config.seed)}")
        mark_run_folder(out.path, "refine", case.name)
    summary = summarize_run(out.path, reward_scale=case.task.reward_scale)
    return {"case": case.name, "source": str(source), "run_dir": str(out.path),
            "checkpoint": str(out.checkpoint), "start_step": start_step, "steps": int(steps),
            "actor": start["actor"], "actor_step": start["actor_step"],
            "physics": physics, **{k: summary[k] for k in ("episodes", "final_mean_return")},
            "wall_s": time.perf_counter() - begin}


# ----------------------------------------------------------------------------------------------
# Policies: loading, shipping, exporting
# ----------------------------------------------------------------------------------------------
