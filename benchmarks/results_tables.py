"""The "Campaigns at a glance" tables of ``benchmarks/results/LOG.md``, generated from the JSON
records beside it: one table per recipe version and machine, one row per campaign.

Run: ``python benchmarks/results_tables.py`` (print the tables), ``--write`` (replace them in
LOG.md, between ``<!-- tables:begin -->`` and ``<!-- tables:end -->``), ``--check`` (exit 1 when
LOG.md's tables are not what the records give).

A campaign is a record holding an ``msr train`` summary (``summary``: case, steps, wall time) and
every seed's distance in 10 s of accurate physics from a zero field with its verdict against the
case's target, as written per seed (``seeds``: ``accurate_10s_mm`` and ``meets_target``, earlier
``reaches_yardstick_accurate`` or ``beats_baseline``) or by ``msr policy export-seeds``
(``export``: ``distance_10s_m``, ``meets_target``). The successes are those verdicts, not the
summary's ``succeeded`` (a count in the training physics). The machine is the one the record's
``what`` names; the recipe version the record's file name gives (``<kind>_<recipe>_...``: the
summaries say only ``fast``, and the versions differ in their minibatch size, which no summary
holds). A record missing any of these is listed under the tables with the reason, never filled in.
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import sys
from dataclasses import dataclass
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"
LOG = RESULTS / "LOG.md"
BEGIN, END = "<!-- tables:begin -->", "<!-- tables:end -->"

# Recipe version by the name the records' files give it, in the order the tables come in.
RECIPE_VERSIONS = {
    "fast": "`fast`, first version: minibatches of 128",
    "fast128": "`fast`, first version: minibatches of 128",
    "fast64": "`fast`, second version: minibatches of 64",
}
# Longest first, so that "AMD EPYC (Zen 5)" is not read as "AMD EPYC".
MACHINE = re.compile(r"Intel Xeon with AMX|Intel Xeon|AMD EPYC \(Zen 5\)|AMD EPYC")
DATE = re.compile(r"\d{4}-\d{2}-\d{2}")
VERDICT_KEYS = ("meets_target", "reaches_yardstick_accurate", "beats_baseline")
COLUMNS = ("case", "date", "seeds", "reach the target", "median (mm)", "best (mm)",
           "steps per seed", "steps run", "wall (min)", "record")


class SkippedRecord(Exception):
    """A record that is not tabulated, and why (the message)."""


@dataclass(frozen=True)
class Campaign:
    """One campaign as its record states it. Distances in mm, 10 s of accurate physics."""

    record: str
    recipe: str
    machine: str
    case: str
    date: str
    steps_per_seed: int
    distances_mm: tuple[float, ...]
    successes: int
    wall_s: float
    steps_run_fraction: float


def seed_results(record: dict) -> list[tuple[float, bool]]:
    """Every seed's (accurate 10 s distance in mm, meets the target) as the record writes them."""
    if isinstance(record.get("seeds"), dict):
        results = []
        for name, seed in record["seeds"].items():
            verdicts = [seed[key] for key in VERDICT_KEYS if key in seed]
            if "accurate_10s_mm" not in seed or len(verdicts) != 1:
                raise SkippedRecord(f"{name} has no accurate 10 s distance and verdict")
            results.append((float(seed["accurate_10s_mm"]), bool(verdicts[0])))
        return results
    exported = (record.get("export") or {}).get("seeds")
    if not exported:
        raise SkippedRecord("no seed's accurate 10 s distance")
    return [(seed["distance_10s_m"] * 1e3, bool(seed["meets_target"])) for seed in exported]


def recipe_version(path: Path, summary: dict) -> str:
    """The recipe version the record's file name gives, checked against the summary's recipe."""
    parts = path.stem.split("_")
    tag = parts[1] if len(parts) > 1 else ""
    if tag not in RECIPE_VERSIONS:
        raise SkippedRecord(f"recipe version `{tag}` of the file name not known")
    if not tag.startswith(summary["recipe"]):
        raise SkippedRecord(f"file name says `{tag}`, the summary `{summary['recipe']}`")
    return RECIPE_VERSIONS[tag]


