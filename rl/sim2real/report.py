"""The robustness report read by a person: a text table and a figure (matplotlib, PNG)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from elastica_magnetic.io import atomic_save

from ..reports.text import millimetres

__all__ = ["plot_identify", "plot_robustness", "plot_tip_robustness", "robustness_table"]

_MODE_NAMES = {"open_loop": "open loop", "closed_loop": "closed loop"}
#: A tip-reach study's two controllers (:data:`~elastica_magnetic_rl.sim2real.tip_robustness.TIP_MODES`).
_TIP_MODE_NAMES = {"policy": "policy", "yardstick": "yardstick"}


def _mm(distance: float | None, fraction: float | None = None) -> str:
    if distance is None:
        return "diverged"
    text = millimetres(distance)
    return text + (f" ({100 * fraction:.0f} %)" if fraction is not None else "")


def robustness_table(report: dict[str, Any]) -> str:
    """The report as text: one line per variant (distance in mm and, in brackets, the fraction of
    the yardstick where the run is comparable with it, 10 s of the accurate physics), then per
    mode the nominal, worst and 10th-percentile distance (and, in another physics or duration,
    the worst and 10th percentile as fractions of the nominal robot in the same physics). A tip-reach
    study's: :func:`tip_robustness_table`."""
    if "targets_m" in report:
        return tip_robustness_table(report)
    modes = [m for m in _MODE_NAMES if m in report["summary"]]
    width = max(len(v["label"]) for v in report["variants"])
    yard = report["yardstick_m"]
    comparable = report.get("yardstick_comparable", True)
    actor = (report.get("design") or {}).get("actor")
    lines = [f"{report['case']}: {report['waveform']}",
             *([f"policy (closed loop): {actor['summary']}"] if actor and "closed_loop" in modes else []),
             f"{report['physics']} physics, {report['duration_s']:g} s; yardstick "
             + (f"{1e3 * yard:.1f} mm in 10 s (accurate physics)" if yard else "none")
             + ("" if comparable or not yard else
                f": not comparable with {report['duration_s']:g} s of the {report['physics']} "
                "physics, so no percentage of it is given (run --physics accurate --duration 10 "
                "for those; below: percentages of the nominal robot, same physics)"), ""]
    lines.append(f"{'variant':<{width}}  " + "  ".join(f"{_MODE_NAMES[m]:>18}" for m in modes))
    for v in report["variants"]:
        cells = [_mm(v[m]["distance_m"], v[m]["fraction_of_yardstick"]) for m in modes]
        lines.append(f"{v['label']:<{width}}  " + "  ".join(f"{c:>18}" for c in cells))
    lines.append("")
    for m in modes:
        s = report["summary"][m]
        worst, p10 = s["worst_fraction"], s["p10_fraction"]
        if not comparable:  # fractions of the nominal robot in the same physics
            worst, p10 = s.get("worst_of_nominal"), s.get("p10_of_nominal")
        of = "" if comparable else " of nominal"
        if "target_m" in s:  # a reach case: how far from the target each robot ends
            nominal = ("" if s["nominal_error_m"] is None
                       else f" ({1e3 * s['nominal_error_m']:.2f} mm from it)")
            lines.append(f"{_MODE_NAMES[m]}: target {1e3 * s['target_m']:+.1f} mm; nominal "
                         f"{_mm(s['nominal_m'])}{nominal}, worst {_mm(s['worst_m'])} ({s['worst_variant']}, "
                         f"{1e3 * s['worst_error_m']:.2f} mm from it)"
                         + (f", {len(s['diverged'])} diverged" if s["diverged"] else ""))
            continue
        still = (" (the nominal robot does not move: no percentage of it)"
                 if s.get("nominal_still") and not comparable else "")
        lines.append(f"{_MODE_NAMES[m]}: nominal {_mm(s['nominal_m'], s['nominal_fraction'])}, worst "
                     f"{_mm(s['worst_m'], worst)}{of if worst is not None else ''} "
                     f"({s['worst_variant']}), 10th percentile {_mm(s['p10_m'], p10)}"
                     f"{of if p10 is not None else ''}{still}"
                     + (f", {len(s['diverged'])} diverged" if s["diverged"] else ""))
    return "\n".join(lines)


