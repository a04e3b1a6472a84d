"""Pictures of open-loop runs: the robot's shapes and its trajectory."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from .io import atomic_save
from .openloop import OpenLoopResult

__all__ = ["plot_open_loop", "plot_tip_path"]


def plot_open_loop(
    result: OpenLoopResult,
    path: str | Path,
    title: str = "",
    reference: pd.DataFrame | None = None,
) -> Path:
    """Save a PNG: side view of the shapes over time, marker positions, height and field.

    Parameters
    ----------
    result : OpenLoopResult
    path : str or Path
        Output PNG.
    title : str
    reference : pandas.DataFrame, optional
        A trajectory with the same columns (e.g. the published one) drawn dashed for comparison.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig = plt.figure(figsize=(10, 8), constrained_layout=True)
    grid = fig.add_gridspec(3, 2)
    traj = result.trajectory
    sideways = [c for c in ("mid_z_m", "back_z_m", "front_z_m") if c in traj.columns]
    moved_sideways = bool(sideways) and float(np.abs(traj[sideways].to_numpy()).max()) > 1e-6
    ax_shape = fig.add_subplot(grid[0, 0] if moved_sideways else grid[0, :])
    if moved_sideways:  # a top view beside the side view: where the robot went on the floor
        _top_view(fig.add_subplot(grid[0, 1]), result, plt)
    ax_x = fig.add_subplot(grid[1, 0])
    ax_h = fig.add_subplot(grid[1, 1])
    ax_b = fig.add_subplot(grid[2, :])

    _side_view(ax_shape, result, plt)
    _markers_and_gait(ax_x, ax_h, traj, reference)
    _field_steps(ax_b, result.fields)
    if title:
        fig.suptitle(title)
    try:
        atomic_save(path, lambda tmp: fig.savefig(tmp, dpi=110))
    finally:
        plt.close(fig)
    return path


def _side_view(ax, result: OpenLoopResult, plt) -> None:
    """The shapes over time seen from the side (x-y, mm), coloured by time, and the ground."""
    colours = plt.cm.viridis(np.linspace(0.0, 1.0, len(result.shapes)))
    for (t, pos), colour in zip(result.shapes, colours, strict=True):
        ax.plot(1e3 * pos[0], 1e3 * pos[1], color=colour, lw=2, label=f"{t:.2f} s")
    ground = -result.spec.radius * 1e3 if result.spec.ground is not None else None
    if ground is not None:
        ax.axhline(ground, color="0.5", lw=1)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title("shapes (side view), colour = time")
    ax.legend(ncol=6, fontsize=7, loc="upper left")


def _markers_and_gait(ax_x, ax_h, traj: pd.DataFrame, reference: pd.DataFrame | None) -> None:
    """The markers' x and the height and span over time (mm), a reference dashed beside them."""
    for name, colour in (("back", "C0"), ("mid", "C1"), ("front", "C2")):
        ax_x.plot(traj.t_s, 1e3 * traj[f"{name}_x_m"], color=colour, label=name)
        if reference is not None:
            ax_x.plot(
                reference.t_s, 1e3 * reference[f"{name}_x_m"], "--", color=colour, lw=1,
                label=f"{name} (reference)",
            )
    ax_x.set_xlabel("t (s)")
    ax_x.set_ylabel("x (mm)")
    ax_x.legend(fontsize=7)

    ax_h.plot(traj.t_s, 1e3 * traj.height_max_m, label="height")
    ax_h.plot(traj.t_s, 1e3 * traj.span_m, label="span")
    if reference is not None:
        ax_h.plot(reference.t_s, 1e3 * reference.height_max_m, "--", lw=1, label="height (ref.)")
        ax_h.plot(reference.t_s, 1e3 * reference.span_m, "--", lw=1, label="span (ref.)")
    ax_h.set_xlabel("t (s)")
    ax_h.set_ylabel("mm")
    ax_h.legend(fontsize=7)


def _field_steps(ax, fields: np.ndarray) -> None:
    """The field ``(steps, 3)`` (T) held over each 0.01 s, in mT."""
    t_field = np.arange(fields.shape[0]) * 0.01
    for k, name in enumerate("xyz"):
        ax.step(t_field, 1e3 * fields[:, k], where="post", label=f"B{name}")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("field (mT)")
    ax.legend(fontsize=7)


def plot_tip_path(result: OpenLoopResult, source, path: str | Path, title: str = "") -> Path:
    """Save a PNG, top view (x-y): the path of the rod's last element centre over time, the rod's
    shapes, and the path of the field source's pose (a magnet's ``position`` or a coil's
    ``centre``) when it has one. Lengths in mm."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    trajectory = result.trajectory
    fig, ax = plt.subplots(figsize=(8, 5), constrained_layout=True)
    for k, (_, positions) in enumerate(result.shapes):
        shade = 0.2 + 0.8 * k / max(len(result.shapes) - 1, 1)
        ax.plot(1e3 * positions[0], 1e3 * positions[1], "-", color=(0.3, 0.3, 0.3, shade), lw=1,
                label="rod shapes" if k == len(result.shapes) - 1 else None)
    points = ax.scatter(1e3 * trajectory.front_x_m, 1e3 * trajectory.front_y_m, c=trajectory.t_s,
                        s=6, cmap="viridis", label="tip")
    fig.colorbar(points, ax=ax, label="t (s)", shrink=0.8)
    pose = getattr(source, "position", None) or getattr(source, "centre", None)
    if callable(pose):
        poses = np.array([pose(t) for t in trajectory.t_s])
        ax.plot(1e3 * poses[:, 0], 1e3 * poses[:, 1], "r--", lw=1.2, label="magnet / coil centre")
        ax.plot(1e3 * poses[-1, 0], 1e3 * poses[-1, 1], "rs")
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.legend(fontsize=8, loc="best")
    ax.set_title(title or "tip path", fontsize=10)
    atomic_save(path, lambda tmp: fig.savefig(tmp, dpi=110))
    plt.close(fig)
    return path


def _top_view(ax, result: OpenLoopResult, plt) -> None:
    """The shapes and the middle's path seen from above (+y): x to the right, the robot's start
    left (-z) up, mm."""
    colours = plt.cm.viridis(np.linspace(0.0, 1.0, len(result.shapes)))
    for (_, pos), colour in zip(result.shapes, colours, strict=True):
        ax.plot(1e3 * pos[0], -1e3 * pos[2], color=colour, lw=2)
    traj = result.trajectory
    ax.plot(1e3 * traj.mid_x_m, -1e3 * traj.mid_z_m, "k--", lw=1, label="middle's path")
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("-z, the start's left (mm)")
    ax.set_title("seen from above, colour = time")
    ax.legend(fontsize=7, loc="best")
