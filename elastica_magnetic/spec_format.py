"""The spec file format: TOML text read and written (units in comments), and one table of it read
key by key (:class:`SpecTable`: typed getters with units and ranges, unknown keys refused), every
problem a :class:`SpecError` naming the file, the table and the key. What the tables mean is
:mod:`elastica_magnetic.specfile` (the robot and its physics) and the learning package (the rest).
"""

from __future__ import annotations

import difflib
import math
import re
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .io import byte_order_mark_problem, missing_folder_hint
from .plausibility import NAMED_CHECKS, judge, mistake_hint, warn_implausible

__all__ = ["REQUIRED", "SpecError", "SpecTable", "accepted_keys", "loads", "read_spec",
           "toml_with_units"]

#: The default of a key that must be given (its getter raises :class:`SpecError` when it is missing).
REQUIRED = object()

class SpecError(ValueError):
    """A spec that does not describe a valid case; the message names the file, table and key."""


#: What a required table is for, named when it is missing.
TABLE_PURPOSES: dict[str, str] = {
    "robot": "the rod: length, section, material, magnetization",
    "robot.magnetization": "its kind and that kind's keys (docs/specs.md)",
    "actuation": "field_limit (T), the largest field the coils make; a case needs it to train or play",
    "task": "what the robot learns, its kind and keys (msr case show m1-4mT --toml shows one); a case "
            "needs it to train or play, a robot alone is simulated with msr field simulate --robot FILE",
}


