"""The pictures of the tasks with targets: a top view of the paths to a goto ring of targets, and
the tip's paths to a tip-reach case's held-out targets."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .figures import MM, _figure, _save

__all__ = ["TOP_VIEW", "plot_heading_view", "plot_ring", "plot_rings_beside", "plot_tip_paths",
           "plot_tip_paths_beside", "plot_top_view"]

#: The file of a goto rollout's top view (:func:`plot_top_view`).
TOP_VIEW = "top_view.png"


def plot_ring(rows: Sequence[dict[str, Any]], paths: Sequence[NDArray[np.float64]],
              path: str | Path, title: str = "") -> Path:
    """Top view (seen from above: +x to the right, the start's left, -z, up) of the middle node's
    path to each target: ``rows`` of :func:`~elastica_magnetic_rl.shipping.goto.goto_result`,
    ``paths`` one ``(T, 2)`` (x, z; m) per row. Targets reached are green, missed red; the circles
    are the tolerance."""
    fig = _figure((6.0, 6.0))
    reached = sum(bool(r["success"]) for r in rows)
    _draw_ring(fig.add_subplot(1, 1, 1), rows, paths, title or f"{reached} of {len(rows)} targets reached")
    return _save(fig, path)


def plot_rings_beside(runs: dict[str, Sequence[dict[str, Any]]],
                      paths: dict[str, Sequence[NDArray[np.float64]]], path: str | Path,
                      title: str = "") -> Path:
    """Several controllers' rings on the same targets, side by side (each as :func:`plot_ring`):
    ``runs`` maps a label to its rows of :func:`~elastica_magnetic_rl.shipping.goto.goto_result`,
    ``paths`` the label to one middle-node path ``(T, 2)`` (x, z; m) per row."""
    fig = _figure((5.2 * len(runs), 5.6))
    for k, (label, rows) in enumerate(runs.items()):
        reached = sum(bool(r["success"]) for r in rows)
        _draw_ring(fig.add_subplot(1, len(runs), k + 1), rows, paths[label],
                   f"{label}: {reached} of {len(rows)} reached")
    if title:
        fig.suptitle(title)
    return _save(fig, path)


def _draw_ring(ax: Any, rows: Sequence[dict[str, Any]], paths: Sequence[NDArray[np.float64]],
               title: str) -> None:
    """One ring's top view into ``ax`` (:func:`plot_ring`)."""
    from matplotlib.patches import Circle

    for row, xz in zip(rows, paths, strict=True):
        color = "tab:green" if row["success"] else "tab:red"
        ax.plot(MM * xz[:, 0], -MM * xz[:, 1], color=color, lw=1.0, alpha=0.8)
        ax.plot(MM * xz[-1, 0], -MM * xz[-1, 1], "o", color=color, ms=3)
        centre = (MM * row["target_x_m"], -MM * row["target_z_m"])
        ax.add_patch(Circle(centre, MM * row["tolerance_m"], fill=False, color=color, lw=1.0))
        ax.plot(*centre, "+", color="black", ms=6)
    if paths:
        ax.plot(MM * paths[0][0, 0], -MM * paths[0][0, 1], "s", color="black", ms=5, label="start")
    _floor_axes(ax, title, "upper right")


def plot_top_view(xz: NDArray[np.float64], targets: Sequence[dict[str, Any]], tolerance: float,
                  path: str | Path, title: str = "") -> Path:
    """Top view (as :func:`plot_ring`) of one goto rollout: the middle node's path ``xz`` ``(T, 2)``
    (x, z; m) and its targets in order (one, or a path's waypoints: ``x_m``, ``z_m`` and
    ``reached_s``, s or ``None``), numbered, each with its tolerance circle (``tolerance``, m):
    green where reached, red where not."""
    from matplotlib.patches import Circle

    fig = _figure((6.0, 6.0))
    ax = fig.add_subplot(1, 1, 1)
    ax.plot(MM * xz[:, 0], -MM * xz[:, 1], color="tab:blue", lw=1.0, label="middle node")
    ax.plot(MM * xz[0, 0], -MM * xz[0, 1], "s", color="black", ms=5, label="start")
    ax.plot(MM * xz[-1, 0], -MM * xz[-1, 1], "o", color="tab:blue", ms=4, label="end")
    if len(targets) > 1:
        ax.plot([MM * t["x_m"] for t in targets], [-MM * t["z_m"] for t in targets], ":", color="grey",
                lw=0.8)
    for k, target in enumerate(targets, start=1):
        color = "tab:green" if target["reached_s"] is not None else "tab:red"
        centre = (MM * target["x_m"], -MM * target["z_m"])
        ax.add_patch(Circle(centre, MM * tolerance, fill=False, color=color, lw=1.0))
        ax.plot(*centre, "+", color="black", ms=6)
        if len(targets) > 1:
            ax.annotate(str(k), centre, textcoords="offset points", xytext=(4, 4), fontsize=8)
    reached = sum(t["reached_s"] is not None for t in targets)
    _floor_axes(ax, title or f"{reached} of {len(targets)} targets reached", "best")
    return _save(fig, path)


def plot_heading_view(xz: NDArray[np.float64], start_heading: float, heading: float, path: str | Path,
                      title: str = "") -> Path:
    """Top view (as :func:`plot_top_view`) of a rollout crawling along a commanded heading: the
    middle node's path ``xz`` ``(T, 2)`` (x, z; m) and the commanded line from its start, at
    ``heading`` rad from the start's heading ``start_heading`` (rad; both counter-clockwise seen
    from above), dashed, as long as the path goes along it (at least the path's extent)."""
    fig = _figure((6.0, 6.0))
    ax = fig.add_subplot(1, 1, 1)
    shown = np.column_stack([MM * xz[:, 0], -MM * xz[:, 1]])  # -z up: the start's left
    direction = np.array([math.cos(start_heading + heading), math.sin(start_heading + heading)])
    reach = max(float(np.max(np.abs((shown - shown[0]) @ direction))), 1.0)
    line = shown[0] + np.outer([0.0, 1.2 * reach], direction)
    ax.plot(line[:, 0], line[:, 1], "--", color="grey", lw=1.0, label="commanded heading")
    ax.plot(shown[:, 0], shown[:, 1], color="tab:blue", lw=1.0, label="middle node")
    ax.plot(*shown[0], "s", color="black", ms=5, label="start")
    ax.plot(*shown[-1], "o", color="tab:blue", ms=4, label="end")
    _floor_axes(ax, title, "best")
    return _save(fig, path)


def _floor_axes(ax: Any, title: str, legend: str) -> None:
    """A top view's title, axes (mm; -z up: the start's left), equal scale, grid and legend."""
    ax.set_title(title)
    ax.set_xlabel("x (mm, ahead of the start)")
    ax.set_ylabel("-z (mm, the start's left)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    ax.legend(loc=legend, fontsize=8)


def plot_tip_paths(rows: Sequence[dict[str, Any]], paths: NDArray[np.float64], path: str | Path,
                   title: str = "") -> Path:
    """The tip's path to each held-out target of a tip-reach run, seen from above (x, y) and from
    the side (x, z): ``rows`` of :func:`~elastica_magnetic_rl.shipping.tip_reach.write_targets`,
    ``paths`` ``(T, N, 3)`` m. Targets reached are green, missed red (a cross each, the tip's end a
    dot); the square is the straight tip at the start."""
    fig = _figure((11.0, 5.0))
    targets = [[row[f"target_{axis}_m"] for axis in "xyz"] for row in rows]
    _draw_tip_paths(fig, 0, 1, targets, [bool(r["success"]) for r in rows], paths)
    reached = sum(bool(r["success"]) for r in rows)
    fig.suptitle(title or f"{reached} of {len(rows)} targets reached")
    return _save(fig, path)


def plot_tip_paths_beside(runs: dict[str, dict[str, Any]], paths: dict[str, NDArray[np.float64]],
                          path: str | Path, title: str = "") -> Path:
    """The tip's paths of several controllers on the same targets, one row of views (from above:
    x, y; from the side: x, z) per controller: ``runs`` maps a label to a result of
    :func:`~elastica_magnetic_rl.shipping.tip_reach.run_targets` (``targets_m``, ``success``,
    ``successes``), ``paths`` the label to its tips ``(T, N, 3)`` m. Colours as
    :func:`plot_tip_paths`."""
    fig = _figure((11.0, 4.6 * len(runs)))
    for k, (label, run) in enumerate(runs.items()):
        heading = f"{label}: {run['successes']} of {len(run['targets_m'])} within the tolerance at the end"
        _draw_tip_paths(fig, k, len(runs), run["targets_m"], [bool(s) for s in run["success"]], paths[label],
                        heading)
    if title:
        fig.suptitle(title)
    return _save(fig, path)


def _draw_tip_paths(fig: Any, row: int, n_rows: int, targets: Sequence[Sequence[float]],
                    success: Sequence[bool], paths: NDArray[np.float64], heading: str = "") -> None:
    """One row of :func:`plot_tip_paths`' two views into ``fig`` (row ``row`` of ``n_rows``):
    targets (m, one ``(x, y, z)`` each), whether each was reached, the tips ``(T, N, 3)`` m."""
    for k, (a, b, label) in enumerate(((0, 1, "y"), (0, 2, "z"))):
        ax = fig.add_subplot(n_rows, 2, 2 * row + k + 1)
        for i, (target, ok) in enumerate(zip(targets, success, strict=True)):
            color = "tab:green" if ok else "tab:red"
            ax.plot(MM * paths[:, i, a], MM * paths[:, i, b], color=color, lw=1.0, alpha=0.8)
            ax.plot(MM * target[a], MM * target[b], "x", color=color, ms=6)
            ax.plot(MM * paths[-1, i, a], MM * paths[-1, i, b], "o", color=color, ms=3,
                    label="tip at the end" if i == 0 else None)
        ax.plot(MM * paths[0, 0, a], MM * paths[0, 0, b], "s", color="black", ms=5, label="tip at the start")
        ax.set_xlabel("x (mm, along the clamped catheter)")
        ax.set_ylabel(f"{label} (mm)")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
        ax.legend(loc="upper left", fontsize=8)
        if heading and k == 0:
            ax.set_title(heading, loc="left", fontsize=10)
