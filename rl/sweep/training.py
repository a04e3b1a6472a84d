"""Training of crawling policies (``msr train``): seeds in groups that train side by side
(:func:`elastica_magnetic_rl.runner.loop.train_seeds`), groups in worker processes or Ray tasks
(:mod:`elastica_magnetic_rl.sweep.backends`), one summary per case
(:mod:`elastica_magnetic_rl.sweep.summaries`), once every check and the plan are done
(:mod:`elastica_magnetic_rl.sweep.sweep_plan`). Refinement (``msr refine``) is in
:mod:`elastica_magnetic_rl.sweep.refine`.

Each seed writes ``OUT/<case>/seed<k>/`` (``episodes.csv``, TensorBoard scalars, ``checkpoint.pt``
and ``replay.bin``, ``evaluations.csv`` and ``best.pt``, ``run.json``:
:mod:`elastica_magnetic_rl.sweep.run_records`); ``OUT/<case>/summary.json`` collects every seed of the
case.
"""

from __future__ import annotations

import dataclasses
import functools
import os
import sys
import time
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from elastica_magnetic.plausibility import ImplausibleValueWarning

from ..cases.case import Case, case_from_dict, load_case
from ..envs.env import make_env
from ..runfiles.locking import held_run_folders, mark_run_folder
from ..runfiles.rundir import CaseDir, RunDir
from ..runner.memory import peak_rss_bytes
from ..td3.devices import torch_threads
from .backends import run_jobs
from .jobs import GroupJob
from .randomize_settings import randomized_cases
from .rebalance import GroupRebalancing
from .run_records import recorded_run_settings, run_metadata, write_run_json
from .stop_settings import (
    seed_state,
    stop_record,
    target_return,
)
from .summaries import case_summary, failed_group_results, summarize_run
from .sweep_plan import Resolved, case_defaults, default_layout, load_cases, plan_sweep
from .sweep_settings import SweepSettings

__all__ = ["SweepSettings", "default_layout", "train_case", "train_cases"]


def _train_group(job: GroupJob) -> dict[str, Any]:
    """:func:`_train_group_unlocked` holding each seed's folder (a second process on one of them
    is refused, naming this one) and marking it as a training run's."""
    with held_run_folders(job.run_dirs) as notes:
        for note in notes:  # a stale lock of a killed run taken over
            print(f"note: {note}", file=sys.stderr)
        for run_dir in job.run_dirs:
            mark_run_folder(run_dir, "train", job.case)
        try:
            with torch_threads(job.threads):  # restored: one worker trains in the caller's process
                result = _train_group_unlocked(job)
        except OSError as exc:  # a write that names no file (a log, replay.bin): say whose
            if exc.filename is not None or exc.errno is None:
                raise
            folders = ", ".join(str(d) for d in job.run_dirs)
            raise OSError(exc.errno, f"{exc.strerror or exc} while writing the run in {folders} (its "
                                     "last checkpoint stays: make room, then the same command with "
                                     "--resume)") from exc
        for run_dir in job.run_dirs:
            mark_run_folder(run_dir, "train", job.case)
    return result


