"""The end of ``msr design``: the starting and the best design judged by the same sweep of
rotating fields, and the files of the design folder (see :mod:`elastica_magnetic_rl.design.run`)."""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any

import numpy as np

from elastica_magnetic.io import atomic_write, atomic_write_json, atomic_write_text

from ..cases.case import EVAL_DURATION, case_from_dict
from ..reports.text import millimetres
from .evaluate import Trial, run_trials
from .search import DIVERGED_SCORE, SearchState, _worst, variant_specs, variation_set

__all__ = ["judge", "write_outputs"]


def judge(design, settings, x: np.ndarray | None, periods: list[float],
          known: dict[tuple[float, bool], float] | None = None,
          robust_fields: list[tuple[float, bool]] = ()) -> dict[str, Any]:
    """One design (the search vector ``x``; ``None``: the spec's own magnetization) under every
    period (s) in both senses for ``settings.final_duration`` s of ``settings.final_physics``:
    ``sweep`` (period, sense, distance in m), the best rotating field (``distance_m``,
    ``period_s``, ``clockwise``), and for the robust objective ``robust_m`` (the worst over the
    default variation set with its corners) under the better of that best field and
    ``robust_fields`` (period s, clockwise: the field the search found for the set), that
    field (``robust_field``) and its ``variants``.
    ``known``: distances (m, ``nan``: diverged) already measured by the same simulations, by
    ``(period, clockwise)``: not run again."""
    spec = design.base if x is None else design.space.spec_of(design.base, x)
    robot = variant_specs(design.case, spec, settings.final_physics, None)[0]
    known = known or {}
    trials = [Trial(robot, p, cw) for p in periods for cw in (True, False) if (p, cw) not in known]
    measured = dict(zip([(t.period, t.clockwise) for t in trials],
                        run_trials(design.case, trials, settings.final_duration, settings.workers),
                        strict=True))
    distances = [known.get((p, cw), measured.get((p, cw))) for p in periods for cw in (True, False)]
    sweep = [{"period_s": p, "clockwise": cw, "distance_m": None if math.isnan(d) else float(d)}
             for (p, cw), d in zip([(p, cw) for p in periods for cw in (True, False)], distances,
                                   strict=True)]
    finite = [s for s in sweep if s["distance_m"] is not None]
    best = max(finite, key=lambda s: s["distance_m"]) if finite else {
        "period_s": periods[0], "clockwise": True, "distance_m": None}
    result = {"sweep": sweep, "distance_m": best["distance_m"], "period_s": best["period_s"],
              "clockwise": best["clockwise"]}
    variations = variation_set(design.start_spec(), settings.objective, corners=True)
    if variations is not None:
        result.update(_robust(design, settings, spec, variations,
                              [(best["period_s"], best["clockwise"]), *robust_fields]))
    return result


def _robust(design, settings, spec: dict[str, Any], variations, fields: list[tuple[float, bool]]
            ) -> dict[str, Any]:
    """The worst distance (m) over the robots of ``variations`` under each field (period s,
    clockwise; the repeated ones once), in one batched simulation: the better field's
    ``robust_m``, ``robust_field`` and ``variants``."""
    # to 12 digits as the sweep's periods (a searched period is 5.999999999999999 s)
    fields = list(dict.fromkeys((float(f"{p:.12g}"), bool(cw)) for p, cw in fields))
    robots = variant_specs(design.case, spec, settings.final_physics, variations)
    varied = run_trials(design.case, [Trial(r, p, cw) for p, cw in fields for r in robots],
                        settings.final_duration, settings.workers).reshape(len(fields), len(robots))
    worst = [_worst(list(row)) for row in varied]
    k = int(np.argmax(worst))  # the first of equals: the nominal robot's best field
    return {"robust_m": worst[k],
            "robust_field": {"period_s": fields[k][0], "clockwise": fields[k][1]},
            "variants": [{"variant": v.label, "distance_m": None if math.isnan(d) else float(d)}
                         for v, d in zip(variations[1], varied[k], strict=True)]}


def _start_sweep(record: dict[str, Any], settings) -> dict[tuple[float, bool], float]:
    """The starting design's distances (m) the search's own start sweep measured, when the
    search runs the judgement's simulations (same physics and duration, the yardstick
    objective): the judgement reuses them."""
    if (settings.objective != "yardstick" or settings.physics != settings.final_physics
            or settings.search_duration != settings.final_duration):
        return {}
    known = {}
    for row in record["start"]["sweep"]:
        for clockwise, key in ((True, "distance_cw_m"), (False, "distance_ccw_m")):
            d = float(row[key])
            known[(float(row["period_s"]), clockwise)] = math.nan if d == DIVERGED_SCORE else d
    return known


