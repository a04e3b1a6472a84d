"""The column vocabulary of the CSV files msr reads (a column spelled in another unit is named by
:func:`other_spelling_hint`), and above all their clock columns: a header read as a time (``t_s``, ``t_ms``,
``time (s)``, ``timestamp_us``, ``Time [min]``) and its unit's scale to seconds. One vocabulary
for every reader: a field CSV checks such a column's steps (its rows are 0.01 s apart whatever it
says), and the files that need ``t_s`` itself (a trajectory, a tracker's CSV, coil currents) name
a clock found in another spelling or unit instead of only saying that ``t_s`` is missing."""

from __future__ import annotations

import re
from collections.abc import Sequence

__all__ = ["CLOCK_UNITS", "ROW_UNITS", "TIME_COLUMN", "clock_scale", "clock_text_seconds", "is_clock",
           "other_clock_hint", "other_spelling_hint", "trailing_time_unit"]

#: The time column of the files msr writes and of those that need one (s).
TIME_COLUMN = "t_s"
#: Words that make a header a clock wherever they stand (``Elapsed Time [s]``, ``sample_time_s``,
#: ``TimeStamp``); ``t`` does as the first word (``t``, ``t_ms``, ``t [min]``). The words after the
#: last of them name the unit (none: seconds).
_TIME_WORDS = frozenset({"time", "times", "timestamp", "stamp", "elapsed", "clock", "ts", "epoch"})
#: A unit of time alone is a clock too (``sec``, ``ms``: not ``s``, ``min`` or ``h``, other words' too).
_BARE_UNITS = frozenset({"sec", "secs", "second", "seconds", "ms", "msec", "millis", "milliseconds", "us",
                         "usec", "micros", "microseconds", "nanos", "nanoseconds"})
#: A clock column's units, in s (an unknown one is refused where steps are checked).
CLOCK_UNITS = {"": 1.0, "s": 1.0, "sec": 1.0, "secs": 1.0, "second": 1.0, "seconds": 1.0,
               "ms": 1e-3, "msec": 1e-3, "millis": 1e-3, "millisecond": 1e-3, "milliseconds": 1e-3,
               "us": 1e-6, "µs": 1e-6, "μs": 1e-6, "usec": 1e-6, "micros": 1e-6, "microsecond": 1e-6,
               "microseconds": 1e-6, "ns": 1e-9, "nanos": 1e-9, "nanoseconds": 1e-9, "min": 60.0,
               "mins": 60.0, "minute": 60.0, "minutes": 60.0, "h": 3600.0, "hr": 3600.0, "hour": 3600.0,
               "hours": 3600.0}


#: A time written as a clock reads it: ``H:MM:SS.ss`` or ``MM:SS.ss`` (a decimal point or comma), on a
#: 12-hour clock with ``AM``/``PM`` after it.
_CLOCK_TEXT = re.compile(
    r"^(?:(?P<h>\d+):)?(?P<m>\d{1,2}):(?P<s>\d{1,2}(?:[.,]\d*)?)\s*(?P<half>[ap]\.?m\.?)?$", re.IGNORECASE)
#: A time written with its unit: ``0.02 s``, ``20ms``, ``0,02 s``.
_TIME_WITH_UNIT = re.compile(r"^(?P<value>[-+]?\d+(?:[.,]\d+)?(?:[eE][-+]?\d+)?)\s*(?P<unit>[a-zµμ]+)$",
                             re.IGNORECASE)


def clock_text_seconds(text: str) -> float | None:
    """Seconds of a time written as a clock reads it (``00:00:01.25``, ``01:01,5``, ``10:00:00.02 AM``),
    with its unit (``0.02 s``, ``20 ms``) or as a date and time (ISO 8601: ``2026-12-05T10:00:00.010``,
    seconds since the epoch); ``None`` for any other text (a plain number is read with the column's
    unit, not here)."""
    text = text.strip()
    match = _CLOCK_TEXT.match(text)
    if match:
        hours = int(match.group("h") or 0)
        if match.group("half"):  # 12 AM is midnight, 12 PM noon
            hours = hours % 12 + (12 if match.group("half").lower().startswith("p") else 0)
        return 3600.0 * hours + 60.0 * int(match.group("m")) + float(match.group("s").replace(",", "."))
    match = _TIME_WITH_UNIT.match(text)
    if match:
        scale = CLOCK_UNITS.get(match.group("unit").lower())
        return None if scale is None else float(match.group("value").replace(",", ".")) * scale
    return _iso_seconds(text)


def _iso_seconds(text: str) -> float | None:
    """Seconds since the epoch of an ISO 8601 date and time (a decimal comma too), else ``None``."""
    import datetime

    if len(text) < 10 or text[4:5] != "-":
        return None
    try:
        stamp = datetime.datetime.fromisoformat(re.sub(r"(:\d\d),(\d)", r"\1.\2", text))
    except ValueError:
        return None
    if stamp.tzinfo is None:  # a local clock: only its steps matter
        stamp = stamp.replace(tzinfo=datetime.UTC)
    return stamp.timestamp()