def _variation_panels(count: int) -> tuple[Any, Any, int]:
    """A figure of one panel per variation (at most 4 a row, a shared y axis): the figure, its
    axes (flat) and the number of columns."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    n = max(count, 1)
    cols = min(n, 4)
    rows = math.ceil(n / cols)
    fig = Figure(figsize=(3.6 * cols + 0.6, 3.2 * rows + 0.9), constrained_layout=True)
    FigureCanvasAgg(fig)
    return fig, np.atleast_1d(fig.subplots(rows, cols, sharey=True, squeeze=False)).ravel(), cols


def _label_panel(ax: Any, variation: dict[str, Any], nominal: float) -> None:
    """A variation's panel: the nominal setting as a vertical line, the setting's name and unit."""
    ax.axvline(nominal, color="0.8", lw=0.8, zorder=0)
    name = variation["name"]
    unit = "value" if variation["absolute"] else "x nominal"
    ax.set_xlabel(f"{name} ({unit})", fontsize=8 if len(name) > 30 else 10)
    ax.grid(alpha=0.3)


def _finish_panels(axes: Any, used: int, cols: int, ylabel: str) -> None:
    """The panels past ``used`` hidden, the y label on each row's first, the legend on the first."""
    for ax in axes[used:]:
        ax.set_visible(False)
    for ax in axes[::cols]:
        ax.set_ylabel(ylabel)
    axes[0].legend(fontsize=7, loc="best")


def plot_robustness(report: dict[str, Any], path: str | Path) -> Path:
    """One panel per variation: the distance (mm) of every variant against that variation's
    setting (factor or value), open loop (blue circles) and closed loop (orange triangles); the
    one-at-a-time variants and the nominal robot joined by a line, the others (corners, samples)
    as small points; the yardstick and 80 % of it as horizontal lines (for a 10 s run: the
    yardstick is the distance in 10 s)."""
    variations = report["variations"]
    fig, axes, cols = _variation_panels(len(variations))
    styles = {"open_loop": ("C0", "o"), "closed_loop": ("C1", "^")}
    yard = report["yardstick_m"]
    variants = report["variants"]
    for ax, variation in zip(axes, variations, strict=False):
        name = variation["name"]
        others = [w["name"] for w in variations if w["name"] != name]
        nominal = variants[0]["settings"]
        for mode, (colour, marker) in styles.items():
            if mode not in report["summary"]:
                continue
            points = [(v["settings"][name], v[mode]["distance_m"]) for v in variants
                      if v[mode]["distance_m"] is not None]
            if points:
                xs, ys = zip(*points, strict=True)
                ax.scatter(xs, 1e3 * np.array(ys), s=12, color=colour, marker=marker, alpha=0.35,
                           linewidths=0)
            line = sorted((v["settings"][name], v[mode]["distance_m"]) for v in variants
                          if v[mode]["distance_m"] is not None
                          and all(v["settings"][o] == nominal[o] for o in others)
                          and v["kind"] in ("nominal", "one-at-a-time"))
            if line:
                xs, ys = zip(*line, strict=True)
                ax.plot(xs, 1e3 * np.array(ys), color=colour, marker=marker, ms=6, lw=1.8,
                        label=_MODE_NAMES[mode])
        if yard and report.get("yardstick_comparable", abs(report["duration_s"] - 10.0) < 1e-9):
            ax.axhline(1e3 * yard, color="0.3", ls="--", lw=1, label=f"yardstick {1e3 * yard:.1f} mm")
            ax.axhline(0.8 * 1e3 * yard, color="0.5", ls=":", lw=1, label="80 % of it")
        _label_panel(ax, variation, nominal[name])
    _finish_panels(axes, len(variations), cols, f"distance in {report['duration_s']:g} s (mm)")
    summary = report["summary"]
    worst = ", ".join(f"{_MODE_NAMES[m]} worst {_mm(s['worst_m'], s['worst_fraction'])}"
                      for m, s in summary.items())
    fig.suptitle(f"{report['case']}, {report['physics']} physics, {report['duration_s']:g} s: "
                 f"{worst}\nlines: one parameter at a time; points: all corners and samples",
                 fontsize=10)
    path = Path(path)
    atomic_save(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))
    return path