class SpecTable:
    """Checked, typed access to one table of a spec; :meth:`finish` rejects keys never read.

    ``source`` names the file (or ``"<spec>"``), ``path`` the table (``"robot.ground"``; ``""`` for
    the top level). Every getter records the key and returns a plain Python value.
    """

    def __init__(self, data: Any, source: str, path: str = "",
                 accept: frozenset[str] | None = None) -> None:
        if not isinstance(data, Mapping):
            raise SpecError(f"{source}: {self._name(path) or 'the spec'} must be a table, "
                            f"got {type(data).__name__}")
        self.data, self.source, self.path = data, source, path
        self._read: set[str] = set()
        self._takes: set[str] = set()
        #: Dotted keys whose plausibility warnings the spec accepts (``[checks] accept``).
        self.accept = accepted_keys(data, source) if accept is None and not path else (
            accept or frozenset())

    @staticmethod
    def _name(path: str) -> str:
        return f"[{path}]" if path else ""

    def where(self, key: str) -> str:
        """``file: [table] key`` for error messages."""
        table = self._name(self.path)
        return f"{self.source}: {table + ' ' if table else ''}{key}"

    def error(self, key: str, message: str) -> SpecError:
        return SpecError(f"{self.where(key)}: {message}")

    def has(self, key: str) -> bool:
        return key in self.data

    def takes(self, *keys: str) -> None:
        """Name ``keys`` among those the table takes although this spec may leave them out (an
        optional key read only when given), for :meth:`finish`'s message about a misspelt one."""
        self._takes.update(keys)

    def _get(self, key: str, default: Any) -> Any:
        self._read.add(key)
        if key in self.data:
            return self.data[key]
        if default is REQUIRED:
            raise self.error(key, "missing (required)" + self._misspelt(key))
        return default

    def _misspelt(self, key: str) -> str:
        """``"; found X: a misspelling of KEY?"`` when a key of the table not read so far is close to
        ``key`` (``widht`` for ``width``), else ``""``."""
        others = sorted(set(self.data) - self._read - self._takes - {key})
        close = difflib.get_close_matches(key, others, n=1, cutoff=0.8)
        if close:
            return f"; found {close[0]}: a misspelling of {key}?"
        # a key the table takes in its place (poisson_ratio for shear_modulus), misspelt: "poisson"
        absent = sorted(self._takes - set(self.data) - {key})
        for other in others:
            near = difflib.get_close_matches(other, absent, n=1, cutoff=0.6)
            if near:
                return f"; found {other}: a misspelling of {near[0]}?"
        return ""

    def number(self, key: str, unit: str, default: Any = REQUIRED, *, low: float | None = None,
               low_open: bool = False, high: float | None = None, integer: bool = False,
               plausible: str | None = None) -> Any:
        """A finite number in ``[low, high]`` (``(low, high]`` if ``low_open``), ``unit`` for the
        message; ``integer``: a TOML integer. A missing optional key returns ``default`` as is.
        ``plausible``: a quantity of :data:`~elastica_magnetic.plausibility.QUANTITIES` the given
        value is judged as (:meth:`check_plausible`)."""
        value = self._get(key, default)
        if key not in self.data:
            return value
        number = self._number(key, value, unit, integer, low, low_open, high, plausible)
        if plausible is not None:
            self.check_plausible(key, number, plausible)
        return number

    def dotted(self, key: str) -> str:
        """``robot.youngs_modulus``: the key as ``[checks] accept`` names it."""
        return f"{self.path}.{key}" if self.path else key

    def check_plausible(self, key: str, value: float, quantity: str, shown: str | None = None) -> None:
        """Judge ``value`` (SI) of ``key`` as ``quantity``: refuse (:class:`SpecError`) a value that
        cannot be physical, warn (:class:`~elastica_magnetic.plausibility.ImplausibleValueWarning`)
        about an unusual one unless ``[checks] accept`` names the key. ``shown``: how the message
        names the value (default ``key = value``, e.g. ``"|moment| = 2e+04"``)."""
        finding = judge(quantity, value)
        if finding is None:
            return
        text = (f"{self.where(key)} = {finding.text}" if shown is None else
                f"{self.where(key)}: {shown} = {finding.text}")
        if finding.refuse:
            raise SpecError(text)
        self._warn(key, text)

    def warn(self, key: str, message: str) -> None:
        """Warn that ``key`` (or a check of :data:`~elastica_magnetic.plausibility.NAMED_CHECKS`,
        ``"resolution"`` in ``[field]``) is unusual, unless ``[checks] accept`` names it."""
        self._warn(key, f"{self.where(key)}: {message}")

    def _warn(self, key: str, text: str) -> None:
        dotted = self.dotted(key)
        if dotted not in self.accept:
            warn_implausible(f"{text}; if it is meant, add \"{dotted}\" to [checks] accept", dotted,
                             stacklevel=5)

    def _number(self, key: str, value: Any, unit: str, integer: bool, low: float | None,
                low_open: bool, high: float | None, plausible: str | None) -> Any:
        kind = "an integer" if integer else "a number"
        if isinstance(value, bool) or not isinstance(value, (int, float)) or (
                integer and not isinstance(value, int)):
            raise self.error(key, f"expected {kind} ({unit}), got {value!r}")
        if not math.isfinite(value):
            raise self.error(key, f"expected a finite number ({unit}), got {value!r}")
        if low is not None and (value <= low if low_open else value < low):
            raise self.error(key, f"must be {'>' if low_open else '>='} {low:g} ({unit}), got {value!r}")
        if high is not None and value > high:
            hint = "" if plausible is None else mistake_hint(plausible, value)
            raise self.error(key, f"must be <= {high:g} ({unit}), got {value!r}{hint}")
        return int(value) if integer else float(value)

    def string(self, key: str, default: Any = REQUIRED, choices: tuple[str, ...] | None = None) -> Any:
        value = self._get(key, default)
        if key not in self.data:
            return value
        if not isinstance(value, str):
            raise self.error(key, f"expected a string, got {value!r}")
        if choices is not None and value not in choices:
            raise self.error(key, f"expected one of {', '.join(choices)}; got {value!r}")
        return value

    def boolean(self, key: str, default: Any = REQUIRED) -> Any:
        value = self._get(key, default)
        if key in self.data and not isinstance(value, bool):
            raise self.error(key, f"expected true or false, got {value!r}")
        return value

    def vector(self, key: str, unit: str, size: int, default: Any = REQUIRED) -> Any:
        """A list of ``size`` finite numbers."""
        value = self._get(key, default)
        if key not in self.data:
            return value
        if (not isinstance(value, list) or len(value) != size or any(
                isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v)
                for v in value)):
            raise self.error(key, f"expected a list of {size} finite numbers ({unit}), got {value!r}")
        return [float(v) for v in value]

    def table(self, key: str, required: bool = True) -> SpecTable | None:
        """A sub-table (``None`` if optional and absent)."""
        path = f"{self.path}.{key}" if self.path else key
        if required and key not in self.data:
            raise SpecError(f"{self.source}: [{path}] missing: a required table "
                            f"({TABLE_PURPOSES.get(path, 'see docs/specs.md')})")
        value = self._get(key, None)
        if value is None and key not in self.data:
            return None
        if not isinstance(value, Mapping):
            raise SpecError(f"{self.source}: [{path}] must be a table, got {value!r}")
        return SpecTable(value, self.source, path, self.accept)

    def raw(self, key: str, default: Any = REQUIRED) -> Any:
        """The value as written (checked by the caller)."""
        return self._get(key, default)

    def finish(self) -> None:
        """Raise on keys that were never read (typos, keys of another kind)."""
        unknown = sorted(set(self.data) - self._read)
        if unknown:
            taken = sorted(self._read | self._takes)
            close = difflib.get_close_matches(unknown[0], taken, n=1, cutoff=0.6)
            hint = f"; did you mean {close[0]}?" if close else ""
            raise SpecError(f"{self.where(unknown[0])}: unknown key{hint} (this table takes: "
                            f"{', '.join(taken) or 'none'})")


