"""How a tip-reach policy (a catheter steered by a magnet on an arm or by coils) holds up on catheters
whose spec values differ from the nominal one: what ``msr real robustness`` runs for such a policy.

Each variant is steered twice to the same targets, the case's held-out ones
(:func:`~elastica_magnetic_rl.shipping.tip_reach.held_out_targets`, drawn with a seed no training
uses): by the *policy* (its actor, deterministic) and by the case's *yardstick* (the steering law
of :func:`~elastica_magnetic_rl.shipping.tip_reach.steering_controller`), each target for the task's
episode (or ``duration`` s), all targets of a run in one batched environment. A target is reached
when the tip ends within the task's tolerance (as ``msr policy generate`` judges it). There is no
open loop here: a catheter's policy answers the tip it sees, so the study is of the closed loop, and
the yardstick beside it says whether a varied catheter is harder for the policy or for any steering.

Everything is checked before the first simulation: the policy, the variations and every varied spec
(through the spec parser, so an invalid variant gets its named error). Lengths in m, times in s.
"""

from __future__ import annotations

import os
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic.batch import BATCHED_UNMODELLED_KEYS

from ..cases.case import Case, case_from_dict
from ..cases.variations import (
    Variant,
    Variation,
    apply_variant,
    default_variations,
    design,
    resolve_variations,
    variant_values,
)
from ..shipping.policy_files import LoadedPolicy

__all__ = ["TIP_MODES", "TIP_REPORT_FORMAT", "TIP_REPORT_KIND", "TipRobustnessPlan", "plan_tip_robustness",
           "run_tip_robustness", "run_tip_variant", "summarize_tip"]

#: The two controllers each variant is steered by.
TIP_MODES = ("policy", "yardstick")
#: ``format`` and ``kind`` of a tip-reach study's report (a field study's kind is ``"policy"`` or
#: ``"field_csv"``, its format ``msr-robustness-v1``).
TIP_REPORT_FORMAT, TIP_REPORT_KIND = "msr-tip-robustness-v1", "tip_reach_policy"


@dataclass
class TipRobustnessPlan:
    """A tip-reach study, checked: the policy and its case, the held-out ``targets`` (``(n, 3)``
    m), the variations and the variants with their checked specs, the ``physics`` and ``duration``
    (s) of each run."""

    source: str
    case: Case
    policy: LoadedPolicy
    targets: NDArray[np.float64]
    variations: list[Variation]
    variants: list[Variant]
    specs: list[dict[str, Any]]
    physics: str
    duration: float
    design: dict[str, Any]


def plan_tip_robustness(source: str, policy: LoadedPolicy, variations: Sequence[Variation] | None, *,
                        one_at_a_time: bool = True, corners: bool = True, samples: int = 0, seed: int = 0,
                        physics: str = "training", duration: float | None = None,
                        actor: dict[str, Any] | None = None) -> TipRobustnessPlan:
    """Check a study of ``policy`` (a tip-reach case's) on varied catheters. ``variations``:
    default :func:`~elastica_magnetic_rl.cases.variations.default_variations` of its spec (the
    magnet's moment among them for a magnet on an arm); ``duration``: s, default the task's
    episode; ``actor``: for a run, which of its actors is studied (``ActorChoice.to_dict()`` with
    its ``summary``), recorded in the report. Raises ValueError (VariationError, SpecError) naming
    the problem."""
    from ..shipping.tip_reach import held_out_targets

    the_case = policy.case
    episode = float(the_case.task.episode_duration)
    duration = episode if duration is None else float(duration)
    if duration > episode + 1e-9:
        raise ValueError(f"--duration {duration:g} s: longer than case {the_case.name!r}'s episode "
                         f"({episode:g} s), which ends every run; give at most {episode:g} s, or leave "
                         "--duration out (the episode)")
    spec = the_case.to_dict()
    # every target's catheter in one batched simulator: what it leaves out cannot be studied
    unmodelled = {key: f"a catheter's study steers every target in one batched simulator, which does "
                       f"not model it ({what})" for key, what in BATCHED_UNMODELLED_KEYS.items()}
    chosen = resolve_variations(list(variations) if variations else default_variations(spec), spec,
                                unmodelled=unmodelled)
    variants = design(chosen, spec, one_at_a_time=one_at_a_time, corners=corners, samples=samples,
                      seed=seed)
    specs = []
    for variant in variants:
        varied = apply_variant(spec, chosen, variant)
        checked = case_from_dict(varied, f"variant {variant.label!r}", default_name=the_case.name)
        checked.robot_spec(physics)  # builds the robot: its own checks
        specs.append(varied)
    info = {"one_at_a_time": one_at_a_time, "corners": corners, "samples": samples, "seed": seed,
            **({} if actor is None else {"actor": actor})}
    return TipRobustnessPlan(str(source), the_case, policy, held_out_targets(the_case), chosen, variants,
                             specs, physics, duration, info)


