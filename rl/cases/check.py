"""A case's spec check and its readable summary (``msr case check``, ``msr case show``): the robot's
derived quantities, time steps, sag and validity warnings
(:mod:`elastica_magnetic.spec_check`), with the case's actuation, task, training and yardstick."""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from elastica_magnetic.plausibility import ImplausibleValueWarning
from elastica_magnetic.spec_check import Issue, SpecCheck, check_robot, check_spec, format_check
from elastica_magnetic.specfile import describe_robot, read_spec

from .case import CASE_UNITS, Case, case_names, load_case, warmup_refusal
from .field_actuation import Actuation

__all__ = ["RobotOnlySpec", "case_summary", "check_case", "check_robot_only", "check_with_warnings",
           "coverage", "robot_only_spec"]


@dataclass(frozen=True)
class RobotOnlySpec:
    """A spec file without a ``[task]`` table: a robot that ``msr field simulate --robot`` simulates,
    not a case that ``msr train`` trains (``data``: its parsed TOML)."""

    source: str
    data: Mapping[str, Any]


def robot_only_spec(value: str | Path) -> RobotOnlySpec | None:
    """The spec file ``value`` when it has no ``[task]`` table, its ``[robot]`` and ``[physics]``
    checked (a :class:`~elastica_magnetic.specfile.SpecError` names the key); ``None`` for a
    shipped case's name, a file with a task or a path that is no file (``load_case`` takes or
    names those)."""
    if str(value) in case_names() or not Path(value).is_file():
        return None
    data = read_spec(value)
    if "task" in data:
        return None
    describe_robot(data, str(value))  # a bad key is named now, before the sag simulations
    return RobotOnlySpec(str(value), data)


def check_robot_only(spec: RobotOnlySpec, sag: bool = True) -> SpecCheck:
    """:func:`~elastica_magnetic.spec_check.check_spec` of a spec without a task: its robot, time
    steps, sag, its ``[field]`` in space and ``[boundary]`` (as ``msr field simulate`` builds them) and,
    with an ``[actuation]`` table, its field limit (T)."""
    return check_spec(spec.data, spec.source, sag=sag)