def _reached(run: dict[str, Any], targets: int) -> str:
    if run.get("successes") is None:
        return "failed"
    return f"{run['successes']}/{targets} ({1e3 * run['median_m']:.2f} mm)"


def tip_robustness_table(report: dict[str, Any]) -> str:
    """A tip-reach study as text: per variant, the targets the policy and the yardstick reached and
    the median final distance (mm), then per controller the nominal, worst and mean successes, and on
    how many variants the policy reached at least as many targets as the yardstick."""
    n = len(report["targets_m"])
    width = max(len(v["label"]) for v in report["variants"])
    lines = [f"{report['case']}: {n} held-out targets, tolerance {1e3 * report['tolerance_m']:g} mm, "
             f"{report['physics']} physics, {report['duration_s']:g} s each; reached (median final "
             "distance)", "",
             f"{'variant':<{width}}  " + "  ".join(f"{name:>20}" for name in _TIP_MODE_NAMES.values())]
    actor = (report.get("design") or {}).get("actor")
    if actor:  # a run's: which of its actors is the policy
        lines.insert(1, f"policy: {actor['summary']}")
    for v in report["variants"]:
        cells = [f"{_reached(v[m], n):>20}" for m in _TIP_MODE_NAMES]
        lines.append(f"{v['label']:<{width}}  " + "  ".join(cells))
    lines.append("")
    for mode, name in _TIP_MODE_NAMES.items():
        s = report["summary"][mode]
        if s["worst_successes"] is None:
            lines.append(f"{name}: every run failed")
            continue
        lines.append(f"{name}: nominal {s['nominal_successes']}/{n}, worst {s['worst_successes']}/{n} "
                     f"({s['worst_variant']}), mean {s['mean_successes']:.1f}/{n}"
                     + (f", {len(s['failed'])} failed" if s["failed"] else ""))
    lines.append(f"the policy did at least as well as the yardstick (more targets reached, or as many "
                 f"and a median final distance no larger) on {report['policy_at_least_yardstick']} of "
                 f"{report['variants_compared']} variants"
                 + ("" if report.get("any_reached", True) else
                    f"; neither reached any of the {n} targets on any variant"))
    return "\n".join(lines)


