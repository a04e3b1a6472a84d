"""The columns that mark the recorded drives of a steered catheter, so that a reader of another
format names such a file for what it is: the coils' currents (``current_<K>_A``, A) and a magnet
arm's path (``magnet_x_m``, ... m); what every drive file shares (its header line, the insertion
stage's column, the 0.01 s grid's tolerance). Their readers are in ``elastica_magnetic_rl.sim2real``
(for identification) and :mod:`elastica_magnetic.hardware.coil_currents` (for the board)."""

from __future__ import annotations

import csv
import re
from collections.abc import Sequence
from pathlib import Path

#: A coil's current column: ``current_<K>_A``, K its index among the spec's coils (from 0), A.
CURRENT_COLUMN = re.compile(r"^current_(\d+)_A$")
#: A coil's current column in any unit or none, spelled in any case and with any separators
#: (``current_0_mA``, ``current_0``, ``Current0_A``, ``current_0 [A]``, ``current 0 (mA)``,
#: ``current_0_A_``, ``I_0_A``, ``coil_0_A``): a current column spelled otherwise is named for
#: what it is (:func:`current_unit_problem`), never read as another format. Its unit is group
#: ``unit`` (None where none is written).
CURRENT_ANY_UNIT = re.compile(
    r"^(?:current|curr|coil|i)[\s_\-]*(\d+)[\s_\-]*"
    r"(?:[\[(]\s*(?P<unit>[A-Za-z\u00b5\u03bc]+)\s*[\])]|(?P<bare_unit>[A-Za-z\u00b5\u03bc]+))?[\s_\-]*$",
    re.IGNORECASE)
#: Spellings of the ampere (lower case): such a column needs its name mended, not its values.
_AMPERE = ("a", "amp", "amps", "ampere", "amperes")
#: What turns a current in these units into A.
_TO_AMPERES = {"mA": "divide by 1000", "uA": "divide by 1e6", "\u00b5A": "divide by 1e6",
               "\u03bcA": "divide by 1e6", "kA": "multiply by 1000"}
#: The column that marks a magnet arm's path (its first position column, m).
MAGNET_COLUMN = "magnet_x_m"
#: The insertion stage's column of a recorded drive (m; only with a stage).
INSERTION_COLUMN = "insertion_m"
#: A drive's rows must lie on the 0.01 s control grid within this (s).
GRID_TOLERANCE_S = 1e-6


def grid_remedy(times: Sequence[float], period: float, resample: str) -> str:
    """What mends rows off the control grid (one row per ``period`` s from t_s = 0): a file whose
    rows are ``period`` apart but start later (a logger stamping each period's end) is shifted;
    anything else is resampled (``resample``: the advice, e.g. "resample the currents to 100 rows
    per second")."""
    t = [float(x) for x in times]
    shifted = all(abs(t[k] - t[0] - k * period) <= GRID_TOLERANCE_S for k in range(len(t)))
    if t and shifted and abs(t[0]) > GRID_TOLERANCE_S:
        return (f"the rows are {period:g} s apart but start at t_s = {t[0]:g} s: shift t_s by {-t[0]:g} s "
                "so that the first row is at 0")
    if len(t) > 1 and all(abs(t[k] - t[0] - k * 1000.0 * period) <= 1000.0 * GRID_TOLERANCE_S
                          for k in range(len(t))):  # 10 per row: a logger's milliseconds
        return (f"t_s rises by {1000.0 * period:g} per row, 1000 x the {period:g} s step: the times look "
                "like milliseconds; give seconds (divide t_s by 1000)")
    return resample


def header_names(path: str | Path) -> list[str]:
    """The column names on the first line of the CSV file ``path`` (a byte-order mark dropped,
    names stripped; [] when it cannot be read: its reader then names why)."""
    try:
        with open(path, encoding="utf-8-sig", newline="") as handle:
            return [name.strip() for name in next(csv.reader(handle), [])]
    except (OSError, UnicodeDecodeError, csv.Error):
        return []


def drive_described(names: Sequence[str]) -> str | None:
    """What a CSV whose header holds ``names`` is, when it is a catheter's recorded drive (as a
    person reads it: ``"the currents of 8 coils (current_0_A, ..., A)"``), else None."""
    currents = [n for n in names if CURRENT_ANY_UNIT.match(n)]
    if currents:
        return (f"the currents of {len(currents)} coil{'s' if len(currents) != 1 else ''} "
                f"({currents[0]}, ..., A), a catheter's drive by coil currents")
    if MAGNET_COLUMN in names:
        return f"a magnet arm's path ({MAGNET_COLUMN}, ..., m), a catheter's drive by a magnet"
    return None


def is_coil_currents(path: str | Path) -> bool:
    """Whether the CSV file at ``path`` is a coil-current drive: its header names a
    ``current_<K>_A`` column (:data:`CURRENT_COLUMN`), however numbered (its reader names a
    numbering that does not start at 0), or one in another unit (:data:`CURRENT_ANY_UNIT`: its
    reader names the unit, :func:`current_unit_problem`)."""
    return any(CURRENT_ANY_UNIT.match(name) for name in header_names(path))


def current_unit_problem(names: Sequence[str]) -> str | None:
    """What is wrong with current columns in another unit than A among ``names``
    (``current_0_mA``), as a person reads it, or ``None``."""
    wrong = [n for n in names if CURRENT_ANY_UNIT.match(n) and not CURRENT_COLUMN.match(n)]
    if not wrong:
        return None
    shown = ", ".join(wrong) if len(wrong) <= 3 else f"{wrong[0]}, ..., {wrong[-1]}"
    units = {_unit_of(n) for n in wrong}
    if "" in units:  # no unit written: what the values are in is not known
        return (f"column(s) {shown}: a coil's current column is named current_<K>_A, its values in A; "
                "rename the columns current_0_A, current_1_A, ... (with the values in A)")
    if all(unit.lower() in _AMPERE for unit in units):  # amperes already: only the names differ
        return (f"column(s) {shown}: a coil's current column is named current_<K>_A exactly (lower-case "
                "current, capital A); the values are amperes already: rename the columns current_0_A, "
                "current_1_A, ...")
    unit = next(u for u in sorted(units) if u.lower() not in _AMPERE)
    # mA spelled in any case (ma, MA: no coil runs mega-amperes)
    convert = {k.lower(): v for k, v in _TO_AMPERES.items()}.get(unit.lower(), f"convert {unit} to A")
    return (f"column(s) {shown}: a coil's current is in A, its column current_<K>_A; the currents in "
            f"{unit}? {convert} and name the columns current_0_A, current_1_A, ...")


def _unit_of(name: str) -> str:
    """The unit written in the current column ``name`` (``""`` where none is)."""
    match = CURRENT_ANY_UNIT.match(name)
    return (match.group("unit") or match.group("bare_unit") or "") if match else ""


def is_magnet_path(path: str | Path) -> bool:
    """Whether the CSV file at ``path`` is a magnet arm's path (its header names
    :data:`MAGNET_COLUMN`)."""
    return MAGNET_COLUMN in header_names(path)
