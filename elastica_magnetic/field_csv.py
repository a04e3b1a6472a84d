"""Reading and writing field CSV files: the paper's interchange format and the firmware's input.

Format (as published by Yao et al. 2023): an optional header line ``,mag_x,mag_y,mag_z`` (or
``index,mag_x,mag_y,mag_z``), then one row per 1/100 s: an optional integer index column, then the
field components in **millitesla**. Row ``i`` holds the field during ``[i/100, (i+1)/100)`` s.

Inside the package fields are in tesla; the conversion happens here and only here, in decimal:
a value is written as the shortest decimal of its tesla value with the point moved three places,
and read by moving the point back, so a field written and read again is the same float to the
last bit (the waveform a policy played is the waveform its CSV replays), and a hand-written
``3.9876`` reads as the double nearest 3.9876e-3 T.
"""

from __future__ import annotations

import csv
import io
import math
import re
from decimal import MAX_EMAX, MIN_EMIN, Context, Decimal
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from .clock_columns import clock_scale, clock_text_seconds, other_spelling_hint, trailing_time_unit
from .drive_columns import MAGNET_COLUMN, drive_described
from .io import atomic_write, missing_folder_hint
from .plausibility import judge, warn_implausible
from .robot_spec import ACTION_PERIOD

#: Rows per second of a field CSV (the paper's 100 Hz field update).
FIELD_CSV_RATE_HZ = 100.0
#: Column names of the field components, in mT.
FIELD_COLUMNS = ("mag_x", "mag_y", "mag_z")
# headers read as a row index 0, 1, 2... in the first column (pandas writes an unnamed one)
INDEX_HEADERS = ("", "index", "unnamed: 0", "row", "step", "i", "idx", "#", "n", "k", "sample", "row_index")
MILLITESLA = 1e-3


class FieldCSVError(ValueError):
    """A field CSV file that cannot be read; the message names the file, row and problem."""


def read_field_csv(path: str | Path, *, plausible: bool = False) -> NDArray[np.float64]:
    """Read a field CSV (mT) and return the field in tesla.

    Parameters
    ----------
    path : str or Path
        CSV file with columns ``mag_x, mag_y, mag_z`` in mT, optionally preceded by an index
        column and a header line.
    plausible : bool
        Also judge the largest field as a coil field (what the doors that play a file do:
        ``msr field replay``, ``export-firmware``, ``stream``): refuse one below 0.05 mT or above 1 T
        (tesla or gauss written as mT), warn about one below 0.5 mT or above 100 mT
        (:class:`~elastica_magnetic.plausibility.ImplausibleValueWarning`).

    Returns
    -------
    numpy.ndarray
        ``(n_rows, 3)`` float64 array of the field in **tesla**; row ``i`` is the field held on
        ``[i/100, (i+1)/100)`` s.

    Raises
    ------
    FieldCSVError
        Missing file, missing columns, a malformed or non-numeric row, a non-finite value, an
        index column that does not count 0, 1, 2, ..., or (``plausible``) a largest field no coil
        makes. The message names the file and the row (1-based line number in the file).
    """
    path = Path(path)
    if path.is_dir():
        inside = sorted(p.name for p in path.glob("*.csv"))
        raise FieldCSVError(f"{path}: is a folder, not a field CSV file; give a CSV file"
                            + (f" (this folder has: {', '.join(inside)})" if inside else ""))
    if not path.is_file():
        if path.exists():  # a FIFO, a device such as /dev/null: read once, or never ends
            raise FieldCSVError(f"{path}: is not a regular file (a pipe or a device); give a field "
                                "CSV file")
        raise FieldCSVError(f"{path}: no such field CSV file{missing_folder_hint(path)}")
    rows_with_lines = numbered_rows(path, _csv_rows(path, FieldCSVError), FieldCSVError)
    if not rows_with_lines:
        raise FieldCSVError(f"{path}: empty file, expected columns {', '.join(FIELD_COLUMNS)} (mT)")
    columns, index_column, ncols, body = _column_layout(path, rows_with_lines)
    if not body:
        raise FieldCSVError(f"{path}: header but no data rows")
    field = np.empty((len(body), 3))
    header = rows_with_lines[0][1] if len(body) < len(rows_with_lines) else None
    index = "the first of four columns" if header is None else f"the first column, {header[0].strip()!r},"
    for k, (line, row) in enumerate(body):
        field[k] = _field_row(path, line, row, k, columns, (index_column, index), ncols)
    _check_clock_columns(path, rows_with_lines[0][1], body, columns, index_column)
    if plausible:
        _check_plausible(path, field, [line for line, _ in body])
    return field


