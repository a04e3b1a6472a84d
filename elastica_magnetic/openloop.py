"""Open-loop runs: play a field on a robot and record its trajectory (what ``msr field replay`` does)."""

from __future__ import annotations

import math
import time as wallclock
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from .forcing import evaluate_field
from .io import atomic_write
from .robot_spec import ACTION_PERIOD, RobotSpec
from .simulation import TRAJECTORY_COLUMNS, FieldFunction
from .spatial_fields import is_spatial
from .uniform_simulation import uniform_field_simulation

__all__ = ["MAX_DURATION_S", "OpenLoopResult", "check_duration", "run_open_loop", "write_trajectory_csv"]

#: Longest simulated time a run accepts, s (an hour: ~10 h of accurate physics, 360000 rows).
MAX_DURATION_S = 3600.0


def check_duration(duration: float) -> float:
    """``duration`` (s) if it is finite, at least one 0.01 s interval and at most
    :data:`MAX_DURATION_S`; else ValueError saying so."""
    duration = float(duration)
    if not (math.isfinite(duration) and ACTION_PERIOD - 1e-12 <= duration <= MAX_DURATION_S):
        raise ValueError(
            f"duration must be a time in s from {ACTION_PERIOD:g} to {MAX_DURATION_S:g}, got {duration}"
        )
    return duration


@dataclass
class OpenLoopResult:
    """What an open-loop run produced.

    Attributes
    ----------
    trajectory : pandas.DataFrame
        One row per 0.01 s, first row the initial state at t = 0 (:data:`TRAJECTORY_COLUMNS`).
    shapes : list of (float, ndarray)
        ``(time, positions)`` snapshots, positions ``(3, n_nodes)`` in m.
    fields : ndarray
        ``(n_rows, 3)`` field (T) applied during each 0.01 s interval.
    wall_s : float
        Wall-clock time of the stepping, s.
    steps : int
        Time steps taken.
    """

    spec: RobotSpec
    trajectory: pd.DataFrame
    shapes: list[tuple[float, NDArray[np.float64]]] = field(repr=False)
    fields: NDArray[np.float64] = field(repr=False)
    wall_s: float = 0.0
    steps: int = 0

    @property
    def mid_dx(self) -> float:
        """Displacement of the middle along x over the run, m."""
        return float(self.trajectory.mid_x_m.iloc[-1] - self.trajectory.mid_x_m.iloc[0])

    @property
    def max_height(self) -> float:
        """Largest element height reached, m."""
        return float(self.trajectory.height_max_m.max())

    @property
    def step_us(self) -> float:
        """Wall-clock cost of one time step, microseconds."""
        return 1e6 * self.wall_s / max(self.steps, 1)


def run_open_loop(
    spec: RobotSpec,
    field_source: FieldFunction,
    duration: float,
    *,
    n_shapes: int = 11,
    progress: Callable[[int], None] | None = None,
    clamp: bool = False,
) -> OpenLoopResult:
    """Simulate ``spec`` under ``field_source`` for ``duration`` seconds, sampling at 100 Hz.

    Parameters
    ----------
    spec : RobotSpec
        Robot and physics (SI).
    field_source : callable or spatial source
        ``field(time) -> (3,)`` in tesla, or a source that varies in space
        (:mod:`elastica_magnetic.spatial_fields`): :attr:`OpenLoopResult.fields` then records
        the field at the last element's centre.
    duration : float
        s, rounded to whole 0.01 s intervals.
    n_shapes : int
        Number of shape snapshots, evenly spaced in time (first and last included).
    progress : callable, optional
        Called with the number of 0.01 s intervals done after each one (for progress bars).
    clamp : bool
        Clamp the first node and element (see :func:`~elastica_magnetic.build_simulation`).

    Raises
    ------
    SimulationDivergedError
        On NaN or a runaway velocity, naming the time and element.
    """
    n_actions = int(round(check_duration(duration) / ACTION_PERIOD))
    steps = spec.steps_per_action
    # on the batched kernel where it models the robot, its field and its base (the same trajectory)
    simulation = uniform_field_simulation(spec, field_source, clamp=clamp)
    spatial = is_spatial(field_source)
    shape_at = set(np.linspace(0, n_actions, max(n_shapes, 2)).round().astype(int).tolist())
    rows = [simulation.markers()]
    shapes = [(0.0, simulation.rod.position_collection.copy())]
    fields = np.empty((n_actions, 3))
    start = wallclock.perf_counter()
    for i in range(n_actions):
        if spatial:
            tip = simulation.rod.position_collection[:, -2:].mean(axis=1)[:, None]
            fields[i] = field_source.at(tip, simulation.time)[:, 0]
        else:
            fields[i] = evaluate_field(field_source, simulation.time)
        simulation.step(steps)
        rows.append(simulation.markers())
        if i + 1 in shape_at:
            shapes.append((simulation.time, simulation.rod.position_collection.copy()))
        if progress is not None:
            progress(i + 1)
    wall = wallclock.perf_counter() - start
    trajectory = pd.DataFrame(rows, columns=list(TRAJECTORY_COLUMNS))
    return OpenLoopResult(spec, trajectory, shapes, fields, wall, n_actions * steps)


def write_trajectory_csv(trajectory: pd.DataFrame, path: str | Path) -> Path:
    """Write a trajectory with the reference's columns and number format (atomically)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    out = trajectory[list(TRAJECTORY_COLUMNS)]
    with atomic_write(path, "w", newline="") as handle:
        handle.write(",".join(TRAJECTORY_COLUMNS) + "\n")
        for row in out.itertuples(index=False):
            handle.write(f"{row[0]:.6f}," + ",".join(f"{v:.9e}" for v in row[1:]) + "\n")
    return path