def _search_best(state: SearchState, record: dict[str, Any]) -> dict[str, Any]:
    """The search's best candidate as a finalist's record (``vector``, its rotating field's
    ``period_s`` and ``clockwise``): its row of the history, or the start when none beat it."""
    best = [float(v) for v in state.best_x]
    found = next((r for r in state.history if r["vector"] == best), record["start"])
    return {"vector": best, "objective_m": 0.0, "period_s": found.get("period_s"),
            "clockwise": found.get("clockwise")}


def _searched_field(found: dict[str, Any], settings) -> list[tuple[float, bool]]:
    """The rotating field (period s, clockwise) the robust search found for a design (its start
    record, or a finalist's), judged beside the nominal robot's best; none for the yardstick
    objective or a record without one (a search that measured as judged keeps no finalists)."""
    if settings.objective != "robust" or found.get("period_s") is None or "clockwise" not in found:
        return []
    return [(float(found["period_s"]), bool(found["clockwise"]))]


def _objective(result: dict[str, Any], objective: str) -> float | None:
    return result.get("robust_m") if objective == "robust" else result["distance_m"]


def write_outputs(folder: Path, design, settings, record: dict[str, Any], state: SearchState,
                  final: Path | None = None) -> dict[str, Any]:
    """Judge the starting and the best design, write the result files into ``folder`` (their
    paths recorded as under ``final``, where they are moved after, default ``folder``); the
    summary."""
    from ..reports.design_figures import plot_convergence, plot_magnetization

    finalists = record.get("finalists") or [_search_best(state, record)]
    chosen = max(finalists, key=lambda r: r["objective_m"])  # the first of equals: the search's best
    best_x = np.asarray(chosen["vector"], dtype=float)
    periods = judged_periods(*settings.final_periods, float(record["start"]["period_s"]),
                             design.space.period(best_x))
    start = judge(design, settings, None, periods, _start_sweep(record, settings),
                  _searched_field(record["start"], settings))
    best = judge(design, settings, best_x, periods, robust_fields=_searched_field(chosen, settings))
    objective_start, objective_best = (_objective(start, settings.objective),
                                       _objective(best, settings.objective))
    improved = objective_best is not None and (objective_start is None or objective_best > objective_start)
    name = f"{design.case.name}-designed"
    best_case = _best_case(design, best_x, best, settings, name)
    atomic_write_text(folder / "best.toml", _best_toml(best_case, design, settings, state))
    _write_sweep(folder / "final_sweep.csv", start, best)
    summary = {
        "case": design.case.name, "designed_case": name, "objective": settings.objective,
        "objective_start_m": objective_start, "objective_best_m": objective_best,
        "ratio": (objective_best / objective_start if objective_start and objective_best is not None
                  and objective_start > 0 else None),
        "improved": bool(improved),
        "judged_in": {"physics": settings.final_physics, "duration_s": settings.final_duration,
                      "periods_s": periods, "senses": ["clockwise", "counter-clockwise"]},
        "start": _without_sweep(start), "best": _without_sweep(best),
        "best_segments": design.space.segment_list(best_x),
        "best_sizes_m": design.space.size_values(best_x),
        "search": {"generations": state.generation, "evaluations": len(state.history),
                   "popsize": int(state.es.popsize), "wall_s": state.elapsed_s,
                   "physics": settings.physics, "duration_s": settings.search_duration,
                   "best_objective_search_m": chosen.get("objective_search_m", state.best_objective),
                   "start_objective_search_m": record["start"]["objective_search_m"],
                   "seed": settings.seed, "stopped": record.get("stopped"),
                   "finalists": [{"objective_search_m": r.get("objective_search_m"),
                                  "objective_m": r["objective_m"], "period_s": r.get("period_s")}
                                 for r in record.get("finalists") or []],
                   "chosen_finalist": (record.get("finalists") or [chosen]).index(chosen)},
        "space": design.space.to_dict(),
    }
    atomic_write_json(folder / "summary.json", summary)
    plot_convergence(state.history, record["start"]["objective_search_m"], folder / "convergence.png")
    start_robot = design.case.robot_spec("accurate")
    plot_magnetization(start_robot.magnetization, best_case.robot_spec("accurate").magnetization,
                       start_robot.length, folder / "magnetization.png")
    atomic_write_text(folder / "report.md", _report(summary))
    _write_gait(folder / "gait", best_case, best, settings, (final or folder) / "gait")
    return summary


