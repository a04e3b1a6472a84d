"""Figures of training runs and generated gaits (matplotlib, PNG and GIF; no pyplot state).

:func:`make_figures` regenerates everything from a folder (the ``msr policy figures`` command):

- a **training output** (``DIR``, ``DIR/<case>``, or one run ``DIR/<case>/seed<k>``, holding
  ``episodes.csv`` files): learning curves across seeds, EMA-smoothed, mean with the min-max spread
  and the individual seeds, x = environment steps (:func:`plot_learning_curves`);
- a **generate output** (holding ``rollout.npz``): positions and velocities of the front, middle and
  back (paper Fig. S4C-D), field waveforms (Fig. S4E), the field points in polar coordinates
  (Fig. 3D), height, span and contact strength of both ends (Fig. 3B-C), Q-value heat maps over the
  action grid at the start and at the states of maximum and minimum height (Fig. 5, when the
  policy's critic is available), a filmstrip PNG and an animated GIF of the gait.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from elastica_magnetic.io import atomic_save

from ..envs.rollout import ROLLOUT_NPZ, Rollout
from ..runfiles.logs import read_log
from ..runfiles.rundir import RunDir

__all__ = [
    "animate_gait",
    "ema",
    "find_runs",
    "make_figures",
    "plot_field_polar",
    "plot_field_waveforms",
    "plot_filmstrip",
    "plot_height_span_contact",
    "plot_learning_curves",
    "plot_positions_velocities",
    "plot_q_heatmaps",
    "q_value_states",
    "rollout_figures",
]

MM, MT = 1e3, 1e3  # m -> mm, T -> mT


def _figure(figsize: tuple[float, float], **kw: Any):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, **kw)
    FigureCanvasAgg(fig)
    return fig


def _save(fig, path: str | Path, dpi: int = 110) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return atomic_save(path, lambda tmp: fig.savefig(tmp, dpi=dpi))


# ----------------------------------------------------------------------------------------------
# Learning curves
# ----------------------------------------------------------------------------------------------
def ema(values: Sequence[float], alpha: float = 0.2) -> NDArray[np.float64]:
    """Exponential moving average ``s_k = alpha x_k + (1 - alpha) s_{k-1}``, ``s_0 = x_0``."""
    values = np.asarray(values, dtype=np.float64)
    out = np.empty_like(values)
    acc = values[0] if values.size else 0.0
    for k, v in enumerate(values):
        acc = v if k == 0 else alpha * v + (1.0 - alpha) * acc
        out[k] = acc
    return out


def _read_evaluations(run_dir: Path) -> pd.DataFrame:
    """A run's evaluations, every row checked (a damaged log is a ``ValueError`` naming the file,
    row and column, not a ``KeyError`` or a ``TypeError`` in the plotting)."""
    rows = read_log(RunDir(run_dir).evaluations_csv, ("global_step", "mean_return"))
    return pd.DataFrame({
        "global_step": [int(float(r["global_step"])) for r in rows],
        "mean_return": [float(r["mean_return"]) for r in rows],
    })


def _read_episodes(run_dir: Path) -> pd.DataFrame:
    rows = read_log(RunDir(run_dir).episodes_csv, ("global_step", "return"))
    return pd.DataFrame({
        "global_step": [int(r["global_step"]) for r in rows],
        "return": [float(r["return"]) for r in rows],
    })


def find_runs(path: str | Path) -> dict[str, list[Path]]:
    """Run directories (holding ``episodes.csv``) under ``path``, grouped by case folder.

    ``path`` may be a run, a case folder of runs, or a training output of case folders. Refined
    runs (``seed<k>/refined``) are left out: they continue in another physics.
    """
    path = Path(path)
    if RunDir(path).has_episodes():
        return {path.parent.name or path.name: [path]}
    groups: dict[str, list[Path]] = {}
    for csv_path in sorted(path.rglob(RunDir.EPISODES_CSV)):
        run = csv_path.parent
        if RunDir.REFINED in run.relative_to(path).parts:
            continue
        groups.setdefault(run.parent.name if run.parent != path else path.name, []).append(run)
    return groups


def plot_learning_curves(
    runs: Sequence[str | Path], path: str | Path, title: str = "", alpha: float = 0.2,
    n_grid: int = 200,
) -> Path:
    """Episode return against environment steps over seeds: per-seed EMA (thin), their mean (thick)
    and the min-max spread (shaded), on the step range every seed has reached (so the mean is
    always over all seeds).

    The return of a 20 s episode is ``1e4 x`` the middle node's displacement in m (the authors'
    ``10 x mm``), so 100 = 1 cm per episode. Runs with evaluations during training
    (``evaluations.csv``) get a second panel: the distance of each evaluation (10 s from a zero
    field, deterministic), mm.
    """
    runs = [Path(run) for run in runs]
    evaluated = [run for run in runs if RunDir(run).evaluations_csv.is_file()]
    fig = _figure((7, 6.5 if evaluated else 4), constrained_layout=True)
    if evaluated:
        ax, ax_eval = fig.subplots(2, 1, sharex=True, height_ratios=(3, 2))
    else:
        ax, ax_eval = fig.add_subplot(), None
    curves = []
    for k, run in enumerate(runs):
        ep = _read_episodes(run)
        if ep.empty:
            continue
        smooth = ema(ep["return"].to_numpy(), alpha)
        steps = ep["global_step"].to_numpy()
        ax.plot(steps, smooth, lw=0.8, alpha=0.5, label=run.name, color=f"C{k % 10}")
        curves.append((steps, smooth))
        if ax_eval is not None and run in evaluated:
            ev = _read_evaluations(run)
            # reward = 1e4 x displacement (m) = 10 x mm
            ax_eval.plot(ev["global_step"], ev["mean_return"] / 10.0, "o-", ms=3, lw=0.8,
                         color=f"C{k % 10}", label=run.name)
    physics = _runs_physics(runs)
    if ax_eval is not None:
        ax_eval.set_xlabel("environment steps")
        ax_eval.set_ylabel(f"evaluation: 10 s, {physics} physics,\nfrom zero field (mm)")
        ax_eval.grid(alpha=0.3)
        if ax_eval.get_legend_handles_labels()[0]:
            ax_eval.legend(fontsize=7, ncol=2)
    if curves:
        grid = np.linspace(max(c[0][0] for c in curves), min(c[0][-1] for c in curves), n_grid)
        values = np.full((len(curves), n_grid), np.nan)
        for k, (steps, smooth) in enumerate(curves):
            inside = (grid >= steps[0]) & (grid <= steps[-1])
            values[k, inside] = np.interp(grid[inside], steps, smooth)
        with np.errstate(all="ignore"), _quiet_nan_warnings():
            mean = np.nanmean(values, axis=0)
            low, high = np.nanmin(values, axis=0), np.nanmax(values, axis=0)
        ax.fill_between(grid, low, high, color="k", alpha=0.12, lw=0, label="min-max over seeds")
        ax.plot(grid, mean, color="k", lw=2, label=f"mean of {len(curves)} seed(s)")
    if ax_eval is None:
        ax.set_xlabel("environment steps")
    ax.set_ylabel(f"training episode return\n(EMA, alpha = {alpha:g}; {physics} physics)")
    ax.set_title(title or "learning curves")
    ax.grid(alpha=0.3)
    if curves:
        ax.legend(fontsize=7, ncol=2)
    else:  # a run shorter than one episode: an empty curve, said on the figure
        ax.text(0.5, 0.5, "no finished episode: the learning curve is empty", transform=ax.transAxes,
                ha="center", va="center")
    return _save(fig, path)


def _runs_physics(runs: Sequence[Path]) -> str:
    """The physics the runs trained (and were evaluated) in, from their ``run.json``: one name,
    ``"a, b"`` when they differ, ``"training"`` (the default of ``msr train``) when none says."""
    import json

    found = []
    for run in runs:
        try:
            physics = json.loads(RunDir(run).run_json.read_text()).get("physics")
        except (OSError, ValueError, AttributeError):
            physics = None
        if physics and physics not in found:
            found.append(str(physics))
    return ", ".join(found) or "training"


class _quiet_nan_warnings:
    def __enter__(self):
        import warnings

        self._ctx = warnings.catch_warnings()
        self._ctx.__enter__()
        warnings.simplefilter("ignore", RuntimeWarning)

    def __exit__(self, *exc):
        return self._ctx.__exit__(*exc)


# ----------------------------------------------------------------------------------------------
# Gait figures
# ----------------------------------------------------------------------------------------------
def plot_positions_velocities(trajectory: pd.DataFrame, path: str | Path, title: str = "") -> Path:
    """x of the back, middle and front (element centres, as ``trajectory.csv``) and their
    velocities (central differences), against time (paper Fig. S4C-D)."""
    fig = _figure((8, 6), constrained_layout=True)
    ax_x, ax_v = fig.subplots(2, 1, sharex=True)
    t = trajectory["t_s"].to_numpy()
    for name, colour in (("front", "C2"), ("mid", "C1"), ("back", "C0")):
        x = trajectory[f"{name}_x_m"].to_numpy()
        ax_x.plot(t, MM * (x - x[0]), color=colour, label=name)
        v = np.gradient(x, t) if t.size > 1 else np.zeros_like(x)
        ax_v.plot(t, MM * v, color=colour, lw=0.9, label=name)
    ax_x.set_ylabel("x displacement (mm)")
    ax_v.set_ylabel("velocity (mm/s)")
    ax_v.set_xlabel("t (s)")
    for ax in (ax_x, ax_v):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    if title:
        fig.suptitle(title)
    return _save(fig, path)


def plot_field_waveforms(
    fields: NDArray[np.float64], path: str | Path, limit: float | None = None, title: str = ""
) -> Path:
    """B_x, B_y (and B_z where it is not zero: a three-axis waveform) and the amplitude (mT)
    against time, zero-order hold at 100 Hz (Fig. S4E)."""
    fig = _figure((8, 3.5), constrained_layout=True)
    ax = fig.add_subplot()
    t = np.arange(fields.shape[0] + 1) * 0.01
    three_axis = bool(np.any(fields[:, 2] != 0.0))
    for k, name in ((0, "B_x"), (1, "B_y"), (2, "B_z"))[: 3 if three_axis else 2]:
        ax.stairs(MT * fields[:, k], t, label=name, lw=1.2, baseline=None)
    amplitude = np.hypot(np.hypot(fields[:, 0], fields[:, 1]), fields[:, 2])
    ax.stairs(MT * amplitude, t, label="|B|", color="0.4", lw=0.8, baseline=None, ls="--")
    if limit is not None:
        for s in (-1, 1):
            ax.axhline(s * MT * limit, color="0.6", lw=0.6, ls=":")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("field (mT)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, ncol=3)
    ax.set_title(title or "field waveforms")
    return _save(fig, path)


def plot_field_polar(
    fields: NDArray[np.float64], path: str | Path, limit: float | None = None, title: str = ""
) -> Path:
    """The field points (angle, amplitude in mT) in polar coordinates, coloured by time (Fig. 3D):
    the x-y part of the field (a three-axis waveform's B_z is in :func:`plot_field_waveforms`)."""
    fig = _figure((5, 5), constrained_layout=True)
    ax = fig.add_subplot(projection="polar")
    angle = np.arctan2(fields[:, 1], fields[:, 0])
    amplitude = MT * np.hypot(fields[:, 0], fields[:, 1])
    points = ax.scatter(angle, amplitude, c=np.arange(fields.shape[0]) * 0.01, s=6, cmap="viridis")
    if limit is not None:
        ax.set_rmax(MT * limit)
    fig.colorbar(points, ax=ax, shrink=0.7, label="t (s)")
    ax.set_title(title or "field points (mT)")
    return _save(fig, path)


def plot_height_span_contact(rollout: Rollout, path: str | Path, t_max: float | None = 3.0) -> Path:
    """Normalised height and span (Fig. 3B) and contact strength of the back and front nodes
    (Fig. 3C) over ``[0, t_max]`` s (the paper shows 0-3 s; ``None``: the whole run).

    Height is the largest element-centre height, span the x distance back to front; both are
    normalised to [0, 1] over the window (their ranges in mm are in the legend). Contact strength is
    the observation's contact indicator: ``1 + 1e4 * penetration[m]`` while touching, else 0.
    """
    traj = rollout.trajectory
    t = traj["t_s"].to_numpy()
    window = t <= (t_max if t_max is not None else np.inf) + 1e-9
    fig = _figure((8, 6), constrained_layout=True)
    ax_h, ax_c = fig.subplots(2, 1, sharex=True)
    for name, column, colour in (("height", "height_max_m", "C3"), ("span", "span_m", "C0")):
        v = traj[column].to_numpy()[window]
        lo, hi = float(v.min()), float(v.max())
        norm = (v - lo) / (hi - lo) if hi > lo else np.zeros_like(v)
        ax_h.plot(t[window], norm, color=colour,
                  label=f"{name} ({MM * lo:.2f}-{MM * hi:.2f} mm)")
    ax_h.set_ylabel("normalised")
    ax_h.legend(fontsize=8)
    contact = rollout.contact()
    ax_c.plot(t[window], contact[window, 0], color="C0", label="back (node 0)")
    ax_c.plot(t[window], contact[window, -1], color="C2", label="front (last node)")
    ax_c.set_ylabel("contact strength")
    ax_c.set_xlabel("t (s)")
    ax_c.legend(fontsize=8)
    for ax in (ax_h, ax_c):
        ax.grid(alpha=0.3)
    return _save(fig, path)


def q_value_states(rollout: Rollout) -> list[tuple[str, int]]:
    """Chosen states for Q heat maps: the start, the maximum height, and the minimum height after
    that maximum (the flattest point of the gait); as ``(label, index into observations)``."""
    h = rollout.trajectory["height_max_m"].to_numpy()
    k_max = int(np.argmax(h))
    states = [("start (t = 0)", 0), (f"max height (t = {rollout.times[k_max]:.2f} s)", k_max)]
    if k_max + 1 < h.size:
        k_min = k_max + 1 + int(np.argmin(h[k_max + 1:]))
        states.append((f"min height (t = {rollout.times[k_min]:.2f} s)", k_min))
    # Only states where an action was taken (the last observation has none).
    return [(label, min(k, rollout.n_steps - 1)) for label, k in states]


def plot_q_heatmaps(
    critic, actor, states: Sequence[tuple[str, NDArray[np.float32]]], path: str | Path,
    max_increment: float = 0.3e-3, n_grid: int = 51, title: str = "",
) -> Path:
    """Heat maps of ``Q1(s, a)`` over the 2-D action grid at the given states (paper Fig. 5), axes
    in mT of field increment; the actor's action is marked (x) and the grid maximum (+). A
    three-axis actor's maps are the (dB_x, dB_y) slice at the dB_z it chose in that state.

    ``critic`` is a :class:`~elastica_magnetic_rl.td3.algorithm.TwinCritic`, ``actor`` an
    :class:`~elastica_magnetic_rl.td3.algorithm.Actor` (normalised
    actions).
    """
    import torch

    a = np.linspace(-1.0, 1.0, n_grid, dtype=np.float32)
    ax_grid, ay_grid = np.meshgrid(a, a)  # rows: a_y, columns: a_x
    actions = torch.from_numpy(np.stack([ax_grid.ravel(), ay_grid.ravel()], axis=1))
    fig = _figure((4.2 * len(states), 3.9), constrained_layout=True)
    axes = np.atleast_1d(fig.subplots(1, len(states)))
    extent = [-MT * max_increment, MT * max_increment] * 2
    for ax, (label, obs) in zip(axes, states, strict=True):
        obs_t = torch.as_tensor(np.asarray(obs, dtype=np.float32).reshape(1, -1))
        with torch.no_grad():
            chosen = actor(obs_t)[0].numpy()
            grid = actions
            if chosen.shape[0] > 2:  # the slice through the actor's own dB_z
                held = np.broadcast_to(chosen[2:], (actions.shape[0], chosen.shape[0] - 2))
                grid = torch.cat([actions, torch.from_numpy(held.copy())], dim=1)
            q = critic.q1(obs_t.expand(actions.shape[0], -1), grid).numpy().reshape(n_grid, n_grid)
        image = ax.imshow(q, origin="lower", extent=extent, cmap="viridis", aspect="equal")
        fig.colorbar(image, ax=ax, shrink=0.8, label="Q1")
        iy, ix = np.unravel_index(int(np.argmax(q)), q.shape)
        scale = MT * max_increment
        ax.plot(scale * a[ix], scale * a[iy], "+", color="k", ms=12, mew=2, label="max Q",
                clip_on=False, zorder=5)
        ax.plot(scale * chosen[0], scale * chosen[1], "x", color="r", ms=10, mew=2,
                label="action chosen", clip_on=False, zorder=6)
        ax.set_xlabel("dB_x (mT)")
        ax.set_ylabel("dB_y (mT)")
        at_z = f", at dB_z {scale * chosen[2]:+.2f}" if chosen.shape[0] > 2 else ""
        ax.set_title(f"{label}\nchosen ({scale * chosen[0]:+.2f}, {scale * chosen[1]:+.2f}) mT, "
                     f"max Q at ({scale * a[ix]:+.2f}, {scale * a[iy]:+.2f}) mT{at_z}", fontsize=8)
    axes[0].legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.18), ncol=2)
    if title:
        fig.suptitle(title)
    return _save(fig, path)


