"""``msr train --stop-when``: a case's stop rule, its checks before any work, and what a sweep
reports of it (each seed's state: stopped, learned, still improving).

The rules themselves are :mod:`elastica_magnetic_rl.runner.stopping`'s. The ``target`` threshold
of a crawling case is its yardstick as an evaluation return: the periodic evaluation is a 10 s
episode from a zero field in the run's physics, whose return is ``reward_scale`` (1/m) times the
middle node's distance (m), so the threshold is ``reward_scale * [yardstick] distance_10s``. A
case without a yardstick distance, and the reach task (its evaluation return is not a distance),
refuse ``target``.
"""

from __future__ import annotations

import csv
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from ..cases.case import EVAL_DURATION, Case
from ..cases.recipes import RECIPE_RUN_SETTINGS
from ..runfiles.rundir import RunDir
from ..runner.stopping import STOP_KINDS, StopRule

__all__ = ["DEFAULT_CONFIRM", "STOP_CHOICES", "case_stop_rule", "check_resumed_stop_rules",
           "recipe_stop_when", "resumed_stop_rule", "seed_state", "stop_record", "stop_summary",
           "target_return"]

#: What ``--stop-when`` accepts: a rule, or ``none`` (off, also for a recipe that has one).
STOP_CHOICES = (*STOP_KINDS, "none")

#: Where a fired ``target`` rule is confirmed by default (``--stop-confirm``): the training
#: physics' evaluations can reach a yardstick that the actor misses in the accurate physics the
#: yardstick was measured in (seen: 170 mm in training, 69.7 mm accurate).
DEFAULT_CONFIRM = "accurate"


def recipe_stop_when(stop_when: str | None, recipe: str) -> str | None:
    """The stop rule's kind: the one given (``"none"``: off), else the recipe's
    (:data:`~elastica_magnetic_rl.cases.recipes.RECIPE_RUN_SETTINGS`), else off (``None``)."""
    if stop_when is None:
        stop_when = RECIPE_RUN_SETTINGS.get(recipe, {}).get("stop_when")
    if stop_when is not None and stop_when not in STOP_CHOICES:
        raise ValueError(f"--stop-when must be one of {', '.join(STOP_CHOICES)}, got {stop_when!r}")
    return None if stop_when in (None, "none") else stop_when


def target_return(case: Case) -> float | None:
    """The evaluation return at the case's yardstick (``reward_scale * distance_10s``), or
    ``None`` when the case has none (no yardstick distance, or not a crawling task)."""
    if case.task.kind != "crawl" or not case.yardstick.distance_10s > 0.0:
        return None
    return float(case.task.reward_scale * case.yardstick.distance_10s)


def case_stop_rule(case: Case, kind: str | None, *, consecutive: int | None = None,
                   patience: int | None = None, tolerance: float | None = None,
                   confirm: str | None = None, eval_every: int | None = None,
                   eval_duration: float = 0.0) -> StopRule | None:
    """The stop rule ``kind`` (``None``: no rule) for ``case``, checked before any work: ``target``
    needs the case's yardstick (:func:`target_return`), every rule needs evaluations
    (``eval_every > 0``); ``target`` compares evaluations of the case's length (``eval_duration``
    0 or that length, s) with the yardstick's return. Unset options keep :class:`StopRule`'s
    defaults; ``target`` is confirmed in the accurate physics unless ``confirm`` is ``"none"``
    (:data:`DEFAULT_CONFIRM`)."""
    if kind is None:
        for name, value, rule in (("--stop-consecutive", consecutive, "target"),
                                  ("--stop-patience", patience, "plateau"),
                                  ("--stop-tolerance", tolerance, "plateau"),
                                  ("--stop-confirm", confirm, "target")):
            if value is not None:  # each option belongs to one rule
                raise ValueError(f"{name} needs --stop-when {rule}")
        return None
    if eval_every is not None and eval_every <= 0:
        raise ValueError(f"--stop-when {kind} decides at the periodic evaluations: it needs "
                         "--set eval_every > 0 (got 0)")
    options: dict[str, Any] = {}
    if kind == "target":
        threshold = target_return(case)
        if threshold is None:
            raise ValueError(f"--stop-when target: case {case.name!r} has no target return (its "
                             f"task is {case.task.kind!r}, [yardstick] distance_10s = "
                             f"{case.yardstick.distance_10s:g} m; target needs a crawling task with "
                             "a yardstick distance > 0); use --stop-when plateau")
        if eval_duration and abs(eval_duration - case.evaluation_duration) > 1e-9:
            raise ValueError(f"--stop-when target compares each evaluation's return with the yardstick's "
                             f"over {case.evaluation_duration:g} s; eval_duration {eval_duration:g} s "
                             "evaluates another length: leave eval_duration 0 (the case's), or give "
                             "--stop-when plateau or none")
        options["threshold"] = threshold
        if patience is not None or tolerance is not None:
            raise ValueError("--stop-patience and --stop-tolerance are for --stop-when plateau")
        if consecutive is not None:
            options["consecutive"] = int(consecutive)
        confirm = DEFAULT_CONFIRM if confirm is None else confirm
        options["confirm"] = None if confirm == "none" else confirm
    else:
        if consecutive is not None:
            raise ValueError("--stop-consecutive is for --stop-when target")
        if confirm is not None:
            raise ValueError("--stop-confirm is for --stop-when target")
        if patience is not None:
            options["patience"] = int(patience)
        if tolerance is not None:
            options["tolerance"] = float(tolerance)
    return StopRule(kind, **options)