def _check_plausible(path: Path, field: NDArray[np.float64], lines: list[int]) -> None:
    """Judge the largest |field| of the file as a coil field (:mod:`~elastica_magnetic.plausibility`):
    refuse one no coil makes around a robot (tesla or gauss written as mT), warn about an unusual one."""
    _check_column_units(path, field)
    strength = np.linalg.norm(field, axis=1) / MILLITESLA
    k = int(np.argmax(strength))
    finding = judge("coil field", float(strength[k]), "mT", MILLITESLA)
    if finding is None:
        return
    text = f"{path}: line {lines[k]}: the largest |field| = {finding.text}"
    if finding.refuse:
        raise FieldCSVError(text)
    warn_implausible(f"{text}; the file is played as written", stacklevel=4)


#: A column whose largest |value| is below this fraction of another's is about 1000 times
#: smaller: one column in T among columns in mT.
_COLUMN_RATIO_TESLA = 3e-3


def _check_column_units(path: Path, field: NDArray[np.float64]) -> None:
    """Warn about a column about 1000 times weaker than another (tesla written in one column of
    an mT file): no coil set makes one axis 1000 times weaker on purpose."""
    largest = np.abs(field).max(axis=0) / MILLITESLA  # per column, mT
    strongest = int(np.argmax(largest))
    for k, value in enumerate(largest):
        if 0.0 < value < _COLUMN_RATIO_TESLA * largest[strongest]:
            name, other = FIELD_COLUMNS[k], FIELD_COLUMNS[strongest]
            ratio = largest[strongest] / value
            if ratio < 1e5:  # about 1000: the unit mistake it looks like
                reading = f"about {ratio:.0f} times less: {name} in T where the file is in mT?"
            else:  # far beyond a unit: round-off or a stray value, not tesla for millitesla
                times = f"{ratio:.3g} times" if math.isfinite(ratio) else "more than 1e308 times"
                reading = f"{times} less: a column of round-off or stray values?"
            warn_implausible(
                f"{path}: column {name} reaches only {value:.3g} mT while {other} reaches "
                f"{largest[strongest]:.3g} mT, {reading} (every column of a field CSV is in mT); "
                "the file is played as written", stacklevel=5)


def named_twice(names: list[str]) -> str:
    """``"names mag_x twice (columns 2 and 5)"`` for the first column named more than once, or
    ``""``: which of two columns is meant cannot be guessed (every CSV reader checks it)."""
    for k, name in enumerate(names):
        if name and name in names[k + 1:]:
            where = [str(i + 1) for i, other in enumerate(names) if other == name]
            return f"names {name} {len(where)} times (columns {' and '.join(where)})".replace(
                "2 times", "twice")
    return ""


def header_named_twice(path: str | Path) -> str:
    """:func:`named_twice` of the header line of the CSV file ``path`` (a reader that renames a
    repeated column, as pandas does, would drop one copy in silence); ``""`` when the file cannot
    be read here (its reader names that)."""
    import csv

    try:
        with open(path, encoding="utf-8-sig", newline="") as handle:
            names = next(csv.reader(handle), [])
    except (OSError, UnicodeDecodeError, csv.Error):
        return ""
    return named_twice([name.strip() for name in names])


#: Separators other than the comma that spreadsheets write (locales with a decimal comma use ';').
_OTHER_SEPARATORS = {";": "semicolons", "\t": "tabs", "|": "vertical bars"}


def separator_hint(names: list[str]) -> str:
    """For a header read as comma-separated: ``"; its columns are separated by semicolons ..."``
    where it came as one column holding another separator (a spreadsheet's export in a locale
    with a decimal comma), else ``""``. Every CSV reader adds it to its missing-column message."""
    if len(names) == 1:
        for separator, name in _OTHER_SEPARATORS.items():
            if separator in names[0]:
                return (f"; its columns are separated by {name}, not commas (the first line "
                        f"{names[0]!r} was read as one column): save the file as CSV with commas "
                        "between columns and dots in numbers")
    return ""


