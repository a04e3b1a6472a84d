"""A magnet arm's recorded path, and the catheter it steered simulated along it (what ``msr real
identify`` fits a magnet-arm case with: the magnet's moment, the rod's values).

A lab that steers a catheter with a magnet on a robot arm records what the arm did (its pose at
every control step, as the arm's controller reports it) and where the catheter's tip went (a
tracker). The first is the *magnet path* CSV (a header line, SI units, one row per 0.01 s control
step from ``t_s = 0``):

``t_s, magnet_x_m, magnet_y_m, magnet_z_m, direction_x, direction_y, direction_z[, insertion_m]``

the magnet's centre (m) and its moment's direction (normalized when read) in the spec's frame (the
catheter's clamped base at the origin, the rod straight along +x at the start), and, for a case
with an insertion stage, how far the stage has pushed the base (m). The second is a tip path (see
:mod:`.tracking`: ``t_s, tip_x_m, tip_y_m, tip_z_m``, any frame rate).

:class:`MagnetDrive` replays a path exactly as it happened (between rows the magnet moves at
constant velocity and turns at a constant rate, as the arm's commands move it; the stage likewise)
on one clamped rod of the batched simulator, so a fitted moment is judged in the same physics the
catheter cases train in. :func:`record_steering` makes a path and its tip path in simulation (a
synthetic measurement, and what a lab's arm would be sent).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic.clock_columns import TIME_COLUMN, other_clock_hint
from elastica_magnetic.robot_spec import ACTION_PERIOD

from .recorded_paths import (
    INSERTION_COLUMN,
    DriveRecorder,
    RecordedDrive,
    check_insertion,
    control_grid,
    quiet_case,
    read_path_table,
    steer_and_record,
    write_path_csv,
)
from .tracking import MAX_COORDINATE_M, TrajectoryError, numeric_columns

__all__ = ["MAGNET_PATH_COLUMNS", "MAGNET_RECORDER", "MagnetDrive", "MagnetPath", "read_magnet_path",
           "record_steering", "simulate_tips", "write_magnet_path"]

#: The magnet path's columns (``insertion_m`` only with a stage).
MAGNET_PATH_COLUMNS = ("t_s", "magnet_x_m", "magnet_y_m", "magnet_z_m", "direction_x", "direction_y",
                       "direction_z")
#: A magnet path faster than the arm's ``max_speed`` by more than this fraction is warned about
#: (an arm's log rounds, its controller overshoots a little).
ARM_SPEED_SLACK = 0.1
#: m: a magnet path beyond the arm's workspace by more than this is warned about (a tracker's noise).
WORKSPACE_SLACK_M = 1e-3


@dataclass(frozen=True)
class MagnetPath:
    """The magnet's pose at every control step.

    Attributes
    ----------
    times : ndarray (n,)
        s, ``0, 0.01, 0.02, ...``.
    positions : ndarray (n, 3)
        m, the magnet's centre.
    directions : ndarray (n, 3)
        The moment's unit direction.
    insertion : ndarray (n,) or None
        m, the stage's insertion (``None`` without a stage).
    """

    source: str
    times: NDArray[np.float64]
    positions: NDArray[np.float64]
    directions: NDArray[np.float64]
    insertion: NDArray[np.float64] | None = None

    @property
    def duration(self) -> float:
        """s, the last row's time."""
        return float(self.times[-1])


