"""A coil-current file played by the board (``msr real stream coil_currents.csv``, ``STREAM
CURRENTS``): the currents of up to three coils, one per DAC output, in A.

The file is the coils' drive as ``msr field baseline --case ... --target ...`` and ``msr policy
generate ... --target ...`` write it (``coil_currents.csv``, docs/sim_to_real.md): a header line,
then one row per 0.01 s control step from ``t_s = 0``::

    t_s,current_0_A,current_1_A,current_2_A[,insertion_m]

Column ``current_K_A`` is played on output K (:data:`BOARD_OUTPUTS`); outputs without a column get
0 A. The board converts each current with the calibration's tail (current limit, slew limit,
``V = I / transconductance + offset``, code; the actuation matrix is not used), which
:meth:`~elastica_magnetic.hardware.calibration.DacCodeModel.currents_to_codes` repeats bit for bit.
A file of more coils than outputs is refused by name before anything is sent.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic.clock_columns import TIME_COLUMN, other_clock_hint
from elastica_magnetic.drive_columns import (
    CURRENT_COLUMN,
    GRID_TOLERANCE_S,
    INSERTION_COLUMN,
    current_unit_problem,
    grid_remedy,
)
from elastica_magnetic.field_csv import numbered_rows
from elastica_magnetic.robot_spec import ACTION_PERIOD

from ..io import missing_folder_hint
from .calibration import Calibration

#: The board's outputs in the order of a row, one coil each (docs/firmware.md, "Wiring").
BOARD_OUTPUTS = ("DAC8563 #1 A", "DAC8563 #1 B", "DAC8563 #2 A")
#: The time between the rows the board plays (s): one row per control step.
ROW_PERIOD_S = ACTION_PERIOD
#: A current above this (A) is milliamperes written as amperes (no coil driver makes more).
UNIT_MISTAKE_A = 1000.0
#: What a coil-current file holds, for messages.
FORM = (f"a coil-current file has {TIME_COLUMN} (s, 0, 0.01, 0.02, ...) and current_0_A, current_1_A, "
        f"current_2_A (A, one per board output: {', '.join(BOARD_OUTPUTS)})")


class CoilCurrentsError(ValueError):
    """A coil-current file the board cannot play; the message names the file, line and column."""


@dataclass(frozen=True)
class BoardCurrents:
    """The currents of one coil-current file, as the coil board plays them (not
    :class:`elastica_magnetic.CoilCurrents`, which simulates coils driven by currents).

    Attributes
    ----------
    source : str
        The file, for messages.
    columns : tuple of str
        The current columns, ``current_0_A`` ... in order (at most :data:`BOARD_OUTPUTS`).
    currents_A : ndarray (n, len(columns))
        A, column K on output K.
    lines : list of int
        The file's line of every row (1-based), for messages.
    """

    source: str
    columns: tuple[str, ...]
    currents_A: NDArray[np.float64]
    lines: tuple[int, ...]

    def board_rows(self) -> NDArray[np.float64]:
        """``(n, 3)`` A, one column per board output, 0 A on an output without a column."""
        rows = np.zeros((self.currents_A.shape[0], len(BOARD_OUTPUTS)))
        rows[:, :self.currents_A.shape[1]] = self.currents_A
        return rows


def read_coil_currents(path: str | Path) -> BoardCurrents:
    """Read a coil-current file for the board (see the module docstring).

    Raises
    ------
    CoilCurrentsError
        More current columns than the board has outputs ("needs 8 channels, the board drives 3"),
        columns not numbered 0, 1, ... in order, no ``t_s``, a value that is not a finite number,
        a row off the 0.01 s grid, a current past :data:`UNIT_MISTAKE_A` (mA for A), an insertion
        stage that moves (the board drives coils only). Each names the file and, for a value, its
        line and column.
    """
    path = Path(path)
    names, body = _table(path)
    columns = _current_columns(path, names)
    used = [names.index(TIME_COLUMN), *(names.index(c) for c in columns)]
    insertion = names.index(INSERTION_COLUMN) if INSERTION_COLUMN in names else None
    values = np.array([[_number(path, line, row, k, names) for k in used] for line, row in body])
    lines = tuple(line for line, _ in body)
    _check_grid(path, values[:, 0], lines)
    currents = values[:, 1:]
    _check_unit(path, currents, columns, lines)
    if insertion is not None:
        _check_insertion(path, [_number(path, line, row, insertion, names) for line, row in body], lines)
    return BoardCurrents(str(path), tuple(columns), currents, lines)


def _table(path: Path) -> tuple[list[str], list[tuple[int, list[str]]]]:
    """The header's names and the data rows with their line numbers (blank lines skipped)."""
    if path.is_dir():
        raise CoilCurrentsError(f"{path}: is a folder, not a coil-current CSV file")
    if not path.is_file():
        raise CoilCurrentsError(f"{path}: no such coil-current file{missing_folder_hint(path)}")
    try:
        text = path.read_bytes().decode("utf-8-sig")
        rows = list(csv.reader(io.StringIO(text, newline="")))
    except UnicodeDecodeError as exc:
        raise CoilCurrentsError(f"{path}: not UTF-8 text (byte {exc.start}); save it as a UTF-8 "
                                "CSV") from None
    except csv.Error as exc:
        raise CoilCurrentsError(f"{path}: not a readable CSV: {exc}") from None
    numbered = numbered_rows(path, rows, CoilCurrentsError)
    if not numbered:
        raise CoilCurrentsError(f"{path}: empty file; {FORM}")
    names = [c.strip() for c in numbered[0][1]]
    body = numbered[1:]
    if not body:
        raise CoilCurrentsError(f"{path}: header but no data rows; {FORM}")
    for line, row in body:
        if len(row) != len(names):
            raise CoilCurrentsError(f"{path}: line {line} has {len(row)} columns, the header "
                                    f"{len(names)}: {','.join(row)!r}")
    return names, body