def accepted_keys(spec: Mapping[str, Any], source: str = "<spec>") -> frozenset[str]:
    """The dotted keys of ``[checks] accept = ["robot.youngs_modulus", ...]``: unusual values the
    spec's author accepts on purpose (their plausibility warnings are not shown; values that cannot
    be physical are refused all the same). Each must name a key of the spec or one of
    :data:`~elastica_magnetic.plausibility.NAMED_CHECKS`."""
    checks = spec.get("checks")
    if checks is None:
        return frozenset()
    if not isinstance(checks, Mapping):
        raise SpecError(f"{source}: [checks] must be a table, got {checks!r}")
    unknown = sorted(set(checks) - {"accept"})
    if unknown:
        raise SpecError(f"{source}: [checks] {unknown[0]}: unknown key (this table takes: accept)")
    keys = checks.get("accept", [])
    if not isinstance(keys, list) or not all(isinstance(k, str) for k in keys):
        raise SpecError(f"{source}: [checks] accept: expected a list of dotted keys such as "
                        f"\"robot.youngs_modulus\", got {keys!r}")
    for key in keys:
        if key not in NAMED_CHECKS and not _has_dotted(spec, key):
            raise SpecError(f"{source}: [checks] accept: {key!r} names no key of this spec (give "
                            "dotted keys such as \"robot.youngs_modulus\", or one of "
                            f"{', '.join(NAMED_CHECKS)})")
    return frozenset(keys)


def _has_dotted(spec: Mapping[str, Any], key: str) -> bool:
    table: Any = spec
    for part in key.split("."):
        name, _, index = part.partition("[")
        if not isinstance(table, Mapping) or name not in table:
            return False
        table = table[name]
        if index:  # segments[0]
            k = index.rstrip("]")
            if not (k.isdigit() and isinstance(table, list) and int(k) < len(table)):
                return False
            table = table[int(k)]
    return key != "checks" and not key.startswith("checks.")


def read_spec(path: str | Path) -> dict[str, Any]:
    """The TOML data of a spec file; a missing file or a syntax error is a :class:`SpecError`."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SpecError(f"{path}: no such spec file{missing_folder_hint(path)}") from None
    except UnicodeDecodeError as exc:  # e.g. saved as Latin-1 or UTF-16 by an editor
        raw = path.read_bytes()
        line = raw[: exc.start].count(b"\n") + 1
        encoding = ("UTF-16 (it starts with a UTF-16 byte order mark)"
                    if raw[:2] in (b"\xff\xfe", b"\xfe\xff") else
                    f"another encoding (byte 0x{raw[exc.start]:02x} on line {line} is not UTF-8, "
                    "e.g. a Latin-1 character)")
        raise SpecError(f"{path}: not UTF-8 text: saved in {encoding}; a spec file (TOML) is UTF-8: "
                        "save it as UTF-8 in your editor") from None
    except IsADirectoryError:
        raise SpecError(f"{path}: a folder, not a spec file: give a shipped case's name or a spec "
                        "file (.toml)") from None
    except OSError as exc:
        raise SpecError(f"{path}: cannot be read as a spec file ({exc})") from None
    problem = byte_order_mark_problem(path, text)
    if problem is not None:  # else "not valid TOML: Invalid statement (at line 1, column 1)"
        raise SpecError(problem)
    return loads(text, str(path))


def loads(text: str, source: str = "<spec>") -> dict[str, Any]:
    """Parse spec text (TOML); syntax errors name ``source`` and the line."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{source}: not valid TOML: {exc}{_overwrite_hint(str(exc), text)}") from None