def read_magnet_path(path: str | Path) -> MagnetPath:
    """Read and check a magnet path CSV (see the module docstring). Raises
    :class:`~.tracking.TrajectoryError` naming the file, line and column: a missing column, a value
    that is not a finite number, rows off the 0.01 s grid, a zero direction, a position past
    :data:`~.tracking.MAX_COORDINATE_M` (millimetres for metres)."""
    path = Path(path)
    table = read_path_table(path, "magnet path")
    missing = [c for c in MAGNET_PATH_COLUMNS if c not in table.columns]
    if missing:
        clock = other_clock_hint([str(c) for c in table.columns]) if TIME_COLUMN in missing else ""
        raise TrajectoryError(f"{path}: no column {', '.join(missing)}{clock}; a magnet path has "
                              f"{', '.join(MAGNET_PATH_COLUMNS)} (m; a unit direction) and, with an "
                              f"insertion stage, {INSERTION_COLUMN} (m), one row per 0.01 s from t_s = 0")
    used = list(MAGNET_PATH_COLUMNS) + ([INSERTION_COLUMN] if INSERTION_COLUMN in table.columns else [])
    values = numeric_columns(path, table, used)
    grid = control_grid(path, values[:, 0], "magnet path", "the arm's log")
    positions, directions = values[:, 1:4], values[:, 4:7]
    far = np.abs(positions) > MAX_COORDINATE_M
    if far.any():
        row, col = (int(i) for i in np.argwhere(far)[0])
        raise TrajectoryError(f"{path}: line {row + 2}, column {used[col + 1]}: {positions[row, col]:g} m; "
                              f"positions past {MAX_COORDINATE_M:g} m look like millimetres: give metres "
                              "(divide by 1000)")
    norms = np.linalg.norm(directions, axis=1)
    if (norms <= 0.0).any():
        row = int(np.flatnonzero(norms <= 0.0)[0])
        raise TrajectoryError(f"{path}: line {row + 2}: direction (0, 0, 0); the moment's direction must "
                              "be a non-zero vector")
    insertion = values[:, 7] if len(used) > 7 else None
    return MagnetPath(str(path), grid, positions.copy(), directions / norms[:, None], insertion)


def write_magnet_path(path: str | Path, magnet: MagnetPath) -> Path:
    """Write ``magnet`` as a magnet path CSV at ``path`` (atomically). Returns the path."""
    columns = dict(zip(MAGNET_PATH_COLUMNS, [magnet.times, *magnet.positions.T, *magnet.directions.T],
                       strict=True))
    return write_path_csv(path, columns, magnet.insertion)


