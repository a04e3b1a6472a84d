"""Measured trajectories: reading them, checking them, and the simulated motion of the same points.

Two formats are read (CSV, a header line, SI units):

- the ``trajectory.csv`` that ``msr field replay`` and ``msr policy generate`` write: ``t_s`` and the markers
  ``back``, ``mid`` and ``front`` (``<name>_x_m``, ``<name>_y_m``; element centres: the first,
  the mean of the two central ones, the last);
- a tracker's CSV: ``t_s`` (s, from the moment the waveform's first row starts) and, for each
  tracked point, ``x_<s>_m`` and ``y_<s>_m`` (m), where ``<s>`` is the point's place along the body
  as a fraction of its length, from the back end (0, the end at smaller x when the robot lies
  straight) to the front end (1): e.g. ``t_s,x_0_m,y_0_m,x_0.5_m,y_0.5_m,x_1_m,y_1_m``. Any frame
  rate; x along the ground in the direction of the robot's front, y up; the origin is free (only
  displacements from the first frame are compared);
- a catheter's tip path: ``t_s`` and ``tip_x_m``, ``tip_y_m``, ``tip_z_m`` (m, the spec's frame: the
  clamped base at the origin, the rod along +x at the start), any frame rate, compared in 3D with the
  tip simulated along the magnet's recorded path (:mod:`.magnet_path`).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from elastica_magnetic.clock_columns import other_clock_hint
from elastica_magnetic.field_csv import decimal_comma_hint, header_named_twice, separator_hint
from elastica_magnetic.io import missing_folder_hint

__all__ = [
    "MARKERS",
    "TIP_COLUMNS",
    "MAX_COORDINATE_M",
    "MIN_DURATION_S",
    "MIN_FRAMES",
    "MeasuredTrajectory",
    "TrajectoryError",
    "check_against_robot",
    "numeric_columns",
    "points_at_rows",
    "read_trajectory",
]

#: The markers of ``trajectory.csv`` used as tracked points.
MARKERS = ("back", "mid", "front")
#: Where msr's trajectory.csv markers sit along the body, fractions of its length from the back end.
MARKER_FRACTIONS = {"back": 0.0, "mid": 0.5, "front": 1.0}
#: The columns of a catheter's tip path (m, the spec's frame).
TIP_COLUMNS = ("tip_x_m", "tip_y_m", "tip_z_m")
#: Fewest frames and shortest time span of a trajectory to fit.
MIN_FRAMES = 5
MIN_DURATION_S = 0.1
#: A coordinate beyond this (m) is taken for millimetres.
MAX_COORDINATE_M = 10.0
#: Least motion to fit: the largest displacement of a point, as a fraction of the body length.
MIN_MOTION = 0.01
#: Most a point may move (in body lengths) or two points be apart (x the length) before the
#: values are taken for another unit.
MAX_MOTION_LENGTHS = 100.0
MAX_SEPARATION = 1.5
#: Least distance of the outermost tracked points at the first frame, as a fraction of their
#: distance along the straight body (a robot at rest before the waveform acts lies nearly straight).
MIN_SPAN = 0.5

_TRACKER_COLUMN = re.compile(r"^([xy])_([0-9]*\.?[0-9]+)_m$")
#: A tracked point's sideways column (not compared: the fit uses the side view).
_TRACKER_Z_COLUMN = re.compile(r"^z_([0-9]*\.?[0-9]+)_m$")
#: What looks like a tracked point's column, however spelled (``X_1_m``, ``x_1_mm``, ``x_-0.5_m``):
#: one that is not exactly :data:`_TRACKER_COLUMN` is named, never dropped without a word.
_NEAR_TRACKER_COLUMN = re.compile(r"^[xyz][\s_\-]*[-+]?\.?\d", re.IGNORECASE)
#: A marker's or tip's column of msr's own files, exactly; and what looks like one however spelled
#: (``mid_x_mm``, ``Mid_X_m``, ``tip x``): one that is not exact is named, never dropped.
#: msr's own trajectory.csv columns that are no tracked point (read by no fit, said by no warning).
TRAJECTORY_EXTRAS = frozenset({"height_max_m", "span_m"})
#: An unused column that looks like a coordinate: an x or y word, in m.
_COORDINATE_LIKE = re.compile(r"(^|[_\s\-])[xy]([_\s\-]|$).*m$|_[xy]_?m$", re.IGNORECASE)
_MARKER_COLUMN = re.compile(r"^(back|mid|front|tip)_[xyz]_m$")
_NEAR_MARKER_COLUMN = re.compile(r"^(back|mid|front|tip)[\s_\-]*[xyz](?![a-z])", re.IGNORECASE)


class TrajectoryError(ValueError):
    """A measured trajectory that cannot be fitted: the message names the file, the line or column
    and the problem (units, too short, no motion, ...)."""


@dataclass(frozen=True)
class MeasuredTrajectory:
    """Positions of tracked points over time.

    Attributes
    ----------
    times : ndarray (n,)
        s, strictly increasing, from the start of the waveform.
    positions : ndarray (n, k, d)
        x and y (and z, ``d = 3``, for a tip path) of the ``k`` points, m.
    points : tuple of str
        Their names (``"back"``, ``"mid"``, ``"front"``, or ``"s=0.5"``).
    fractions : tuple
        For a tracker's points, their place along the body (0 back end, 1 front end); ``None``
        for the markers of ``trajectory.csv``.
    """

    source: str
    kind: str  # "trajectory.csv" or "tracker"
    times: NDArray[np.float64]
    positions: NDArray[np.float64]
    points: tuple[str, ...]
    fractions: tuple[float, ...] | None

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    def until(self, horizon: float) -> MeasuredTrajectory:
        """The frames at or before ``horizon`` s (the first two at least)."""
        n = max(int(np.searchsorted(self.times, horizon + 1e-9, side="right")), 2)
        return MeasuredTrajectory(self.source, self.kind, self.times[:n], self.positions[:n],
                                  self.points, self.fractions)

    def displacements(self) -> NDArray[np.float64]:
        """``(n, k, d)`` positions minus the first frame's, m."""
        return self.positions - self.positions[:1]


