"""A case's spec check and its readable summary (``msr case check``, ``msr case show``): the robot's
derived quantities, time steps, sag and validity warnings
(:mod:`elastica_magnetic.spec_check`), with the case's actuation, task, training and yardstick."""

from __future__ import annotations

from elastica_magnetic.spec_check import SpecCheck, check_robot, format_check

from .case import Case

__all__ = ["case_summary", "check_case"]


def check_case(case: Case, sag: bool = True) -> SpecCheck:
    """:func:`~elastica_magnetic.spec_check.check_robot` of a case's robot with its field limit
    (T), task kind and yardstick (m in 10 s; 0 is checked as none: no run of the case would be
    judged). ``sag``: simulate the sag into the ground (a few seconds)."""
    return check_robot(case.robot, field_limit=case.field_limit, task_kind=case.task.kind,
                       yardstick_m=case.yardstick.distance_10s, name=case.name,
                       source=str(case.source), sag=sag)


def case_summary(case: Case, check: SpecCheck | None = None) -> str:
    """A compact, readable summary of a case: what it is, its actuation, task, training and
    yardstick, then the robot's check (``check``, default :func:`check_case` without the sag
    simulations). Per-element tables are summarized, not listed."""
    a, t, tr = case.actuation, case.task, case.training
    task = ", ".join(f"{k} {v:g}" if isinstance(v, float) else f"{k} {v}"
                     for k, v in t.to_dict().items() if k != "kind")
    lines = [
        f"{case.name}: {case.description}" if case.description else case.name,
        f"  actuation    field limit {1e3 * a.field_limit:g} mT, at most {1e3 * a.max_increment:g} mT "
        f"per axis per {1e3 / a.control_rate:g} ms, training episodes from a {a.initial_field} field",
        f"  task         {t.kind} ({task})",
        f"  training     recipe {tr.recipe}, {tr.steps} steps per seed"
        + (f", TD3 settings {dict(tr.td3)}" if tr.td3 else ""),
        f"  target       {case.target_label}" + (f" ({case.yardstick.source})"
                                                 if case.yardstick.source else ""),
    ]
    check = check if check is not None else check_case(case, sag=False)
    return "\n".join(lines) + "\n" + format_check(check)
