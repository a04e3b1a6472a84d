"""The yardstick that searches (``msr field baseline --case C`` without ``--period``): the rotating-field
baseline (:class:`~elastica_magnetic_rl.envs.yardsticks.RotatingFieldPolicy`) over a grid of
periods and both directions, each in a worker process; the distance of each, the period the field
actually turned at under the rate limit (:func:`elastica_magnetic.rotation.measure_rotation` on
the played field), a table, a figure of distance against period, and the farthest one's files as
a single-period ``msr field baseline`` writes them. :func:`yardstick_spec` writes a spec copy with the
best distance as the case's ``[yardstick] distance_10s``."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from typing import Any

from elastica_magnetic.io import atomic_write, atomic_write_json, atomic_write_text
from elastica_magnetic.result_file import result_file
from elastica_magnetic.results import check_result_folder, result_folder
from elastica_magnetic.robot_spec import ACTION_PERIOD
from elastica_magnetic.rotation import measure_rotation, min_rotation_period
from elastica_magnetic.specfile import SPEC_FILE

from ..cases.case import EVAL_DURATION, Case, case_from_dict, load_case
from ..envs.yardsticks import RotatingFieldPolicy, rotating_amplitude
from .generate import GENERATE_FILES, Pictures, generate
from .policy_files import check_policy_case

__all__ = ["DEFAULT_PERIODS", "PERIOD_TOLERANCE", "achieved_period", "periods_that_turn",
           "sweep_baseline", "yardstick_spec"]

#: What the sweep writes beside the best run's files (:data:`GENERATE_FILES`).
SWEEP_FILES = ("sweep.csv", "sweep.png", "sweep.json", *GENERATE_FILES)
#: The periods the sweep tries, s (each in both directions): from faster than the rate limit
#: allows at the paper's fields to slow turns.
DEFAULT_PERIODS = (0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0)
#: Relative difference between the asked and the achieved period beyond which it is reported.
PERIOD_TOLERANCE = 0.05


def achieved_period(fields_T: Any, asked_s: float, case: Case) -> dict[str, Any]:
    """The period a played field ``(steps, 3)`` (T, 100 Hz) turned at, against the ``asked_s``
    one: ``period_asked_s``, ``period_achieved_s`` (``inf``: it did not turn a full step),
    ``min_period_s`` (the rate limit's shortest uniform turn at the case's field limit) and
    ``warning`` (text, or ``None`` when they agree within :data:`PERIOD_TOLERANCE`); the rate
    limit is blamed only when the asked period is shorter than its shortest turn."""
    amplitude, increment = rotating_amplitude(case), min(case.actuation.increments[:2])
    fastest = min_rotation_period(amplitude, increment)
    achieved = math.inf
    if len(fields_T) >= 2:
        achieved = measure_rotation(fields_T).period_s
    warning = None
    if not (abs(achieved - asked_s) <= PERIOD_TOLERANCE * asked_s):
        warning = f"asked for a period of {asked_s:g} s, the field turned once per {achieved:.4g} s"
        played_s = len(fields_T) * ACTION_PERIOD
        if asked_s < fastest * (1.0 + PERIOD_TOLERANCE):  # the rate limit is the cause
            warning += (f" (at most {1e3 * increment:g} mT per axis per "
                        f"{ACTION_PERIOD:g} s: at {1e3 * amplitude:g} mT the shortest "
                        f"uniform turn takes {fastest:.4g} s)")
            if achieved < fastest:  # measured while the field was still growing from zero
                warning += (f"; it measured faster than {fastest:.4g} s because the field was still "
                            "growing from zero (a weaker field turns faster under the same limit): "
                            "a longer run measures the settled period")
        elif asked_s > played_s:
            warning += f" (the run, {played_s:g} s, is shorter than one period)"
        else:  # e.g. the ramp from a zero field takes a large part of a short run
            warning += f" (the rate limit allows it: its shortest uniform turn takes {fastest:.4g} s)"
    return {"period_asked_s": asked_s, "period_achieved_s": achieved, "min_period_s": fastest,
            "warning": warning}


def periods_that_turn(periods: tuple[float, ...], duration: float,
                      ) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """``periods`` (s) split into those a ``duration`` s run turns the field at least once in and
    those longer than it (a run shorter than one period never turns the field once: its distance
    and period mean nothing). Raises ``ValueError`` naming them when every period is longer."""
    kept = tuple(p for p in periods if p <= duration)
    dropped = tuple(p for p in periods if p > duration)
    if not kept:
        raise ValueError(f"every period asked ({', '.join(f'{p:g}' for p in dropped)} s) is longer "
                         f"than --duration {duration:g} s: the field would not turn once in a run; "
                         "give a longer --duration or shorter --periods")
    return kept, dropped


def _run_one(job: tuple[dict[str, Any], float, bool, float, str]) -> dict[str, Any]:
    """One baseline run of the sweep (in a worker): its distance and achieved period."""
    from .policy_runs import node_dx, run_policy

    spec, period, clockwise, duration, physics = job
    policy = RotatingFieldPolicy(load_case(spec), period, clockwise=clockwise)
    rollout = run_policy(policy, duration, physics, "zero", progress=False)
    return {"period_s": period, "clockwise": clockwise, "mid_dx_m": rollout.mid_dx,
            "node_dx_m": node_dx(rollout), "diverged": rollout.meta["diverged"],
            **{k: v for k, v in achieved_period(rollout.fields, period, policy.case).items()
               if k != "period_asked_s"}}


def sweep_baseline(
    case: str | Path | Case,
    periods: tuple[float, ...] = DEFAULT_PERIODS,
    duration: float = EVAL_DURATION,
    physics: str = "accurate",
    out: str | Path = "out/baseline",
    workers: int | None = None,
    progress: bool = True,
    figures: bool = True,
    gif: bool = True,
    force: bool = False,
) -> dict[str, Any]:
    """Run the rotating-field baseline for every period in ``periods`` (s) in both directions,
    ``duration`` s in ``physics`` from a zero field, ``workers`` processes at a time (default: one
    per core); write ``out/sweep.csv`` (one row per run), ``out/sweep.png`` (distance against the
    asked period, per direction) and the farthest run's files (:func:`generate` into ``out``), the
    folder written whole as the result of ``msr field baseline`` for the case (an earlier one replaced
    only with ``force``; checked before the runs).

    Periods longer than ``duration`` are left out (:func:`periods_that_turn`; all of them:
    ``ValueError``), listed in ``dropped_periods_s``.

    Returns ``{"case", "physics", "duration_s", "initial_field", "dropped_periods_s", "runs":
    [...], "best": {...}, "table_csv", "figure", "generate": <generate's result for the best>}``;
    each run has
    ``period_s``, ``clockwise``, ``mid_dx_m`` (m), ``diverged``, ``period_achieved_s``,
    ``min_period_s`` and ``warning``."""
    import os

    from ..sweep.backends import run_in_processes

    case = load_case(case)
    if not periods or not all(math.isfinite(p) and p > 0 for p in periods):
        raise ValueError(f"periods must be positive times in s, got {periods}")
    periods, dropped = periods_that_turn(tuple(periods), duration)
    subject = f"case {case.name}"
    check_policy_case(out, case)
    check_result_folder(out, kind="baseline", subject=subject, force=force, known_files=SWEEP_FILES)
    spec = case.to_dict()
    jobs = [(spec, float(p), cw, duration, physics) for p in periods for cw in (True, False)]
    workers = max(1, min(len(jobs), workers or os.cpu_count() or 1))
    if workers == 1:
        runs = [_run_one(job) for job in jobs]
    else:
        runs = run_in_processes(_run_one, jobs, workers)
    moving = [r for r in runs if not r["diverged"]]
    if not moving:
        raise ValueError(f"{case.name}: every baseline run diverged ({physics} physics)")
    best = max(moving, key=lambda r: r["mid_dx_m"])
    policy = RotatingFieldPolicy(case, best["period_s"], clockwise=best["clockwise"])
    with result_folder(out, kind="baseline", subject=subject, force=force,
                       known_files=SWEEP_FILES) as folder:
        generated = generate(policy, duration=duration, out=folder.path, physics=physics,
                             progress=progress, pictures=Pictures(figures, gif), kind="baseline")
        generated.pop("notes", None)
        table = _write_table(folder.path / "sweep.csv", runs)
        figure = (_sweep_figure(folder.path / "sweep.png", runs, best, case, physics, duration)
                  if figures else None)
        result = {"case": case.name, "physics": physics, "duration_s": duration,
                  "initial_field": "zero", "dropped_periods_s": list(dropped), "runs": runs,
                  "best": best, "table_csv": str(table),
                  "figure": str(figure) if figure else None, "generate": generated}
        result = _final_paths(result, folder)
        atomic_write_json(folder.path / "sweep.json", result)
        # generate wrote its generate.json naming this temporary folder: name where it will be
        generate_json = folder.path / "generate.json"
        atomic_write_json(generate_json, _final_paths(json.loads(generate_json.read_text()), folder))
    return result


def _final_paths(data: Any, folder: Any) -> Any:
    """``data`` with the paths under the result's temporary folder replaced by where they will be."""
    return json.loads(json.dumps(data, default=str).replace(str(folder.path), str(folder.final)))


def _write_table(path: Path, runs: list[dict[str, Any]]) -> Path:
    columns = ("period_s", "clockwise", "period_achieved_s", "mid_dx_m", "node_dx_m", "diverged")
    with atomic_write(path, "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(columns)
        for r in runs:
            writer.writerow([r[c] if r[c] is not None else "" for c in columns])
    return path


def _sweep_figure(path: Path, runs: list[dict[str, Any]], best: dict[str, Any], case: Case,
                  physics: str, duration: float) -> Path:
    """Distance against the asked period, one line per direction, the best run marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for clockwise, label in ((True, "clockwise (towards +x)"), (False, "counter-clockwise")):
        rows = sorted((r for r in runs if r["clockwise"] == clockwise and not r["diverged"]),
                      key=lambda r: r["period_s"])
        ax.plot([r["period_s"] for r in rows], [1e3 * r["mid_dx_m"] for r in rows], "o-", label=label)
    ax.plot([best["period_s"]], [1e3 * best["mid_dx_m"]], "k*", markersize=14,
            label=f"best: {best['period_s']:g} s, {1e3 * best['mid_dx_m']:+.1f} mm")
    fastest = best["min_period_s"]
    if fastest > 0:
        ax.axvline(fastest, color="grey", linestyle=":", label=f"rate limit: {fastest:.3g} s")
    ax.axhline(0.0, color="grey", linewidth=0.5)
    ax.set_xlabel("asked period of the rotating field, s")
    ax.set_ylabel(f"distance in {duration:g} s, mm")
    ax.set_title(f"{case.name}: rotating field at {1e3 * case.field_limit:g} mT ({physics} physics, "
                 "from a zero field)", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    with atomic_write(path, "wb") as handle:
        fig.savefig(handle, format="png", dpi=120)
    plt.close(fig)
    return path


def yardstick_spec(case: Case, best: dict[str, Any], path: str | Path, *,
                   force: bool = False, physics: str = "accurate",
                   duration: float = EVAL_DURATION, source: str | None = None) -> Path:
    """Write a copy of ``case``'s spec to ``path`` (TOML, units in comments) with ``best``'s distance
    (m, from a 10 s accurate-physics run) as ``[yardstick] distance_10s``, its field (``period``, s, and
    ``clockwise``) and a ``source`` saying which baseline it is. An existing file is replaced only with
    ``force`` (:func:`elastica_magnetic.result_file.result_file`). ``physics`` and ``duration`` (s) are
    what ``best`` was measured in: anything but 10 s of the accurate physics (a smoke run of ``msr loop
    --quick``) is written into the ``source`` as not a yardstick, and its field not written (the
    spec's own ``period`` and ``clockwise`` kept, if any), so the file never claims what was not
    measured. ``source``: the ``source`` written instead (a distance that is not ``best``'s sweep, e.g.
    the spec's own standing in for a smoke run; the field is then not written either)."""
    spec = case.to_dict()
    turn = "clockwise" if best["clockwise"] else "counter-clockwise"
    smoke = physics != "accurate" or abs(duration - EVAL_DURATION) > 1e-9
    # the field that made distance_10s: the sweep's best, measured as the yardstick is; else (a
    # smoke run, a distance standing in) the spec's own, if any (a training from the yardstick
    # must not clone a smoke field, which may have moved the robot backwards)
    field = (best["period_s"], best["clockwise"]) if source is None and not smoke else (
        case.yardstick.period, case.yardstick.clockwise)
    spec["yardstick"] = {
        "distance_10s": float(best["mid_dx_m"]),
        "source": source or f"msr field baseline sweep: rotating field {turn}, period "
                  f"{best['period_s']:g} s (turned once per {best['period_achieved_s']:.4g} s), "
                  f"{1e3 * best['mid_dx_m']:+.1f} mm in {duration:g} s, {physics} physics, field "
                  "from zero" + (" (a smoke run's stand-in, not a yardstick)" if smoke else ""),
        **({"period": float(field[0]), "clockwise": bool(field[1])} if field[0] is not None else {}),
    }
    if "period" in spec["yardstick"] and field[0] == best["period_s"] and \
            best["period_achieved_s"] > best["period_s"] * (1.0 + 1e-9):
        # the rate limit turned the field slower than asked: measured so, and the source says it, so
        # the copy's own check does not warn about it again (every command reading the copy would)
        accepted = spec.setdefault("checks", {}).setdefault("accept", [])
        if "yardstick.period" not in accepted:
            accepted.append("yardstick.period")
    copy = case_from_dict(spec, str(path), default_name=case.name)
    with result_file(path, force=force, option="--set-yardstick", kind=SPEC_FILE) as written:
        # a name the spec set itself (not its file's) is kept: the copy is the same case
        named = case.name != Path(case.source).stem
        atomic_write_text(written.path, copy.toml(with_name=named))
    return written.final