def _read_csv(path: Path) -> pd.DataFrame:
    if not path.is_file():
        raise TrajectoryError(f"{path}: no such trajectory file{missing_folder_hint(path)}")
    try:
        table = pd.read_csv(path, encoding="utf-8-sig", dtype=str, keep_default_na=False)
    except pd.errors.EmptyDataError:
        raise TrajectoryError(f"{path}: empty file; expected a header line (t_s, ...)") from None
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise TrajectoryError(f"{path}: not a readable UTF-8 CSV ({exc})") from None
    if split := decimal_comma_hint([str(c).strip() for c in table.columns]):
        raise TrajectoryError(f"{path}: {split}")
    if twice := header_named_twice(path):
        raise TrajectoryError(f"{path}: its header {twice}; give each column once (which copy is meant "
                              "cannot be guessed)")
    table.columns = [str(c).strip() for c in table.columns]
    return table


def _layout(path: Path, columns: list[str]) -> tuple[str, list[tuple[str, ...]], tuple | None]:
    """The kind of file and its points: ``(name, x column, y column[, z column])``."""
    if "t_s" not in columns:
        raise TrajectoryError(
            f"{path}: no t_s column (found {', '.join(columns)}){other_clock_hint(columns)}; expected msr's "
            "trajectory.csv or a "
            "tracker's CSV: t_s (s), then x_<s>_m, y_<s>_m (m) per tracked point, <s> its place "
            f"along the body from 0 (back end) to 1 (front end){separator_hint(columns)}")
    near = [c for c in columns if _NEAR_MARKER_COLUMN.match(c) and not _MARKER_COLUMN.match(c)]
    if near:
        raise TrajectoryError(f"{path}: column(s) {', '.join(near)} look like a marker's but are not "
                              "<back|mid|front|tip>_<x|y|z>_m (lower case, the values in m): rename them (a "
                              "column in mm: divide its values by 1000 and name it ..._m)")
    if TIP_COLUMNS[0] in columns:  # a catheter's tip, in 3D
        missing = [c for c in TIP_COLUMNS if c not in columns]
        if missing:
            raise TrajectoryError(f"{path}: a tip path needs {', '.join(TIP_COLUMNS)} (m); no "
                                  f"{', '.join(missing)}")
        points = [c for c in columns if (_MARKER_COLUMN.match(c) and not c.startswith("tip_"))
                  or _TRACKER_COLUMN.match(c) or _TRACKER_Z_COLUMN.match(c)]
        if points:
            raise TrajectoryError(f"{path}: holds a catheter's tip path ({', '.join(TIP_COLUMNS)}) and "
                                  f"tracked points' columns ({', '.join(points)}): a tip path is fitted on "
                                  "the tip alone; keep one kind of column")
        return "tip path", [("tip", *TIP_COLUMNS)], (1.0,)
    for n in MARKERS:  # a marker with one coordinate is a column lost, not a marker to drop
        has = [f"{n}_{a}_m" for a in "xy" if f"{n}_{a}_m" in columns]
        if len(has) == 1:
            lacking = f"{n}_{'y' if has[0].endswith('_x_m') else 'x'}_m"
            raise TrajectoryError(f"{path}: {has[0]} without {lacking}: the {n} marker needs both "
                                  "(m); add the column, or drop both to fit without that marker")
    markers = [(n, f"{n}_x_m", f"{n}_y_m") for n in MARKERS
               if f"{n}_x_m" in columns and f"{n}_y_m" in columns]
    if markers:
        tracker = [c for c in columns if _TRACKER_COLUMN.match(c)]
        if tracker:
            raise TrajectoryError(f"{path}: holds msr's trajectory.csv markers "
                                  f"({', '.join(c for m in markers for c in m[1:])}) and a tracker's "
                                  f"columns ({', '.join(tracker)}): one file is one of the two formats "
                                  "(the fit would use the markers alone); keep one kind of column")
        return "trajectory.csv", markers, None
    near = [c for c in columns if _NEAR_TRACKER_COLUMN.match(c) and not _TRACKER_COLUMN.match(c)
            and not _TRACKER_Z_COLUMN.match(c)]
    if near:
        raise TrajectoryError(f"{path}: column(s) {', '.join(near)} look like a tracked point's but are not "
                              "x_<s>_m / y_<s>_m (lower-case x or y, <s> the place along the body from 0 "
                              "to 1, the values in m): rename them (a column in mm: divide its values "
                              "by 1000 and name it ..._m)")
    found: dict[float, dict[str, str]] = {}
    for column in columns:
        match = _TRACKER_COLUMN.match(column)
        if match:
            point = found.setdefault(float(match.group(2)), {})
            if match.group(1) in point:  # x_0.5_m and x_0.50_m: one place, two columns
                raise TrajectoryError(f"{path}: columns {point[match.group(1)]} and {column} both name the "
                                      f"point at s = {float(match.group(2)):g}: two tracks of one place "
                                      "contradict each other; keep one")
            point[match.group(1)] = column
    bad = [s for s in found if not 0.0 <= s <= 1.0]
    if bad:
        raise TrajectoryError(f"{path}: tracked point at s = {bad[0]:g}: s is a fraction of the body "
                              "length, from 0 (back end) to 1 (front end)")
    single = [s for s, xy in found.items() if len(xy) != 2]
    if single:
        raise TrajectoryError(f"{path}: the point at s = {single[0]:g} needs both x_{single[0]:g}_m "
                              f"and y_{single[0]:g}_m")
    if not found:
        raise TrajectoryError(
            f"{path}: no tracked points (columns {', '.join(columns)}); expected x_<s>_m and y_<s>_m "
            "(m) per point, <s> its place along the body from 0 (back end) to 1 (front end), or "
            "the markers of msr's trajectory.csv (mid_x_m, mid_y_m, ...)")
    fractions = tuple(sorted(found))
    return "tracker", [(f"s={s:g}", found[s]["x"], found[s]["y"]) for s in fractions], fractions


