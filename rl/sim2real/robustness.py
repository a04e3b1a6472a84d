"""How far a waveform (and its policy) carries robots whose spec values differ from the nominal one
(what ``msr real robustness`` runs).

*Open loop*: the waveform as the coils play it (a field CSV, or a policy's generated
``fields.csv``) replayed on each varied robot. *Closed loop* (a policy only): the policy acting on
each varied robot from a zero field. Each run's distance is the middle's x displacement over
``duration`` s (``mid_x_m`` of ``trajectory.csv``), compared with the case's yardstick (the
authors' distance in 10 s).

Everything is checked before the first simulation: the source, the waveform's length, the
variations and every varied spec (through the normal spec parser, so an invalid variant gets its
named error). The runs go to worker processes (:func:`~elastica_magnetic_rl.sweep.backends.run_in_processes`),
one run per job.
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic.field_csv import limit_problem, read_field_csv, write_field_csv
from elastica_magnetic.io import atomic_write_json
from elastica_magnetic.openloop import check_duration
from elastica_magnetic.robot_spec import ACTION_PERIOD

from ..cases.case import Case, case_from_dict, load_case
from ..cases.variations import (
    Variant,
    Variation,
    apply_variant,
    default_variations,
    design,
    resolve_variations,
    variant_values,
)
from ..shipping.policy_files import LoadedPolicy, resolve_policy
from .output import write_folder_whole
from .tip_robustness import TipRobustnessPlan, plan_tip_robustness, run_tip_robustness

__all__ = ["MODES", "REPORT_FORMAT", "RobustnessPlan", "plan_robustness", "run_robustness",
           "run_variant", "summarize", "write_robustness"]

REPORT_FORMAT = "msr-robustness-v1"
#: The two ways a variant is run.
MODES = ("open_loop", "closed_loop")
#: Percentile reported besides the worst case.
PERCENTILE = 10.0
#: m: a nominal robot moving less than this (the table's 0.1 mm resolution) does not move: no
#: variant is given as a fraction of it.
STILL_M = 5e-5
#: s: how long a field study's runs last by default (the yardstick's 10 s).
FIELD_STUDY_DURATION = 10.0


@dataclass
class RobustnessPlan:
    """Everything a robustness study needs, checked: the case, the waveform (``(n, 3)`` T, row
    ``i`` held on ``[i/100, (i+1)/100)`` s), the policy (``None`` for a field CSV), the variations
    and the variants with their checked specs."""

    source: str
    case: Case
    fields: NDArray[np.float64]
    waveform: str
    policy: LoadedPolicy | None
    variations: list[Variation]
    variants: list[Variant]
    specs: list[dict[str, Any]]
    physics: str
    duration: float
    design: dict[str, Any]


def _is_field_csv(source: str | Path) -> bool:
    return Path(source).suffix.lower() == ".csv"


@dataclasses.dataclass(frozen=True)
class StudySettings:
    """What a robustness study plays and on which robots: ``case`` (a shipped name, a spec file
    or a :class:`Case`: the robot of a field CSV source), ``fields_csv`` (a policy's waveform),
    ``variations`` (default: :func:`default_variations`), the design (``one_at_a_time``,
    ``corners``, ``samples`` drawn with ``seed``: :func:`design`), the ``physics`` and
    ``duration`` (s) of each run (default :data:`FIELD_STUDY_DURATION`; a tip-reach policy's: its
    task's episode), ``progress`` bars, and for a run, which actor (``checkpoint``: ``"auto"``, the
    farther of its final and best actors as ``msr policy generate`` chooses, ``"final"``, ``"best"``
    or a checkpoint file: :func:`~elastica_magnetic_rl.shipping.policy_runs.choose_actor`)."""

    case: str | Path | Case | None = None
    fields_csv: str | Path | None = None
    variations: Sequence[Variation] | None = None
    one_at_a_time: bool = True
    corners: bool = True
    samples: int = 0
    seed: int = 0
    physics: str = "training"
    duration: float | None = None
    progress: bool = True
    checkpoint: str = "auto"


def plan_robustness(source: str | Path, settings: StudySettings | None = None, /,
                    **changes: Any) -> RobustnessPlan | TipRobustnessPlan:
    """Check a robustness study and load what it needs (nothing is simulated, except a policy's
    waveform when it has none: see below).

    ``source`` is a field CSV (mT, 100 Hz; then ``case``, a shipped name or a spec file, gives the
    robot and the yardstick) or a policy (a shipped name, a run folder, a checkpoint). A policy's
    waveform is ``fields_csv`` when given, else the ``fields.csv`` of a shipped policy, else it is
    generated as ``msr policy generate`` does (the policy on the nominal robot, accurate physics, field
    from zero, ``duration`` s). ``variations`` default to :func:`default_variations`.

    Raises ValueError (SpecError, FieldCSVError, VariationError, PolicyFileError) or
    FileNotFoundError naming the problem. ``settings`` (:class:`StudySettings`) with ``changes``
    (its fields by name) say the rest.
    """
    o = dataclasses.replace(settings or StudySettings(), **changes)
    if o.physics not in ("training", "accurate"):
        raise ValueError(f"--physics must be 'training' or 'accurate', got {o.physics!r}")
    steered = _tip_reach_policy(source, o)
    if steered is not None:
        return _plan_tip(source, steered, o)
    duration = check_duration(FIELD_STUDY_DURATION if o.duration is None else o.duration)
    the_case, policy, fields, waveform = _study_source(source, o.case, o.fields_csv)
    actor = None
    if policy is not None and policy.kind == "checkpoint":  # a run: the actor generate would play
        from ..shipping.policy_runs import choose_actor

        choice = choose_actor(source, o.checkpoint, duration, o.progress)
        if choice is not None:
            policy, actor = _resolved(choice.path), choice
    elif o.checkpoint != "auto":
        raise ValueError(f"--checkpoint {o.checkpoint}: {source} is not a training run (a shipped policy "
                         "or a field CSV has one waveform): leave --checkpoint out")
    if fields is not None:  # a waveform the case's coils cannot play is no study of that robot
        actuation = the_case.actuation
        over = limit_problem(fields, dict(zip(actuation.axes, actuation.limits, strict=False)),
                             waveform)
        if over is not None:
            raise ValueError(over)
    if the_case.task.kind == "goto":  # the study's distances are distances ahead
        raise ValueError(f"case {the_case.name!r} has the goto task: a robustness study measures "
                         "how far ahead a waveform carries varied robots, not whether they reach a "
                         "target; not available for goto cases yet (the closed loop with a tracker, "
                         "run_closed_loop, corrects what an open-loop waveform cannot)")
    spec = the_case.to_dict()
    chosen = resolve_variations(list(o.variations) if o.variations else default_variations(spec),
                                spec)
    variants = design(chosen, spec, one_at_a_time=o.one_at_a_time, corners=o.corners,
                      samples=o.samples, seed=o.seed)
    specs = []
    for variant in variants:
        varied = apply_variant(spec, chosen, variant)
        checked = case_from_dict(varied, f"variant {variant.label!r}", default_name=the_case.name)
        checked.robot_spec(o.physics)  # builds the robot: its own checks
        specs.append(varied)
    if fields is None:  # a run or checkpoint without a waveform: generate it, as msr policy generate
        from ..shipping.policy_runs import run_policy

        rollout = run_policy(policy, duration, "accurate", "zero", o.progress)
        if rollout.meta["diverged"]:
            raise ValueError(f"{source}: generating the waveform diverged ({rollout.meta['diverged']})")
        fields = rollout.fields
        played = f"{source}" if actor is None else f"{source}, {actor.describe()},"
        waveform = f"generated: {played} on the nominal robot, accurate physics, field from zero"
    rows = int(round(duration / ACTION_PERIOD))
    if rows > fields.shape[0]:
        length = fields.shape[0] * ACTION_PERIOD
        asked = f"--duration {duration:g} s" if o.duration is not None else f"the default {duration:g} s"
        raise ValueError(f"{asked} is past the end of the waveform {waveform} ({length:g} s: "
                         f"{fields.shape[0]} rows at 100 Hz): give --duration {length:g} or less, or "
                         "a longer waveform with --fields")
    info = {"one_at_a_time": o.one_at_a_time, "corners": o.corners, "samples": o.samples,
            "seed": o.seed,
            **({} if actor is None else {"actor": {**actor.to_dict(), "summary": actor.describe()}})}
    return RobustnessPlan(str(source), the_case, fields, waveform, policy, chosen, variants, specs,
                          o.physics, duration, info)


def _plan_tip(source: str | Path, steered: LoadedPolicy, o: StudySettings) -> TipRobustnessPlan:
    """:func:`plan_robustness` of a tip-reach policy: of a run, the actor ``msr policy generate``
    plays for it (``o.checkpoint``), named in the plan."""
    actor = None
    if steered.kind == "checkpoint":
        from ..shipping.policy_runs import choose_tip_reach_actor

        choice = choose_tip_reach_actor(source, o.checkpoint)
        if choice is not None:
            steered = _resolved(choice.path)
            actor = {**choice.to_dict(), "summary": choice.describe()}
    elif o.checkpoint != "auto":
        raise ValueError(f"--checkpoint {o.checkpoint}: {source} is not a training run (a shipped "
                         "policy has one actor): leave --checkpoint out")
    return plan_tip_robustness(str(source), steered, o.variations, actor=actor,
                               one_at_a_time=o.one_at_a_time, corners=o.corners, samples=o.samples,
                               seed=o.seed, physics=o.physics,
                               duration=None if o.duration is None else check_duration(o.duration))


def _resolved(source: str | Path) -> LoadedPolicy:
    """The policy of ``source``; a run another live process still trains refused, naming it (its
    checkpoints are a step of the training)."""
    from ..shipping.policy_runs import check_not_training

    policy = resolve_policy(source)
    if policy.kind == "checkpoint":
        path = Path(policy.source)
        check_not_training(path if path.is_dir() else path.parent)
    return policy


def _tip_reach_policy(source: str | Path, o: StudySettings) -> LoadedPolicy | None:
    """The policy of ``source`` when it steers a catheter (a tip-reach case, studied by
    :mod:`~elastica_magnetic_rl.sim2real.tip_robustness`), else ``None``; ``--fields``, which such a
    study cannot use, refused by name."""
    if _is_field_csv(source) or o.case is not None:  # a field CSV; or a policy with --case: refused later
        return None
    policy = _resolved(source)
    if policy.case.field_actuated:
        return None
    if o.fields_csv is not None:
        raise ValueError(f"--fields: {source} is a policy of the tip-reach case {policy.case.name!r}: it "
                         "plays no waveform (it steers the source from the tip it sees); leave --fields out")
    return policy


def _study_source(source: str | Path, case: str | Path | Case | None,
                  fields_csv: str | Path | None) -> tuple[Case, Any, Any, str]:
    """The case, the policy (``None`` for a field CSV), the waveform (``None``: to generate) and
    its description, of a study's ``source``."""
    policy = None
    if _is_field_csv(source):
        if case is None:
            raise ValueError(f"{source}: a field CSV needs --case (the robot it is played on: a "
                             "shipped case or a spec file)")
        if fields_csv is not None:
            raise ValueError("--fields is for a policy's waveform; the source is already a field CSV")
        the_case = load_case(case)
        fields, waveform = read_field_csv(source, plausible=True), str(source)  # as msr field replay
    else:
        if case is not None:
            raise ValueError(f"{source}: a policy carries its case; --case is for a field CSV")
        policy = _resolved(source)
        the_case = policy.case
        shipped_csv = Path(policy.source) / "fields.csv" if policy.kind == "shipped" else None
        if fields_csv is not None:
            fields, waveform = read_field_csv(fields_csv, plausible=True), str(fields_csv)
        elif shipped_csv is not None and shipped_csv.is_file():
            fields = read_field_csv(shipped_csv)
            waveform = f"fields.csv of the shipped-format policy {Path(policy.source).name}"
        else:
            fields, waveform = None, "generated"
    return the_case, policy, fields, waveform


# -- running --------------------------------------------------------------------------------------


def run_variant(job: dict[str, Any]) -> dict[str, Any]:
    """One run of one variant (module level: it runs in worker processes). ``job``: ``mode``
    (:data:`MODES`), ``spec`` (the varied spec, plain data), ``physics``, ``duration`` (s), and
    ``fields`` (``(n, 3)`` T, open loop) or ``policy`` (its path, closed loop). Returns
    ``distance_m`` (m, ``None`` when the run diverged), ``diverged`` (the reason or ``None``) and
    ``wall_s``."""
    from elastica_magnetic.simulation import SimulationDivergedError

    start = time.perf_counter()
    case = case_from_dict(job["spec"], "variant", default_name=job.get("case_name"))
    distance, diverged = None, None
    if job["mode"] == "open_loop":
        from elastica_magnetic.fields import TabulatedField
        from elastica_magnetic.openloop import run_open_loop

        try:
            result = run_open_loop(case.robot_spec(job["physics"]), TabulatedField(job["fields"]),
                                   job["duration"])
            distance = result.mid_dx
        except SimulationDivergedError as exc:
            diverged = str(exc)
    else:
        from ..shipping.policy_runs import run_policy
        from ..td3.devices import torch_threads

        policy = dataclasses.replace(resolve_policy(job["policy"]), case=case)
        with torch_threads(1):
            rollout = run_policy(policy, job["duration"], job["physics"], "zero", progress=False)
        diverged = rollout.meta["diverged"]
        distance = None if diverged else rollout.mid_dx
    return {"distance_m": distance, "diverged": diverged, "wall_s": time.perf_counter() - start}


def _jobs(plan: RobustnessPlan, closed_loop: bool) -> list[dict[str, Any]]:
    modes = [m for m in MODES if m == "open_loop" or (closed_loop and plan.policy is not None)]
    jobs = []
    for k, spec in enumerate(plan.specs):
        for mode in modes:
            job = {"variant": k, "mode": mode, "spec": spec, "case_name": plan.case.name,
                   "physics": plan.physics, "duration": plan.duration}
            if mode == "open_loop":
                job["fields"] = plan.fields
            else:
                job["policy"] = str(plan.policy.source)
            jobs.append(job)
    return jobs


def run_robustness(
    plan: RobustnessPlan | TipRobustnessPlan,
    *,
    closed_loop: bool = True,
    workers: int | None = None,
    progress: bool = True,
) -> dict[str, Any]:
    """Run every variant of ``plan`` open loop and (a policy, ``closed_loop``) closed loop, in
    ``workers`` processes (default: every core; 1: in this process). Returns the report written
    to ``robustness.json`` (see :func:`summarize`). A tip-reach study (:class:`TipRobustnessPlan`)
    is the closed loop of the policy and of the yardstick on every variant
    (:func:`~elastica_magnetic_rl.sim2real.tip_robustness.run_tip_robustness`)."""
    if isinstance(plan, TipRobustnessPlan):
        return run_tip_robustness(plan, workers=workers, progress=progress)
    from ..sweep.backends import run_each

    jobs = _jobs(plan, closed_loop)
    workers = max(1, min(int(workers or os.cpu_count() or 1), len(jobs)))
    start = time.perf_counter()
    results = run_each(run_variant, jobs, workers, progress=progress, label="robustness",
                       on_error=lambda k, exc: {"distance_m": None, "wall_s": None,
                                                "diverged": f"{type(exc).__name__}: {exc}"})
    wall = time.perf_counter() - start
    return summarize(plan, jobs, results, wall, workers)


def _fraction(distance: float | None, yardstick: float) -> float | None:
    return None if distance is None or yardstick <= 0.0 else distance / yardstick


def yardstick_comparable(physics: str, duration: float) -> bool:
    """Whether a distance is comparable with the yardstick: the yardstick is a 10 s distance in
    the accurate physics (the training physics moves the robot otherwise: its heavier, slower
    robot and larger time step)."""
    return physics == "accurate" and abs(duration - 10.0) < 1e-9


def _reach_summary(case: Any, nominal: float | None, done: list[tuple[str, float]]) -> dict[str, Any] | None:
    """For a reach case (go ``target`` m ahead and stop there), each robot judged by how far it ends
    from the target: the target, the nominal robot's error and the largest error with its
    variant, m (``None`` for any other task: there the shortest distance is the worst)."""
    if case.task.kind != "reach" or not done:
        return None
    target = float(case.task.target)
    label, error = max(((label, abs(d - target)) for label, d in done), key=lambda item: item[1])
    return {"target_m": target, "nominal_error_m": None if nominal is None else abs(nominal - target),
            "worst_error_m": error, "worst_error_variant": label}


def summarize(plan: RobustnessPlan, jobs: list[dict[str, Any]], results: list[dict[str, Any]],
              wall_s: float, workers: int) -> dict[str, Any]:
    """The report: each variant's settings, spec values and per-mode result (distance in m, its
    fraction of the yardstick, divergence), and per mode the nominal, worst and 10th-percentile
    distance (over the variants that did not diverge) with their fractions: of the yardstick
    (``*_fraction``) only where the run is comparable with it (:func:`yardstick_comparable`: 10 s
    of the accurate physics; ``None`` otherwise), and of the nominal robot in the same physics
    (``*_of_nominal``) always. For a reach case the worst robot is the one that ends farthest from
    the target, over or short (``worst_error_m``, ``target_m``; no fraction of the nominal)."""
    spec = plan.case.to_dict()
    comparable = yardstick_comparable(plan.physics, plan.duration)
    yardstick = float(plan.case.yardstick.distance_10s) if comparable else 0.0
    variants = [{"label": v.label, "kind": v.kind, "settings": dict(v.settings),
                 "values": variant_values(plan.variations, v, spec)} for v in plan.variants]
    for job, result in zip(jobs, results, strict=True):
        entry = dict(result)
        entry["fraction_of_yardstick"] = _fraction(result["distance_m"], yardstick)
        variants[job["variant"]][job["mode"]] = entry
    summary = {}
    for mode in MODES:
        runs = [(v["label"], v[mode]) for v in variants if mode in v]
        if not runs:
            continue
        done = [(label, r["distance_m"]) for label, r in runs if r["distance_m"] is not None]
        distances = np.array([d for _, d in done])
        worst = min(done, key=lambda item: item[1]) if done else (None, None)
        p10 = float(np.percentile(distances, PERCENTILE)) if done else None
        nominal = runs[0][1]["distance_m"]
        # a nominal robot that does not move is no reference: ratios of round-off are no percentages
        still = nominal is not None and abs(nominal) < STILL_M
        reference = nominal if nominal is not None and nominal > 0.0 and not still else 0.0
        reach = _reach_summary(plan.case, runs[0][1]["distance_m"], done)
        if reach is not None:  # the worst robot misses its target most, over or short
            worst = (reach["worst_error_variant"], dict(done)[reach["worst_error_variant"]])
            reference = 0.0  # a fraction of the nominal distance means nothing here
        summary[mode] = {
            "nominal_m": nominal, "worst_m": worst[1], "worst_variant": worst[0],
            "p10_m": p10, "best_m": float(distances.max()) if done else None,
            "nominal_fraction": _fraction(nominal, yardstick),
            "worst_fraction": _fraction(worst[1], yardstick),
            "p10_fraction": _fraction(p10, yardstick),
            "worst_of_nominal": _fraction(worst[1], reference),
            "p10_of_nominal": _fraction(p10, reference),
            "runs": len(runs), "diverged": [label for label, r in runs if r["distance_m"] is None],
            "nominal_still": still,
            **(reach or {}),
        }
    return {
        "format": REPORT_FORMAT,
        "source": plan.source,
        "kind": "field_csv" if plan.policy is None else "policy",
        "case": plan.case.name,
        "waveform": plan.waveform,
        "physics": plan.physics,
        "duration_s": plan.duration,
        "yardstick_m": float(plan.case.yardstick.distance_10s) or None,
        "yardstick_comparable": comparable,
        "yardstick_note": plan.case.yardstick.source or None,
        "variations": [v.to_dict() for v in plan.variations],
        "design": plan.design,
        "summary": summary,
        "variants": variants,
        "workers": workers,
        "wall_s": wall_s,
    }


# -- output ---------------------------------------------------------------------------------------


def write_robustness(report: dict[str, Any], plan: RobustnessPlan | TipRobustnessPlan, out: str | Path,
                     force: bool = False, figure: bool = True) -> Path:
    """Write ``out/robustness.json``, ``out/robustness.png`` (see
    :func:`~elastica_magnetic_rl.sim2real.report.plot_robustness`) and ``out/fields.csv`` (the
    waveform played, mT) as one folder (see :func:`write_folder_whole`); for a tip-reach study
    ``out/targets.csv`` (the held-out targets, m) in place of the waveform and
    :func:`~elastica_magnetic_rl.sim2real.report.plot_tip_robustness`'s figure. Returns ``out``."""
    tip = isinstance(plan, TipRobustnessPlan)

    def fill(folder: Path) -> None:
        if tip:
            np.savetxt(folder / "targets.csv", plan.targets, delimiter=",", header="x_m,y_m,z_m",
                       comments="", fmt="%.9g")
        else:
            write_field_csv(folder / "fields.csv", plan.fields[: int(round(plan.duration / ACTION_PERIOD))])
        if figure:
            from .report import plot_robustness, plot_tip_robustness

            (plot_tip_robustness if tip else plot_robustness)(report, folder / "robustness.png")
        atomic_write_json(folder / "robustness.json", report)

    write_folder_whole(out, fill, force, kind="robustness")
    return Path(out)