def decimal_comma_hint(names: list[str]) -> str:
    """For a header read as comma-separated: what looks like a name holding a decimal comma split
    in two columns (``x_0`` then ``5_m``: ``x_0,5_m`` for ``x_0.5_m``), as a person reads it, or
    ``""``."""

    for first, second in zip(names, names[1:], strict=False):
        if re.search(r"_\d+$", first) and re.match(r"\d+(_|$)", second):
            return (f"the columns {first!r} and {second!r} look like one name written with a decimal "
                    f"comma ({first},{second}) and split at it: write numbers with a dot ({first}.{second})")
    return ""


def _column_layout(path: Path, rows_with_lines: list[tuple[int, list[str]]]
                   ) -> tuple[list[int], int | None, int, list[tuple[int, list[str]]]]:
    """Where the field components are: their column indices, the index column (``None``: none),
    the number of columns every row must have, and the data rows (after a header, if any)."""
    first_line, first = rows_with_lines[0]
    if len(first) > 1 and not first[-1].strip() and all(is_number(c) for c in first[:-1]):
        raise FieldCSVError(
            f"{path}: line {first_line} has {len(first)} columns, the last one empty (a trailing "
            f"comma?); expected 3 (mag_x, mag_y, mag_z in mT) or 4 (index first): remove the "
            "comma at the end of each row")
    if is_number(first[-1]):  # no header
        ncols = len(first)
        if ncols == 3:
            return [0, 1, 2], None, ncols, rows_with_lines
        if ncols == 4:
            return [1, 2, 3], 0, ncols, rows_with_lines
        raise FieldCSVError(
            f"{path}: line {first_line} has {ncols} columns; expected 3 (mag_x, mag_y, mag_z "
            "in mT) or 4 (index first)"
        )
    names = [c.strip() for c in first]
    twice = named_twice(names)
    if twice:
        raise FieldCSVError(f"{path}: header on line {first_line} {twice}; give each column once")
    missing = [c for c in FIELD_COLUMNS if c not in names]
    drive = drive_described(names) if missing else None
    if drive:  # a drive is played by its own hardware, not as a uniform field
        player = ("'msr real stream FILE' (up to 3 coils, one board output each; more coils by their own "
                  "drivers)" if MAGNET_COLUMN not in names else "the arm's controller")
        raise FieldCSVError(
            f"{path}: holds {drive}, not a field ({', '.join(FIELD_COLUMNS)} in mT): a field CSV is "
            "a uniform field, what msr field replay simulates and the coil board plays through its three "
            f"field axes; a catheter's drive is replayed by msr real identify and played by {player}")
    if missing:
        spelled = other_spelling_hint(missing, names,
                                      "name the columns exactly mag_x, mag_y, mag_z, the values in mT")
        raise FieldCSVError(
            f"{path}: header on line {first_line} lacks column(s) {', '.join(missing)}{spelled}; "
            f"expected {', '.join(FIELD_COLUMNS)} in mT (found {names}){separator_hint(names)}"
            + (f"; line {first_line} is a comment (it starts with #): msr reads no comment lines, delete it"
               if names and names[0].startswith("#") else "")
        )
    columns = [names.index(c) for c in FIELD_COLUMNS]
    # a first column before the field's headed as a row index (pandas writes '' for its index); one
    # headed otherwise is another column (a current I_A, a clock t_ms checked in its unit: 0, 1, 2 ms
    # is a 1 kHz waveform), not read
    index_column = 0 if columns == [1, 2, 3] and names[0].lower() in INDEX_HEADERS else None
    unread = [n for k, n in enumerate(names) if k not in columns and k != index_column]
    if unread:  # a column a user may think is played (a current, a time)
        warn_implausible(f"{path}: column(s) {', '.join(repr(n) for n in unread)} are not read: the field "
                         f"is {', '.join(FIELD_COLUMNS)} (mT), one row per 0.01 s", stacklevel=4)
    return columns, index_column, len(names), rows_with_lines[1:]