def numeric_columns(path: Path, table: pd.DataFrame, used: list[str]) -> NDArray[np.float64]:
    """The columns ``used`` of a CSV ``table`` read from ``path`` as numbers, ``(rows, len(used))``;
    :class:`TrajectoryError` names the line and column of the first value that is not a finite
    number."""
    values = table[used].apply(pd.to_numeric, errors="coerce").to_numpy(dtype=np.float64)
    bad = ~np.isfinite(values)
    if bad.any():
        row, col = (int(i) for i in np.argwhere(bad)[0])
        unit = used[col].rsplit("_", 1)[-1] if "_" in used[col] else ""  # t_s, tip_x_m, current_0_A
        shown = f"({unit})" if unit in ("s", "m", "A") else "(SI units: s, m, A)"
        raise TrajectoryError(f"{path}: line {row + 2}, column {used[col]}: {table[used[col]].iloc[row]!r} "
                              f"is not a finite number {shown}")
    return values


def _check_unused(path: Path, unused: list[str]) -> None:
    """No column is dropped without a word: one that looks like a coordinate in m (an x or y word,
    ``head_x_m``, ``x_mid_m``, ``center_y_m``) is refused (a tracked point the fit would leave
    out), any other (a frame number, a tracker's likelihood) is said unused; msr's own
    trajectory.csv extras (:data:`TRAJECTORY_EXTRAS`) go without a word."""
    unused = [c for c in unused if c not in TRAJECTORY_EXTRAS]
    points = [c for c in unused if _COORDINATE_LIKE.search(c)]
    if points:
        raise TrajectoryError(f"{path}: column(s) {', '.join(points)} look like a tracked point's but are "
                              "not one the fit reads: a tracker's point is x_<s>_m, y_<s>_m (<s> its place "
                              "along the body, a number from 0 at the back end to 1 at the front end), "
                              "msr's markers back_/mid_/front_<x|y>_m; rename them, or drop them")
    if unused:
        from elastica_magnetic.plausibility import warn_implausible

        warn_implausible(f"{path}: column(s) {', '.join(unused)} are not used (the fit reads t_s and the "
                         "tracked points' x and y)", "")


