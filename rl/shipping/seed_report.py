"""Every seed of a case, by recipe: how many succeed, how far each goes.

Reads the committed seed folders ``<policies>/<case>/seeds/<recipe>/seeds.json`` (written by ``msr
policy export-seeds``; one object per seed with ``seed``, ``steps``, ``distance_10s_m``, ``actor``)
and judges each seed by the case's own success test
(:meth:`~elastica_magnetic_rl.cases.case.Case.meets_yardstick`: 10 s in the accurate physics from a
zero field reach the yardstick). A case without a yardstick judges no seed: its successes are not
applicable ("n/a"), whatever ``meets_target`` an older file stored. ``msr policy seeds`` prints the
table, draws the seeds' distances per recipe, and keeps the table in the shipped policy's model
card."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from elastica_magnetic.filesets import update_recorded_text

from ..cases.case import Case
from ..runfiles.rundir import RunDir
from ..sweep.run_records import first_difference
from .model_card import replace_card_section
from .policy_files import POLICIES_DIR, POLICY_JSON, SEEDS_FOLDER, case_spec_difference, read_policy_json

__all__ = ["REPOSITORY_SEEDS", "RecipeSeeds", "SeedsOfAnotherSpec", "case_seeds", "no_seeds_message",
           "seeds_markdown", "recipes_markdown", "update_model_card", "case_cards", "seeds_figure",
           "learning_curves_by_recipe"]

#: The model card's section that :func:`update_model_card` keeps current.
CARD_SECTION = "## Every seed, by recipe"


class SeedsOfAnotherSpec(ValueError):
    """Seeds stored under a case's name but measured on another spec (another robot of that name)."""


@dataclass
class RecipeSeeds:
    """The committed seeds of one case trained with one recipe (one ``seeds/<folder>/``)."""

    folder: str  # e.g. "paper", "pink", "paper-bf16"
    entries: list[dict[str, Any]]  # seeds.json, ordered by seed
    succeeded: list[bool | None]  # per entry: the case's success test (None: the case has none)
    path: Path | None = None  # the seeds folder

    @property
    def judged(self) -> bool:
        """Whether the seeds have verdicts (not for a case without a yardstick)."""
        return all(ok is not None for ok in self.succeeded)

    @property
    def count(self) -> int | None:
        """The seeds that succeed; ``None`` when they are not judged (never a count of movers)."""
        return sum(bool(ok) for ok in self.succeeded) if self.judged else None

    @property
    def summary(self) -> str:
        return f"{self.count} of {len(self.entries)}" if self.judged else f"n/a ({len(self.entries)} seeds)"

    def to_dict(self) -> dict[str, Any]:
        return {"folder": self.folder, "seeds": len(self.entries), "succeeded": self.count,
                "per_seed": [{"seed": e["seed"], "steps": e.get("steps"),
                              "distance_10s_m": e["distance_10s_m"], "succeeded": ok}
                             for e, ok in zip(self.entries, self.succeeded, strict=True)]}