def _check_clock_columns(path: Path, header: list[str], body: list[tuple[int, list[str]]],
                         columns: list[int], index_column: int | None) -> None:
    """Refuse a clock column the field does not read whose times are not the rows' 0.01 s steps
    (or that misses a time): the rows are played 0.01 s apart whatever it says (a waveform
    sampled at 50 Hz would play twice as fast). A clock is a column headed as one
    (:func:`~elastica_magnetic.clock_columns.clock_scale`) or any column of times written as times;
    its times are numbers in the header's unit, or written as a clock reads them (``00:00:00.02``,
    ``10:00:00,02 AM``), with their unit (``0.02 s``) or as dates and times (ISO 8601)."""
    for c, name in enumerate(header):
        if c in columns or c == index_column:
            continue
        texts = [row[c].strip() for _, row in body]
        clock = clock_scale(name, row_period=ACTION_PERIOD)
        if clock is None and texts and all(clock_text_seconds(t) is not None for t in texts):
            clock = ("", 1.0)  # another header over times written as times (00:00:00.02, 0.02 s)
        if clock is None:
            _check_evenly_rising(path, name, texts, body)
            continue
        times = _clock_times(path, name, clock, texts, [line for line, _ in body])
        steps = np.diff(times)
        if steps.size and np.all(steps < 0.0):  # a clock running backwards: the rows' order reversed
            raise FieldCSVError(
                f"{path}: column {name!r} reads as a clock whose times fall every row (from "
                f"{times[0]:g} s at line {body[0][0]} to {times[-1]:g} s at line {body[-1][0]}): the rows "
                "run backwards in time, and a field CSV's rows are played from its first line down: sort "
                "the rows by time (or, if the column counts down the time left, drop it)")
        # a logger's clock jitters: on 0.01 s on average, each step may be off by a tenth of it
        even = steps.size > 0 and abs(float(np.mean(steps)) - ACTION_PERIOD) <= 1e-3 * ACTION_PERIOD
        tolerance = CLOCK_JITTER if even else 1e-3
        off = np.flatnonzero(np.abs(steps - ACTION_PERIOD) > tolerance * ACTION_PERIOD)
        if off.size:
            k = int(off[0])
            # dates (seconds since 1970) printed whole would read alike: from the column's first time
            # (and times of day, 36000 s and more, whose steps would not show either)
            relative = abs(times[0]) >= 1e5 or f"{times[k]:g}" == f"{times[k + 1]:g}"
            origin, since = (times[0], " after its first time") if relative else (0.0, "")
            raise FieldCSVError(
                f"{path}: column {name!r} reads as a clock stepping {steps[k]:g} s at line "
                f"{body[k + 1][0]} (from {times[k] - origin:g} to {times[k + 1] - origin:g} s{since}), but "
                f"a field CSV's rows are played {ACTION_PERIOD:g} s apart whatever it says: "
                f"{_clock_remedy(name, steps)}")


#: How far one step of a clock column whose mean step is the rows' 0.01 s may be off it, as a
#: fraction of 0.01 s (a logger stamping its rows to within a millisecond).
CLOCK_JITTER = 0.1

#: The steps a column rising evenly may take and agree with the rows' 0.01 s: 0.01 in s, ms, us or ns.
_ROW_PERIOD_IN_UNITS = tuple(ACTION_PERIOD / scale for scale in (1.0, 1e-3, 1e-6, 1e-9))


def _check_evenly_rising(path: Path, name: str, texts: list[str], body: list[tuple[int, list[str]]]) -> None:
    """Refuse a column of another header that rises by one step every row, as a clock does, by a
    step that is not the rows' 0.01 s in s, ms, us or ns (``micros`` at 20000, ``Zeit`` at 0.02: a
    50 Hz waveform would play at 100 Hz): no list of clock headers holds every logger's. A count of
    the rows (a step of 1 from 0 or 1: a frame number) and a column of uneven steps are left to the
    unread-column warning."""
    texts = [re.sub(r"^([-+]?\d+),(\d+)$", r"\1.\2", t) for t in texts]  # a decimal comma ("0,02")
    if len(texts) < 3 or not all(is_number(t) for t in texts):
        return
    values = np.array([float(t) for t in texts])
    steps = np.diff(values)
    step = float(np.median(steps))
    if step == 0.0 or np.any(np.abs(steps - step) > 0.05 * abs(step)):
        return  # not a clock's even rise (nor a countdown's even fall)
    rises = "rises" if step > 0.0 else "falls"
    step = abs(step)
    named = trailing_time_unit(name)
    if named is not None:  # a clock in a language msr has no words for: its unit says the step
        unit, scale = named
        if abs(step * scale - ACTION_PERIOD) <= 1e-3 * ACTION_PERIOD:
            return
        raise FieldCSVError(
            f"{path}: column {name!r} {rises} by {step:g} {unit} every row (from line {body[0][0]}), evenly, "
            f"as a clock does: {step * scale:g} s per row, and a field CSV's rows are played "
            f"{ACTION_PERIOD:g} s apart whatever it says: resample the waveform to {ACTION_PERIOD:g} s "
            "steps and drop the column (if it is no clock, drop it)")
    if rises == "rises" and step == 1.0 and values[0] in (0.0, 1.0):
        return  # the rows counted
    if any(abs(step - period) <= 1e-3 * period for period in _ROW_PERIOD_IN_UNITS):
        return  # a clock of the rows' steps in some unit
    raise FieldCSVError(
        f"{path}: column {name!r} {rises} by {step:g} every row (from line {body[0][0]}), evenly, as a clock "
        f"does, and not by {ACTION_PERIOD:g} in s, ms, us or ns: if it is a clock, the rows are not "
        f"{ACTION_PERIOD:g} s apart, and a field CSV's rows are played {ACTION_PERIOD:g} s apart whatever "
        f"it says: resample the waveform to {ACTION_PERIOD:g} s steps and drop the column; if it is no "
        "clock, drop it")