def _current_columns(path: Path, names: list[str]) -> list[str]:
    """The current columns, checked: at most one per board output, numbered from 0 in order, and
    a ``t_s`` column."""
    if (problem := current_unit_problem(names)) is not None:
        raise CoilCurrentsError(f"{path}: {problem}; nothing was sent")
    columns = [n for n in names if CURRENT_COLUMN.match(n)]
    outputs = len(BOARD_OUTPUTS)
    if len(columns) > outputs:
        raise CoilCurrentsError(
            f"{path}: needs {len(columns)} channels, the board drives {outputs} ({', '.join(BOARD_OUTPUTS)}: "
            f"current_0_A to current_{outputs - 1}_A, in A); nothing was sent. Play a drive of more "
            "coils through the navigation system's own coil drivers")
    numbers = [int(CURRENT_COLUMN.match(c).group(1)) for c in columns]  # type: ignore[union-attr]
    if not columns or numbers != list(range(len(columns))):
        found = ", ".join(columns) or "none"
        raise CoilCurrentsError(f"{path}: current columns {found}: they are numbered from 0 in "
                                f"order, current_K_A played on output K; {FORM}")
    if TIME_COLUMN not in names:
        raise CoilCurrentsError(f"{path}: no column {TIME_COLUMN}{other_clock_hint(names)}; {FORM}")
    others = [n for n in names if n not in (TIME_COLUMN, INSERTION_COLUMN, *columns)]
    if others:
        raise CoilCurrentsError(f"{path}: column(s) {', '.join(repr(n) for n in others)} are not "
                                f"played; {FORM} (and {INSERTION_COLUMN}, m, held at 0): remove them")
    return columns


def _number(path: Path, line: int, row: list[str], k: int, names: list[str]) -> float:
    text = row[k].strip()
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        unit = "s" if names[k] == TIME_COLUMN else ("m" if names[k] == INSERTION_COLUMN else "A")
        raise CoilCurrentsError(f"{path}: line {line}, column {names[k]}: {text!r} is not a finite "
                                f"number ({unit})")
    return value


def _check_grid(path: Path, times: NDArray[np.float64], lines: tuple[int, ...]) -> None:
    grid = np.arange(times.shape[0]) * ROW_PERIOD_S
    off = np.abs(times - grid) > GRID_TOLERANCE_S
    if off.any():
        k = int(np.flatnonzero(off)[0])
        raise CoilCurrentsError(
            f"{path}: line {lines[k]}, column {TIME_COLUMN}: {times[k]:g} s, expected {grid[k]:g} s: "
            f"the board plays one row per {ROW_PERIOD_S:g} s from {TIME_COLUMN} = 0 ("
            + grid_remedy(times, ROW_PERIOD_S, "resample the currents to 100 rows per second") + ")")


