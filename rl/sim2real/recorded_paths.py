"""What the recorded paths of a steered catheter share (a magnet arm's, :mod:`.magnet_path`; fixed
coils' currents, :mod:`.coil_path`): the CSV's table and its 0.01 s control grid, the insertion
stage's column, the tracked tip checked against the catheter, and a steering recorded in
simulation."""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from elastica_magnetic.drive_columns import (
    CURRENT_COLUMN,
    GRID_TOLERANCE_S,
    INSERTION_COLUMN,
    MAGNET_COLUMN,
    grid_remedy,
    header_names,
)
from elastica_magnetic.field_csv import FIELD_COLUMNS, header_named_twice
from elastica_magnetic.io import missing_folder_hint
from elastica_magnetic.robot_spec import ACTION_PERIOD

from .tracking import TIP_COLUMNS, MeasuredTrajectory, TrajectoryError

__all__ = ["CURRENT_COLUMN", "FILE_KINDS", "GRID_TOLERANCE_S", "INSERTION_COLUMN", "MAGNET_COLUMN",
           "TIP_PATH_FILE", "DriveRecorder", "RecordedDrive", "check_insertion", "check_tip_path",
           "control_grid", "file_kind", "header_names", "quiet_case", "read_path_table", "steer_and_record",
           "write_path_csv", "write_tip_path"]

#: The files ``msr real identify`` tells apart by their first line (:func:`file_kind`), as named to a user.
FILE_KINDS = {"tip": "a catheter's tip path", "magnet-pose": "a magnet arm's path",
              "coil-currents": "the coils' recorded currents",
              "field": f"a field CSV ({', '.join(FIELD_COLUMNS)} in mT)"}
#: The tip path a recorded steering writes beside its drive (:meth:`DriveRecorder.write`).
TIP_PATH_FILE = "tip_path.csv"
#: The tracked tip at t_s 0 must lie within this fraction of the rod's length of the straight rod's
#: tip (the spec's frame: the base at the origin, the rod along +x); anywhere along the path within
#: :data:`TIP_REACH_FACTOR` x the rod's reach (its length plus the stage's travel) of the base.
TIP_START_FRACTION = 0.25
TIP_REACH_FACTOR = 1.5


def file_kind(path: str | Path) -> str | None:
    """What the CSV at ``path`` is, told by its first line: a key of :data:`FILE_KINDS` (a tip path,
    a magnet path, the coils' currents, a field CSV), or None (a crawler's trajectory, or a file
    whose reader names what it lacks)."""
    columns = header_names(path)
    if TIP_COLUMNS[0] in columns:
        return "tip"
    if MAGNET_COLUMN in columns:
        return "magnet-pose"
    if any(CURRENT_COLUMN.match(name) for name in columns):
        return "coil-currents"
    if set(FIELD_COLUMNS) <= set(columns):
        return "field"
    return None


def read_path_table(path: Path, what: str) -> pd.DataFrame:
    """The CSV at ``path`` as text columns with stripped names; :class:`~.tracking.TrajectoryError`
    naming ``path`` and ``what`` it should be (``"magnet path"``) when it is absent, unreadable or
    names a column twice."""
    try:
        table = pd.read_csv(path, encoding="utf-8-sig", dtype=str, keep_default_na=False)
    except FileNotFoundError:
        raise TrajectoryError(f"{path}: no such {what} file{missing_folder_hint(path)}") from None
    except (pd.errors.EmptyDataError, pd.errors.ParserError, UnicodeDecodeError, IsADirectoryError) as exc:
        raise TrajectoryError(f"{path}: not a readable {what} CSV ({exc})") from None
    if twice := header_named_twice(path):
        raise TrajectoryError(f"{path}: its header {twice}; give each column once (which copy is meant "
                              "cannot be guessed)")
    table.columns = [str(c).strip() for c in table.columns]
    return table


def control_grid(path: Path, times: NDArray[np.float64], what: str, log: str) -> NDArray[np.float64]:
    """The rows' times on the 0.01 s control grid from 0, ``(n,)`` s: two rows or more, each within
    :data:`GRID_TOLERANCE_S` of its grid time, else a :class:`~.tracking.TrajectoryError` naming the
    line (``what``: the path's name, ``log``: what to resample, "the arm's log")."""
    if times.shape[0] < 2:
        raise TrajectoryError(f"{path}: {times.shape[0]} row(s); a path needs two or more (0.01 s apart)")
    grid = np.arange(times.shape[0]) * ACTION_PERIOD
    off = np.abs(times - grid) > GRID_TOLERANCE_S
    if off.any():
        k = int(np.flatnonzero(off)[0])
        remedy = grid_remedy(times, ACTION_PERIOD, f"resample {log} to the control rate")
        raise TrajectoryError(f"{path}: line {k + 2}: t_s {times[k]:g} s, expected {grid[k]:g} s: a {what} "
                              f"has one row per {ACTION_PERIOD:g} s control step from 0 ({remedy})")
    return grid