class MagnetDrive(RecordedDrive):
    """What played a catheter's motion: a magnet arm's :class:`MagnetPath`, replayed on the
    robot of a magnet-arm case's spec (the drive of :func:`~.identify.identify` for such a case)."""

    what = "magnet path"
    path: MagnetPath

    def check_spec(self, spec: Mapping[str, Any]) -> None:
        """Refuse a spec this path cannot drive: not a magnet arm; a magnet beyond any arm's reach
        (cm or mm written as m) or starting within the arm's ``min_clearance`` of the straight rod;
        insertion given without a stage or missing with one, or beyond the stage's travel."""
        from ..cases.steered import MAX_REACH

        case = quiet_case(spec, "the spec", "identified")
        kind = getattr(case.actuation, "kind", "field")
        if kind != "magnet-pose":
            raise TrajectoryError(f"{self.path.source}: a magnet path drives a case steered by a magnet on "
                                  f"an arm ([actuation] kind = \"magnet-pose\"); this spec's actuation is "
                                  f"{kind!r}")
        reach = np.linalg.norm(self.path.positions, axis=1)
        if (reach > MAX_REACH).any():
            row = int(np.flatnonzero(reach > MAX_REACH)[0])
            raise TrajectoryError(f"{self.path.source}: line {row + 2}: the magnet is {reach[row]:g} m "
                                  f"from the rod's base, beyond any arm ({MAX_REACH:g} m): centimetres or "
                                  "millimetres written as metres?")
        self._check_arm_motion(case.actuation)
        length = float(spec["robot"]["length"])
        start = self.path.positions[0]
        along = min(max(float(start[0]), 0.0), length)
        clearance = float(np.linalg.norm(start - np.array([along, 0.0, 0.0])))
        if clearance < case.actuation.min_clearance:
            raise TrajectoryError(f"{self.path.source}: line 2: the magnet starts {1e3 * clearance:.3g} mm "
                                  f"from the straight rod, nearer than the arm's min_clearance "
                                  f"({1e3 * case.actuation.min_clearance:g} mm): a path through the "
                                  "catheter? (positions in the spec's frame: the base at the origin, the rod "
                                  "along +x)")
        check_insertion(self.path.source, self.path.insertion, case.actuation.insertion)

    def _check_arm_motion(self, arm: Any) -> None:
        """The magnet's motion against the arm of the spec (``arm``: its
        :class:`~elastica_magnetic_rl.cases.arm_actuation.MagnetArm`): a step faster than any arm
        (:data:`~elastica_magnetic_rl.cases.steered.MAX_SPEED`: a glitch in the log, or mm for m)
        refused by line; faster than the spec's ``max_speed``, or outside its ``workspace`` (the
        box the arm keeps the magnet in: another frame?), warned by line."""
        from elastica_magnetic.plausibility import warn_implausible

        from ..cases.steered import MAX_SPEED

        path, positions = self.path.source, self.path.positions
        speeds = np.linalg.norm(np.diff(positions, axis=0), axis=1) / np.diff(self.path.times)
        if len(speeds) and speeds.max() > MAX_SPEED:
            row = int(np.flatnonzero(speeds > MAX_SPEED)[0]) + 1
            step = float(np.linalg.norm(positions[row] - positions[row - 1]))
            took = float(self.path.times[row] - self.path.times[row - 1])
            raise TrajectoryError(f"{path}: line {row + 2}: the magnet moves {1e3 * step:.4g} mm in "
                                  f"{1e3 * took:.3g} ms ({speeds[row - 1]:.3g} m/s), faster than any arm "
                                  f"({MAX_SPEED:g} m/s): a glitch in the arm's log, or millimetres written "
                                  "as metres?")
        fast = speeds > arm.max_speed * (1.0 + ARM_SPEED_SLACK)
        if fast.any():
            row = int(np.flatnonzero(fast)[0]) + 1
            warn_implausible(f"{path}: line {row + 2}: the magnet moves at {speeds[row - 1]:.3g} m/s, faster "
                             f"than the arm's max_speed ({arm.max_speed:g} m/s) that the case's policies "
                             "command: another arm, or a glitch in its log?", "actuation.max_speed")
        low, high = np.asarray(arm.workspace, dtype=float)
        outside = ((positions < low - WORKSPACE_SLACK_M) | (positions > high + WORKSPACE_SLACK_M)).any(axis=1)
        if outside.any():
            row = int(np.flatnonzero(outside)[0])
            warn_implausible(f"{path}: line {row + 2}: the magnet at {positions[row].tolist()} m is outside "
                             f"the arm's workspace {[list(b) for b in arm.workspace]} m, the box the case "
                             "keeps it in: another frame (the base at the origin, the rod along +x)?",
                             "actuation.workspace")

    def simulate(self, spec: Mapping[str, Any], physics: str) -> NDArray[np.float64]:
        return simulate_tips(spec, physics, self.path)