def _train_group_unlocked(job: GroupJob) -> dict[str, Any]:
    """Train a group of seeds of one case side by side in one worker process: their crawlers in
    one batched simulator (``job.envs`` each), their networks updated as one computation
    (:func:`~elastica_magnetic_rl.runner.loop.train_seeds`). Returns ``{"group": [one result per
    seed]}``, and ``"handed_back": [run folders]`` when the group was asked to hand back its
    seeds (``job.hand_back_file``) and did: those seeds go on in other jobs
    (:mod:`elastica_magnetic_rl.sweep.rebalance`) and have no result here."""
    from ..runfiles.checkpoint import load_checkpoint
    from ..runner.stopping import StopRule
    from ..td3.algorithm import PrecisionFallbackWarning, resolve_precision
    from ..td3.config import TD3Config

    configs = [TD3Config.from_dict(c) for c in job.configs]
    run_dirs = [Path(d) for d in job.run_dirs]
    with warnings.catch_warnings():  # the command warned of these before the jobs began
        warnings.simplefilter("ignore", ImplausibleValueWarning)
        warnings.simplefilter("ignore", PrecisionFallbackWarning)
        case = case_from_dict(job.case_spec, job.case)
        metadata = [run_metadata(case, job.physics, job.duration, c.seed, command="train",
                                 envs=job.envs, shared_simulator_seeds=len(configs),
                                 precision=resolve_precision(c.precision, c.device), recipe=job.recipe,
                                 stop_rule=job.stop_rule)
                    for c in configs]
    for config, run_dir, meta in zip(configs, run_dirs, metadata, strict=True):
        if not job.resume:
            run_dir.mkdir(parents=True, exist_ok=True)
            RunDir(run_dir).run_json.unlink(missing_ok=True)  # a stale record of a run without checkpoint
            write_run_json(run_dir, config, meta, 0, job.threads, resumed_now=False)
    rule = None if job.stop_rule is None else StopRule.from_dict(job.stop_rule)
    start = time.perf_counter()
    with warnings.catch_warnings():
        # a resume keeps each run's hyperparameters: those given that differ were refused before
        # any work (resume_checks), the others are the recipe's defaults, nothing to warn about
        warnings.filterwarnings("ignore", message="resuming: using the checkpoint's hyperparameters")
        warnings.simplefilter("ignore", PrecisionFallbackWarning)
        _train_seeds_of(job, case, configs, run_dirs, metadata, rule)
    wall, peak = time.perf_counter() - start, peak_rss_bytes()
    results, handed_back = [], []
    for run_dir, meta in zip(run_dirs, metadata, strict=True):
        ckpt = load_checkpoint(run_dir)  # what was actually done, with the settings actually used
        write_run_json(run_dir, TD3Config.from_dict(ckpt["config"]), meta,
                        int(ckpt["global_step"]), job.threads,
                        resumed_now=job.resume and not job.continued)
        record = stop_record(ckpt, job.steps)
        if not record["stopped_early"] and int(ckpt["global_step"]) < job.steps:
            handed_back.append(str(run_dir))  # goes on in another job
            continue
        summary = summarize_run(run_dir, reward_scale=case.task.reward_scale, travels=case.field_actuated)
        results.append({"seed": int(ckpt["config"]["seed"]), **summary, **record,
                        "state": seed_state(run_dir, record, target_return(case)),
                        "wall_s": wall, "peak_rss_bytes": peak,
                        # the periodic evaluations' episode, s (the run's eval_duration, else the
                        # case's); None for a run that made none
                        "evaluation_duration_s": float(ckpt["config"].get("eval_duration") or
                                                       case.evaluation_duration)
                        if ckpt["config"].get("eval_every", 0) > 0 else None,
                        "group_seeds": [c.seed for c in configs],
                        "group_timing_s": ckpt.get("timing"),
                        **_diverged_throughout(summary, case)})
    return {"group": results, **({"handed_back": handed_back} if handed_back else {})}


def _diverged_throughout(summary: dict[str, Any], case: Case) -> dict[str, Any]:
    """A seed whose every training episode blew up on its first step (``terminated``: only a
    numerical blow-up ends an episode early) learned nothing: an ``error`` naming why, so it
    counts as failed."""
    episodes = summary["episodes"]
    if not episodes or summary.get("diverged_at_first_step", 0) < episodes:
        return {}
    return {"error": f"every training episode diverged at its first step ({episodes} of {episodes}: "
                     "the simulation blew up, nothing was learned); the time step is likely unstable: "
                     f"msr case check on case {case.name}'s spec estimates a stable one"}