def read_campaign(path: Path) -> Campaign:
    """The campaign a record holds; :class:`SkippedRecord` when it holds none or lacks a value."""
    record = json.loads(path.read_text())
    summary = record.get("summary") if isinstance(record, dict) else None
    if not isinstance(summary, dict) or "wall_s" not in summary:
        raise SkippedRecord("no `msr train` summary")
    machines = set(MACHINE.findall(record.get("what", "")))
    if len(machines) != 1:
        raise SkippedRecord(f"machine not named once in `what`: {sorted(machines)}")
    date = DATE.search(path.stem)
    if date is None:
        raise SkippedRecord("no date in the file name")
    results = seed_results(record)
    return Campaign(
        record=path.name, recipe=recipe_version(path, summary), machine=machines.pop(),
        case=summary["case"], date=date.group(), steps_per_seed=int(summary["steps"]),
        distances_mm=tuple(distance for distance, _ in results),
        successes=sum(meets for _, meets in results), wall_s=float(summary["wall_s"]),
        steps_run_fraction=float(summary["steps_run_fraction"]))


def read_records(folder: Path = RESULTS) -> tuple[list[Campaign], dict[str, str]]:
    """The campaigns of every ``*.json`` in ``folder``, and the other records with the reason."""
    campaigns, skipped = [], {}
    for path in sorted(folder.glob("*.json")):
        try:
            campaigns.append(read_campaign(path))
        except SkippedRecord as reason:
            skipped[path.name] = str(reason)
    return campaigns, skipped


def row(campaign: Campaign) -> str:
    """One Markdown table row."""
    distances = campaign.distances_mm
    cells = (
        f"`{campaign.case}`", campaign.date, str(len(distances)),
        f"{campaign.successes} of {len(distances)}",
        f"{statistics.median(distances):+.1f}", f"{max(distances):+.1f}",
        f"{campaign.steps_per_seed:,}", f"{campaign.steps_run_fraction:.2f}",
        f"{campaign.wall_s / 60:.1f}", f"`{campaign.record}`")
    return "| " + " | ".join(cells) + " |"


def render(campaigns: list[Campaign], skipped: dict[str, str]) -> str:
    """The tables (one per recipe version and machine) and the records left out, in Markdown."""
    order = list(dict.fromkeys(RECIPE_VERSIONS.values()))
    groups: dict[tuple[str, str], list[Campaign]] = {}
    for campaign in campaigns:
        groups.setdefault((campaign.recipe, campaign.machine), []).append(campaign)
    lines = []
    for recipe, machine in sorted(groups, key=lambda key: (order.index(key[0]), key[1])):
        lines += [f"#### {recipe}; {machine}", "",
                  "| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
        members = sorted(groups[recipe, machine], key=lambda c: (c.date, c.case, c.record))
        lines += [row(campaign) for campaign in members] + [""]
    by_reason: dict[str, list[str]] = {}
    for name, reason in skipped.items():
        by_reason.setdefault(reason, []).append(f"`{name}`")
    lines += ["Records not tabulated, by reason:", ""]
    lines += [f"- {reason}: {', '.join(names)}" for reason, names in sorted(by_reason.items())]
    return "\n".join(lines)


def replace_tables(text: str, tables: str) -> str:
    """``text`` with what stands between the markers replaced by ``tables``."""
    if text.count(BEGIN) != 1 or text.count(END) != 1 or text.index(BEGIN) > text.index(END):
        raise ValueError(f"expected one {BEGIN} before one {END}")
    head, rest = text.split(BEGIN)
    _, tail = rest.split(END)
    return f"{head}{BEGIN}\n{tables}\n{END}{tail}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    action = parser.add_mutually_exclusive_group()
    action.add_argument("--write", action="store_true", help="replace the tables in LOG.md")
    action.add_argument("--check", action="store_true",
                        help="exit 1 when LOG.md's tables differ from the records")
    args = parser.parse_args(argv)
    tables = render(*read_records(RESULTS))
    if not (args.write or args.check):
        print(tables)
        return 0
    text = LOG.read_text()
    updated = replace_tables(text, tables)
    if args.check:
        if updated != text:
            print(f"{LOG}: the tables differ from the records; run "
                  "python benchmarks/results_tables.py --write", file=sys.stderr)
        return int(updated != text)
    LOG.write_text(updated)
    return 0


if __name__ == "__main__":
    sys.exit(main())