def check_with_warnings(spec: Case | RobotOnlySpec, sag: bool = True) -> SpecCheck:
    """The check of a case (:func:`check_case`) or a spec without a task
    (:func:`check_robot_only`), with the warnings reading the spec gives (unusual values, shown on
    stderr as it is read) among its issues: the summary counts them and ``--json`` lists them."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ImplausibleValueWarning)
        if isinstance(spec, RobotOnlySpec):
            robot_only_spec(spec.source)
            check = check_robot_only(spec, sag=sag)
        else:
            load_case(spec.source if Path(spec.source).is_file() else spec.name)
            check = check_case(spec, sag=sag)
    found: list[Issue] = []
    for warning in caught:
        # shown as before (msr shows each once: those of the parse are not repeated)
        warnings.warn_explicit(warning.message, warning.category, warning.filename, warning.lineno)
        if issubclass(warning.category, ImplausibleValueWarning):
            issue = _issue_of(warning.message, str(spec.source))
            if issue not in found:
                found.append(issue)
    return dataclasses.replace(check, issues=[*found, *check.issues])


def _issue_of(warning: Any, source: str) -> Issue:
    """A spec's warning (``FILE: [table] key...``, its dotted ``key``) as an issue whose key is
    ``[table] key`` and whose message is the rest."""
    text = str(warning).removeprefix(f"{source}: ")
    table, _, name = str(getattr(warning, "key", "")).rpartition(".")
    key = f"[{table}] {name}" if table else name or "spec"
    return Issue("warning", key, text.removeprefix(key).lstrip(":= "))


def coverage(spec: RobotOnlySpec, check: SpecCheck, sag: bool = True) -> dict[str, list[str]]:
    """What ``msr case check`` checked of a spec without a task, and what not, and why."""
    checked, not_checked = ["robot", "time steps"], []
    # check_spec built these as msr field simulate does (a mistake there is an error before the report)
    checked += [table for table in ("field", "boundary") if table in spec.data]
    if check.field_limit_T is not None:
        checked.append("field limit")
    else:
        not_checked.append("field limit (no [actuation] field_limit)")
    if check.sag is not None:
        checked.append("sag")
    else:
        why = "--no-sag" if not sag else ("no [robot.ground]" if check.spring_only_sag_m is None
                                          else "see the warnings")
        not_checked.append(f"sag ({why})")
    unread = ", so its [training] table is not read either" if "training" in spec.data else ""
    not_checked.append(f"training (the spec has no [task] table{unread}; it can be simulated "
                       f"with msr field simulate --robot {spec.source}, not trained)")
    return {"checked": checked, "not_checked": not_checked}


def check_case(case: Case, sag: bool = True) -> SpecCheck:
    """:func:`~elastica_magnetic.spec_check.check_robot` of a case's robot with its field limit
    (T), task kind and yardstick (m in 10 s; 0 is checked as none: no run of the case would be
    judged). ``sag``: simulate the sag into the ground (a few seconds)."""
    # a magnet on an arm: the field its start pose makes at the straight tip sets the scale
    field = (case.field_limit if case.field_actuated else
             case.actuation.field_at_tip(float(case.robot.tables["robot"]["length"])))
    check = check_robot(case.robot, field_limit=field, task_kind=case.task.kind,
                        # distance_10s judges a crawl; goto and reach are judged on their targets
                        yardstick_m=case.yardstick.distance_10s if case.task.kind == "crawl" else None,
                        name=case.name, source=str(case.source), sag=sag,
                        field_name="field limit" if case.field_actuated else case.actuation.tip_field_words)
    refusal = warmup_refusal(case)
    if refusal is None:
        return check
    # valid for a sweep or msr loop, which record the period; msr train refuses it until then
    issue = Issue("warning", "[training.td3] yardstick_warmup",
                  f"msr train refuses it: {refusal.removeprefix(f'{case.source}: ')}")
    return dataclasses.replace(check, issues=[*check.issues, issue])


def case_summary(case: Case, check: SpecCheck | None = None) -> str:
    """A compact, readable summary of a case: what it is, its actuation, task, training and
    yardstick, then the robot's check (``check``, default :func:`check_case` without the sag
    simulations). Per-element tables are summarized, not listed."""
    t, tr = case.task, case.training
    task = _settings_text({k: v for k, v in t.to_dict().items() if k != "kind"}, "task")
    lines = [
        f"{case.name}: {case.description}" if case.description else case.name,
        f"  actuation    {_actuation_text(case)}",
        f"  task         {t.kind} ({task})",
        f"  training     recipe {tr.recipe}, {tr.steps} steps per seed"
        + (f", TD3 settings: {_settings_text(tr.td3, 'training.td3')}" if tr.td3 else ""),
        f"  target       {case.target_label}" + (f" ({case.yardstick.source})"
                                                 if case.yardstick.source else ""),
    ]
    check = check if check is not None else check_case(case, sag=False)
    return "\n".join(lines) + "\n" + format_check(check)


def _settings_text(values: Mapping[str, Any], table: str) -> str:
    """``key value unit, ...`` of a table's settings for people: numbers to 6 digits, lists in
    brackets, each with its unit where the case tables name one (the unit alone, not its gloss)."""
    def shown(value: Any) -> str:
        if isinstance(value, bool):
            return "yes" if value else "no"
        if isinstance(value, float):
            return f"{value:.6g}"
        if isinstance(value, (list, tuple)):
            return "[" + ", ".join(shown(v) for v in value) + "]"
        return str(value)

    parts = []
    for key, value in values.items():
        gloss = CASE_UNITS.get((table, key), "").split(",")[0]
        unit = gloss if gloss in SHORT_UNITS else (gloss.split() or [""])[0]
        unit = unit if unit in SHORT_UNITS else ""
        parts.append(f"{key} {shown(value)}" + (f" {unit}" if unit else ""))
    return ", ".join(parts)


#: The units :func:`_settings_text` writes after a value (a longer gloss stays in the spec's comments).
SHORT_UNITS = ("m", "s", "rad", "T", "Hz", "A", "A/s", "m/s", "rad/s", "A m^2", "per m")


def _actuation_text(case: Case) -> str:
    """The actuation in words: the field's axes, limits and increments, or the steering source."""
    a = case.actuation
    if not case.field_actuated:
        return a.describe(float(case.robot.tables["robot"]["length"]))
    return f"{_axes_text(a)}, training episodes from a {a.initial_field} field"


def _axes_text(a: Actuation) -> str:
    """The field the policy controls in words: its axes, limits and increments (mT)."""
    pairs = "the third coil pair too" if a.n_axes == 3 else "the paper's two coil pairs"
    axes = f"axes {a.axes} ({pairs})"
    per = f"per {1e3 / a.control_rate:g} ms"
    if not (a.axis_limits or a.axis_increments):
        return (f"{axes}, field limit {1e3 * a.field_limit:g} mT, at most {1e3 * a.max_increment:g} "
                f"mT per axis {per}")
    limits = ", ".join(f"{axis} {1e3 * v:g}" for axis, v in zip(a.axes, a.limits, strict=False))
    steps = ", ".join(f"{axis} {1e3 * v:g}" for axis, v in zip(a.axes, a.increments, strict=False))
    return (f"{axes}, field limits {limits} mT (amplitude {1e3 * a.field_limit:g} mT), at most "
            f"{steps} mT {per}")
