"""Validation results and the report: every compared number, with its tolerance and verdict."""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from elastica_magnetic.io import atomic_write_text

__all__ = ["MARGIN", "Gate", "Comparison", "CaseResult", "shipped_verdict", "write_report"]

#: Every tolerance set from a measured error is this many times the worst error achieved, so a
#: regression of this factor on the worst point fails the check.
MARGIN = 4.0


@dataclass(frozen=True)
class Gate:
    """The tolerance of one group of compared quantities and where it comes from.

    ``achieved`` is the worst ``abs(error)`` of the run the tolerance was set from (the published
    report for a full run, the ``--quick`` run for quick), rounded up to two digits; the
    tolerance is ``MARGIN * achieved``. Invariance checks use :meth:`round_off` instead: their
    exact answer is zero, and the bound is a round-off level, not a multiple of a measured error.
    """

    name: str
    achieved: float
    tolerance: float
    basis: str
    relative: bool = False
    unit: str = ""

    @classmethod
    def from_achieved(cls, name: str, achieved: float, relative: bool = False, unit: str = "") -> Gate:
        return cls(name, achieved, MARGIN * achieved, f"{MARGIN:g} x worst achieved", relative, unit)

    @classmethod
    def round_off(cls, name: str, achieved: float, bound: float, why: str) -> Gate:
        return cls(name, achieved, bound, f"round-off bound ({why})")


@dataclass
class Comparison:
    """One compared quantity.

    ``error`` is what the tolerance applies to (absolute unless ``relative``); the check passes
    when ``abs(error) <= tolerance``. ``checked=False`` marks a number reported for information,
    and ``note`` then says why it does not gate; ``gate`` names the :class:`Gate` that set the
    tolerance.
    """

    quantity: str
    simulated: float
    reference: float
    error: float
    tolerance: float
    unit: str = ""
    relative: bool = False
    checked: bool = True
    gate: str = ""
    note: str = ""

    @classmethod
    def gated(cls, quantity: str, simulated: float, reference: float, error: float, gate: Gate) -> Comparison:
        """A checked comparison whose tolerance, unit and relative flag come from ``gate``."""
        return cls(quantity, simulated, reference, error, gate.tolerance, gate.unit, gate.relative,
                   gate=gate.name)

    @classmethod
    def informational(
        cls, quantity: str, simulated: float, reference: float, error: float, unit: str, why: str
    ) -> Comparison:
        """A number reported and not checked; ``why`` is printed with it."""
        return cls(quantity, simulated, reference, error, 0.0, unit, checked=False, note=why)

    @property
    def passed(self) -> bool:
        if not self.checked:
            return True
        return math.isfinite(self.error) and abs(self.error) <= self.tolerance

    def as_dict(self) -> dict:
        return {**asdict(self), "passed": self.passed}


@dataclass
class CaseResult:
    """The outcome of one validation case."""

    name: str
    title: str
    description: str
    comparisons: list[Comparison] = field(default_factory=list)
    gates: list[Gate] = field(default_factory=list)
    figures: list[Path] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    tables: list[str] = field(default_factory=list)  # extra Markdown tables
    quick: bool = False
    wall_s: float = 0.0

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.comparisons)

    def as_dict(self) -> dict:
        return {
            "name": self.name,
            "passed": self.passed,
            "quick": self.quick,
            "wall_s": self.wall_s,
            "n_compared": sum(c.checked for c in self.comparisons),
            "n_failed": sum(not c.passed for c in self.comparisons),
            "gates": [asdict(g) for g in self.gates],
            "comparisons": [c.as_dict() for c in self.comparisons],
            "figures": [str(f) for f in self.figures],
            "notes": self.notes,
        }


def _fmt(value: float) -> str:
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return f"{value:.6g}"


def worst_error(result: CaseResult, gate: str) -> float:
    """Largest ``abs(error)`` among the comparisons checked by ``gate`` (nan when none)."""
    errors = [abs(c.error) for c in result.comparisons if c.gate == gate]
    return max(errors) if errors else math.nan


def _headroom(tolerance: float, worst: float) -> str:
    if not math.isfinite(worst):
        return "-"
    if worst == 0.0:
        return "inf"
    return f"{tolerance / worst:.3g}"


