"""Coil currents as they were played, and the catheter they steered simulated under them (what
``msr real identify`` fits a coil-currents case with: the coils' gains, the rod's values).

A lab that steers a catheter with the coils of an electromagnetic navigation system logs the
currents its drivers made (a current sensor per coil, or the commands of drivers that follow
them) and tracks the catheter's tip. The first is the *coil path* CSV (a header line, SI units,
one row per 0.01 s control step from ``t_s = 0``):

``t_s, current_0_A, current_1_A, ..., current_{N-1}_A[, insertion_m]``

one column per coil of the spec's ``[[actuation.coils]]``, in their order (the index is the one
of the dotted key ``actuation.coils.K.turns`` that fits coil K's gain), and, for a case with an
insertion stage, how far the stage has pushed the base (m). The second is a tip path (see
:mod:`.tracking`).

:class:`CoilDrive` replays the currents on one clamped rod of the batched simulator, each current
ramping linearly from one row to the next (as :class:`elastica_magnetic.CoilCurrents` ramps a
command within a control step). A coil's field is proportional to its ``turns``: a fitted factor
on ``actuation.coils.K.turns`` is the coil's gain (field per ampere) against its nominal one, the
same for any error that scales its field (a winding count, a driver's current sense).
:func:`record_coil_steering` makes a coil path and its tip path in simulation.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic.clock_columns import TIME_COLUMN, other_clock_hint
from elastica_magnetic.drive_columns import current_unit_problem
from elastica_magnetic.robot_spec import ACTION_PERIOD

from .recorded_paths import (
    CURRENT_COLUMN,
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
from .tracking import TrajectoryError, numeric_columns

__all__ = ["COIL_RECORDER", "CoilDrive", "CoilPath", "read_coil_path", "record_coil_steering",
           "simulate_coil_tips", "write_coil_path"]

#: A current above this (A) is a value in mA written as A (no navigation system drives more).
MAX_PATH_CURRENT = 1000.0
#: A current beyond the case's ``current_limit`` by more than this fraction is warned about (a
#: driver's sensor reads a little past its command).
CURRENT_SLACK = 0.05


@dataclass(frozen=True)
class CoilPath:
    """The coils' currents at every control step.

    Attributes
    ----------
    times : ndarray (n,)
        s, ``0, 0.01, 0.02, ...``.
    currents : ndarray (n, N)
        A, coil K's current in column K.
    insertion : ndarray (n,) or None
        m, the stage's insertion (``None`` without a stage).
    """

    source: str
    times: NDArray[np.float64]
    currents: NDArray[np.float64]
    insertion: NDArray[np.float64] | None = None

    @property
    def duration(self) -> float:
        """s, the last row's time."""
        return float(self.times[-1])


def read_coil_path(path: str | Path) -> CoilPath:
    """Read and check a coil path CSV (see the module docstring). Raises
    :class:`~.tracking.TrajectoryError` naming the file, line and column: current columns not
    numbered 0, 1, ... in order, a value that is not a finite number, rows off the 0.01 s grid, a
    current past :data:`MAX_PATH_CURRENT` (mA for A)."""
    path = Path(path)
    table = read_path_table(path, "coil path")
    form = (f"a coil path has t_s, current_0_A, current_1_A, ... (A, one per coil of the spec, in its "
            f"order) and, with an insertion stage, {INSERTION_COLUMN} (m), one row per 0.01 s from t_s = 0")
    if (problem := current_unit_problem(list(table.columns))) is not None:
        raise TrajectoryError(f"{path}: {problem}")
    currents = [c for c in table.columns if CURRENT_COLUMN.match(c)]
    numbers = [int(CURRENT_COLUMN.match(c).group(1)) for c in currents]
    if "t_s" not in table.columns or not currents:
        missing = TIME_COLUMN if TIME_COLUMN not in table.columns else "current_0_A"
        clock = other_clock_hint([str(c) for c in table.columns]) if missing == TIME_COLUMN else ""
        raise TrajectoryError(f"{path}: no column {missing}{clock}; {form}")
    if numbers != list(range(len(numbers))):
        raise TrajectoryError(f"{path}: current columns {', '.join(currents)}: a coil path numbers its "
                              f"coils from 0, in order (current_0_A for the spec's first coil); {form}")
    used = ["t_s", *currents] + ([INSERTION_COLUMN] if INSERTION_COLUMN in table.columns else [])
    values = numeric_columns(path, table, used)
    grid = control_grid(path, values[:, 0], "coil path", "the drivers' log")
    amps = values[:, 1:1 + len(currents)]
    high = np.abs(amps) > MAX_PATH_CURRENT
    if high.any():
        row, col = (int(i) for i in np.argwhere(high)[0])
        raise TrajectoryError(f"{path}: line {row + 2}, column {currents[col]}: {amps[row, col]:g} A; no "
                              f"navigation system drives more than {MAX_PATH_CURRENT:g} A: milliamperes "
                              "written as amperes? (give A)")
    insertion = values[:, -1] if used[-1] == INSERTION_COLUMN else None
    return CoilPath(str(path), grid, amps.copy(), insertion)