def _words(name: str) -> list[str]:
    """The words of a header, lower case: ``"Elapsed Time [s]"`` and ``"ElapsedTime_s"`` are
    ``["elapsed", "time", "s"]``."""
    spaced = re.sub(r"(?<=[a-z])(?=[A-Z])", " ", name.strip())
    return re.findall(r"[a-zµμ]+|\d+(?:\.\d+)?", spaced.lower())


def is_clock(name: str) -> bool:
    """Whether the header ``name`` reads as a clock, in any unit or none."""
    return clock_scale(name) is not None


#: Units that count the file's own rows (``time_step``, ``t [rows]``): s per unit is the row period
#: of the reader (:func:`clock_scale`'s ``row_period``).
ROW_UNITS = frozenset({"step", "steps", "row", "rows"})


#: Units that make a header ``T`` something else than a clock: a temperature (``T (°C)``), a field.
_OTHER_T_UNITS = frozenset({"c", "degc", "celsius", "k", "kelvin", "f", "degf", "fahrenheit", "mt", "ut",
                            "nt", "g", "gauss", "tesla"})


def _t_is_clock(name: str, words: list[str]) -> bool:
    """Whether a header whose first word is ``t`` is a clock: ``t`` alone or with a unit of time
    (``t_ms``, ``t [min]``, ``t [rows]``), or with any other unit in brackets (``t [weeks]``: a
    clock in a unit msr does not know); not ``T_coil`` (a name) nor ``T (°C)`` (a temperature)."""
    if words[0] != "t":
        return False
    rest = " ".join(words[1:])
    if rest == "" or rest in CLOCK_UNITS or rest in ROW_UNITS:
        return True
    return rest not in _OTHER_T_UNITS and re.match(r"^\s*t\s*[\[(]", name, re.IGNORECASE) is not None


def clock_scale(name: str, row_period: float | None = None) -> tuple[str, float | None] | None:
    """``(unit, s per unit)`` of a clock header (``None`` scale: a unit msr does not know; a count of
    rows, :data:`ROW_UNITS`, is ``row_period`` s each where the reader gives its row period);
    ``None`` when ``name`` is not a clock."""
    words = _words(name)
    if len(words) == 1 and words[0] in _BARE_UNITS:
        return words[0], CLOCK_UNITS[words[0]]
    marks = [k for k, w in enumerate(words) if w in _TIME_WORDS or (k == 0 and _t_is_clock(name, words))]
    if not marks:
        return None
    unit = " ".join(words[marks[-1] + 1:])
    return unit, row_period if unit in ROW_UNITS else CLOCK_UNITS.get(unit)


def trailing_time_unit(name: str) -> tuple[str, float] | None:
    """``(unit, s per unit)`` of the unit of time a header of several words ends with, in a
    language msr has no clock words for (``Zeit [ms]``, ``tiempo_ms``, ``Zeit_s``); ``None`` when
    its last word is no unit of time."""
    words = _words(name)
    if len(words) < 2 or words[-1] not in CLOCK_UNITS or words[-1] == "":
        return None
    return words[-1], CLOCK_UNITS[words[-1]]


def other_clock_hint(names: Sequence[str]) -> str:
    """For a file that needs :data:`TIME_COLUMN` and lacks it: ``"; 't_ms' reads as a clock in ms:
    give seconds under t_s (divided by 1000)"``, naming the first clock in another spelling or unit;
    ``""`` when there is none."""
    for name in names:
        found = clock_scale(name)
        if found is None or name.strip() == TIME_COLUMN:
            continue
        unit, scale = found
        if scale is None:
            return f"; {name!r} reads as a clock in {unit!r}: give its times in seconds under {TIME_COLUMN}"
        if scale == 1.0:
            return f"; {name!r} reads as a clock in seconds: name it {TIME_COLUMN}"
        convert = f"multiplied by {scale:g}" if scale > 1.0 else f"divided by {1.0 / scale:g}"
        return f"; {name!r} reads as a clock in {unit}: give seconds under {TIME_COLUMN} ({convert})"
    return ""


def other_spelling_hint(missing: list[str], names: list[str], units: str) -> str:
    """For a header that lacks ``missing`` columns: ``" (found 'mag_x (mT)', ...: <units>)"``, the
    columns that spell one of them otherwise (a unit in brackets, another unit: ``mag_x (mT)``,
    ``current_x_mA``, ``mid_x_mm``), else ``""``. A clock for ``t_s`` is named too."""
    found: list[str] = []
    for column in missing:
        if column == TIME_COLUMN:  # a clock in any spelling or unit
            found += [n for n in names if n not in found and is_clock(n)]
            continue
        stems = {column.lower(), column.rsplit("_", 1)[0].lower()}
        found += [n for n in names if n not in found and n.lower() != column.lower()
                  and any(n.lower().startswith((f"{s}_", f"{s} ", f"{s}[", f"{s}(", f"{s}/")) for s in stems)]
    return f" (found {', '.join(repr(n) for n in found)}: {units})" if found else ""
