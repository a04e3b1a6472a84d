"""``msr design SPEC --out DIR``: the design search from a spec to a folder, resumable.

The folder (written in place under a lock, like a training run, its marker of kind ``design``):

- ``design.json``: the spec searched from, the design space, the settings, the starting design's
  search result (written first; a resume checks that its spec and settings are the same);
- ``search/state.pkl``: the CMA-ES checkpoint after the last whole generation;
- ``history.csv``: every candidate evaluated (rewritten after every generation);
- at the end: ``best.toml`` (a complete spec of the best design, ready for ``msr train``,
  its ``[yardstick] distance_10s`` the best rotating field's distance), ``summary.json``,
  ``final_sweep.csv`` (the starting and the best design under the same sweep of rotating
  fields, the measurement that judges them), ``convergence.png``, ``magnetization.png``,
  ``report.md`` and ``gait/`` (the best design under its best rotating field, as
  ``msr field baseline`` writes it, with a GIF).

A folder that holds a design is continued with ``resume`` and started afresh with ``force`` (its
earlier design's files, those the marker lists, are removed first); anything else in it is
refused before any work.
"""

from __future__ import annotations

import csv
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic.io import atomic_write, atomic_write_json, display_path, normalized_path, read_json
from elastica_magnetic.locks import FolderLock
from elastica_magnetic.results import (
    OutputPathError,
    check_result_folder,
    mark_folder,
    read_marker,
    remove_tree,
)
from elastica_magnetic.specfile import SpecError, read_spec

from ..cases.case import EVAL_DURATION, SPECS_DIR, Case, case_from_dict, case_names
from ..cases.design_space import DESIGN_TABLE, DesignSpace, design_space
from ..shipping.baseline_sweep import DEFAULT_PERIODS
from .search import (
    OBJECTIVES,
    SearchState,
    VariationSet,
    evaluate_candidates,
    new_search,
    run_generation,
    variation_set,
)

__all__ = ["DESIGN_KIND", "Design", "DesignError", "DesignSettings", "load_design", "run_design"]

#: The marker kind of a design folder.
DESIGN_KIND = "design"
DESIGN_JSON = "design.json"
STATE_FILE = "search/state.pkl"
HISTORY_CSV = "history.csv"
#: What the end of a design writes (:func:`~elastica_magnetic_rl.design.outputs.write_outputs`).
OUTPUT_FILES = ("best.toml", "final_sweep.csv", "summary.json", "convergence.png",
                "magnetization.png", "report.md", "gait")
#: Every name a design folder holds: anything else there is the user's (refused, never removed).
DESIGN_NAMES = frozenset((DESIGN_JSON, STATE_FILE.split("/")[0], HISTORY_CSV, *OUTPUT_FILES))


class DesignError(ValueError):
    """A design that cannot run as asked; the command line prints it as one line."""


@dataclass(frozen=True)
class DesignSettings:
    """How ``msr design`` searches and judges. Durations in s, budgets in minutes.

    The search evaluates each candidate for ``search_duration`` s of ``physics`` (the accurate
    physics by default: the training physics' heavier robot walks differently under slow
    rotations); the starting and the best design are then judged by the same sweep of rotating
    fields (``final_periods`` and the periods the search found, both senses) for
    ``final_duration`` s of ``final_physics``: the numbers the summary reports."""

    objective: str = "yardstick"
    seed: int = 0
    minutes: float | None = 30.0
    generations: int | None = None
    popsize: int | None = None  # None: CMA-ES's default, 4 + 3 ln(dimension)
    sigma0: float = 0.25
    search_duration: float = 5.0
    physics: str = "accurate"
    final_duration: float = EVAL_DURATION
    final_physics: str = "accurate"
    final_periods: tuple[float, ...] = DEFAULT_PERIODS
    workers: int = 2
    gif: bool = True

    def recorded(self) -> dict[str, Any]:
        """The settings a resume must repeat (not the budgets, the worker count or the GIF)."""
        data = asdict(self)
        for key in ("minutes", "generations", "workers", "gif"):
            data.pop(key)
        data["final_periods"] = list(self.final_periods)
        return data

    def check(self) -> None:
        """Refuse settings that cannot act, naming the option."""
        if self.objective not in OBJECTIVES:
            raise DesignError(f"--objective: expected one of {', '.join(OBJECTIVES)}, got {self.objective!r}")
        if self.minutes is None and self.generations is None:
            raise DesignError("give a budget: --minutes or --generations")
        if self.minutes is not None and not (self.minutes > 0 and math.isfinite(self.minutes)):
            raise DesignError(f"--minutes must be a positive number of minutes, got {self.minutes}")
        if self.generations is not None and self.generations < 1:
            raise DesignError(f"--generations must be >= 1, got {self.generations}")
        if self.popsize is not None and self.popsize < 2:
            raise DesignError(f"--popsize must be >= 2 (CMA-ES needs two candidates to rank), "
                              f"got {self.popsize}")
        if self.workers < 1:
            raise DesignError(f"--workers must be >= 1, got {self.workers}")
        for name, value in (("search duration", self.search_duration),
                            ("final duration", self.final_duration)):
            if not (value > 0 and math.isfinite(value)):
                raise DesignError(f"the {name} must be a positive time in s, got {value}")


