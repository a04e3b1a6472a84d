"""Reading a run's CSV logs (``episodes.csv``, ``evaluations.csv``) with every row checked: a
damaged log (cut by a full disk, edited by hand) is an error naming the file, the row and the
column, never a traceback or a silently wrong curve. A log cut by a kill while it was written (its
last line, or its header, without the line's end; an empty file) can be read back to its last
whole row instead (``whole_rows_only``): what a resumed run keeps of it."""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Iterable
from pathlib import Path

__all__ = ["EmptyLogError", "read_log", "unfinished_line"]


class EmptyLogError(ValueError):
    """A log with nothing in it, not even its header (a run whose first episode has not ended):
    no damage, just nothing to read yet."""


def unfinished_line(path: str | Path) -> str:
    """The text after the last line end of the log ``path``: a row or header that a kill cut
    while it was being written (``""`` for a log of whole lines; the whole text of a log that has
    no line end, an empty file giving ``""``)."""
    data = Path(path).read_bytes()
    return data[data.rfind(b"\n") + 1:].decode("utf-8", errors="replace")


def read_log(path: str | Path, numeric: Iterable[str], *,
             whole_rows_only: bool = False) -> list[dict[str, str]]:
    """The rows of the CSV log ``path`` (dicts of strings), after checking that its header has
    the columns ``numeric`` and that each row's value in them is a number (``nan``/``inf`` are
    not accepted). Raises ``ValueError`` naming the file, the row (1 = the header) and the
    column; ``FileNotFoundError`` when it is absent.

    ``whole_rows_only``: the text after the last line end (:func:`unfinished_line`: a row, or the
    header, that a kill cut while it was written) is left out, and a log without a whole header
    line (an empty file, a header cut short) has no rows; damage before the last line end is
    still an error."""
    path = Path(path)
    numeric = tuple(numeric)
    try:
        data = path.read_bytes()
        if whole_rows_only:
            data = data[:data.rfind(b"\n") + 1]
            if not data:
                return []  # no whole header line: nothing was logged before the kill
        if not data.strip():  # written empty when the run started: no episode has ended yet
            raise EmptyLogError(f"{path}: empty: nothing was logged yet (no training episode of this run "
                                "has ended: a run just started, or killed before its first episode ended)")
        with io.StringIO(data.decode("utf-8-sig"), newline="") as f:  # a spreadsheet's BOM too
            reader = csv.DictReader(f)
            fields = reader.fieldnames or []
            missing = [c for c in numeric if c not in fields]
            if missing:
                raise ValueError(f"{path}: damaged log: the header lacks {', '.join(missing)} "
                                 f"(found {', '.join(fields) or 'no header'})")
            rows: list[dict[str, str]] = []
            for line, row in enumerate(reader, start=2):
                for column in numeric:
                    value = row.get(column)
                    try:
                        ok = value is not None and math.isfinite(float(value))
                    except ValueError:
                        ok = False
                    if not ok:
                        raise ValueError(f"{path}: damaged log: row {line}, column {column!r}: "
                                         f"{value!r} is not a number (move the file away, or "
                                         "cut the log back to its last good row)")
                if "global_step" in numeric and rows and (
                        float(row["global_step"]) < float(rows[-1]["global_step"])):
                    raise ValueError(f"{path}: damaged log: row {line}: global_step "
                                     f"{row['global_step']} is before the previous row's "
                                     f"{rows[-1]['global_step']} (a log's steps never go back; "
                                     "move the file away, or restore it)")
                rows.append(row)
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: damaged log: not UTF-8 text (byte {exc.start})") from None
    except csv.Error as exc:
        raise ValueError(f"{path}: damaged log: {exc}") from None
    return rows