def check_insertion(source: str, insertion: NDArray[np.float64] | None,
                    stage: tuple[float, float] | None) -> None:
    """A recorded path's ``insertion`` column (m per row, or ``None``) against the case's stage
    (its travel, m, or ``None``): given without a stage or missing with one, not 0 at t_s 0, or
    beyond the travel is refused (:class:`~.tracking.TrajectoryError` naming ``source``'s line)."""
    if stage is None and insertion is not None:
        raise TrajectoryError(f"{source}: has an {INSERTION_COLUMN} column, and the case has "
                              "no insertion stage ([actuation] insertion); drop the column or give the "
                              "stage")
    if stage is not None and insertion is None:
        raise TrajectoryError(f"{source}: no {INSERTION_COLUMN} column, and the case's "
                              f"insertion stage travels {list(stage)} m: give the stage's position "
                              "at every row (0 where it did not move)")
    if stage is None:
        return
    if abs(float(insertion[0])) > 1e-9:
        raise TrajectoryError(f"{source}: line 2: {INSERTION_COLUMN} "
                              f"{insertion[0]:g} m at t_s 0; the rod starts where it is "
                              "built (insertion 0): give the stage's motion from there")
    low, high = stage
    beyond = (insertion < low - 1e-9) | (insertion > high + 1e-9)
    if beyond.any():
        row = int(np.flatnonzero(beyond)[0])
        raise TrajectoryError(f"{source}: line {row + 2}: {INSERTION_COLUMN} "
                              f"{insertion[row]:g} m is beyond the stage's travel "
                              f"[{low:g}, {high:g}] m (millimetres for metres?)")


def check_tip_path(measured: MeasuredTrajectory, spec: Mapping[str, Any]) -> None:
    """Refuse a tracked tip that is not the catheter of ``spec`` in the spec's frame: at t_s 0
    farther than :data:`TIP_START_FRACTION` of the rod's length from the straight rod's tip, or
    anywhere beyond :data:`TIP_REACH_FACTOR` x its reach from the base (cm or mm for m, another
    frame's origin)."""
    length = float(spec["robot"]["length"])
    stage = (spec.get("actuation") or {}).get("insertion") or (0.0, 0.0)
    tips = measured.positions[:, 0, :]
    start = float(np.linalg.norm(tips[0] - np.array([length, 0.0, 0.0])))
    frame = "(positions in the spec's frame: the base at the origin, the rod along +x; in metres)"
    if start > TIP_START_FRACTION * length:
        raise TrajectoryError(f"{measured.source}: line 2: the tip starts at {tips[0].tolist()} m, "
                              f"{1e3 * start:.4g} mm from the straight {1e3 * length:g} mm catheter's "
                              f"tip ({length:g}, 0, 0) m: another robot, unit or frame? {frame}")
    reach = TIP_REACH_FACTOR * (length + max(float(stage[1]), 0.0))
    distance = np.linalg.norm(tips, axis=1)
    if (distance > reach).any():
        row = int(np.flatnonzero(distance > reach)[0])
        raise TrajectoryError(f"{measured.source}: line {row + 2}: the tip is {distance[row]:g} m from "
                              f"the base of a {length:g} m catheter (beyond {reach:g} m): centimetres "
                              f"or millimetres written as metres? {frame}")


def steer_and_record(case: Any, target: Any, row: Callable[[Any, int], Any],
                     make_controller: Callable[[Any], Any] | None = None, physics: str = "accurate",
                     duration: float | None = None) -> tuple[list[Any], NDArray[np.float64]]:
    """Steer the tip of a catheter ``case`` to ``target`` (m, ``(3,)``) in ``physics`` with a
    controller (default the case's steering yardstick) for ``duration`` s (default the task's
    episode) less the last step (which would end, and reset, the episode), recording ``row(env,
    0)`` (the actuator's state, as :attr:`DriveRecorder.row`) at every control step. Returns the
    rows and the tip at every row ``(n, 3)`` m. Raises RuntimeError if the episode ends early (a
    collision, a blow-up)."""
    from ..envs.catheter_env import make_catheter_env
    from ..shipping.tip_reach import steering_controller

    env = make_catheter_env(case, 1, physics, duration)
    obs, info = env.reset(seed=0, options={"target": np.asarray(target, dtype=np.float64)})
    act = (make_controller or steering_controller)(env)
    rows, tips = [row(env, 0)], [info["tip_m"][0].copy()]
    for _ in range(env.max_episode_steps - 1):  # the last step would end (and reset) the episode
        obs, _, terminated, truncated, info = env.step(act(env, obs))
        if terminated[0]:
            raise RuntimeError(f"the steering ended by {info['final_info']['ended_by'][0]} after "
                               f"{len(rows)} steps: no path to record")
        rows.append(row(env, 0))
        tips.append(info["tip_m"][0].copy())
    return rows, np.stack(tips)