def _clock_remedy(name: str, steps: NDArray[np.float64]) -> str:
    """What mends a clock column whose ``steps`` (s) are not the rows' 0.01 s: its unit, where every
    step is 0.01 s in a unit 1000 or 1e6 times smaller than its header says (a logger's ms under an
    s header); else a resampling."""
    for factor in (1e3, 1e6):
        if np.allclose(steps, factor * ACTION_PERIOD, rtol=1e-3, atol=0.0):
            return (f"its times step {ACTION_PERIOD:g} s in a unit {factor:g} times smaller than {name!r} "
                    f"says: name that unit in the header or divide its times by {factor:g} (or drop the "
                    "column)")
    return (f"resample the waveform to {ACTION_PERIOD:g} s steps (100 rows per second), or drop the "
            "column")


def _clock_times(path: Path, name: str, clock: tuple[str, float | None], texts: list[str],
                 lines: list[int]) -> NDArray[np.float64]:
    """The times (s) of clock column ``name``: numbers in its unit, or clock, date-and-time or
    with-unit texts. A row without a time, times in no form msr reads, or numbers in a unit msr does
    not know are a :class:`FieldCSVError`: a clock is checked or refused, never passed."""
    texts = [re.sub(r"^([-+]?\d+),(\d+)$", r"\1.\2", t) for t in texts]  # a decimal comma ("0,02")
    numbers = [float(t) if is_number(t) else None for t in texts]
    stamps = [clock_text_seconds(t) for t in texts]
    values = numbers if any(v is not None for v in numbers) else stamps
    if all(v is None for v in values) and any(texts):  # its steps cannot be checked: never passed
        example = next(t for t in texts if t)
        raise FieldCSVError(
            f"{path}: column {name!r} reads as a clock, but its times ({example!r} at line "
            f"{lines[texts.index(example)]}) are in a form msr does not read, so its steps cannot be "
            f"checked: a field CSV's rows are played {ACTION_PERIOD:g} s apart whatever it says: give "
            "seconds (0.01 s apart), or drop the column")
    if any(v is None for v in values):
        k = next(k for k, v in enumerate(values) if v is None)
        raise FieldCSVError(
            f"{path}: column {name!r} reads as a clock, but line {lines[k]} has "
            f"{'no time' if not texts[k] else repr(texts[k])} there: a field CSV's rows are played "
            f"{ACTION_PERIOD:g} s apart whatever it says: give every row its time, 0.01 s apart, or drop "
            "the column")
    if values is stamps:  # the texts carry their own unit
        return np.array(values, dtype=np.float64)
    unit, scale = clock
    if scale is None:
        raise FieldCSVError(
            f"{path}: column {name!r} reads as a clock in an unknown unit {unit!r}: a field CSV's rows "
            f"are played {ACTION_PERIOD:g} s apart whatever it says, and its steps cannot be checked: "
            "drop the column, or name its unit (s, ms, us, min)")
    return np.array(values, dtype=np.float64) * scale


