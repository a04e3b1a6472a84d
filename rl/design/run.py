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

A folder that holds a design is continued with ``resume`` and replaced with ``force``: the new
design is then searched in a folder beside it and swapped in whole when it is finished (an
interrupted replacement leaves the earlier design as it was; it cannot be resumed, a new
``force`` starts it again); a finished design continued with ``resume`` is continued the same way,
beside it, and swapped in whole with its new end; anything else in the folder is refused before any
work. The end's
files are written beside the search's and moved into place together, so a design that has a
``summary.json`` is finished.
"""

from __future__ import annotations

import csv
import math
import os
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic.batch import batched_refusal
from elastica_magnetic.interrupts import signals_held
from elastica_magnetic.io import (
    OutputPathError,
    atomic_write,
    atomic_write_json,
    display_path,
    normalized_path,
)
from elastica_magnetic.locks import FolderLock, release_claim
from elastica_magnetic.result_markers import mark_folder, unrecorded_files
from elastica_magnetic.results import remove_tree, result_folder
from elastica_magnetic.specfile import SpecError, read_spec

from ..cases.case import EVAL_DURATION, SPECS_DIR, Case, case_from_dict, case_names
from ..cases.design_space import DESIGN_TABLE, DesignSpace, design_space
from ..shipping.baseline_sweep import DEFAULT_PERIODS
from .folder import (
    DESIGN_JSON,
    DESIGN_KIND,
    END_STAGING,
    HISTORY_CSV,
    OUTPUT_FILES,
    STATE_FILE,
    DesignError,
    check_folder,
    copy_search,
    design_files,
    holds_design,
    prepare_record,
    recover_leftovers,
)
from .search import (
    OBJECTIVES,
    SearchState,
    VariationSet,
    evaluate_candidates,
    new_search,
    run_generation,
    variation_set,
)

__all__ = ["Design", "DesignSettings", "load_design", "run_design"]

@dataclass(frozen=True)
class DesignSettings:
    """How ``msr design`` searches and judges. Durations in s, budgets in minutes.

    The search evaluates each candidate for ``search_duration`` s of ``physics`` (by default the
    judgement's own 10 s of the accurate physics: shorter runs rank designs differently, and the
    training physics' heavier robot walks differently under slow rotations; when the search
    measures less, its ``finalists`` are run again as judged before the best is chosen); the
    starting and the best design are then judged by the same sweep of rotating
    fields (``final_periods`` and the periods the search found, both senses) for
    ``final_duration`` s of ``final_physics``: the numbers the summary reports."""

    objective: str = "yardstick"
    seed: int = 0
    minutes: float | None = 30.0
    generations: int | None = None
    popsize: int | None = None  # None: CMA-ES's default, 4 + 3 ln(dimension)
    #: CMA-ES's first step, in the vector's units (0.12: ~22 degrees of a segment's direction; a
    #: 45-degree step breaks most gaits).
    sigma0: float = 0.12
    #: The best distinct candidates of the search run again at the judged duration and physics
    #: before the final judgement, which takes the best of them (the search's shorter runs rank
    #: designs differently from the judgement: a gait builds up over seconds).
    finalists: int = 6
    search_duration: float = EVAL_DURATION
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
        if self.finalists < 1:
            raise DesignError(f"--finalists must be >= 1, got {self.finalists}")
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
    shown = f"{text} (a shipped case)" if text in case_names() else source  # no file of that name here
    if case.task.kind != "crawl":
        raise DesignError(f"{shown}: [task] kind = {case.task.kind!r}: msr design judges a design "
                          "by the distance a rotating field moves it ahead in 10 s (a crawl task); "
                          "design the robot of a crawl case (the same [robot] with a uniform field's "
                          "[actuation], kind = \"field\", and [task] kind = \"crawl\") and use the "
                          "design for the other task")
    space = case.design or design_space(None, case.robot.tables["robot"], case.actuation.axes, source,
                                        case.robot_spec("accurate").magnetization)
    refusal = batched_refusal(case.robot_spec("accurate"), "msr design")
    if refusal:
        raise DesignError(f"{shown}: {refusal}")
    base = case.to_dict()
    base.pop(DESIGN_TABLE, None)  # the designs are robots, not searches
    return Design(case, _stable_for_sizes(base, space, source), space)


def _stable_for_sizes(base: dict[str, Any], space: DesignSpace, source: str) -> dict[str, Any]:
    """``base`` whose time steps hold for every size the search may choose: with size ranges,
    each physics' ``dt`` lowered (never raised) to the suggested step of the least stable corner
    of the ranges, so every candidate runs, and the best design is written, with a step
    ``msr case check`` calls stable. Units: m, s."""
    import copy
    import itertools
    import warnings

    from elastica_magnetic.specfile import PHYSICS_DEFAULTS, describe_robot
    from elastica_magnetic.stability import estimated_stable_time_step, suggested_time_step

    if not space.sizes:
        return base
    keys = [key for key, _, _ in space.sizes]
    stable = dict.fromkeys(PHYSICS_DEFAULTS, math.inf)
    for corner in itertools.product(*[(low, high) for _, low, high in space.sizes]):
        probe = copy.deepcopy(base)
        probe["robot"].update(zip(keys, corner, strict=True))
        probe["physics"] = {setting: {**(base.get("physics") or {}).get(setting, {}), "dt": 1e-7}
                            for setting in PHYSICS_DEFAULTS}
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # the corner's own oddities are the spec's
                description = describe_robot(probe, source)
        except SpecError as exc:
            sizes = ", ".join(f"{key} = {value:g} m" for key, value in zip(keys, corner, strict=True))
            raise DesignError(f"{source}: [design] the size ranges hold a robot that is not valid "
                              f"({sizes}): {exc}") from None
        for setting in PHYSICS_DEFAULTS:
            stable[setting] = min(stable[setting], estimated_stable_time_step(description.robot(setting))[0])
    out = copy.deepcopy(base)
    physics = out.setdefault("physics", {})
    for setting, defaults in PHYSICS_DEFAULTS.items():
        table = physics.setdefault(setting, {})
        if float(table.get("dt", defaults["dt"])) > stable[setting]:
            table["dt"] = suggested_time_step(stable[setting])
            table.setdefault("mass_scale", defaults["mass_scale"])
    return out


def run_design(spec: str | Path | Design, out: str | Path, settings: DesignSettings, *, resume: bool = False,
               force: bool = False, progress: Callable[[dict[str, Any]], None] | None = None
               ) -> dict[str, Any]:
    """Run (or continue) the design of ``spec`` (a shipped case, a spec file or a loaded
    :class:`Design`) into ``out``; returns the summary
    (``summary.json``: ``objective_start_m``, ``objective_best_m`` and the rest). ``progress``
    is called with each generation's state (generation, evaluations, best objective in m,
    elapsed s). Everything is checked before any simulation."""
    settings.check()
    design = spec if isinstance(spec, Design) else load_design(spec)
    folder = normalized_path(out)
    subject = f"case {design.case.name}"
    try:
        check_folder(folder, resume, force, subject)  # claims the folder first: a live writer is named
        recover_leftovers(folder)
        if force and holds_design(folder):
            # built beside and swapped in whole: the earlier design stays until the new one is done
            with result_folder(folder, kind=DESIGN_KIND, force=True, option="--out",
                               known_files=design_files(folder)) as result:
                summary = _design_into(result.path, design, settings, False, progress, replacing=True)
                result.subject = subject
            return summary
        if resume and (folder / "summary.json").is_file():
            # a finished design continued: its search goes on in a copy beside it, swapped in whole
            # with its new end (killed before, the finished design stays as it was, whole); its spec
            # and settings checked here first, so that a refusal names this folder, not the copy
            prepare_record(folder, design, settings, resume=True)
            with result_folder(folder, kind=DESIGN_KIND, force=True, option="--out",
                               known_files=design_files(folder)) as result:
                copy_search(folder, result.path)
                summary = _design_into(result.path, design, settings, True, progress, replacing=True)
                result.subject = subject
            return summary
        with FolderLock(folder, option="--out"):
            check_folder(folder, resume, force, subject)  # again, under the lock
            return _design_into(folder, design, settings, resume, progress)
    finally:
        release_claim(folder)


def _design_into(folder: Path, design: Design, settings: DesignSettings, resume: bool,
                 progress: Callable[[dict[str, Any]], None] | None, *, replacing: bool = False
                 ) -> dict[str, Any]:
    """The search and the end, in ``folder`` (held by the caller; ``replacing``: a folder beside
    the design it will replace)."""
    subject = f"case {design.case.name}"
    record = prepare_record(folder, design, settings, resume)
    mark_folder(folder, kind=DESIGN_KIND, subject=subject)
    state = _search(folder, design, settings, record, progress)
    record["outputs"] = list(OUTPUT_FILES)
    record["stopped"] = _stopped(state, settings)
    record["finalists"] = _finalists(design, settings, state, record.get("finalists"))
    atomic_write_json(folder / DESIGN_JSON, record)
    summary = _end(folder, design, settings, record, state, replacing)
    mark_folder(folder, kind=DESIGN_KIND, subject=subject)
    return summary


def _finalists(design: Design, settings: DesignSettings, state: SearchState,
               done: list[dict[str, Any]] | None) -> list[dict[str, Any]]:
    """The best ``settings.finalists`` distinct candidates of the search (the best so far among
    them), each run again under its own period, both senses, for ``final_duration`` s of
    ``final_physics``: records with ``vector``, ``objective_search_m`` and ``objective_m`` (the
    longer run's). ``done``: the records of an earlier end of the same search (reused)."""
    if settings.search_duration == settings.final_duration and settings.physics == settings.final_physics:
        return []  # the search measured what the judgement measures: its best is the finalist
    ranked = sorted(state.history, key=lambda r: -r["objective_m"])
    picked: list[NDArray[np.float64]] = [np.asarray(state.best_x, dtype=float)]
    searched = [float(state.best_objective)]
    for row in ranked:
        if len(picked) >= settings.finalists:
            break
        x = np.asarray(row["vector"], dtype=float)
        if not any(np.array_equal(x, y) for y in picked):
            picked.append(x)
            searched.append(float(row["objective_m"]))
    vectors = [[float(v) for v in x] for x in picked]
    if done and [r["vector"] for r in done] == vectors:
        return done
    records = evaluate_candidates(design.case, [design.space.spec_of(design.base, x) for x in picked],
                                  [design.space.period(x) for x in picked], settings.final_physics,
                                  settings.final_duration, settings.workers,
                                  _variation_set(design, settings))
    return [{**r, "vector": v, "objective_search_m": o}
            for r, v, o in zip(records, vectors, searched, strict=True)]


def _stopped(state: SearchState, settings: DesignSettings) -> dict[str, Any] | None:
    """What cut the search short of ``--generations`` (``None``: nothing); with ``--minutes`` alone,
    the budget always ends it (``generations_asked``: ``None``)."""
    if settings.generations is not None and state.generation >= settings.generations:
        return None
    return {"by": "--minutes", "minutes": settings.minutes, "generations": state.generation,
            "generations_asked": settings.generations}


def _end(folder: Path, design: Design, settings: DesignSettings, record: dict[str, Any],
         state: SearchState, replacing: bool) -> dict[str, Any]:
    """The end's files, written beside the search's and then moved into place together (a
    failure, a full disk, leaves the search whole and no end that looks finished)."""
    from .outputs import write_outputs

    staging = folder / END_STAGING
    remove_tree(staging)
    try:
        staging.mkdir()
        summary = write_outputs(staging, design, settings, record, state, folder)
    except (OSError, OutputPathError) as exc:
        remove_tree(staging)
        text = str(exc).replace(str(staging), str(folder))
        if replacing:  # the folder beside goes; the earlier design stays
            raise OutputPathError(f"{text}; the replacement design was not finished") from exc
        raise OutputPathError(f"{text}; the design in {display_path(folder)} is unfinished (its search "
                              "is whole): free space or fix the cause and continue with --resume") from exc
    except BaseException:
        remove_tree(staging)
        raise
    foreign = [f"{name}/{f}" for name in OUTPUT_FILES if (folder / name).is_dir()
               for f in unrecorded_files(folder / name)]
    if foreign:  # saved there while the design ran: never removed
        remove_tree(staging)
        raise OutputPathError(f"--out {display_path(folder)}: files msr did not write appeared in the "
                              f"design's folders while it ran ({', '.join(foreign[:5])}); the end was "
                              "not put in place: move them away and continue with --resume")
    with signals_held():
        for name in OUTPUT_FILES:
            if (staging / name).is_dir():
                remove_tree(folder / name)
            if os.path.lexists(staging / name):
                os.replace(staging / name, folder / name)
        remove_tree(staging)
    return summary


# -- the search ---------------------------------------------------------------------------------------

def _variation_set(design: Design, settings: DesignSettings) -> VariationSet | None:
    """The robots a robust search judges each candidate on: the default set with its corners
    (25), the set the final judgement uses (without them, the search cannot see the corners
    where both the magnetization is weak and the moduli stiff, and they set the worst case)."""
    return variation_set(design.start_spec(), settings.objective, corners=True)


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
        if settings.generations is not None and state.generation > settings.generations:
            import warnings

            from elastica_magnetic.plausibility import SettingNotAppliedWarning

            warnings.warn(f"--generations {settings.generations}: the search has {state.generation} "
                          "generations already; none is searched and none undone (its end is written "
                          "again from all of them)", SettingNotAppliedWarning, stacklevel=2)
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
    slower = (design.case.robot_spec(settings.final_physics).steps_per_action
              / design.case.robot_spec(settings.physics).steps_per_action)
    while not _spent(state, settings, last, trials, float(start.get("wall_s", 0.0)), slower):
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
           start_s: float, slower: float = 1.0) -> bool:
    """Whether the budget (``--minutes``: the whole design, the starting sweep ``start_s`` and
    the final judgement included) leaves no room for another generation (``last_s``, of
    ``trials`` simulations) and the end (``slower``: the judged physics' time steps per
    simulated second over the search's)."""
    if settings.generations is not None and state.generation >= settings.generations:
        return True
    if settings.minutes is None:
        return False
    if state.generation == 0:
        return False  # at least one generation
    trial_s = last_s / max(1, trials)  # wall time of one search simulation, the workers busy
    longer = settings.final_duration / settings.search_duration * slower
    same = settings.search_duration == settings.final_duration and settings.physics == settings.final_physics
    # both senses of the periods, for both designs (the start's reused from the search when it
    # measured the same), and the finalists run again when the search measured less
    judged = (1 if same and settings.objective == "yardstick" else 2) * 2 * (len(settings.final_periods) + 2)
    if not same:
        judged += settings.finalists * trials // max(1, _popsize(state))
    if settings.objective == "robust":
        # each design's worst case over the default set with its corners, under two fields
        judged += 2 * 2 * 25
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