@dataclass(frozen=True)
class Design:
    """A spec ready to be designed: its case (the starting design), the spec as data without
    ``[design]`` (``base``), and the :class:`DesignSpace`."""

    case: Case
    base: dict[str, Any]
    space: DesignSpace

    def start_spec(self) -> dict[str, Any]:
        """The spec of the starting design's search vector (its magnetization as segments)."""
        return self.space.spec_of(self.base, self.start_vector(1.0))

    def start_vector(self, period: float) -> NDArray[np.float64]:
        """The search vector of the starting design (its magnetization as segments, its own
        sizes) with a rotating field of ``period`` s."""
        robot = self.base["robot"]
        return self.space.start_vector(self.case.robot_spec("accurate").magnetization, period,
                                       {key: float(robot[key]) for key, _, _ in self.space.sizes})

    def case_of(self, x: NDArray[np.float64], name: str | None = None) -> Case:
        """The case of a search vector (named ``name``, default the starting case's)."""
        spec = self.space.spec_of(self.base, x)
        return case_from_dict(spec, self.case.source, name or self.case.name)


def load_design(spec: str | Path) -> Design:
    """The :class:`Design` of a shipped case name or a spec file (with or without ``[design]``).
    Raises :class:`SpecError` naming the file and key, or :class:`DesignError` for a case the
    search cannot judge (a task that is not a crawl ahead)."""
    text = str(spec)
    path = SPECS_DIR / f"{text}.toml" if text in case_names() else Path(spec)
    if not (text in case_names() or path.suffix == ".toml" or path.exists()):
        raise SpecError(f"unknown case {text!r}: not a shipped case ({', '.join(case_names())}) "
                        "and not a spec file (.toml)")
    source = f"{text}.toml" if text in case_names() else str(path)
    case = case_from_dict(read_spec(path), source, default_name=path.stem)
    if case.task.kind != "crawl":
        raise DesignError(f"{source}: [task] kind = {case.task.kind!r}: msr design judges a design "
                          "by the distance a rotating field moves it ahead in 10 s (a crawl task); "
                          "design the robot of a crawl case (the same [robot] with [task] kind = "
                          "\"crawl\") and use the design for the other task")
    space = case.design or design_space(None, case.robot.tables["robot"], case.actuation.axes, source,
                                        case.robot_spec("accurate").magnetization)
    base = case.to_dict()
    base.pop(DESIGN_TABLE, None)  # the designs are robots, not searches
    return Design(case, base, space)


def run_design(spec: str | Path | Design, out: str | Path, settings: DesignSettings, *, resume: bool = False,
               force: bool = False, progress: Callable[[dict[str, Any]], None] | None = None
               ) -> dict[str, Any]:
    """Run (or continue) the design of ``spec`` (a shipped case, a spec file or a loaded
    :class:`Design`) into ``out``; returns the summary
    (``summary.json``: ``objective_start_m``, ``objective_best_m`` and the rest). ``progress``
    is called with each generation's state (generation, evaluations, best objective in m,
    elapsed s). Everything is checked before any simulation."""
    from .outputs import write_outputs

    settings.check()
    design = spec if isinstance(spec, Design) else load_design(spec)
    folder = normalized_path(out)
    _check_folder(folder, resume, force)
    with FolderLock(folder, option="--out"):
        _check_folder(folder, resume, force)  # again, under the lock
        record = _prepare(folder, design, settings, resume, force)
        mark_folder(folder, kind=DESIGN_KIND, subject=f"case {design.case.name}")
        state = _search(folder, design, settings, record, progress)
        record["outputs"] = list(OUTPUT_FILES)
        atomic_write_json(folder / DESIGN_JSON, record)
        summary = write_outputs(folder, design, settings, record, state)
        mark_folder(folder, kind=DESIGN_KIND, subject=f"case {design.case.name}")
    return summary


# -- the folder -------------------------------------------------------------------------------------