def write_coil_path(path: str | Path, coils: CoilPath) -> Path:
    """Write ``coils`` as a coil path CSV at ``path`` (atomically). Returns the path."""
    columns = {"t_s": coils.times}
    columns.update({f"current_{k}_A": coils.currents[:, k] for k in range(coils.currents.shape[1])})
    return write_path_csv(path, columns, coils.insertion)


class CoilDrive(RecordedDrive):
    """What played a catheter's motion: the coils' :class:`CoilPath`, replayed on the robot of a
    coil-currents case's spec (the drive of :func:`~.identify.identify` for such a case)."""

    what = "coil path"
    path: CoilPath

    def check_spec(self, spec: Mapping[str, Any]) -> None:
        """Refuse a spec this path cannot drive (not a coil-currents case, another number of coils,
        insertion given without a stage or missing with one, or beyond its travel) and a path of
        zero currents (nothing moved: nothing to fit); warn of a current beyond the case's
        ``current_limit`` or changing faster than its ``max_slew`` (another system's log, or its
        sensors' scale?)."""
        from elastica_magnetic.plausibility import warn_implausible

        case = quiet_case(spec, "the spec", "identified")
        kind = getattr(case.actuation, "kind", "field")
        if kind != "coil-currents":
            raise TrajectoryError(f"{self.path.source}: a coil path drives a case steered by coil "
                                  "currents ([actuation] kind = \"coil-currents\"); this spec's actuation "
                                  f"is {kind!r}")
        if not np.any(self.path.currents):
            raise TrajectoryError(f"{self.path.source}: every current is 0 A: the coils never made a "
                                  "field, so nothing moved the catheter and no gain or value can be "
                                  "fitted from it; give the currents the drivers made during a steering")
        n_coils, n_columns = len(case.actuation.coils), self.path.currents.shape[1]
        if n_columns != n_coils:
            raise TrajectoryError(f"{self.path.source}: {n_columns} current column(s), and the spec has "
                                  f"{n_coils} coils ([[actuation.coils]]): one current_K_A per coil, K "
                                  "from 0 in the spec's order")
        limit = case.actuation.current_limit
        beyond = np.abs(self.path.currents) > limit * (1.0 + CURRENT_SLACK)
        if beyond.any():
            row, col = (int(i) for i in np.argwhere(beyond)[0])
            warn_implausible(f"{self.path.source}: line {row + 2}: current_{col}_A "
                             f"{self.path.currents[row, col]:g} A is beyond the case's current_limit "
                             f"({limit:g} A) that its policies command: another system's log, or its "
                             "sensors' scale?", "actuation.current_limit")
        self._warn_slew(case.actuation.max_slew)
        check_insertion(self.path.source, self.path.insertion, case.actuation.insertion)

    def _warn_slew(self, max_slew: float | None) -> None:
        """Warn of a current changing faster than the case's ``max_slew`` (A/s; None: no limit) from
        one row to the next, as an arm faster than its ``max_speed`` is."""
        from elastica_magnetic.plausibility import warn_implausible

        if max_slew is None or len(self.path.times) < 2:
            return
        rates = np.abs(np.diff(self.path.currents, axis=0)) / np.diff(self.path.times)[:, None]
        fast = rates > max_slew * (1.0 + CURRENT_SLACK)
        if fast.any():
            row, col = (int(i) for i in np.argwhere(fast)[0])
            warn_implausible(f"{self.path.source}: line {row + 3}: current_{col}_A changes at "
                             f"{rates[row, col]:.4g} A/s, faster than the case's max_slew ({max_slew:g} "
                             "A/s) that its policies command: another system's drivers, or a glitch in "
                             "its log?", "actuation.max_slew")

    def simulate(self, spec: Mapping[str, Any], physics: str) -> NDArray[np.float64]:
        return simulate_coil_tips(spec, physics, self.path)