def shipped_verdict(r: dict[str, Any]) -> str:
    """One shipped policy's verdict in words (``r``: a result of
    :func:`~elastica_magnetic_rl.shipping.shipped.verify_shipped`): what was compared, and where a
    check fails, by how much against what and from which row."""
    head = f"shipped {r['name']}: {'pass' if r['passed'] else 'FAIL'}: "
    if "summary" in r:  # a tip-reach policy: its held-out targets again
        return head + r["summary"]
    if "problem" in r:  # its files do not say what to compare
        return head + r["problem"]
    exact = r["waveform_check"] == "exact"
    if exact and r["first_row_apart"] is not None:
        text = (f"the waveform differs from fields.csv by {r['max_field_diff_mT']:.2g} mT (at most "
                f"{r['field_atol_mT']:.0e} mT on the machine that recorded it) from row "
                f"{r['first_row_apart']} of {r['rows_compared']}")
    else:
        text = (f"waveform within {r['max_field_diff_mT']:.1e} mT of fields.csv over "
                f"{r['rows_compared']} rows ({r['waveform_check']})")
    if r.get("diverged"):
        text += f"; the simulation diverged ({r['diverged']})"
    if "recorded_mid_dx_m" in r:
        text += (f", distance {r['mid_dx_m'] * 1e3:+.2f} mm (recorded {r['recorded_mid_dx_m'] * 1e3:+.2f}, "
                 f"relative difference {r['relative_diff']:.1e}"
                 + (f", at most {r['distance_rtol']:.0e}" if r.get("distance_check") == "closed loop" else "")
                 + f"; target {r['target']}"
                 + ("" if r.get("meets_target") is not False else ", NOT met") + ")")
    if "replay_mid_dx_m" in r:  # another machine: the waveform's distance is the check
        text += (f"; the shipped waveform open loop {r['replay_mid_dx_m'] * 1e3:+.4f} mm (recorded "
                 f"{r['recorded_mid_dx_m'] * 1e3:+.4f}, at most "
                 f"{r['replay_allowed_diff_m'] * 1e6:.0f} um apart)")
    return head + text


def write_report(results: list[CaseResult], out: Path, command: str,
                 final: Path | None = None, shipped: list[dict[str, Any]] | None = None) -> Path:
    """Write ``report.md`` (tables and figures) and ``results.json`` into ``out``; ``final``: the
    folder the report will end up in when ``out`` is a temporary one (the figures' paths are
    under it), else ``out``; ``shipped``: the verdicts of the shipped policies when they were
    re-run too (a section of their own)."""
    out.mkdir(parents=True, exist_ok=True)
    base = out if final is None else final
    lines = [
        "# Validation report",
        "",
        f"Generated by `{command}`. Every number compared is listed with its tolerance; a case",
        "passes when all its checked comparisons do. Tolerances are set from measured errors:",
        f"{MARGIN:g} x the worst error achieved in the run they were set from (the full run for the",
        "full report, the `--quick` run for quick), except invariance checks, which are bounded at",
        "round-off level. Each case lists its tolerances next to the errors achieved now; a number",
        "marked *info* does not gate, for the reason given with it.",
        "",
        "| case | verdict | compared | failed | wall time |",
        "|---|---|---|---|---|",
    ]
    for r in results:
        verdict = "pass" if r.passed else "**FAIL**"
        n = sum(c.checked for c in r.comparisons)
        failed = sum(not c.passed for c in r.comparisons)
        lines.append(f"| {r.name}{' (quick)' if r.quick else ''} | {verdict} | {n} | {failed} | "
                     f"{r.wall_s:.0f} s |")
    for r in results:
        lines += ["", f"## {r.title}", "", r.description, ""]
        for note in r.notes:
            lines.append(f"- {note}")
        if r.notes:
            lines.append("")
        for table in r.tables:
            lines += [table, ""]
        if r.gates:
            lines += [
                "| tolerance | worst error when set | basis | tolerance | worst error now | "
                "tolerance / worst now |",
                "|---|---|---|---|---|---|",
            ]
            for g in r.gates:
                now = worst_error(r, g.name)
                rel = " (rel.)" if g.relative else ""
                unit = f" {g.unit}" if g.unit and not g.relative else ""  # relative: no unit
                lines.append(
                    f"| {g.name} | {_fmt(g.achieved)}{unit}{rel} | {g.basis} | "
                    f"{_fmt(g.tolerance)}{unit}{rel} | {_fmt(now)}{unit} | {_headroom(g.tolerance, now)} |"
                )
            lines.append("")
        lines += [
            "| quantity | simulated | reference | error | tolerance | unit | verdict |",
            "|---|---|---|---|---|---|---|",
        ]
        for c in r.comparisons:
            verdict = f"info: {c.note}" if not c.checked else ("pass" if c.passed else "**FAIL**")
            tol = f"{_fmt(c.tolerance)}{' (rel.)' if c.relative else ''}" if c.checked else ""
            lines.append(
                f"| {c.quantity} | {_fmt(c.simulated)} | {_fmt(c.reference)} | {_fmt(c.error)} | "
                f"{tol} | {c.unit} | {verdict} |"
            )
        for figure in r.figures:
            lines += ["", f"![{r.name}: {figure.stem}]({figure.relative_to(base).as_posix()})"]
    if shipped is not None:
        lines += ["", "## The shipped policies", "",
                  "Each shipped policy re-run against its files (`msr validate shipped`):", ""]
        lines += [f"- {shipped_verdict(r)}" for r in shipped]
    report = atomic_write_text(out / "report.md", "\n".join(lines) + "\n")
    record: dict[str, Any] = {"cases": [r.as_dict() for r in results]}
    if shipped is not None:
        record["shipped"] = shipped
    atomic_write_text(out / "results.json", json.dumps(record, indent=2, default=str))
    return report