def _train_seeds_of(job: GroupJob, case: Case, configs: list[Any], run_dirs: list[Path],
                    metadata: list[dict[str, Any]], rule: Any) -> None:
    """:func:`~elastica_magnetic_rl.runner.loop.train_seeds` of a group job's seeds, with the
    case's environments (training, evaluation and the stop rule's confirmation)."""
    from ..envs.residual import residual_env, residual_vector_env
    from ..envs.vector_env import make_vector_env
    from ..envs.yardsticks import yardstick_controller
    from ..runner.loop import train_seeds

    # a residual learner's environments play corrections of the case's yardstick (envs.residual)
    vector, single = make_vector_env, make_env
    if configs[0].residual:
        vector = functools.partial(residual_vector_env, make_vector_env, case, configs[0].residual)
        single = functools.partial(residual_env, make_env, case, configs[0].residual)
    train_seeds(functools.partial(vector, case, physics=job.physics,
                                  initial_field="random", duration=job.duration,
                                  randomize=case.training.randomize),
                configs, job.steps, run_dirs, envs_per_seed=job.envs, resume=job.resume,
                progress=job.progress, metadata=metadata,
                # the duration a keyword: a run's eval_duration replaces it (GroupLoop)
                eval_env_fn=functools.partial(single, case, job.physics, "zero",
                                              duration=case.evaluation_duration),
                eval_vec_env_fn=functools.partial(vector, case, physics=job.physics,
                                                  initial_field="zero",
                                                  duration=case.evaluation_duration),
                progress_position=job.position, progress_desc=job.case,
                stop_rules=[rule] * len(configs),
                confirm_vec_env_fn=None if rule is None or rule.confirm is None else functools.partial(
                    vector, case, physics=rule.confirm, initial_field="zero",
                    duration=case.evaluation_duration),
                hand_back=None if job.hand_back_file is None else functools.partial(
                    os.path.exists, job.hand_back_file),
                yardstick_fn=yardstick_controller(case))


def train_case(case: str | Path | Case, seeds: int = 8, **changes: Any) -> dict[str, Any]:
    """Train seeds of one case: :func:`train_cases` with ``[case]`` and ``seeds`` and the other
    :class:`~elastica_magnetic_rl.sweep.sweep_settings.SweepSettings` fields in ``changes``;
    returns its summary."""
    return train_cases([case], seeds=seeds, **changes)[load_case(case).name]