def _field_row(path: Path, line: int, row: list[str], k: int, columns: list[int],
               index: tuple[int | None, str], ncols: int) -> NDArray[np.float64]:
    """Data row ``k`` (on file line ``line``) as a field ``(3,)`` in tesla, its columns and index
    (``(column or None, how messages name it)``) checked."""
    index_column, index_name = index
    if len(row) != ncols:
        raise FieldCSVError(
            f"{path}: line {line} has {len(row)} columns, expected {ncols}: {','.join(row)!r}"
        )
    field = np.empty(3)
    for j, c in enumerate(columns):
        text = row[c].strip()
        try:
            if "_" in text:  # Python's float reads "1_0" as 10; no logger writes a number so
                raise ValueError(text)
            value = float(text)
        except ValueError:
            raise FieldCSVError(
                f"{path}: line {line}, column {FIELD_COLUMNS[j]}: {text!r} is not a number "
                "(field in mT)"
            ) from None
        if not math.isfinite(value):
            raise FieldCSVError(
                f"{path}: line {line}, column {FIELD_COLUMNS[j]}: non-finite value {text!r}"
            )
        field[j] = millitesla_text_to_tesla(text)
    if index_column is not None:
        text = row[index_column].strip()
        if text and (not is_number(text) or float(text) != k):
            # a time in s (0.01, 0.02...) or in ms (10, 20... every 10: t_ms) read as an index
            # (on the first row, any number but 0: a clock that does not start at 0, or rows
            # numbered from 1, which the next row would otherwise be refused for)
            time_like = is_number(text) and (k == 0 or not float(text).is_integer()
                                              or math.isclose(float(text), 10.0 * k))
            hint = (f"; {index_name} is read as a row index 0, 1, 2..., not as a time (rows are 0.01 s "
                    "apart by definition): drop that column or number the rows" if time_like else
                    f"; {index_name} is read as a row index 0, 1, 2...: number the rows, or drop it")
            raise FieldCSVError(
                f"{path}: line {line}: index {text!r} out of sequence, expected {k}{hint}"
            )
    return field


def numbered_rows(path: Path, rows: list[list[str]], error: type[Exception]) -> list[tuple[int, list[str]]]:
    """The rows of a CSV file that hold a value, with their 1-based line numbers: blank lines and
    rows of empty cells (``,,``, as a spreadsheet writes) before the first and after the last of
    them are skipped; one between them is a sample without values (or a stray line), and dropping
    it would play every later row one step early: raised as ``error`` naming its line."""
    numbered = [(i + 1, r) for i, r in enumerate(rows) if any(c.strip() for c in r)]
    if numbered:
        first, last = numbered[0][0], numbered[-1][0]
        for i in range(first, last - 1):
            if not any(c.strip() for c in rows[i]):
                what = "a row of empty cells" if len(rows[i]) > 1 else "a blank line"
                raise error(f"{path}: line {i + 1}: {what} between rows of values (a sample whose values "
                            "are missing: dropped, every later row would come one step early); fill it "
                            "in, or delete the line")
    return numbered


def _csv_rows(path: Path, error: type[Exception]) -> list[list[str]]:
    """Rows of a UTF-8 CSV file (a byte-order mark is skipped); decoding and CSV syntax errors are
    raised as ``error`` naming the file and line."""
    data = path.read_bytes()
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise error(
            f"{path}: line {line}: byte {data[exc.start]:#04x} is not UTF-8 text; save the file as "
            "UTF-8 (or plain ASCII) CSV"
        ) from None
    reader = csv.reader(io.StringIO(text, newline=""))
    try:
        return list(reader)
    except csv.Error as exc:
        raise error(f"{path}: line {reader.line_num}: {exc}") from None


#: How far (relative) a waveform's row may pass the spec's field limit: a CSV's rounding (3
#: decimals of mT on a 1 mT field: 0.09 % of the amplitude), well within any coil calibration.
LIMIT_TOLERANCE = 1e-3


#: Largest field (T) taken for zero on an axis the spec's coils do not drive (a file's rounding).
UNDRIVEN_AXIS_T = 1e-9