def _check_folder(folder: Path, resume: bool, force: bool) -> None:
    """Refuse, before any work, a folder that is not a design's (or not this request's)."""
    marker = read_marker(folder) if folder.is_dir() else None
    shown = display_path(folder)
    if marker is None or marker.get("kind") != DESIGN_KIND:
        if resume:
            if folder.exists() and any(folder.iterdir()):
                check_result_folder(folder, kind=DESIGN_KIND, force=True, option="--out")
            raise DesignError(f"--resume: {shown} holds no design to continue; leave out --resume "
                              "to start one")
        check_result_folder(folder, kind=DESIGN_KIND, force=True, option="--out")  # raises unless empty
        return
    # the design's own names, not the marker's list (which lists what the folder held when it was
    # written: a user's file saved there during a run would pass for the design's)
    foreign = [p.name for p in folder.iterdir() if p.name not in DESIGN_NAMES
               and not p.name.startswith(".msr")]
    if foreign:
        raise OutputPathError(f"--out {shown}: holds a design and files msr did not write "
                              f"({', '.join(sorted(foreign)[:5])}); move them away first")
    if resume and force:
        raise DesignError("--resume and --force: choose one (continue the design in "
                          f"{shown}, or replace it)")
    if not resume and not force:
        raise OutputPathError(f"--out {shown} holds a design ({marker.get('subject')}): continue "
                              "it with --resume, or replace it with --force")


def _prepare(folder: Path, design: Design, settings: DesignSettings, resume: bool,
             force: bool) -> dict[str, Any]:
    """The design's record (``design.json``): read back and checked on a resume, else written
    anew (after the earlier design's files are removed, with ``force``)."""
    spec = {**design.base, DESIGN_TABLE: design.space.to_dict()}
    if resume and (folder / DESIGN_JSON).exists():
        record = read_json(folder / DESIGN_JSON, fix="start the design afresh with --force")
        _check_same(record, spec, settings, folder)
        return record
    if force:
        for name in sorted(DESIGN_NAMES):
            path = folder / name
            remove_tree(path) if path.is_dir() else path.unlink(missing_ok=True)
    folder.mkdir(parents=True, exist_ok=True)
    record = {"format": "msr-design-v1", "case": design.case.name, "spec": spec,
              "settings": settings.recorded(), "start": None}
    atomic_write_json(folder / DESIGN_JSON, record)
    return record


def _check_same(record: Mapping[str, Any], spec: dict[str, Any], settings: DesignSettings,
                folder: Path) -> None:
    from ..sweep.run_records import first_difference

    for what, old, new in (("spec", record.get("spec"), spec),
                           ("settings", record.get("settings"), settings.recorded())):
        if _plain(old) != _plain(new):
            difference = first_difference(_plain(old), _plain(new))
            raise DesignError(f"--resume: the design in {display_path(folder)} was started with "
                              f"another {what} ({difference}); resume it with the same spec and "
                              "options, or start afresh with --force")


def _plain(data: Any) -> Any:
    """JSON's view of data (tuples as lists), so a record read back compares with a fresh one."""
    import json

    return json.loads(json.dumps(data))


# -- the search ---------------------------------------------------------------------------------------

def _variation_set(design: Design, settings: DesignSettings) -> VariationSet | None:
    return variation_set(design.start_spec(), settings.objective, corners=False)


def _start(folder: Path, design: Design, settings: DesignSettings, record: dict[str, Any]) -> dict[str, Any]:
    """The starting design under the search's own measure, a sweep of the periods (both senses):
    its objective and the best period, which the search starts from (recorded)."""
    if record.get("start"):
        return record["start"]
    space = design.space
    low, high = space.period_range
    periods = [p for p in settings.final_periods if low <= p <= high] or [math.sqrt(low * high)]
    began = time.perf_counter()
    records = evaluate_candidates(design.case, [design.base] * len(periods), periods,
                                  settings.physics, settings.search_duration, settings.workers,
                                  _variation_set(design, settings))
    best = max(records, key=lambda r: r["objective_m"])
    x0 = design.start_vector(best["period_s"])
    record["start"] = {"x0": [float(v) for v in x0], "objective_search_m": best["objective_m"],
                       "period_s": best["period_s"], "clockwise": best["clockwise"],
                       "sweep": records, "wall_s": time.perf_counter() - began}
    atomic_write_json(folder / DESIGN_JSON, record)
    return record["start"]