def plot_tip_robustness(report: dict[str, Any], path: str | Path) -> Path:
    """One panel per variation: the median final distance from the held-out targets (mm) of the
    policy (orange triangles) and the yardstick (grey squares) on every variant against that
    variation's setting, the task's tolerance as a line; the one-at-a-time variants and the nominal
    catheter joined by a line, the others (corners, samples) as small points. The title gives each
    controller's fewest targets reached."""
    variations, variants = report["variations"], report["variants"]
    fig, axes, cols = _variation_panels(len(variations))
    styles = {"policy": ("C1", "^"), "yardstick": ("0.4", "s")}
    nominal = variants[0]["settings"]
    for ax, variation in zip(axes, variations, strict=False):
        name = variation["name"]
        others = [w["name"] for w in variations if w["name"] != name]
        for mode, (colour, marker) in styles.items():
            points = [(v["settings"][name], 1e3 * v[mode]["median_m"]) for v in variants
                      if v[mode].get("successes") is not None]
            if points:
                xs, ys = zip(*points, strict=True)
                ax.scatter(xs, ys, s=12, color=colour, marker=marker, alpha=0.35, linewidths=0)
            line = sorted((v["settings"][name], 1e3 * v[mode]["median_m"]) for v in variants
                          if v[mode].get("successes") is not None
                          and v["kind"] in ("nominal", "one-at-a-time")
                          and all(v["settings"][o] == nominal[o] for o in others))
            if line:
                xs, ys = zip(*line, strict=True)
                ax.plot(xs, ys, color=colour, marker=marker, ms=6, lw=1.8, label=_TIP_MODE_NAMES[mode])
        ax.axhline(1e3 * report["tolerance_m"], color="0.3", ls="--", lw=1, label="tolerance")
        ax.set_ylim(bottom=0.0)
        _label_panel(ax, variation, nominal[name])
    _finish_panels(axes, len(variations), cols,
                   f"median final distance, {len(report['targets_m'])} targets (mm)")
    n = len(report["targets_m"])
    worst = ", ".join(f"{_TIP_MODE_NAMES[m]} reached at worst {s['worst_successes']}/{n}"
                      for m, s in report["summary"].items())
    fig.suptitle(f"{report['case']}, {report['physics']} physics, {report['duration_s']:g} s per target: "
                 f"{worst}\nlines: one parameter at a time; points: all corners and samples", fontsize=10)
    path = Path(path)
    atomic_save(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))
    return path


def plot_identify(report: dict[str, Any], measured: Any, path: str | Path) -> Path:
    """Measured against simulated motion of each tracked point: x and y (and z, a catheter's tip)
    displacement from the first frame (mm) over time; measured as dots, the fitted robot as lines,
    the nominal robot dashed. ``report`` is
    :func:`~elastica_magnetic_rl.sim2real.identify.identify`'s result (with ``predicted``),
    ``measured`` the :class:`~elastica_magnetic_rl.sim2real.tracking.MeasuredTrajectory`."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    shown = measured.displacements()
    dims = shown.shape[2]  # x and y (a crawler's side view), or x, y and z (a catheter's tip)
    fig = Figure(figsize=(11, 3.25 * dims), constrained_layout=True)
    FigureCanvasAgg(fig)
    axes = fig.subplots(dims, 1, sharex=True)
    for j, point in enumerate(measured.points):
        colour = f"C{j % 10}"
        for c, ax in enumerate(axes):
            ax.plot(measured.times, 1e3 * shown[:, j, c], ".", ms=3, color=colour,
                    label=f"{point} measured" if c == 0 else None)
            ax.plot(measured.times, 1e3 * report["predicted"]["fitted"][:, j, c], "-", lw=1.4,
                    color=colour, label=f"{point} fitted" if c == 0 else None)
            ax.plot(measured.times, 1e3 * report["predicted"]["nominal"][:, j, c], "--", lw=0.9,
                    color=colour, alpha=0.6)
    for ax, axis in zip(axes, "xyz", strict=False):
        ax.set_ylabel(f"{axis} displacement (mm)")
    axes[-1].set_xlabel("time (s)")
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7, ncol=min(len(measured.points), 6), loc="best")
    fitted = ", ".join(f"{name} x{f['factor']:.3f} "
                       + (f"[{f['interval'][0]:.3f}, {f['interval'][1]:.3f}]"
                          if f.get("interval") is not None else
                          "(not judged)" if f.get("identifiable", False) is None else "(not identifiable)")
                       for name, f in report["fitted"].items())
    r = report["residual_m"]
    fig.suptitle(f"{report['physics']} physics: {fitted}\nresidual RMS {1e3 * r['rms']:.3f} mm (nominal "
                 f"robot, dashed: {1e3 * r['nominal_rms']:.3f} mm)", fontsize=10)
    path = Path(path)
    atomic_save(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))
    return path