def limit_problem(field: NDArray[np.float64], axis_limits: dict[str, float],
                  where: str) -> str | None:
    """Why a waveform ``(steps, 3)`` (T) exceeds a spec's ``[actuation]`` limits (``axis_limits``:
    T by axis name, as :func:`~elastica_magnetic.specfile.axis_limits_of` gives them; the
    amplitude's limit is the largest), naming the first row (0-based data row) and its value in
    mT; ``None`` when within them. Rows at the limit pass, within :data:`LIMIT_TOLERANCE` (a
    file's rounding: a 4 mT rotation written to 3 decimals of mT reaches 4.00015 mT)."""
    field = np.asarray(field, dtype=np.float64).reshape(-1, 3)
    if not axis_limits or not field.size:
        return None
    for k, axis in enumerate("xyz"):  # an axis the spec's coils do not drive must stay at zero
        if axis not in axis_limits and np.any(np.abs(field[:, k]) > UNDRIVEN_AXIS_T):
            row = int(np.flatnonzero(np.abs(field[:, k]) > UNDRIVEN_AXIS_T)[0])
            return (f"{where}: data row {row} asks B_{axis} = {1e3 * field[row, k]:.6g} mT, and the spec's "
                    f"[actuation] drives the axes {''.join(axis_limits)} only (axes = "
                    f"\"{''.join(axis_limits)}\": no coil pair along {axis}): the coils the spec describes "
                    f"cannot play it; zero that column, or give the spec axes = \"xyz\" with its limit")
    checks = [(axis, np.abs(field[:, "xyz".index(axis)]), limit)
              for axis, limit in axis_limits.items()]
    checks.append(("amplitude", np.linalg.norm(field, axis=1), max(axis_limits.values())))
    for what, values, limit in checks:
        over = np.flatnonzero(values > limit * (1.0 + LIMIT_TOLERANCE))
        if over.size:
            row = int(over[0])
            excess = 100.0 * (values[row] / limit - 1.0)
            return (f"{where}: data row {row} asks {1e3 * values[row]:.6g} mT "
                    f"({'|B|' if what == 'amplitude' else 'B_' + what}), {excess:.3g} % above the spec's "
                    f"[actuation] field_limit of {1e3 * limit:.6g} mT ({over.size} row(s) over it): "
                    "the coils the spec describes cannot play it; lower the waveform, or raise the "
                    "spec's field_limit if the coils can")
    return None


def write_field_csv(path: str | Path, field_tesla: NDArray[np.float64]) -> Path:
    """Write a field (``(n_rows, 3)`` in tesla) as a field CSV in the paper's format (mT).

    The header is ``,mag_x,mag_y,mag_z`` with an unnamed index column, as published. The file is
    written atomically (:func:`~elastica_magnetic.io.atomic_write`).
    """
    field_tesla = np.asarray(field_tesla, dtype=np.float64)
    if field_tesla.ndim != 2 or field_tesla.shape[1] != 3:
        raise ValueError(f"field must have shape (n_rows, 3) in tesla, got {field_tesla.shape}")
    if not np.all(np.isfinite(field_tesla)):
        raise ValueError("field contains non-finite values")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_write(path, "w", newline="") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(["", *FIELD_COLUMNS])
        for i, b in enumerate(field_tesla):
            writer.writerow([i, *(tesla_to_millitesla_text(float(v)) for v in b)])
    return path


def tesla_to_millitesla_text(value: float) -> str:
    """A field component (T) as the decimal text of a field CSV (mT): the shortest decimal that
    reads back as ``value`` (``repr``) with its point moved three places, so that
    :func:`millitesla_text_to_tesla` returns ``value`` exactly (``0.0003`` -> ``"0.3"``)."""
    millitesla = Decimal(repr(float(value))).scaleb(3)
    text = format(millitesla, "f") if -7 < millitesla.adjusted() < 17 else str(millitesla)
    return text if any(c in text for c in ".En") else text + ".0"


#: Decimal arithmetic wide enough for any exponent a CSV cell can spell (``1e-999999999999999999999``).
_WIDE = Context(Emax=MAX_EMAX, Emin=MIN_EMIN)


def millitesla_text_to_tesla(text: str) -> float:
    """A field CSV's number (mT, as text, one ``float`` reads) in tesla: the double nearest the
    decimal value / 1000 (exact decimal shift, one rounding: the inverse of
    :func:`tesla_to_millitesla_text`)."""
    return float(_WIDE.create_decimal(text.strip()).scaleb(-3, _WIDE))


def is_number(text: str) -> bool:
    """Whether ``text`` reads as a float (``"0.02"``, ``"1e-3"``, ``"nan"``); the readers of
    numbers typed by hand share it."""
    try:
        float(text)
    except ValueError:
        return False
    return True