def _search(folder: Path, design: Design, settings: DesignSettings, record: dict[str, Any],
            progress: Callable[[dict[str, Any]], None] | None) -> SearchState:
    """Generations until the budget is spent, a checkpoint after each."""
    state_path = folder / STATE_FILE
    start = _start(folder, design, settings, record)
    if state_path.exists():
        state = SearchState.load(state_path)
    else:
        state = new_search(design.space, np.array(start["x0"]), settings.seed, settings.popsize,
                           settings.sigma0)
        state.best_x, state.best_objective = np.array(start["x0"]), start["objective_search_m"]
        state_path.parent.mkdir(exist_ok=True)
        state.save(state_path)
    variations = _variation_set(design, settings)

    def evaluate(vectors: list[NDArray[np.float64]]) -> list[dict[str, Any]]:
        specs = [design.space.spec_of(design.base, x) for x in vectors]
        periods = [design.space.period(x) for x in vectors]
        return evaluate_candidates(design.case, specs, periods, settings.physics,
                                   settings.search_duration, settings.workers, variations)

    trials = _popsize(state) * 2 * (1 if variations is None else len(variations[1]))
    last = 0.0
    while not _spent(state, settings, last, trials, float(start.get("wall_s", 0.0))):
        began = time.perf_counter()
        run_generation(state, design.space, evaluate)
        last = time.perf_counter() - began
        state.elapsed_s += last
        state.save(state_path)
        write_history(folder / HISTORY_CSV, design.space, state)
        mark_folder(folder, kind=DESIGN_KIND, subject=f"case {design.case.name}")
        if progress is not None:
            progress({"generation": state.generation, "evaluations": len(state.history),
                      "best_objective_m": state.best_objective, "elapsed_s": state.elapsed_s})
    return state


#: Wall time the figures, the report and the gait's GIF take beyond their simulations, s.
OUTPUT_OVERHEAD_S = 60.0


def _spent(state: SearchState, settings: DesignSettings, last_s: float, trials: int,
           start_s: float) -> bool:
    """Whether the budget (``--minutes``: the whole design, the starting sweep ``start_s`` and
    the final judgement included) leaves no room for another generation (``last_s``, of
    ``trials`` simulations) and the end."""
    if settings.generations is not None and state.generation >= settings.generations:
        return True
    if settings.minutes is None:
        return False
    if state.generation == 0:
        return False  # at least one generation
    trial_s = last_s / max(1, trials)  # wall time of one search simulation, the workers busy
    longer = settings.final_duration / settings.search_duration
    judged = 2 * 2 * (len(settings.final_periods) + 2)  # two designs, both senses, the periods
    if settings.objective == "robust":
        judged += 2 * 25  # each design's worst case over the default set with its corners
    gait = settings.workers * trial_s * longer  # one rollout, on one core
    end = judged * trial_s * longer + gait + OUTPUT_OVERHEAD_S
    return start_s + state.elapsed_s + last_s + end > 60.0 * settings.minutes


def _popsize(state: SearchState) -> int:
    return int(state.es.popsize)


def write_history(path: Path, space: DesignSpace, state: SearchState) -> None:
    """``history.csv``: one row per candidate: generation, candidate, objective (m), period (s),
    the better sense, both senses' distances (m), and the design (angles in degrees, magnitudes
    in A/m, elements per segment, the sizes searched in m)."""
    n = space.segments
    columns = ["generation", "candidate", "objective_m", "period_s", "clockwise", "distance_cw_m",
               "distance_ccw_m"]
    columns += [f"angle_deg_{k}" for k in range(n)]
    if space.directions == "3d":
        columns += [f"elevation_deg_{k}" for k in range(n)]
    columns += [f"magnitude_A_per_m_{k}" for k in range(n)] + [f"elements_{k}" for k in range(n)]
    columns += [f"{key}_m" for key, _, _ in space.sizes]
    with atomic_write(path) as f:
        writer = csv.writer(f)
        writer.writerow(columns)
        for row in state.history:
            segments = space.segment_list(np.array(row["vector"]))
            d = [np.array(s["direction"]) for s in segments]
            values = [row["generation"], row["candidate"], f"{row['objective_m']:.9g}",
                      f"{row['period_s']:.6g}", int(row["clockwise"]),
                      f"{row['distance_cw_m']:.9g}", f"{row['distance_ccw_m']:.9g}"]
            values += [f"{math.degrees(math.atan2(v[1], v[0])):.3f}" for v in d]
            if space.directions == "3d":
                values += [f"{math.degrees(math.asin(max(-1.0, min(1.0, v[2])))):.3f}" for v in d]
            values += [f"{s['magnitude']:.6g}" for s in segments] + [s["elements"] for s in segments]
            values += [f"{v:.6g}" for v in space.size_values(np.array(row["vector"])).values()]
            writer.writerow(values)


def final_settings(settings: DesignSettings, **changes: Any) -> DesignSettings:
    """``settings`` with changes (for tests and ``--quick``)."""
    return replace(settings, **changes)