def _overwrite_hint(message: str, text: str) -> str:
    """What ``Cannot overwrite a value`` at a table's header means: a key of the parent table has
    the table's name (``randomize = "none"`` in ``[training]`` and a ``[training.randomize]``
    table), else ``""``."""
    found = re.search(r"Cannot overwrite a value \(at line (\d+)", message)
    if not found:
        return ""
    lines = text.splitlines()
    number = int(found.group(1))
    header = re.match(r"^\s*\[+\s*([^\]]+?)\s*\]+", lines[number - 1] if number <= len(lines) else "")
    if not header or "." not in header.group(1):
        return ""
    parent, key = header.group(1).rsplit(".", 1)
    return (f": line {number} opens the table [{header.group(1)}], and [{parent}] already gives {key} a "
            f"value ({key} = ...): a key and a table of one name; keep one of them")


def toml_with_units(data: Mapping[str, Any], units: Mapping[tuple[str, str], str]) -> str:
    """TOML text of ``data`` (written with ``tomli_w``), with ``units[(table, key)]`` in a comment
    after each value that has one."""
    import tomli_w

    lines, table = [], ""
    for line in _inline_number_arrays(tomli_w.dumps(_plain(data), multiline_strings=False).splitlines()):
        stripped = line.strip()
        if stripped.startswith("["):  # a table, or an array of tables ([[actuation.coils]])
            table = stripped.strip("[]")
        elif " = " in line and not line.startswith(" "):
            unit = units.get((table, line.split(" = ", 1)[0]))
            if unit is not None and not line.rstrip().endswith("["):
                line = f"{line}  # {unit}"
        lines.append(line)
    return "\n".join(lines) + "\n"


#: A line of a multi-line array of numbers as ``tomli_w`` writes it (``    1.0,``, ``    [``, ``],``).
_NUMBER_ARRAY_LINE = re.compile(r"^\s*(\[|\]|[-+0-9.eEinfa]+),?\s*$")
#: Longest ``key = [...]`` line made of a multi-line array of numbers.
_INLINE_WIDTH = 100


def _inline_number_arrays(lines: list[str]) -> list[str]:
    """``tomli_w``'s multi-line arrays of numbers (``key = [`` ... ``]``) on one line when they fit
    in :data:`_INLINE_WIDTH` characters: ``direction = [1.0, 0.0, 0.0]``, ``box = [[0.0, 0.0], [1.0,
    1.0]]`` (a vector reads as one value, and a unit comment can follow it)."""
    out, k = [], 0
    while k < len(lines):
        line = lines[k]
        end = k + 1
        if line.endswith(" = [") and not line.startswith(" "):
            depth = 1
            while end < len(lines) and depth and _NUMBER_ARRAY_LINE.match(lines[end]):
                depth += lines[end].count("[") - lines[end].count("]")
                end += 1
            if depth == 0:
                items = " ".join(part.strip() for part in lines[k + 1:end])
                text = line[:-1] + "[" + items.rstrip(",")
                text = re.sub(r",\s*\]", "]", text).replace("[ ", "[")
                if len(text) <= _INLINE_WIDTH:
                    out.append(text)
                    k = end
                    continue
            end = k + 1
        out.append(line)
        k = end
    return out


def _plain(value: Any) -> Any:
    """Numpy scalars/arrays and tuples as plain TOML-able Python values."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in (value.tolist() if isinstance(value, np.ndarray) else value)]
    if isinstance(value, np.generic):
        return value.item()
    return value