def read_trajectory(path: str | Path) -> MeasuredTrajectory:
    """Read and check a measured trajectory (see the module docstring for the formats).

    Raises :class:`TrajectoryError` naming the file and the line or column: missing columns, a
    value that is not a finite number (NaN, empty), fewer than :data:`MIN_FRAMES` frames or less
    than :data:`MIN_DURATION_S`, time that does not increase or starts before 0, coordinates past
    :data:`MAX_COORDINATE_M` (millimetres given for metres)."""
    path = Path(path)
    table = _read_csv(path)
    kind, layout, fractions = _layout(path, list(table.columns))
    sideways = [c for c in table.columns
                if (str(c).endswith("_z_m") or _TRACKER_Z_COLUMN.match(str(c))) and kind != "tip path"]
    if sideways:  # e.g. msr's own trajectory.csv: its z markers are not compared
        from elastica_magnetic.plausibility import warn_implausible

        warn_implausible(f"{path}: columns {', '.join(sideways)} are not used: the fit compares the "
                         "side view (x and height y of each tracked point) only, so sideways motion "
                         "neither helps nor hurts it", "")
    used = ["t_s"] + [c for _, *xyz in layout for c in xyz]
    _check_unused(path, [str(c) for c in table.columns if c not in used and c not in sideways])
    values = numeric_columns(path, table, used)
    times = values[:, 0]
    if times.shape[0] < MIN_FRAMES:
        raise TrajectoryError(f"{path}: {times.shape[0]} frame(s); too short to fit, need at least "
                              f"{MIN_FRAMES} spanning {MIN_DURATION_S:g} s or more")
    steps = np.diff(times)
    if (steps <= 0).any():
        k = int(np.flatnonzero(steps <= 0)[0])
        raise TrajectoryError(f"{path}: line {k + 3}: t_s {times[k + 1]:g} s does not increase (line "
                              f"{k + 2} has {times[k]:g} s); frames must be in time order, once each")
    if times[0] < 0.0:
        raise TrajectoryError(f"{path}: line 2: t_s {times[0]:g} s is before the waveform starts; t_s "
                              "counts from the moment the waveform's first row is played")
    if times[-1] - times[0] < MIN_DURATION_S:
        raise TrajectoryError(f"{path}: spans {times[-1] - times[0]:g} s; too short to fit, need at "
                              f"least {MIN_DURATION_S:g} s")
    coordinates = values[:, 1:]
    if np.abs(coordinates).max() > MAX_COORDINATE_M:
        row, col = (int(i) for i in np.argwhere(np.abs(coordinates) > MAX_COORDINATE_M)[0])
        unit = ("micrometres: give metres (divide by 1e6)" if np.abs(coordinates).max() > 1e4
                else "millimetres: give metres (divide by 1000)")
        raise TrajectoryError(
            f"{path}: line {row + 2}, column {used[col + 1]}: {coordinates[row, col]:g} m; positions "
            f"past {MAX_COORDINATE_M:g} m look like {unit}")
    positions = coordinates.reshape(times.shape[0], len(layout), len(layout[0]) - 1)
    return MeasuredTrajectory(str(path), kind, times, positions, tuple(n for n, *_ in layout),
                              fractions)