def check_resumed_stop_rules(run_dirs: Iterable[Path], rule: StopRule | None) -> None:
    """Before a resume: every run keeps its stop rule; a different one is refused, naming both
    (a run from before stop rules had none)."""
    from ..runfiles.checkpoint import load_checkpoint

    def name(r: Mapping[str, Any] | None) -> str:
        if r is None:
            return "none"
        settings = ", ".join(f"{k} {v:g}" if isinstance(v, float) else f"{k} {v}"
                             for k, v in r.items() if k != "kind")
        return f"{r['kind']} ({settings})" if settings else str(r["kind"])

    wanted = None if rule is None else rule.to_dict()
    for run_dir in run_dirs:
        saved = load_checkpoint(run_dir, with_buffer=False).get("stop_rule")
        if saved != wanted:
            raise ValueError(f"{RunDir(run_dir).checkpoint}: the run's stop rule is {name(saved)}, "
                             f"not {name(wanted)} (--stop-when): a resumed run keeps its stop rule")


def resumed_stop_rule(run_dirs: Iterable[Path]) -> StopRule | None:
    """The stop rule the runs being resumed share (what ``--resume`` without ``--stop-when``
    keeps); runs of one case with different rules are refused, naming two of them."""
    from ..runfiles.checkpoint import load_checkpoint

    first: tuple[Path, Any] | None = None
    for run_dir in run_dirs:
        saved = load_checkpoint(run_dir, with_buffer=False).get("stop_rule")
        if first is None:
            first = (run_dir, saved)
        elif saved != first[1]:
            raise ValueError(f"the runs to resume have different stop rules ({first[0]}: {first[1]}; "
                             f"{run_dir}: {saved}): resume them apart, or give --stop-when")
    saved = None if first is None else first[1]
    return None if saved is None else StopRule.from_dict(saved)


def stop_record(ckpt: Mapping[str, Any], steps: int) -> dict[str, Any]:
    """A seed's entry of ``summary.json`` about stopping: ``stopped_early``, ``stop_reason``,
    ``stop_step`` and ``steps_saved`` (of the budget ``steps``; 0 when it ran to the end)."""
    stopped = ckpt.get("stopped")
    if not stopped:
        return {"stopped_early": False, "stop_reason": None, "stop_step": None, "steps_saved": 0}
    return {"stopped_early": True, "stop_reason": stopped["reason"], "stop_step": int(stopped["step"]),
            "steps_saved": max(0, int(steps) - int(stopped["step"]))}


def seed_state(run_dir: str | Path, record: Mapping[str, Any], target: float | None) -> str:
    """A seed's state in words: ``stopped`` (its rule fired), ``learned`` (an evaluation reached
    ``target``, the case's target return), ``still improving`` (the ``plateau`` rule with its
    defaults would not stop it) or ``plateaued``; ``not evaluated`` without evaluations."""
    if record.get("stopped_early"):
        return "stopped"
    path = RunDir(run_dir).evaluations_csv
    returns: list[float] = []
    if path.is_file():
        with open(path, newline="") as f:
            returns = [float(r["mean_return"]) for r in csv.DictReader(f)]
    if not returns:
        return "not evaluated"
    if target is not None and max(returns) >= target:
        return "learned"
    return "plateaued" if StopRule("plateau").decide(returns) else "still improving"


def stop_summary(per_seed: list[Mapping[str, Any]], steps: int, rule: StopRule | None,
                 evaluation_duration: float = EVAL_DURATION) -> dict[str, Any]:
    """The case's summary about stopping: the rule, the seeds stopped early, the fraction of
    the seeds' step budget they ran (``steps_run_fraction``, 1 without stops; ``None`` when no
    seed ran to its end) and the evaluations' episode (s, :attr:`Case.evaluation_duration`)."""
    entries = [r for r in per_seed if "error" not in r]
    saved = sum(int(r.get("steps_saved") or 0) for r in entries)
    budget = int(steps) * len(entries)
    return {"stop_rule": None if rule is None else rule.to_dict(),
            "stopped_early": [r["seed"] for r in entries if r.get("stopped_early")],
            # null (not NaN, which strict JSON readers refuse) when no seed ran: nothing to count
            "steps_run_fraction": (1.0 - saved / budget) if budget else None,
            "evaluation_duration_s": evaluation_duration}