def train_cases(
    cases: Sequence[str | Path | Case],
    settings: SweepSettings | None = None,
    /,
    **changes: Any,
) -> dict[str, dict[str, Any]]:
    """Train seeds ``seed_offset .. seed_offset + seeds - 1`` of every case in ``cases`` for ``steps``
    environment steps each, in groups of seeds of one case that train side by side in one worker
    (:func:`_train_group`), ``workers`` groups at a time in separate processes (forked from a fork server, one
    progress bar per seed) or Ray tasks.

    The layout (``workers``, ``seeds_per_simulator``, ``threads``) defaults to :func:`default_layout`, the
    fastest one known for this machine; with one torch thread per worker (the default) the results
    do not depend on it (a seed trained in a group is bit-identical to the same seed trained
    alone: :mod:`elastica_magnetic_rl.td3.algorithm`); with more threads per worker a stack and a
    seed alone round differently, and training amplifies it (measured: 5e-3 in the actor's weights
    after 160 steps of a smoke run).

    Writes ``out/<case>/seed<k>/`` per seed and ``out/<case>/summary.json`` per case; returns the
    summaries by case. A summary covers every seed folder of its case, also those of earlier calls
    (trained with another ``seed_offset``), so success counts and the best seed are over all of them; a
    seed *succeeded* when its final mean return reaches ``success_fraction`` of the yardstick's
    (:func:`~elastica_magnetic_rl.sweep.summaries.case_summary`).

    ``cases`` are shipped names or spec files (or :class:`~elastica_magnetic_rl.cases.case.Case`); the
    folders are named after the cases. ``steps``, ``episode_duration`` and ``recipe`` default to each
    case's ``[training]`` / ``[task]`` values (so to one value when the cases agree), and
    ``config_overrides`` go on top of the case's ``[training.td3]``.

    ``settings`` (:class:`~elastica_magnetic_rl.sweep.sweep_settings.SweepSettings`, default: its
    defaults) with ``changes`` (its fields by name, e.g. ``seeds=2, out="runs"``). Notes on some:
    ``threads``: exact resume needs the same thread count; ``envs``: resume with the same value;
    ``backend="ray"``: one Ray task per group (:mod:`elastica_magnetic_rl.sweep.backends`; with
    ``address`` the output folder must be on a filesystem every node sees at the same path);
    ``stop_when``: recorded in each run, a resume keeps it
    (:mod:`elastica_magnetic_rl.sweep.stop_settings`); ``rebalance``: a moved seed ends
    bit-identical to one that stayed (:mod:`elastica_magnetic_rl.sweep.rebalance`);
    ``warm_up_only``: otherwise a run whose weights would never be updated is refused before any
    work (:mod:`elastica_magnetic_rl.sweep.inert_settings`).
    """
    s = dataclasses.replace(settings or SweepSettings(), **changes)
    loaded = load_cases(cases)
    recorded: dict[str, Any] = {}
    if s.resume:  # options left out keep the runs' recorded values (as the runs' own defaults)
        seeds = range(s.seed_offset, s.seed_offset + s.seeds)
        recorded = recorded_run_settings(CaseDir.of(s.out, case).seed(k).path
                                         for case in loaded for k in seeds)
    duration = s.episode_duration if s.episode_duration is not None else recorded.get("episode_duration")
    steps, episode_duration, recipe = case_defaults(
        loaded, s.steps, duration, s.recipe if s.recipe is not None else recorded.get("recipe"))
    loaded = randomized_cases(loaded, s.randomize, recipe)
    resolved = Resolved(steps, episode_duration, recipe, steps_given=s.steps is not None)
    seed_list, groups, workers, configs, sweep = plan_sweep(loaded, s, resolved)
    start = time.perf_counter()
    results = _run_groups(_group_jobs(s.out, loaded, groups, configs, sweep, s.resume, s.progress),
                          workers, s.backend, s.address, s.progress, s.rebalance)
    wall = time.perf_counter() - start
    return {case: case_summary(CaseDir.of(s.out, case), loaded[case],
                               [r for c, r in results if c == case], seed_list,
                               s.success_fraction, sweep, wall)
            for case in loaded}


def _group_jobs(out: str | Path, loaded: dict[str, Case], groups: list[list[int]],
                configs: dict[int, Any], sweep: dict[str, Any], resume: bool,
                progress: bool) -> list[GroupJob]:
    """One job per case and group of seeds (the settings of :func:`_sweep_record`'s ``sweep``),
    progress bars numbered across them."""
    backend, stop_rules = sweep["backend"], sweep["stop_rules"]
    settings = {"physics": sweep["physics"], "duration": sweep["episode_duration_s"],
                "steps": sweep["steps"], "resume": resume, "progress": progress,
                "threads": sweep["torch_threads_per_worker"], "envs": sweep["envs_per_seed"],
                "recipe": sweep["recipe"]}

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
                progress: bool, rebalance: bool = True) -> list[tuple[str, dict[str, Any]]]:
    """``(case, result)`` of every seed; a failed group reports what its folders hold."""
    results = []
    with GroupRebalancing() as rebalancing:  # an idle core takes over seeds of a busy one
        # one torch thread per worker: with more, a stack's products round by its size too
        rebalance = (rebalance and backend == "process" and workers > 1
                     and all(j.threads == 1 for j in jobs))
        if rebalance:
            jobs = rebalancing.askable(jobs)
        for job, result in zip(jobs, run_jobs(_train_group, jobs, workers, backend=backend,
                                              address=address, progress=progress,
                                              rebalancing=rebalancing.protocol() if rebalance
                                              else None), strict=True):
            if "group" in result:
                results += [(job.case, r) for r in result["group"]]
            else:  # the whole group failed: what its folders hold is still reported
                results += [(job.case, r) for r in failed_group_results(job.configs, job.run_dirs,
                                                                         result["error"])]
    return results