#: A trajectory this many times longer than its waveform has its times in milliseconds.
_MILLISECONDS_FROM = 100.0
#: Points spread over this many body lengths (or more) are taken for centimetres, over
#: :data:`_MILLIMETRES_FROM` for millimetres (tracked points on a body lie 0.25 to 1 length
#: apart: x100 gives 25-100 lengths, x1000 250-1000).
_CENTIMETRES_FROM = 10.0
_MILLIMETRES_FROM = 160.0


def _length_unit_guess(lengths: float) -> str:
    """The unit mistake that makes a distance ``lengths`` body lengths (far too many)."""
    if lengths >= _MILLIMETRES_FROM:
        return "millimetres; give metres (divide by 1000)"
    if lengths >= _CENTIMETRES_FROM:
        return "centimetres; give metres (divide by 100)"
    return "another unit than metres (or from another recording)"


def check_against_robot(measured: MeasuredTrajectory, length: float, field_duration: float) -> None:
    """Checks that need the robot (``length``, m) and the waveform (``field_duration``, s): the
    frames lie within the waveform (a clock started elsewhere named as such), the points move (at
    least :data:`MIN_MOTION` of the length)
    and their motion and spacing fit the body (else a unit is wrong: mm or cm for m, ms for s)."""
    where = measured.source
    first = float(measured.times[0])
    if measured.duration > field_duration + 1e-9 and measured.duration - first <= field_duration + 1e-9:
        # the frames span no more than the waveform, but later: another clock (not milliseconds)
        raise TrajectoryError(f"{where}: its frames run from t_s = {first:g} s to {measured.duration:g} s, "
                              f"and the waveform's time runs from 0 to {field_duration:g} s: a tracker "
                              "clock that does not start with the waveform? subtract the tracker's time "
                              f"of the waveform's start from t_s ({first:g} s if the first frame is at it)")
    if measured.duration > _MILLISECONDS_FROM * field_duration:
        raise TrajectoryError(f"{where}: its frames reach t_s = {measured.duration:g} s, "
                              f"{measured.duration / field_duration:.0f} x the {field_duration:g} s "
                              "waveform: the times look like milliseconds; give seconds (divide "
                              "t_s by 1000)")
    if measured.duration > field_duration + 1e-9:
        frames = bool(np.all(measured.times == np.round(measured.times)) and measured.times.size > 2)
        hint = ("; t_s holds whole numbers 0, 1, 2...: frame numbers? give seconds (the frame "
                "number divided by the frames per second)" if frames else "")
        raise TrajectoryError(f"{where}: its frames reach {measured.duration:g} s, past the end of the "
                              f"waveform ({field_duration:g} s); cut the trajectory to the waveform"
                              f"{hint}")
    if measured.positions.shape[1] > 1:
        spread = np.ptp(measured.positions, axis=1)  # (n, 2): extent of the points per frame
        widest = float(np.hypot(spread[:, 0], spread[:, 1]).max())
        if widest > MAX_SEPARATION * length:
            guess = (f"the values look like {_length_unit_guess(widest / length)}"
                     if widest > _CENTIMETRES_FROM * length
                     else "are the points on the robot, and in metres?")
            raise TrajectoryError(f"{where}: tracked points {widest:g} m apart on a {length:g} m body "
                                  f"({widest / length:.3g} x its length): {guess}")
        _check_first_frame_span(measured, length)
    moved = np.linalg.norm(measured.displacements(), axis=2).max()
    if moved < MIN_MOTION * length:
        raise TrajectoryError(f"{where}: no motion to fit: the points move at most {1e3 * moved:.3g} mm, "
                              f"under {100 * MIN_MOTION:g} % of the {1e3 * length:g} mm body (are the "
                              "values in m? is this the right recording?)")
    if moved > MAX_MOTION_LENGTHS * length:
        raise TrajectoryError(f"{where}: a point moves {moved:g} m, {moved / length:.0f} body lengths: "
                              "the values look like millimetres or centimetres; give metres "
                              "(divide by 1000 or 100)")