def _without_sweep(result: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in result.items() if k != "sweep"}


def _best_case(design, x, best: dict[str, Any], settings, name: str):
    """The best design's case, its yardstick the best rotating field's distance (none when the
    judgement was not 10 s of the accurate physics: a smoke run)."""
    spec = design.space.spec_of(design.base, x)
    spec["name"] = name
    # the starting robot's words describe its own magnetization: the design says what it is
    segments = design.space.segment_list(x)
    origin = design.case.description or design.case.name
    spec["description"] = (f"Designed by msr design from {design.case.name}: {len(segments)} segments "
                           f"searched ({settings.objective} objective). Started from: {origin}")
    if isinstance(spec["robot"].get("name"), str):
        spec["robot"]["name"] = f"{spec['robot']['name']}-designed"
    field = played_field(best, settings.objective)
    turn = "clockwise" if field["clockwise"] else "counter-clockwise"
    measured = settings.final_physics == "accurate" and abs(settings.final_duration - EVAL_DURATION) < 1e-9
    # a yardstick is 10 s of the accurate physics: a smoke run's (--quick) distance would be taken
    # by msr train and case check as the robot's 10 s target; the best.toml then has none
    spec.pop("yardstick", None)  # the starting robot's yardstick is of another magnetization
    if measured and field["distance_m"] is not None and field["distance_m"] > 0:
        spec["yardstick"] = {
            "distance_10s": float(field["distance_m"]),
            "source": (f"msr design: {field['words']} of the designed robot, {turn}, period "
                       f"{field['period_s']:.4g} s, {1e3 * field['distance_m']:+.1f} mm in "
                       f"{settings.final_duration:g} s, {settings.final_physics} physics, field from zero"),
            "period": float(field["period_s"]), "clockwise": bool(field["clockwise"])}
    return case_from_dict(spec, "best.toml", name)


def played_field(result: dict[str, Any], objective: str) -> dict[str, Any]:
    """The rotating field a judged design is meant to be driven by: for ``yardstick`` its best
    (the farthest, nominal robot), for ``robust`` the one with the best worst case over the
    variation set (``robust_field``); its ``period_s``, ``clockwise``, the nominal robot's
    ``distance_m`` (m) under it and ``words`` saying which it is."""
    if objective != "robust" or "robust_field" not in result:
        return {"period_s": result["period_s"], "clockwise": result["clockwise"],
                "distance_m": result["distance_m"], "words": "the best rotating field"}
    nominal = next(v["distance_m"] for v in result["variants"] if v["variant"] == "nominal")
    return {**result["robust_field"], "distance_m": nominal,
            "words": ("the rotating field with the best worst case over the default fabrication "
                      f"errors ({millimetres(result['robust_m'])} in the worst of "
                      f"{len(result['variants'])} robots)")}


def _best_toml(case, design, settings, state: SearchState) -> str:
    header = (f"# Designed by msr design from {design.case.source} (objective {settings.objective}, "
              f"seed {settings.seed}, {state.generation} generations, {len(state.history)} candidates).\n")
    return header + case.toml(with_name=True)


def _write_sweep(path: Path, start: dict[str, Any], best: dict[str, Any]) -> None:
    with atomic_write(path) as f:
        writer = csv.writer(f)
        writer.writerow(["design", "period_s", "clockwise", "distance_m"])
        for label, result in (("start", start), ("best", best)):
            for row in result["sweep"]:
                d = row["distance_m"]
                writer.writerow([label, f"{row['period_s']:.6g}", int(row["clockwise"]),
                                 "nan" if d is None else f"{d:.9g}"])


