"""A training sweep planned before any work (``msr train``): the cases loaded and their defaults,
every option and setting checked (each refused by name), the run folders judged (none
overwritten; a resumed run's settings kept), the layout of seeds in groups and workers, each
seed's TD3 configuration, and the settings ``summary.json`` records. The sweep itself runs in
:mod:`elastica_magnetic_rl.sweep.training`.
"""

from __future__ import annotations

import dataclasses
import functools
import os
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from elastica_magnetic.batch import batched_refusal
from elastica_magnetic.io import display_path
from elastica_magnetic.locks import check_lock_name
from elastica_magnetic.plausibility import ImplausibleValueWarning, SettingNotAppliedWarning
from elastica_magnetic.specfile import SpecError

from ..cases.case import Case, case_names, load_case, warmup_refusal
from ..cases.recipes import crawler_config
from ..cases.training_tables import MAX_TRAIN_STEPS
from ..runfiles.locking import check_unlocked
from ..runfiles.logs import read_log
from ..runfiles.rundir import CaseDir, RunDir, being_written_hint
from .backends import BACKENDS
from .case_folders import check_case_folders
from .inert_settings import (
    SettingSources,
    check_episodes_end,
    check_evaluations_made,
    check_noise_colored,
    check_run_learns,
    check_stop_rule_decides,
)
from .resume_checks import check_resumed_checkpoints, check_steps_left
from .run_records import check_resume_settings
from .stop_settings import (
    case_stop_rule,
    check_resumed_stop_rules,
    recipe_stop_when,
    resumed_stop_rule,
    target_return,
)
from .sweep_settings import SweepSettings

__all__ = ["Resolved", "case_defaults", "default_layout", "load_cases", "plan_sweep"]


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


@dataclasses.dataclass(frozen=True)
class Resolved:
    """A sweep's steps, episode length (s) and recipe: the settings', else the cases' own."""

    steps: int
    episode_duration: float
    recipe: str
    steps_given: bool


def plan_sweep(loaded: dict[str, Case], s: SweepSettings, r: Resolved
                ) -> tuple[list[int], list[list[int]], int, dict[int, Any], dict[str, Any]]:
    """Every check of a sweep before any work (options, run folders, resumed runs), then its
    plan: the seeds, their groups, the worker count, each seed's TD3 configuration and the
    settings ``summary.json`` records (:func:`_sweep_record`)."""
    _check_sweep_options(seeds=s.seeds, steps=r.steps, envs=s.envs, workers=s.workers,
                         seeds_per_simulator=s.seeds_per_simulator, threads=s.threads,
                         seed_offset=s.seed_offset, backend=s.backend, address=s.address)
    layout = _sweep_layout(s.seeds, len(loaded), s.workers, s.seeds_per_simulator, s.threads,
                           s.address)
    seed_list = [s.seed_offset + k for k in range(s.seeds)]
    groups, workers, threads = _groups_and_workers(seed_list, layout, len(loaded), s.threads,
                                                   s.address)
    overrides = dict(s.config_overrides or {})
    if s.resume:  # a resumed run keeps its hyperparameters: said first, not advice to add another
        check_resumed_checkpoints([(c, run) for c in loaded for k in seed_list
                                   if (run := CaseDir.of(s.out, c).seed(k)).checkpoint.is_file()], overrides)
    configs = _seed_configs(loaded, seed_list, r.recipe, overrides)
    _check_devices(loaded, overrides)
    _warn_precision(configs[seed_list[0]])
    _check_yardstick_warmup(loaded, configs[seed_list[0]])
    _check_actor_input(loaded, configs[seed_list[0]])
    first = next(iter(loaded.values()))
    acting = _ActingChecks(configs[seed_list[0]], int(r.steps), int(s.envs), SettingSources(
        overrides, first.training.td3, first.source, r.steps_given, recipe=r.recipe),
        stop_given=s.stop_when not in (None, "none") or bool(s.stop_options),
        warm_up_only=s.warm_up_only, episode_duration=float(r.episode_duration),
        duration_given=s.episode_duration is not None)
    stop_rules = _check_before_work(loaded, seed_list, acting, s, r)
    sweep = _sweep_record(layout, configs[seed_list[0]], steps=int(r.steps), physics=s.physics,
                          episode_duration_s=float(r.episode_duration), workers=workers,
                          backend=s.backend, envs_per_seed=int(s.envs), torch_threads_per_worker=threads,
                          recipe=r.recipe, stop_rules=stop_rules)
    return seed_list, groups, workers, configs, sweep