def simulate_coil_tips(spec: Mapping[str, Any], physics: str, path: CoilPath) -> NDArray[np.float64]:
    """The tip (m) at every row of ``path``, ``(n, 3)``, of the rod of a coil-currents case's ``spec``
    (a case dict) in ``physics``, its coils (the spec's windings) carrying ``path``'s currents, each
    ramping linearly between rows, and its stage following ``path``."""
    from elastica_magnetic import Advancer
    from elastica_magnetic.batch import BatchedRobots

    case = quiet_case(spec, "the fitted spec", "fitted")
    robot = case.robot_spec(physics)
    actuation = case.actuation
    coils = actuation.actuator()
    advancer = None if path.insertion is None else Advancer(actuation.insertion, actuation.insertion_speed)
    robots = BatchedRobots(robot, 1, sources=[coils.source], clamp=True,
                           advancers=None if advancer is None else [advancer])
    rod = robots.rods[0]
    tips = np.empty((path.times.shape[0], 3))
    tips[0] = rod.position_collection[:, -1]
    coils.set_motion(np.concatenate([[0.0, 0.0], path.currents[0], path.currents[0]]))
    for k in range(1, path.times.shape[0]):
        now = robots.robot_time(0)
        coils.set_motion(np.concatenate([[now, ACTION_PERIOD], path.currents[k - 1], path.currents[k]]))
        if advancer is not None:
            advancer.follow(float(path.insertion[k]), now, ACTION_PERIOD)
        robots.step(robot.steps_per_action)
        tips[k] = rod.position_collection[:, -1]
    return tips


def record_coil_steering(case: Any, target: Any, make_controller: Callable[[Any], Any] | None = None,
                         physics: str = "accurate", duration: float | None = None
                         ) -> tuple[CoilPath, NDArray[np.float64]]:
    """Steer the tip of a coil-currents ``case`` to ``target`` (m, ``(3,)``) in ``physics`` with a
    controller (default the case's steering yardstick), recording the coils' currents and the stage
    at every control step, for ``duration`` s (default the task's episode) less the last step.
    Returns the :class:`CoilPath` and the tip at every row, ``(n, 3)`` m. Raises RuntimeError if the
    episode ends early."""

    rows, tips = steer_and_record(case, target, COIL_RECORDER.row, make_controller, physics, duration)
    return _coil_path_of(rows), tips


def _currents_row(env: Any, i: int) -> tuple[NDArray[np.float64], float | None]:
    """Sub-environment ``i``'s coil currents at its robot's time (A, ``(N,)``) and the insertion (m,
    None without a stage)."""
    return (env.actuators[i].currents_at(env.robots.robot_time(i)),
            env.insertion(i) if env.advancers else None)


def _coil_path_of(rows: list[Any]) -> CoilPath:
    times = np.arange(len(rows)) * ACTION_PERIOD
    insertion = None if rows[0][1] is None else np.array([r[1] for r in rows])
    return CoilPath("recorded", times, np.stack([r[0] for r in rows]), insertion)


#: The coils' drive recorded while they steer (``msr policy generate --target``): coil_currents.csv.
COIL_RECORDER = DriveRecorder("coil_currents.csv", _currents_row,
                              lambda path, rows: write_coil_path(path, _coil_path_of(rows)))