def _check_first_frame_span(measured: MeasuredTrajectory, length: float) -> None:
    """The outermost points at the first frame (the robot at rest, straight, before the waveform
    acts) lie at least :data:`MIN_SPAN` of their distance along a straight body apart (points
    closer than that are on a shorter robot or in another unit), the back end's at the smaller x
    (else the columns' ends are swapped)."""
    fractions = (measured.fractions if measured.fractions is not None
                 else tuple(MARKER_FRACTIONS[name] for name in measured.points))  # trajectory.csv
    along = (max(fractions) - min(fractions)) * length
    first = measured.positions[0]
    span = float(np.ptp(first, axis=0) @ np.ptp(first, axis=0)) ** 0.5
    if along > 0.0 and span < MIN_SPAN * along:
        raise TrajectoryError(
            f"{measured.source}: at the first frame its outermost tracked points are {1e3 * span:.3g} mm "
            f"apart, and on the {1e3 * length:g} mm robot of the spec they lie {1e3 * along:.3g} mm apart "
            f"along the body (under {MIN_SPAN:g} x that even bent): is this the robot the spec "
            "describes, and are the values in metres?")
    back, front = int(np.argmin(fractions)), int(np.argmax(fractions))
    if first[front, 0] - first[back, 0] < -0.5 * span:  # the front end clearly behind the back end
        names = measured.points
        raise TrajectoryError(
            f"{measured.source}: at the first frame the point {names[front]} lies "
            f"{1e3 * (first[back, 0] - first[front, 0]):.3g} mm behind {names[back]} along x: the points "
            "run from the back end (s = 0, the end at smaller x when the robot lies straight) to the "
            "front end (s = 1); are the columns' ends swapped?")


def points_at_rows(measured: MeasuredTrajectory, trajectory: pd.DataFrame,
                   shapes: list[tuple[float, NDArray[np.float64]]]) -> NDArray[np.float64]:
    """The simulated positions of ``measured``'s points at each 0.01 s row of an open-loop run,
    ``(n_rows, k, 2)`` m: the markers of ``trajectory`` (``trajectory.csv`` points) or the rod's
    nodes interpolated at each point's fraction of the length (``shapes`` at every row, as
    ``run_open_loop(..., n_shapes=rows)`` gives)."""
    if measured.fractions is None:
        columns = [(f"{n}_x_m", f"{n}_y_m") for n in measured.points]
        return np.stack([trajectory[[x, y]].to_numpy() for x, y in columns], axis=1)
    nodes = np.stack([pos[:2] for _, pos in shapes])  # (rows, 2, n_nodes)
    n_elements = nodes.shape[2] - 1
    out = np.empty((nodes.shape[0], len(measured.fractions), 2))
    for j, s in enumerate(measured.fractions):
        f = s * n_elements
        lo = min(int(math.floor(f)), n_elements - 1)
        w = f - lo
        out[:, j, :] = (1.0 - w) * nodes[:, :, lo] + w * nodes[:, :, lo + 1]
    return out