def _check_unit(path: Path, currents: NDArray[np.float64], columns: list[str],
                lines: tuple[int, ...]) -> None:
    high = np.abs(currents) > UNIT_MISTAKE_A
    if high.any():
        row, col = (int(i) for i in np.argwhere(high)[0])
        raise CoilCurrentsError(f"{path}: line {lines[row]}, column {columns[col]}: "
                                f"{currents[row, col]:g} A; "
                                f"no coil driver makes more than {UNIT_MISTAKE_A:g} A: milliamperes "
                                "written as amperes? (give A)")


def _check_insertion(path: Path, insertion: list[float], lines: tuple[int, ...]) -> None:
    moved = [k for k, value in enumerate(insertion) if value != 0.0]
    if moved:
        k = moved[0]
        raise CoilCurrentsError(
            f"{path}: line {lines[k]}, column {INSERTION_COLUMN}: {insertion[k]:g} m: the insertion "
            "stage moves, and the board drives the coils only; play the stage with its own "
            f"controller and give the board the currents alone (drop {INSERTION_COLUMN}, or hold it at 0 m)")


# ----------------------------------------------------------------------------- the calibration's limits
@dataclass(frozen=True)
class LimitFinding:
    """The first row a calibration's limit changes, and how many rows it does."""

    rows: int
    first: int
    column: str
    value: float
    limit: float


def _first_over(values: NDArray[np.float64], limits: NDArray[np.float64],
                columns: tuple[str, ...]) -> LimitFinding | None:
    over = np.abs(values) > limits
    if not over.any():
        return None
    row, col = (int(i) for i in np.argwhere(over)[0])
    return LimitFinding(int(over.any(axis=1).sum()), row, columns[col], float(values[row, col]),
                        float(limits[col]))


def clipping_problem(calibration: Calibration, drive: BoardCurrents) -> str | None:
    """What the board would clamp in ``drive`` with ``calibration``: currents beyond
    ``current_limit_A`` or an amplifier input beyond the DAC's span (``dac_half_span_V``), naming
    the first line and column; ``None`` when nothing is clamped."""
    cal = calibration
    n = len(drive.columns)
    currents = drive.currents_A
    where = f"calibration {cal.name!r}"
    limit = _first_over(currents, np.array(cal.current_limit_A[:n]), drive.columns)
    if limit is not None:
        k = drive.columns.index(limit.column)
        return (f"{drive.source}: line {drive.lines[limit.first]}, column {limit.column}: "
                f"{limit.value:g} A is beyond the current_limit_A[{k}] of {where}, {limit.limit:g} A on "
                f"output {k} ({BOARD_OUTPUTS[k]}; {limit.rows} row(s) over it)")
    clamped = np.clip(currents, -np.array(cal.current_limit_A[:n]), np.array(cal.current_limit_A[:n]))
    volts = clamped / np.array(cal.transconductance_A_per_V[:n]) + np.array(cal.input_offset_V[:n])
    span = _first_over(volts, np.full(n, cal.dac_half_span_V), drive.columns)
    if span is not None:
        k = drive.columns.index(span.column)
        return (f"{drive.source}: line {drive.lines[span.first]}, column {span.column}: needs "
                f"{span.value:.4g} V at the amplifier input of output {k} (I / transconductance_A_per_V + "
                f"input_offset_V of {where}), beyond the DAC's span of +-{span.limit:g} V ({span.rows} "
                "row(s) over it)")
    return None


def slew_problem(calibration: Calibration, drive: BoardCurrents) -> str | None:
    """Where ``drive``'s currents change faster than the calibration's ``slew_limit_A_per_s``
    (from 0 A before the first row, as the board starts): the board reaches them late, so this is
    a warning, not a refusal. ``None`` when no row is slew-limited."""
    cal = calibration
    n = len(drive.columns)
    limits = np.array(cal.current_limit_A[:n])
    clamped = np.clip(drive.currents_A, -limits, limits)
    rates = np.diff(clamped, axis=0, prepend=np.zeros((1, n))) / ROW_PERIOD_S
    fast = _first_over(rates, np.array(cal.slew_limit_A_per_s[:n]), drive.columns)
    if fast is None:
        return None
    return (f"{drive.source}: line {drive.lines[fast.first]}, column {fast.column}: changes at "
            f"{abs(fast.value):.4g} A/s, faster than the slew_limit_A_per_s of calibration {cal.name!r}, "
            f"{fast.limit:g} A/s ({fast.rows} row(s); from 0 A before the first row): the board reaches "
            "these currents late")