def simulate_tips(spec: Mapping[str, Any], physics: str, path: MagnetPath) -> NDArray[np.float64]:
    """The tip (m) at every row of ``path``, ``(n, 3)``, of the rod of a magnet-arm case's ``spec``
    (a case dict) in ``physics``, its magnet (the spec's moment) and stage following ``path``."""
    from elastica_magnetic import Advancer, FieldMapDomainError, FieldValueError, MagnetPose
    from elastica_magnetic.batch import BatchedRobots

    case = quiet_case(spec, "the fitted spec", "fitted")
    robot = case.robot_spec(physics)
    arm = case.actuation
    box = np.stack([path.positions.min(axis=0) - 1.0, path.positions.max(axis=0) + 1.0])
    magnet = MagnetPose(arm.moment, path.positions[0], path.directions[0], box, max_speed=1.0,
                        max_turn_rate=1.0, field_map=None if arm.magnet is None else arm.magnet.field_map())
    advancer = None
    if path.insertion is not None:
        advancer = Advancer(arm.insertion, arm.insertion_speed)
    robots = BatchedRobots(robot, 1, sources=[magnet.source], clamp=True,
                           advancers=None if advancer is None else [advancer])
    rod = robots.rods[0]
    tips = np.empty((path.times.shape[0], 3))
    tips[0] = rod.position_collection[:, -1]
    for k in range(1, path.times.shape[0]):
        # where the arm takes the magnet in this step, against the rod as it is: the environment ends
        # an episode within min_clearance, so no replay goes on beyond it
        nearest = float(np.linalg.norm(rod.position_collection - path.positions[k][:, None], axis=0).min())
        if nearest < arm.min_clearance:
            raise TrajectoryError(f"{path.source}: line {k + 2} (t_s {path.times[k]:g} s): the magnet is "
                                  f"{1e3 * nearest:.3g} mm from the rod, nearer than the arm's "
                                  f"min_clearance ({1e3 * arm.min_clearance:g} mm): a path through the "
                                  "catheter, or another frame or unit?")
        now = robots.robot_time(0)
        magnet.follow(path.positions[k], path.directions[k], now, ACTION_PERIOD)
        if advancer is not None:
            advancer.follow(float(path.insertion[k]), now, ACTION_PERIOD)
        try:
            robots.step(robot.steps_per_action)
        except (FieldValueError, FieldMapDomainError) as exc:
            cause = str(exc).split(": ", 1)[-1]
            raise TrajectoryError(f"{path.source}: line {k + 2} (t_s {path.times[k]:g} s): the magnet's "
                                  f"field cannot act on the rod there ({cause}): a path through the "
                                  "catheter, or the magnet beyond its map?") from None
        tips[k] = rod.position_collection[:, -1]
    return tips


def record_steering(case: Any, target: Any, make_controller: Callable[[Any], Any] | None = None,
                    physics: str = "accurate", duration: float | None = None
                    ) -> tuple[MagnetPath, NDArray[np.float64]]:
    """Steer the tip of a magnet-arm ``case`` (a :class:`~elastica_magnetic_rl.cases.case.Case`) to
    ``target`` (m, ``(3,)``) in ``physics`` with a controller (default the case's steering
    yardstick), recording the arm's pose and the stage at every control step, for ``duration`` s
    (default the task's episode) less the last step (which would end, and reset, the episode).
    Returns the :class:`MagnetPath` and the tip at every row, ``(n, 3)`` m. Raises RuntimeError if
    the episode ends early (a collision, a blow-up)."""

    rows, tips = steer_and_record(case, target, MAGNET_RECORDER.row, make_controller, physics, duration)
    return _magnet_path_of(rows), tips


def _pose_row(env: Any, i: int) -> tuple[NDArray[np.float64], NDArray[np.float64], float | None]:
    """Sub-environment ``i``'s magnet at its robot's time: centre (m), direction, the insertion (m,
    None without a stage)."""
    magnet, t = env.actuators[i], env.robots.robot_time(i)
    return magnet.position_at(t), magnet.direction_at(t), env.insertion(i) if env.advancers else None


def _magnet_path_of(rows: list[Any]) -> MagnetPath:
    times = np.arange(len(rows)) * ACTION_PERIOD
    insertion = None if rows[0][2] is None else np.array([r[2] for r in rows])
    return MagnetPath("recorded", times, np.stack([r[0] for r in rows]), np.stack([r[1] for r in rows]),
                      insertion)


#: A magnet arm's drive recorded while it steers (``msr policy generate --target``): magnet_path.csv.
MAGNET_RECORDER = DriveRecorder("magnet_path.csv", _pose_row,
                                lambda path, rows: write_magnet_path(path, _magnet_path_of(rows)))