def _shape_axes_limits(positions: NDArray[np.float64], radius: float, length: float):
    x, y = MM * positions[:, 0, :], MM * positions[:, 1, :]
    pad = 0.05 * MM * length
    return (float(x.min()) - pad, float(x.max()) + pad,
            -MM * radius - pad, max(float(y.max()), 0.1 * MM * length) + pad)


def _draw_field_arrow(ax, field: NDArray[np.float64], limit: float, origin: tuple[float, float],
                      length_mm: float):
    scale = 0.2 * length_mm / limit
    return ax.annotate("", xy=(origin[0] + scale * field[0], origin[1] + scale * field[1]),
                       xytext=origin, arrowprops={"arrowstyle": "->", "color": "C3", "lw": 1.8})


def plot_filmstrip(
    rollout: Rollout, path: str | Path, n_frames: int = 8, span: float | None = 2.0
) -> Path:
    """Side views of the robot at ``n_frames`` evenly spaced times over ``[0, span]`` s (one gait
    cycle or two; ``None``: the whole run), each with the field arrow and its amplitude."""
    times = rollout.times
    t_end = times[-1] if span is None else min(span, times[-1])
    idx = np.unique(np.searchsorted(times, np.linspace(0.0, t_end, n_frames) - 1e-9))
    meta = rollout.meta
    length, radius, limit = meta["length_m"], meta["radius_m"], meta["field_limit_T"]
    ncols = min(4, len(idx))
    nrows = int(math.ceil(len(idx) / ncols))
    height = max(float(rollout.positions[:, 1, :].max()), 0.1 * length)
    panel_h = 3.2 * (MM * (height + radius) + 1.5) / (1.2 * MM * length) + 0.75
    fig = _figure((3.2 * ncols, panel_h * nrows), constrained_layout=True)
    axes = np.atleast_1d(fig.subplots(nrows, ncols, sharey=True, squeeze=False)).ravel()
    for ax in axes[len(idx):]:
        ax.set_visible(False)
    for ax, k in zip(axes[: len(idx)], idx, strict=True):
        x, y = MM * rollout.positions[k, 0], MM * rollout.positions[k, 1]
        centre = 0.5 * (x.min() + x.max())
        half = 0.6 * MM * length
        ax.axhline(-MM * radius, color="0.4", lw=1)
        ax.plot(x, y, "-", color="C0", lw=2.5, solid_capstyle="round")
        ax.plot(x[rollout.positions.shape[2] // 2], y[rollout.positions.shape[2] // 2], "o",
                color="C1", ms=3)
        field = rollout.fields[min(k, rollout.n_steps - 1)] if k > 0 else np.zeros(3)
        _draw_field_arrow(ax, field, limit, (centre + 0.55 * half, MM * 0.75 * height), MM * length)
        ax.set_xlim(centre - half, centre + half)
        ax.set_ylim(-MM * radius - 0.5, MM * height + 1.0)
        ax.set_aspect("equal")
        ax.set_title(f"t = {times[k]:.2f} s\n|B| = {MT * math.hypot(field[0], field[1]):.2f} mT",
                     fontsize=8)
        ax.tick_params(labelsize=7)
        ax.set_xlabel("x (mm)", fontsize=7)
    for ax in axes[::ncols]:
        ax.set_ylabel("y (mm)", fontsize=7)
    return _save(fig, path, dpi=120)


def animate_gait(rollout: Rollout, path: str | Path, fps: int = 20, dpi: int = 80) -> Path:
    """Animated GIF of the gait (side view, the field arrow, time), ``fps`` frames per simulated
    second (real time), written with matplotlib's ``PillowWriter``."""
    from matplotlib.animation import PillowWriter

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    meta = rollout.meta
    length, radius, limit = meta["length_m"], meta["radius_m"], meta["field_limit_T"]
    times, positions = rollout.times, rollout.positions
    stride = max(1, int(round(1.0 / (fps * 0.01))))
    frames = list(range(0, times.size, stride))
    if frames[-1] != times.size - 1:
        frames.append(times.size - 1)
    x0, x1, y0, y1 = _shape_axes_limits(positions, radius, length)
    fig = _figure((7, max(2.0, 7 * (y1 - y0) / (x1 - x0) + 0.8)))
    ax = fig.add_axes((0.08, 0.18, 0.9, 0.72))
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.axhline(-MM * radius, color="0.4", lw=1)
    ax.set_xlabel("x (mm)")
    (line,) = ax.plot([], [], "-", color="C0", lw=3, solid_capstyle="round")
    (trace,) = ax.plot([], [], "-", color="C1", lw=0.8, alpha=0.6)
    text = ax.set_title("")
    mid = positions.shape[2] // 2
    arrow_origin = (x1 - 0.12 * (x1 - x0), y1 - 0.35 * (y1 - y0))
    arrow = None
    writer = PillowWriter(fps=fps)

    def write(tmp: Path) -> None:
        nonlocal arrow
        with writer.saving(fig, str(tmp), dpi):
            for k in frames:
                line.set_data(MM * positions[k, 0], MM * positions[k, 1])
                trace.set_data(MM * positions[: k + 1, 0, mid], MM * positions[: k + 1, 1, mid])
                field = rollout.fields[k - 1] if k > 0 else np.zeros(3)
                if arrow is not None:
                    arrow.remove()
                arrow = _draw_field_arrow(ax, field, limit, arrow_origin, MM * length)
                text.set_text(
                    f"t = {times[k]:.2f} s   B = ({MT * field[0]:+.2f}, {MT * field[1]:+.2f}) mT"
                )
                writer.grab_frame()

    return atomic_save(path, write)


def rollout_figures(
    rollout: Rollout, out: str | Path, critic=None, actor=None, gif: bool = True
) -> dict[str, str]:
    """Every gait figure of a generated run into ``out``; returns ``{name: path}``.

    The Q-value heat maps need the policy's ``critic`` and ``actor`` (skipped when ``None``).
    """
    out = Path(out)
    label = rollout.meta.get("case", "")
    limit = rollout.meta.get("field_limit_T")
    paths = {
        "positions_velocities": plot_positions_velocities(
            rollout.trajectory, out / "positions_velocities.png", title=label),
        "field_waveforms": plot_field_waveforms(rollout.fields, out / "field_waveforms.png", limit,
                                                title=f"{label} field waveforms"),
        "field_polar": plot_field_polar(rollout.fields, out / "field_polar.png", limit,
                                        title=f"{label} field points (mT)"),
        "height_span_contact": plot_height_span_contact(rollout, out / "height_span_contact.png"),
        "filmstrip": plot_filmstrip(rollout, out / "filmstrip.png"),
    }
    if critic is not None and actor is not None and rollout.n_steps > 0:
        states = [(lab, rollout.observations[k]) for lab, k in q_value_states(rollout)]
        paths["q_values"] = plot_q_heatmaps(
            critic, actor, states, out / "q_values.png",
            max_increment=rollout.meta.get("max_increment_T", 0.3e-3), title=label)
    if gif:
        paths["gait_gif"] = animate_gait(rollout, out / "gait.gif")
    return {k: str(v) for k, v in paths.items()}


#: The files :func:`rollout_figures` writes (at most).
ROLLOUT_FIGURES = ("positions_velocities.png", "field_waveforms.png", "field_polar.png",
                   "height_span_contact.png", "filmstrip.png", "q_values.png", "gait.gif")


def make_figures(path: str | Path, out: str | Path | None = None, gif: bool = True,
                 load_policy: Callable[[str], Any] | None = None, *,
                 force: bool = False) -> dict[str, str]:
    """Regenerate the figures of a generate output (``rollout.npz``) or of training runs.

    Training runs: one ``learning_curves_<case>.png`` per case folder, in ``out`` (default ``path``). Generate
    output: every figure of :func:`rollout_figures`, with the Q maps when ``load_policy`` (e.g.
    :func:`elastica_magnetic_rl.shipping.policy_files.resolve_policy`: source -> an object with ``actor`` and
    ``critic``) can still load the policy recorded in the rollout. Figures already in ``out``
    are replaced only with ``force`` (all together, or none when interrupted).
    """
    from elastica_magnetic.filesets import replace_files

    path = Path(path)
    out = Path(out) if out is not None else path
    names = _figure_names(path)
    _check_not_another_result(path, out)
    # read (and checked) before the output folder is touched
    rollout = Rollout.load(path) if (path / ROLLOUT_NPZ).is_file() else None
    # the figures go in together (the folder holds other things: a run's logs, a rollout):
    # an interruption leaves the earlier figures, never a mix
    with replace_files(out, names, force=force) as files:
        result = _make_figures(path, files.path, gif, load_policy, rollout)
    return {k: str(files.final_path(v)) for k, v in result.items()}


def _check_not_another_result(path: Path, out: Path) -> None:
    """Figures go beside what they show (``out`` = ``path``, their own result's folder) or into a
    folder of no command's: into another command's result they would be files it does not know,
    removed or refused when that result is replaced."""
    from elastica_magnetic.io import normalized_path
    from elastica_magnetic.result_places import check_not_another_result

    if normalized_path(out) != normalized_path(path):
        check_not_another_result(out, "--out")


def _figure_names(path: Path) -> list[str]:
    """The files :func:`make_figures` may write for ``path``."""
    if (path / ROLLOUT_NPZ).is_file():
        return list(ROLLOUT_FIGURES)
    groups = find_runs(path)
    if not groups:
        raise FileNotFoundError(f"{path}: neither a generate output ({ROLLOUT_NPZ}) nor training "
                                "runs (episodes.csv)")
    return [f"learning_curves_{case}.png" for case in groups]


def _make_figures(path: Path, out: Path, gif: bool, load_policy: Callable[[str], Any] | None,
                  rollout: Rollout | None) -> dict[str, str]:
    if rollout is not None:
        critic = actor = None
        source = rollout.meta.get("policy_source")
        if source and load_policy is not None:
            try:
                policy = load_policy(source)
                critic, actor = policy.critic, policy.actor
            except (FileNotFoundError, ValueError, KeyError):
                critic = actor = None
        return rollout_figures(rollout, out, critic, actor, gif=gif)
    groups = find_runs(path)
    if not groups:
        raise FileNotFoundError(f"{path}: neither a generate output ({ROLLOUT_NPZ}) nor training "
                                "runs (episodes.csv)")
    result = {}
    for case, runs in groups.items():
        result[f"learning_curves_{case}"] = str(plot_learning_curves(
            runs, out / f"learning_curves_{case}.png", title=f"{case}: learning curves"))
    return result