def _check_yardstick_warmup(loaded: dict[str, Case], config: Any) -> None:
    """A warm-up played by the yardstick (``yardstick_warmup``), or a correction of it
    (``residual``), needs a case whose yardstick is a controller (``ValueError`` naming the cases
    without one, before any work)."""
    from ..cases.case import YARDSTICK_CONTROLLERS

    if not (config.yardstick_warmup or config.residual):
        return
    without = [name for name, case in loaded.items() if not case.has_yardstick_controller]
    if without:
        what = (f"--set yardstick_warmup={config.yardstick_warmup}: the warm-up is played by"
                if config.yardstick_warmup else f"--set residual={config.residual:g}: the actor learns a "
                "correction of")
        raise ValueError(f"{what} the case's hand-designed controller, and case(s) {', '.join(without)} have "
                         f"none ({YARDSTICK_CONTROLLERS}): train without it, or train {', '.join(without)} "
                         "on the spec msr field baseline --case CASE --set-yardstick FILE writes (it records "
                         "the rotating field's period; a crawl's or a reach's alike)")


def _check_actor_input(loaded: dict[str, Case], config: Any) -> None:
    """A steering actor (``actor_input = "steering"``) reads a goto case's field in three axes,
    heading, target and clock: any other case is refused by name, before any work."""
    if config.actor_input == "observation":
        return
    from ..cases.tasks import GotoTask
    from ..envs.crawler_observation import observation_layout
    from ..td3.steering_inputs import steering_start

    for name, case in loaded.items():
        if not (case.field_actuated and isinstance(case.task, GotoTask)):
            raise ValueError(f"actor_input = 'steering' steers a crawler to a target (a goto case with "
                             f"[actuation] axes = \"xyz\"); case {name} has the {case.task.kind} task: "
                             "train it with actor_input = 'observation'")
        extra = (*case.actuation.observation_blocks, *case.task.extra_observation)
        try:
            steering_start(observation_layout(case.n_elements, extra))
        except ValueError as exc:
            raise ValueError(f"case {name}: {exc}") from None
        if config.actor_mirror:
            _check_mirror_image(name, case)


def _check_mirror_image(name: str, case: Case) -> None:
    """A mirror-symmetric actor (``actor_mirror``) is right only for a robot that is its own mirror
    image through its vertical plane: no z component of its magnetization, in either physics."""
    for physics in ("training", "accurate"):
        m = case.robot.robot(physics).magnetization  # (3, n) A/m
        if np.any(m[2] != 0.0):
            largest = float(np.max(np.abs(m[2])))
            raise ValueError(f"actor_mirror = true assumes a robot that is its own mirror image (z -> -z), "
                             f"and case {name}'s magnetization has a z component (up to {largest:.4g} A/m in "
                             f"the {physics} physics): its left and right are not alike; train it with "
                             "actor_mirror = false")


def _check_devices(loaded: dict[str, Case], overrides: dict[str, Any]) -> None:
    """The networks' device, ``--device`` or a spec's ``[training.td3] device``, is one this
    PyTorch has (``ValueError`` naming where it was given, before any run folder is made)."""
    from ..td3.devices import device_problem

    for case in loaded.values():
        device = overrides.get("device", case.training.td3.get("device"))
        problem = None if device is None else device_problem(str(device))
        if problem is not None:
            where = "--device" if "device" in overrides else f"{case.source}: [training.td3] device ="
            raise ValueError(f"{where} {device}: {problem}; use the device \"cpu\"")


def _warn_precision(config: Any) -> None:
    """Warn once, here, where the seeds' precision falls back (their workers do not repeat it)."""
    from ..td3.algorithm import resolve_precision

    resolve_precision(config.precision, config.device)


def _sweep_record(layout: dict[str, Any], config: Any, **settings: Any) -> dict[str, Any]:
    """The sweep's settings as each case's ``summary.json`` records them: ``settings`` (steps,
    physics, episode length, workers, backend, crawlers per seed, threads, recipe, stop rules),
    the layout and the seeds' precision (the one they train in: ``fp32`` where a CPU has no
    bfloat16 units, with ``precision_asked``) and device."""
    from ..td3.algorithm import precision_used

    used = precision_used(config.precision, config.device)
    asked = {} if used == config.precision else {"precision_asked": config.precision}
    return {**settings, "seeds_per_simulator": int(layout["seeds_per_simulator"]),
            "layout": layout["layout"], "precision": used, **asked, "device": config.device}