def _report(summary: dict[str, Any]) -> str:
    s, b, search = summary["start"], summary["best"], summary["search"]
    judged = summary["judged_in"]
    turn = {True: "clockwise", False: "counter-clockwise"}
    lines = [f"# Design of {summary['case']} ({summary['objective']} objective)", "",
             f"Judged by the same sweep of rotating fields ({len(judged['periods_s'])} periods, both "
             f"senses, {judged['duration_s']:g} s of the {judged['physics']} physics, field from zero).",
             "", "| design | objective | best rotating field | period | sense |", "|---|---|---|---|---|"]
    for label, r, obj in (("start", s, summary["objective_start_m"]),
                          ("best", b, summary["objective_best_m"])):
        lines.append(f"| {label} | {millimetres(obj)} | {millimetres(r['distance_m'])} | "
                     f"{r['period_s']:.3g} s | "
                     f"{turn[r['clockwise']]} |")
    if "robust_m" in b:
        lines += _robust_lines(s, b)
    ratio = summary["ratio"]
    lines += ["", f"Ratio best / start: {ratio:.2f}x." if ratio else "Ratio: undefined (the start "
              "does not move ahead).",
              "" if summary["improved"] else "The search did not beat the starting design.",
              f"Search: {search['generations']} generations, {search['evaluations']} candidates, "
              f"{search['wall_s'] / 60:.1f} min, {search['duration_s']:g} s runs of the "
              f"{search['physics']} physics, seed {search['seed']}."
              + (f" The {len(search['finalists'])} best distinct candidates were run again for "
                 f"{judged['duration_s']:g} s; the best of them (number {search['chosen_finalist'] + 1} "
                 "by the search's measure) is the design judged." if len(search["finalists"]) > 1 else "")
              + (_stopped_words(search["stopped"]) if search.get("stopped") else ""), "",
              "| segment | elements | direction (x, y, z) | magnitude (A/m) |", "|---|---|---|---|"]
    for k, seg in enumerate(summary["best_segments"]):
        d = ", ".join(f"{v:+.3f}" for v in seg["direction"])
        lines.append(f"| {k} | {seg['elements']} | {d} | {seg['magnitude']:.4g} |")
    if summary["best_sizes_m"]:
        lines += ["", "Sizes: " + ", ".join(f"{key} {1e3 * value:.3g} mm"
                                            for key, value in summary["best_sizes_m"].items()) + "."]
    return "\n".join(lines) + "\n"


def _robust_lines(start: dict[str, Any], best: dict[str, Any]) -> list[str]:
    """The report's table of both designs' worst cases (robust objective)."""
    turn = {True: "clockwise", False: "counter-clockwise"}
    lines = ["", f"Objective: the worst of the {len(best['variants'])} robots of the default fabrication "
             "errors (corners included) under the better of the nominal best field and the field the "
             "search found:", "", "| design | worst | its field | worst robot |", "|---|---|---|---|"]
    for label, r in (("start", start), ("best", best)):
        worst = min(r["variants"], key=lambda v: -math.inf if v["distance_m"] is None else v["distance_m"])
        field = r["robust_field"]
        lines.append(f"| {label} | {millimetres(r['robust_m'])} | {field['period_s']:.3g} s, "
                     f"{turn[field['clockwise']]} | {worst['variant']} |")
    return lines


def _write_gait(out: Path, case, best: dict[str, Any], settings, final: Path) -> None:
    """The best design under its field (:func:`played_field`), as ``msr field baseline`` writes it,
    into ``out``; ``generate.json`` names its files where they will be, under ``final``."""
    import json

    from ..envs.yardsticks import RotatingFieldPolicy
    from ..shipping.generate import Pictures, generate

    field = played_field(best, settings.objective)
    policy = RotatingFieldPolicy(case, field["period_s"], field["clockwise"])
    result = generate(policy, out=out, duration=settings.final_duration, physics=settings.final_physics,
                      progress=False, pictures=Pictures(gif=settings.gif), force=True, kind="baseline")
    written = str(Path(result["gait_csv"]).parent)  # as generate names the folder
    moved = json.dumps(result, default=str).replace(written, str(final.resolve()))
    atomic_write_json(out / "generate.json", json.loads(moved))


def judged_periods(*periods: float) -> list[float]:
    """The rotation periods (s) the final sweep judges, each once: to 12 digits, so that a period the
    search computes (the exponential of its logarithm, 0.9999999999999999) is the sweep's own."""
    return sorted({float(f"{p:.12g}") for p in periods})


def _stopped_words(stopped: dict[str, Any]) -> str:
    """The report's sentence on what ended the search (:func:`~.run._stopped`'s record)."""
    if stopped.get("generations_asked") is None:
        return f" Ended by --minutes {stopped['minutes']:g} after {stopped['generations']} generation(s)."
    return (f" Stopped by --minutes after {stopped['generations']} of the {stopped['generations_asked']} "
            "generations asked.")
