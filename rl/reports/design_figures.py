"""Figures of ``msr design``: the search's convergence and the magnetization along the body."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .figures import MM, _figure, _save

__all__ = ["plot_convergence", "plot_magnetization"]


def plot_convergence(history: Sequence[dict[str, Any]], start_m: float, path: str | Path) -> Path:
    """Every candidate's objective (mm) in the order evaluated, the best so far as a line, and the
    starting design's as a dashed line (all measured the search's way)."""
    fig = _figure((6.4, 3.6))
    ax = fig.add_subplot(1, 1, 1)
    values = np.array([h["objective_m"] for h in history], dtype=float) * MM
    index = np.arange(1, len(values) + 1)
    ax.scatter(index, values, s=10, color="0.6", label="candidate")
    if len(values):
        ax.plot(index, np.maximum.accumulate(np.maximum(values, start_m * MM)), color="C0",
                label="best so far")
    ax.axhline(start_m * MM, color="C3", linestyle="--", label="starting design")
    ax.set_xlabel("candidate (in the order evaluated)")
    ax.set_ylabel("objective (mm ahead)")
    ax.set_title("msr design: search")
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    return _save(fig, path)


def plot_magnetization(start: NDArray[np.float64], best: NDArray[np.float64], length: float,
                       path: str | Path) -> Path:
    """The magnetization ``(3, n_elements)`` (A/m) of the starting and the best design along the
    body (``length`` m) drawn straight along +x: an arrow per stretch of elements in the x-y plane
    (the bending plane; its length the magnitude, the strongest 0.3 body lengths), coloured by
    its z component where the design has one."""
    fig = _figure((6.4, 3.4))
    n = start.shape[1]
    s = (np.arange(n) + 0.5) * length / n * MM
    scale = max(float(np.linalg.norm(start, axis=0).max()), float(np.linalg.norm(best, axis=0).max()), 1e-30)
    arrow = 0.08 * length * MM  # mm of arrow for the strongest magnetization
    step = max(1, n // 24)
    for row, (label, m) in enumerate((("starting design", start), ("best design", best))):
        ax = fig.add_subplot(2, 1, row + 1)
        ax.plot([0, length * MM], [0, 0], color="0.85", linewidth=8, zorder=0, solid_capstyle="butt")
        u, v, w = (m[k, ::step] / scale * arrow for k in range(3))
        kw = dict(angles="xy", scale_units="xy", scale=1.0, pivot="middle", width=0.006)
        if np.any(m[2] != 0.0):
            quiver = ax.quiver(s[::step], 0 * u, u, v, w / arrow, cmap="coolwarm", clim=(-1, 1), **kw)
            fig.colorbar(quiver, ax=ax, label="z / |M|max", fraction=0.04)
        else:
            ax.quiver(s[::step], 0 * u, u, v, color="C0", **kw)
        ax.set_xlim(-0.05 * length * MM, 1.05 * length * MM)
        ax.set_ylim(-0.8 * arrow, 0.8 * arrow)
        ax.set_aspect("equal")
        ax.set_yticks([])
        ax.set_title(label, fontsize=9, loc="left")
        if row == 1:
            ax.set_xlabel("arc length from the back (mm); arrows: the magnetization in the x-y plane")
    fig.tight_layout()
    return _save(fig, path)