@dataclasses.dataclass(frozen=True)
class _ActingChecks:
    """That every setting of a sweep can act (:mod:`~elastica_magnetic_rl.sweep.inert_settings`):
    ``config`` (a seed's TD3 configuration) trained to ``steps`` per seed, ``envs`` crawlers each."""

    config: Any
    steps: int
    envs: int
    sources: SettingSources
    stop_given: bool  # --stop-when (or a stop option) given, not just the recipe's rule
    warm_up_only: bool
    episode_duration: float = 20.0  # s
    duration_given: bool = True  # --episode-duration, else the spec's [task] episode_duration

    def new_runs(self, stop_rules: dict[str, Any] | None) -> None:
        """New runs: their weights are updated, an episode ends within them, and a stop rule
        asked for can decide."""
        if not self.warm_up_only:
            check_run_learns(self.config, self.steps, self.sources)
        check_evaluations_made(self.config, self.sources)
        check_noise_colored(self.config, self.sources)
        for rule in (stop_rules or {}).values() if self.stop_given else ():
            check_stop_rule_decides(rule, self.config, self.steps, self.envs, self.sources,
                                    self.episode_duration)
        check_episodes_end(self.episode_duration, self.steps, self.envs, self.sources,
                           self.duration_given)

    def resumed_runs(self, runs: list[tuple[str, RunDir]]) -> None:
        """Resumed runs: something is left to train, and their own settings update weights."""
        from ..runfiles.checkpoint import load_checkpoint
        from ..td3.config import TD3Config

        check_steps_left(runs, self.steps)
        if not self.warm_up_only:
            sources = dataclasses.replace(self.sources, resumed=True)
            for _, run in runs:
                config = load_checkpoint(run.checkpoint, with_buffer=False)["config"]
                check_run_learns(TD3Config.from_dict(config), self.steps, sources)
        check_episodes_end(self.episode_duration, self.steps, self.envs, self.sources,
                           self.duration_given)


def _check_before_work(loaded: dict[str, Case], seed_list: list[int], acting: _ActingChecks,
                       s: SweepSettings, r: Resolved) -> dict[str, Any]:
    """Every check of a sweep before any work: the stop rule given (or the recipe's), that the
    settings can act (``acting``), the run folders (:func:`_check_run_folders`) and, for a
    resume, the runs themselves (:func:`_check_resumed_runs`). Returns each case's stop rule
    (``None``: off)."""
    eval_every = acting.config.eval_every
    stop_options = dict(s.stop_options or {})
    keep_stop_rules = s.resume and s.stop_when is None and not stop_options
    stop_rules = None if keep_stop_rules else _stop_rules(
        loaded, recipe_stop_when(s.stop_when, r.recipe), stop_options, eval_every,
        from_recipe=s.stop_when is None, eval_duration=acting.config.eval_duration)
    _check_run_folders(s.out, loaded, seed_list, s.resume, s.physics, r.episode_duration, r.recipe,
                       int(s.envs), before_making=None if s.resume else functools.partial(acting.new_runs,
                                                                             stop_rules))
    if s.resume:
        stop_rules = _check_resumed_runs(s.out, loaded, seed_list, dict(s.config_overrides or {}),
                                         stop_rules, eval_every)
        acting.resumed_runs([(c, CaseDir.of(s.out, c).seed(k)) for c in loaded for k in seed_list])
    return stop_rules