def case_seeds(case: Case, policies_dir: str | Path | None = None,
               left_out: list[str] | None = None) -> list[RecipeSeeds]:
    """The seed folders of ``case`` under ``policies_dir/<case>/seeds/`` (default: the shipped
    policies), the paper's recipe first, then by name. A campaign measured over another duration
    than 10 s (``msr policy export-seeds --duration``) is left out, why appended to ``left_out``
    (given a list). A ``seeds.json`` that is not a list of seed objects is a ``ValueError`` naming
    the file."""
    root = Path(policies_dir) if policies_dir is not None else POLICIES_DIR
    groups = []
    for path in sorted((root / case.name / SEEDS_FOLDER).glob("*/seeds.json")):
        try:
            entries = json.loads(path.read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise ValueError(f"{path}: unreadable ({exc})") from None
        durations = sorted({e.get("duration_s") for e in entries if isinstance(e, dict)
                            and "distance_10s_m" not in e and isinstance(e.get("distance_m"), int | float)
                            and isinstance(e.get("duration_s"), int | float)})
        if isinstance(entries, list) and entries and durations:
            if left_out is not None:
                shown = ", ".join(f"{d:g} s" for d in durations)
                left_out.append(f"{path.parent}: measured over {shown}, not the 10 s this table "
                                "compares: left out (export it again without --duration)")
            continue
        if not isinstance(entries, list) or not all(
                isinstance(e, dict) and isinstance(e.get("seed"), int)
                and isinstance(e.get("distance_10s_m"), int | float) for e in entries):
            raise ValueError(f"{path}: expected a JSON list of objects with an integer 'seed' and "
                             "a number 'distance_10s_m' (m)")
        entries = sorted(entries, key=lambda e: e["seed"])
        _check_measured_on(case, path.parent, entries)
        if not case.has_yardstick:  # nothing to judge by (a stored meets_target is ignored)
            succeeded: list[bool | None] = [None] * len(entries)
        elif case.task.kind == "crawl":  # judged here, by the case's rule, from the distance
            succeeded = [bool(case.meets_yardstick(e["distance_10s_m"], e["distance_10s_m"], 10.0))
                         for e in entries]
        else:  # a reach task judges the end node, which seeds.json does not hold: its verdict
            if not all(isinstance(e.get("meets_target"), bool) for e in entries):
                raise ValueError(f"{path}: a {case.task.kind} task needs each seed's "
                                 "'meets_target' (true/false), as msr policy export-seeds writes it")
            succeeded = [e["meets_target"] for e in entries]
        groups.append(RecipeSeeds(path.parent.name, entries, succeeded, path.parent))
    groups.sort(key=lambda g: (g.folder != "paper", g.folder))
    return groups


#: Where the shipped cases' seed campaigns are when an installed package lacks them.
REPOSITORY_SEEDS = ("the seed campaigns of the shipped cases are in the elastica-magnetic "
                    "repository, not in the installed package: clone it and pass "
                    "--policies <clone>/rl/policies")


def no_seeds_message(case: Case, policies_dir: str | Path | None = None) -> str:
    """Why no seeds of ``case`` were found and where to get them: for a shipped case read from the
    installed package's policies, the repository (:data:`REPOSITORY_SEEDS`); otherwise the folder
    looked in and how ``msr policy export-seeds`` fills it."""
    root = Path(policies_dir) if policies_dir is not None else POLICIES_DIR
    folder = root / case.name / SEEDS_FOLDER
    if root.resolve() == POLICIES_DIR.resolve() and case.builtin and not folder.is_dir():
        return f"No seeds of `{case.name}` here: {REPOSITORY_SEEDS}."
    return (f"No seeds of `{case.name}` in {folder} (msr policy export-seeds RUNS/{case.name} --out "
            f"{folder}/<recipe> writes them).")


def seeds_markdown(case: Case, groups: list[RecipeSeeds],
                   policies_dir: str | Path | None = None) -> str:
    """A Markdown table: one row per recipe folder, its success count and every seed's distance
    (mm, bold where it succeeds); without seeds, :func:`no_seeds_message` (``policies_dir``:
    where they were looked for)."""
    if not groups:
        return no_seeds_message(case, policies_dir)
    rule = (f"A seed succeeds when its actor, run for 10 s in the accurate physics from a zero "
            f"field, meets the target ({case.target_label})" if case.has_yardstick else
            f"Each seed's distance in 10 s of accurate physics from a zero field; no seed is judged "
            f"(target: {case.target_label})")
    lines = [f"{rule}; each seed's actor is the better of its final one and its `best.pt` (`msr "
             "export-seeds`)." + (" Bold: succeeded." if case.has_yardstick else ""), "",
             "| recipe (folder) | seeds that succeed | distance of each seed in 10 s (mm) |",
             "|---|---|---|"]
    for g in groups:
        cells = ", ".join((f"{e['seed']}: **{1e3 * e['distance_10s_m']:+.1f}**" if ok
                           else f"{e['seed']}: {1e3 * e['distance_10s_m']:+.1f}")
                          for e, ok in zip(g.entries, g.succeeded, strict=True))
        lines.append(f"| `{g.folder}` | {g.summary} | {cells} |")
    return "\n".join(lines)


def recipe_change(folder: str) -> str:
    """What a recipe folder's recipe changes from the paper's, as ``field = value`` settings of
    :class:`~elastica_magnetic_rl.td3.config.TD3Config` (from
    :data:`~elastica_magnetic_rl.cases.recipes.RECIPES`); a folder that names no recipe (e.g. ``paper-bf16``)
    says so."""
    from ..cases.recipes import RECIPES

    if folder not in RECIPES:
        return "(not a recipe: see the folder's seeds)"
    changes = RECIPES[folder]
    return ", ".join(f"`{k} = {v}`" for k, v in changes.items()) or "none (the authors' settings)"


def recipes_markdown(by_case: dict[str, list[RecipeSeeds]]) -> str:
    """The ablation across cases: one row per recipe folder (the paper's first), its change from
    the paper's recipe, and per case the seeds that succeed (``k of n``; blank: none trained)."""
    folders = sorted({g.folder for groups in by_case.values() for g in groups},
                     key=lambda f: (f != "paper", f))
    cases = list(by_case)
    lines = ["| recipe (folder) | change from the paper's | " + " | ".join(cases) + " |",
             "|---|---|" + "---|" * len(cases)]
    for folder in folders:
        cells = []
        for case in cases:
            group = next((g for g in by_case[case] if g.folder == folder), None)
            cells.append(group.summary if group is not None else "")
        lines.append(f"| `{folder}` | {recipe_change(folder)} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _check_measured_on(case: Case, campaign: Path, entries: list[dict[str, Any]]) -> None:
    """Refuse seeds measured on another spec than ``case``'s (each seed's ``policy.json`` records
    its ``case_spec``): a spec of the same name but another robot, physics, field or task would be
    given their distances and verdicts. A ``ValueError`` naming the file and the first difference."""
    spec = case.to_dict()
    for entry in entries:
        record = campaign / str(entry.get("actor", "")) / POLICY_JSON
        if not (entry.get("actor") and record.is_file()):
            continue
        try:
            meta = json.loads(record.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue  # an unreadable record: msr validate shipped reports it
        differ = case_spec_difference(meta.get("case_spec") if isinstance(meta, dict) else None, spec)
        if differ is not None:
            raise SeedsOfAnotherSpec(
                f"{record}: the seeds of {case.name} in {campaign} were measured on another spec than the "
                f"one given (they differ at {differ}): give the spec they ran on (the case {case.name!r} "
                "itself, or its policy.json's case_spec)")


def card_spec_problem(card: Path, case: Case) -> str | None:
    """Why ``case``'s seeds table may not go into ``card``: the card's policy was measured on
    another spec, or judged by another yardstick (its target stays in the card's evaluation and
    a table judged by another target would contradict it); ``None`` when it may."""
    try:
        recorded = read_policy_json(card.parent / POLICY_JSON).get("case_spec")
    except (OSError, ValueError):
        return None  # no readable policy.json: msr validate shipped reports it
    if not isinstance(recorded, dict):
        return None
    spec = case.to_dict()
    differ = case_spec_difference(recorded, spec)
    if differ is None and recorded.get("yardstick") != spec.get("yardstick"):
        differ = first_difference(recorded.get("yardstick"), spec.get("yardstick"), "yardstick")
    if differ is None:
        return None
    return (f"{card}: its policy was measured and judged on another spec than the one given (they "
            f"differ at {differ}): the card keeps its own target; card with the policy's own spec "
            f"(msr policy seeds {case.name} --card), or leave out --card to see the table judged by yours")


def update_model_card(card: Path, case: Case, groups: list[RecipeSeeds]) -> bool:
    """Put the table of :func:`seeds_markdown` into the model card ``card`` as its
    :data:`CARD_SECTION` (replacing the section if there is one, else before "## Evaluation"
    or at the end). Written atomically; returns whether the card changed. Without seeds
    (``groups`` empty) it raises ``ValueError``: a card's seed section is never replaced by
    nothing."""
    if not groups:
        raise ValueError(f"{card}: {no_seeds_message(case, card.parent.parent)} The card is left "
                         "as it is.")
    text = card.read_text()
    new = replace_card_section(text, CARD_SECTION, seeds_markdown(case, groups), before="## Evaluation")
    if new == text:
        return False
    update_recorded_text(card, new)  # msr's record of the card follows its own edit
    return True


def case_cards(case: Case, policies: Path = POLICIES_DIR) -> list[Path]:
    """The model cards that carry ``case``'s seeds table: its own folder's (``policies/<case>``)
    and that of every other policy whose ``policy.json`` names the case, measured on its spec (a
    ``<case>-robust`` one, say); sorted by folder."""
    cards = []
    for folder in sorted(p for p in Path(policies).iterdir() if p.is_dir()):
        card = folder / "MODEL_CARD.md"
        if not card.is_file():
            continue
        if folder.name == case.name:
            cards.append(card)
            continue
        try:
            meta = read_policy_json(folder / POLICY_JSON)
        except (OSError, ValueError):  # PolicyFileError is a ValueError
            continue  # not a policy that can be read; ``msr validate shipped`` reports it
        # a policy of a spec of the same name but another robot is not this case's: not its table
        if meta["case"] == case.name and case_spec_difference(meta.get("case_spec"), case.to_dict()) is None:
            cards.append(card)
    return cards


def _colour(ok: bool | None) -> str:
    """A seed's colour in the figures: succeeded, failed, or not judged (no yardstick)."""
    return "tab:gray" if ok is None else ("tab:green" if ok else "tab:red")


def seeds_figure(case: Case, groups: list[RecipeSeeds], path: str | Path) -> Path:
    """Every seed's 10 s distance (mm) per recipe folder, the success threshold as a line; PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from elastica_magnetic.io import atomic_save

    fig, ax = plt.subplots(figsize=(2.8 + 1.6 * max(len(groups), 1), 3.8))
    for i, g in enumerate(groups):
        n = len(g.entries)
        for j, (e, ok) in enumerate(zip(g.entries, g.succeeded, strict=True)):
            x = i + (0.5 * (j / (n - 1) - 0.5) if n > 1 else 0.0)  # seeds side by side, in order
            ax.scatter(x, 1e3 * e["distance_10s_m"], s=36, color=_colour(ok),
                       edgecolor="black", linewidth=0.5, zorder=3)
            ax.annotate(str(e["seed"]), (x, 1e3 * e["distance_10s_m"]), xytext=(0, 5),
                        textcoords="offset points", fontsize=7, ha="center")
    if case.yardstick.distance_10s > 0 and case.task.kind == "crawl":
        ax.axhline(1e3 * case.yardstick.distance_10s, color="gray", linestyle="--", linewidth=1,
                   label=case.target_label)
        ax.legend(loc="best", fontsize=7)
    ax.set_xticks(range(len(groups)), [f"{g.folder}\n{g.summary}" for g in groups])
    ax.set_xlim(-0.6, len(groups) - 0.4)
    ax.set_ylabel("distance in 10 s (mm)")
    ax.set_title(f"{case.name}: each seed's actor, 10 s from a zero field", fontsize=9)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    out = Path(path)
    atomic_save(out, lambda tmp: fig.savefig(tmp, dpi=120, format="png"))
    plt.close(fig)
    return out


def learning_curves_by_recipe(case: Case, groups: list[RecipeSeeds], path: str | Path,
                              alpha: float = 0.2) -> Path | None:
    """One panel per recipe folder, side by side on one scale: every seed's episode return against
    environment steps (EMA with ``alpha``; green: the seed succeeded, red: it did not), from the
    training log each exported seed keeps (``episodes.csv``). Seeds exported without their log are
    left out (named in the panel's title). Returns ``None`` when no seed has a log."""
    import csv

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from elastica_magnetic.io import atomic_save

    from ..reports.figures import ema

    curves = []
    for g in groups:
        runs, missing = [], []
        for e, ok in zip(g.entries, g.succeeded, strict=True):
            log = RunDir(g.path / str(e["actor"])).episodes_csv if g.path is not None else None
            if log is None or not log.is_file():
                missing.append(e["seed"])
                continue
            with open(log, newline="") as f:
                rows = list(csv.DictReader(f))
            steps = np.array([int(r["global_step"]) for r in rows])
            returns = np.array([float(r["return"]) for r in rows])
            if steps.size:
                runs.append((e["seed"], ok, steps, ema(returns, alpha)))
        curves.append((g, runs, missing))
    if not any(runs for _, runs, _ in curves):
        return None
    fig, axes = plt.subplots(1, len(curves), figsize=(1.5 + 3.6 * len(curves), 3.8), sharey=True,
                             squeeze=False)
    for ax, (g, runs, missing) in zip(axes[0], curves, strict=True):
        for seed, ok, steps, smooth in runs:
            ax.plot(steps, smooth, lw=1.0, color=_colour(ok), alpha=0.8)
            ax.annotate(str(seed), (steps[-1], smooth[-1]), xytext=(2, 0), textcoords="offset points",
                        fontsize=7, va="center")
        title = f"{g.folder}: {g.summary} succeed" if g.judged else f"{g.folder}: {g.summary}"
        if missing:
            title += f"\n(no log: seeds {', '.join(map(str, missing))})"
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("environment steps")
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel(f"episode return (EMA, alpha = {alpha:g})")
    legend = "green: the seed succeeded" if case.has_yardstick else "no yardstick: not judged"
    fig.suptitle(f"{case.name}: learning curves by recipe ({legend})", fontsize=10)
    fig.tight_layout()
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_save(out, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))
    plt.close(fig)
    return out
