"""Reading a run's CSV logs (``episodes.csv``, ``evaluations.csv``) with every row checked: a
damaged log (cut by a full disk, edited by hand) is an error naming the file, the row and the
column, never a traceback or a silently wrong curve."""

from __future__ import annotations

import csv
import math
from collections.abc import Iterable
from pathlib import Path

__all__ = ["read_log"]


def read_log(path: str | Path, numeric: Iterable[str]) -> list[dict[str, str]]:
    """The rows of the CSV log ``path`` (dicts of strings), after checking that its header has
    the columns ``numeric`` and that each row's value in them is a number (``nan``/``inf`` are
    not accepted). Raises ``ValueError`` naming the file, the row (1 = the header) and the
    column; ``FileNotFoundError`` when it is absent."""
    path = Path(path)
    numeric = tuple(numeric)
    try:
        with open(path, newline="", encoding="utf-8") as f:
            reader = csv.DictReader(f)
            fields = reader.fieldnames or []
            missing = [c for c in numeric if c not in fields]
            if missing:
                raise ValueError(f"{path}: damaged log: the header lacks {', '.join(missing)} "
                                 f"(found {', '.join(fields) or 'no header'})")
            rows = []
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
                rows.append(row)
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: damaged log: not UTF-8 text (byte {exc.start})") from None
    except csv.Error as exc:
        raise ValueError(f"{path}: damaged log: {exc}") from None
    return rows