def _groups_and_workers(seed_list: list[int], layout: dict[str, Any], n_cases: int,
                        threads: int | None, address: str | None) -> tuple[list[list[int]], int, int]:
    """The groups of seeds (``layout["seeds_per_simulator"]`` each), the worker count (no more
    than the groups of all cases) and the torch threads per worker (given, else the cores shared
    among the workers; on a Ray cluster, one)."""
    per_group = layout["seeds_per_simulator"]
    groups = [seed_list[i:i + per_group] for i in range(0, len(seed_list), per_group)]
    workers = min(layout["workers"], len(groups) * n_cases)
    if threads is None:  # on a Ray cluster this machine's CPU count says nothing: one per worker
        threads = 1 if address else max(1, _cores() // workers)
    return groups, workers, threads


def _cores() -> int:
    """The cores the networks may compute on: this process's CPUs, or fewer where the user's
    ``OMP_NUM_THREADS`` (PyTorch's own setting of its threads) says so."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    limit = os.environ.get("OMP_NUM_THREADS", "").strip()
    return min(cores, int(limit)) if limit.isdigit() and int(limit) > 0 else cores


def _check_resumed_runs(out: str | Path, loaded: dict[str, Case], seed_list: list[int],
                        config_overrides: dict[str, Any] | None, stop_rules: dict[str, Any] | None,
                        eval_every: int) -> dict[str, Any]:
    """Before resuming: the checkpoints are these cases', no hyperparameter given differs, and
    each run keeps its stop rule (``stop_rules``: the one given, checked against the runs';
    ``None``: the runs' own). Returns each case's stop rule."""
    check_resumed_checkpoints([(c, CaseDir.of(out, c).seed(s)) for c in loaded
                               for s in seed_list], config_overrides)
    folders = {case: [CaseDir.of(out, case).seed(s).path for s in seed_list] for case in loaded}
    if stop_rules is None:
        stop_rules = {case: resumed_stop_rule(dirs) for case, dirs in folders.items()}
        if any(stop_rules.values()) and eval_every <= 0:
            raise ValueError("the runs stop by a rule decided at their evaluations: resume them "
                             "with --set eval_every > 0")
    for case, dirs in folders.items():
        check_resumed_stop_rules(dirs, stop_rules[case])
    return stop_rules


def _stop_rules(loaded: dict[str, Case], kind: str | None, options: dict[str, Any] | None,
                eval_every: int, from_recipe: bool = False, eval_duration: float = 0.0) -> dict[str, Any]:
    """Each case's stop rule (``None``: off), checked before any work. The recipe's ``target``
    rule (not asked for by name) is off, with a warning, for a case that has no target return
    (a goto case, a crawl case without a yardstick): its seeds train their full steps."""
    rules = {}
    for name, case in loaded.items():
        if from_recipe and kind == "target" and not options and target_return(case) is None:
            why = ("no [yardstick] distance_10s" if case.task.kind == "crawl" else
                   "judged on its targets, not on one evaluation's return")
            warnings.warn(f"case {name!r} has no target return (task {case.task.kind!r}, {why}): "
                          "the recipe's target stop rule is off for it, "
                          "its seeds train their full steps (--stop-when plateau stops them at a "
                          "plateau)", SettingNotAppliedWarning, stacklevel=2)
            rules[name] = None
            continue
        rules[name] = case_stop_rule(case, kind, eval_every=eval_every, eval_duration=eval_duration,
                                     **(options or {}))
    return rules


def _named_by(case: Case) -> str:
    """Where ``case``'s name comes from, for a message: a shipped case, or a spec file's ``name``
    key or file name."""
    if case.name in case_names() and str(case.source) == f"{case.name}.toml":
        return f"the shipped case {case.name}"
    source = Path(str(case.source))
    if source.is_file() and source.stem != case.name:
        return f"{display_path(source)} (its `name = {case.name!r}`)"
    return display_path(source) if source.is_file() else str(case.source)


def load_cases(cases: Sequence[str | Path | Case]) -> dict[str, Case]:
    """The cases by name, every spec checked before any work (two different specs may not share
    a name)."""
    loaded: dict[str, Case] = {}
    for case in cases:
        c = load_case(case)
        refusal = warmup_refusal(c) or batched_refusal(c.robot_spec("training"), "msr train")
        if refusal:
            raise SpecError(refusal if refusal.startswith(str(c.source)) else f"{c.source}: {refusal}")
        if c.name in loaded and loaded[c.name].to_dict() == c.to_dict():
            warnings.warn(SettingNotAppliedWarning(f"--case: {c.name} is named twice ({_named_by(c)}): "
                                                   "it is trained once"), stacklevel=2)
        loaded.setdefault(c.name, c)
        if loaded[c.name].to_dict() != c.to_dict():
            raise ValueError(f"two different cases are named {c.name!r}: {_named_by(loaded[c.name])} and "
                             f"{_named_by(c)}; change one spec's top-level `name` (a spec without one is "
                             "named after its file)")
    if not loaded:
        raise ValueError("no case to train")
    return loaded


def case_defaults(loaded: dict[str, Case], steps: int | None, episode_duration: float | None,
                   recipe: str | None) -> tuple[int, float, str]:
    """``steps``, ``episode_duration`` (s) and ``recipe``, each the cases' own value when not
    given (they must then agree)."""
    for key, value in (("steps", steps), ("episode_duration", episode_duration), ("recipe", recipe)):
        defaults = {c.name: {"steps": c.training.steps, "episode_duration": c.task.episode_duration,
                             "recipe": c.training.recipe}[key] for c in loaded.values()}
        if value is None and len(set(defaults.values())) > 1:
            option = {"steps": "--steps", "episode_duration": "--episode-duration", "recipe": "--recipe"}[key]
            raise ValueError(f"the cases' specs give different {key} ({defaults}): give {option} (one "
                             "value for every case), or train the cases apart")
    if episode_duration is not None:
        for case in loaded.values():
            _check_episode_duration_for(case, episode_duration)
    first = next(iter(loaded.values()))
    recipe = first.training.recipe if recipe is None else recipe
    return (first.training.steps if steps is None else steps,
            first.task.episode_duration if episode_duration is None else episode_duration,
            recipe)


def _check_episode_duration_for(case: Case, duration: float) -> None:
    """An episode length given for a case (``--episode-duration``, s), judged as the spec's own
    ``episode_duration`` is (:func:`~elastica_magnetic_rl.cases.task_tables.episode_problem`: a
    catheter's tip speed, a goto or reach target faster than any gait or out of reach)."""
    from ..cases.task_tables import episode_problem

    problem = episode_problem(case, duration)
    if problem is None:
        return
    refuse, text = problem
    if refuse:
        raise ValueError(f"--episode-duration {text} (case {case.name!r})")
    warnings.warn(ImplausibleValueWarning(f"--episode-duration {text} (case {case.name!r})"), stacklevel=3)


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
    if steps > MAX_TRAIN_STEPS:
        raise ValueError(f"steps {steps} per seed is more than {MAX_TRAIN_STEPS:.0e}: months of training "
                         "(a run steps at some hundreds to thousands a second); a count written with extra "
                         "digits?")
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
                       physics: str, episode_duration: float, recipe: str, envs: int = 1,
                       before_making: Callable[[], None] | None = None) -> None:
    """Before any work: no run is overwritten; a resumed run exists, can continue and keeps its
    settings; ``before_making()`` (further checks, before a folder is made); every seed's folder
    can be written."""
    from elastica_magnetic.io import display_path, prepare_output_dir

    from ..runfiles.checkpoint import load_checkpoint, refuse_networks_only

    check_case_folders(out, loaded, seed_list)
    runs = [(case, s, CaseDir.of(out, case).seed(s)) for case in loaded for s in seed_list]
    if not resume:
        existing = [display_path(run.path) for _, _, run in runs if run.checkpoint.exists()]
        if existing:
            raise FileExistsError(f"runs already exist: {', '.join(existing)} (use --resume, another "
                                  "--out, or --seed-offset)")
    else:
        missing = [display_path(run.checkpoint) for _, _, run in runs if not run.checkpoint.exists()]
        writing = [f"{display_path(run.path)}: {hint}" for _, _, run in runs
                   if not run.checkpoint.exists() and (hint := being_written_hint(run.path))]
        if writing:
            raise FileNotFoundError(f"cannot resume: {'; '.join(writing)}")
        if missing:
            raise FileNotFoundError(f"cannot resume: no checkpoint {', '.join(missing)} (train those "
                                    "seeds without --resume, or choose --seeds/--seed-offset)")
        for case, seed, run in runs:  # a resumed run keeps its settings: checked before any work
            # a damaged log is named before any work; a row a kill cut short is repaired
            # (cut off) when the seed resumes, so it blocks no seed
            for log, numeric in ((run.episodes_csv, ("global_step", "return")),
                                 (run.evaluations_csv, ("global_step", "mean_return"))):
                if log.is_file():
                    read_log(log, numeric, whole_rows_only=True)
            saved = load_checkpoint(run.checkpoint, with_buffer=False)
            refuse_networks_only(saved, run.checkpoint)
            check_resume_settings(run.path, {
                "case": case, "case_spec": loaded[case].to_dict(), "physics": physics,
                "episode_duration_s": float(episode_duration), "recipe": recipe, "envs": envs,
                "seed": seed, **({"field_limit_T": loaded[case].field_limit}
                                 if loaded[case].field_actuated else {})}, saved.get("metadata"))
    if before_making is not None:
        before_making()
    for case_dir in {run.path.parent for _, _, run in runs}:  # locked for the summary, at the end
        check_lock_name(case_dir)
    for _, _, run in runs:  # every seed's folder can be written, before any work
        prepare_output_dir(run.path, "--out", given=out)
    check_unlocked(run.path for _, _, run in runs)  # no other process trains one of them now