def run_tip_variant(job: dict[str, Any]) -> dict[str, Any]:
    """One run (module level: it runs in worker processes): the varied catheter (``spec``) steered by
    ``mode`` (:data:`TIP_MODES`; the policy at ``policy``, its path) to ``targets`` (m) in ``physics``
    for ``duration`` s. Returns ``successes``, ``final_distance_m`` per target, their ``median_m`` and
    ``largest_m``, ``ended_early`` (how many targets' runs ended by divergence or collision) and
    ``wall_s``."""
    from ..shipping.policy_files import resolve_policy
    from ..shipping.tip_reach import actor_controller, run_targets, steering_controller
    from ..td3.devices import torch_threads

    start = time.perf_counter()
    case = case_from_dict(job["spec"], "variant", default_name=job.get("case_name"))
    if job["mode"] == "policy":
        controller = actor_controller(resolve_policy(job["policy"]))
    else:
        controller = steering_controller
    with torch_threads(1):
        result = run_targets(case, job["targets"], controller, job["physics"], job["duration"])
    final = np.asarray(result["final_distance_m"], dtype=np.float64)
    return {"successes": result["successes"], "final_distance_m": final.tolist(),
            "median_m": float(np.median(final)), "largest_m": float(final.max()),
            "ended_early": sum(1 for e in result["ended_by"] if e != "time"),
            "wall_s": time.perf_counter() - start}


def _jobs(plan: TipRobustnessPlan) -> list[dict[str, Any]]:
    return [{"variant": k, "mode": mode, "spec": spec, "case_name": plan.case.name, "physics": plan.physics,
             "duration": plan.duration, "targets": plan.targets, "policy": str(plan.policy.source)}
            for k, spec in enumerate(plan.specs) for mode in TIP_MODES]


def run_tip_robustness(plan: TipRobustnessPlan, *, workers: int | None = None,
                       progress: bool = True) -> dict[str, Any]:
    """Run every variant of ``plan`` by the policy and by the yardstick, in ``workers`` processes
    (default: every core; 1: in this process). Returns the report (:func:`summarize_tip`)."""
    from ..sweep.backends import run_each

    jobs = _jobs(plan)
    workers = max(1, min(int(workers or os.cpu_count() or 1), len(jobs)))
    start = time.perf_counter()
    results = run_each(run_tip_variant, jobs, workers, progress=progress, label="robustness",
                       on_error=lambda k, exc: {"successes": None, "wall_s": None,
                                                "error": f"{type(exc).__name__}: {exc}"})
    return summarize_tip(plan, jobs, results, time.perf_counter() - start, workers)


def _at_least(policy: dict[str, Any], yardstick: dict[str, Any]) -> bool:
    """The policy did at least as well as the yardstick on a variant: more targets reached, or as
    many and a median final distance no larger (a tie at no target reached is judged by the
    distances, not called a draw)."""
    if policy["successes"] != yardstick["successes"]:
        return policy["successes"] > yardstick["successes"]
    return policy["median_m"] <= yardstick["median_m"]


def summarize_tip(plan: TipRobustnessPlan, jobs: list[dict[str, Any]], results: list[dict[str, Any]],
                  wall_s: float, workers: int) -> dict[str, Any]:
    """The report: each variant's settings, spec values and, per mode, its successes of the
    targets and final distances (m); per mode the nominal, worst (fewest successes; ties: the larger
    median distance) and mean successes; and on how many variants the policy reached at least as many
    targets as the yardstick."""
    spec = plan.case.to_dict()
    variants = [{"label": v.label, "kind": v.kind, "settings": dict(v.settings),
                 "values": variant_values(plan.variations, v, spec)} for v in plan.variants]
    for job, result in zip(jobs, results, strict=True):
        variants[job["variant"]][job["mode"]] = dict(result)
    summary = {}
    for mode in TIP_MODES:
        runs = [(v["label"], v[mode]) for v in variants]
        done = [(label, r) for label, r in runs if r.get("successes") is not None]
        worst = min(done, key=lambda item: (item[1]["successes"], -item[1]["median_m"])) if done else None
        summary[mode] = {
            "nominal_successes": runs[0][1].get("successes"),
            "nominal_median_m": runs[0][1].get("median_m"),
            "worst_successes": None if worst is None else worst[1]["successes"],
            "worst_variant": None if worst is None else worst[0],
            "worst_median_m": None if worst is None else worst[1]["median_m"],
            "mean_successes": float(np.mean([r["successes"] for _, r in done])) if done else None,
            "runs": len(runs), "failed": [label for label, r in runs if r.get("successes") is None],
        }
    both = [v for v in variants if all(v[m].get("successes") is not None for m in TIP_MODES)]
    return {
        "format": TIP_REPORT_FORMAT,
        "source": plan.source,
        "kind": TIP_REPORT_KIND,
        "case": plan.case.name,
        "physics": plan.physics,
        "duration_s": plan.duration,
        "targets_m": plan.targets.tolist(),
        "tolerance_m": float(plan.case.task.tolerance),
        "variations": [v.to_dict() for v in plan.variations],
        "design": plan.design,
        "summary": summary,
        "policy_at_least_yardstick": sum(1 for v in both if _at_least(v["policy"], v["yardstick"])),
        "variants_compared": len(both),
        "any_reached": any(v[m]["successes"] for v in both for m in TIP_MODES),
        "variants": variants,
        "workers": workers,
        "wall_s": wall_s,
    }