def quiet_case(spec: Mapping[str, Any], what: str, default_name: str) -> Any:
    """The :class:`~elastica_magnetic_rl.cases.case.Case` of a spec dict, its plausibility warnings
    silenced (they were given when the spec was loaded); ``what`` names it in errors."""
    from ..cases.case import case_from_dict

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return case_from_dict(spec, what, default_name=default_name)


def write_path_csv(path: str | Path, columns: dict[str, NDArray[np.float64]],
                   insertion: NDArray[np.float64] | None) -> Path:
    """Write a recorded path's ``columns`` (name -> ``(n,)``, ``t_s`` first) and, with a stage, its
    ``insertion`` (m) as a CSV at ``path`` (atomically). Returns the path."""
    from elastica_magnetic.io import atomic_write

    if insertion is not None:
        columns = {**columns, INSERTION_COLUMN: insertion}
    path = Path(path)
    with atomic_write(path, "w", newline="") as handle:
        pd.DataFrame(columns).to_csv(handle, index=False, float_format="%.9g")
    return path


def write_tip_path(path: str | Path, tips: NDArray[np.float64]) -> Path:
    """Write a catheter's tip at every control step, ``tips`` ``(n, 3)`` m (row k at k x 0.01 s), as
    a tip path CSV (``t_s``, ``tip_x_m``, ``tip_y_m``, ``tip_z_m``) at ``path`` (atomically)."""
    tips = np.asarray(tips, dtype=np.float64).reshape(-1, 3)
    columns = {"t_s": np.arange(len(tips)) * ACTION_PERIOD}
    columns.update(zip(TIP_COLUMNS, tips.T, strict=True))
    return write_path_csv(path, columns, None)


@dataclass(frozen=True)
class DriveRecorder:
    """How a steered catheter's drive is recorded at every control step and written as the file
    ``msr real identify`` reads (a magnet arm's path, the coils' currents).

    ``row(env, i)``: sub-environment ``i``'s actuator state at its robot's time (and the stage's
    insertion, m, or None without a stage); ``write_rows(path, rows)``: the rows written as the
    drive's CSV at ``path``; ``file_name``: the drive file's name in a result folder."""

    file_name: str
    row: Callable[[Any, int], Any]
    write_rows: Callable[[Path, list[Any]], Path]

    @property
    def file_names(self) -> tuple[str, str]:
        """The files :meth:`write` writes: the drive and the tip path."""
        return self.file_name, TIP_PATH_FILE

    def write(self, folder: Path, rows: list[Any], tips: NDArray[np.float64]) -> dict[str, str]:
        """The drive (``rows``, one per control step) and its tips (``(len(rows), 3)`` m) written
        into ``folder`` as :attr:`file_name` and :data:`TIP_PATH_FILE`; returns name -> path."""
        drive = self.write_rows(folder / self.file_name, rows)
        tip = write_tip_path(folder / TIP_PATH_FILE, np.asarray(tips)[:len(rows)])
        return {self.file_name: str(drive), TIP_PATH_FILE: str(tip)}


class RecordedDrive:
    """What played a catheter's motion: a recorded path (its ``times`` s and ``source``) replayed on
    the robot of a steered case's spec (the drive of :func:`~.identify.identify` for such a case).
    A kind of path names itself (:attr:`what`), checks a spec it can drive (``check_spec``) and
    replays itself (``simulate(spec, physics)`` -> the tip at every row, ``(n, 3)`` m)."""

    what: ClassVar[str] = "recorded path"

    def __init__(self, path: Any) -> None:
        self.path = path

    @property
    def duration(self) -> float:
        """s, how long the path lasts."""
        return self.path.duration

    def describe(self) -> str:
        return f"the {self.what} {self.path.source}"

    def check_spec(self, spec: Mapping[str, Any]) -> None:
        raise NotImplementedError

    def simulate(self, spec: Mapping[str, Any], physics: str) -> NDArray[np.float64]:
        raise NotImplementedError

    def check_measured(self, measured: MeasuredTrajectory, spec: Mapping[str, Any]) -> None:
        """Refuse a tracked tip that is not this spec's catheter's in the spec's frame
        (:func:`check_tip_path`)."""
        check_tip_path(measured, spec)

    def rows(self, spec: Mapping[str, Any], physics: str,
             measured: MeasuredTrajectory) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The tip (m) at every row of the path, ``(n, 1, 3)``, with the rows' times ``(n,)`` (s),
        for the robot and its source of ``spec`` in ``physics``. Raises SimulationDivergedError."""
        return self.path.times, self.simulate(spec, physics)[:, None, :]
