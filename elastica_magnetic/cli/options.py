"""The argparse types and option helpers of every ``msr`` command module: numbers in a range with
their unit (:func:`number`, naming a value written 1000x off), headings in rad (:func:`heading_option`,
naming degrees), the one path rule of every output option (:func:`output_path`), ``--duration``
(:func:`duration_option`) and an option's earlier spelling kept working (:func:`add_old_option`)."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ["OUTPUT_TYPES", "add_old_option", "duration_option", "heading_option", "number", "output_path"]


#: SI units whose thousandth a value is often written in by mistake (mT for T, mm for m, ms for s,
#: mA for A): an option given 1000x its range is refused naming the slip.
_MILLI_SLIPS = ("T", "m", "s", "A")


def number(
    unit: str,
    low: float | None = None,
    high: float | None = None,
    *,
    integer: bool = False,
    low_open: bool = False,
    high_open: bool = False,
) -> Callable[[str], Any]:
    """An argparse ``type`` for a finite number (an integer with ``integer``) in a range, with its
    unit in the message: ``type=number("s", 0, 3600, low_open=True)`` accepts ``(0, 3600]``."""
    if low is not None and high is not None:
        where = f"{'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"
    elif low is not None:
        where = f"{'>' if low_open else '>='} {low:g}"
    elif high is not None:
        where = f"{'<' if high_open else '<='} {high:g}"
    else:
        where = ""
    kind = "an integer" if integer else "a finite number"
    if where:
        where = f" in {where}" if where[0] in "[(" else f" {where}"
    expected = f"{kind}{' of ' + unit if unit else ''}{where}"

    def parse(text: str) -> Any:
        try:
            value: Any = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}") from None
        ok = math.isfinite(value)
        if ok and low is not None:
            ok = value > low if low_open else value >= low
        if ok and high is not None:
            ok = value < high if high_open else value <= high
        if not ok:
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}{milli_hint(value)}")
        return value

    def milli_hint(value: float) -> str:
        """Where a value 1000x too large fits the range as a thousandth (mT for T, mm for m;
        a length that does not, as a millionth: um): the likely slip, named."""
        if unit not in _MILLI_SLIPS or high is None or not (math.isfinite(value) and value > high):
            return ""
        for prefix, size in (("m", 1e-3), ("u", 1e-6)) if unit == "m" else (("m", 1e-3),):
            small = value * size
            if (low is None or (small > low if low_open else small >= low)) and (
                    small < high if high_open else small <= high):
                return (f" ({prefix}{unit} written where {unit} is expected? {value:g} {prefix}{unit} "
                        f"is {small:g} {unit})")
        return ""

    parse.__name__ = f"number ({unit})" if unit else "number"
    return parse


def heading_option(text: str) -> float:
    """An argparse ``type`` for a heading (``--heading``): an angle in rad within one turn; a value of
    degrees is named as such."""
    value = number("rad", -2 * math.pi, 2 * math.pi)
    try:
        return value(text)
    except argparse.ArgumentTypeError as exc:
        try:
            degrees = float(text)
        except ValueError:
            raise exc from None
        if math.isfinite(degrees) and abs(degrees) <= 360.0:
            raise argparse.ArgumentTypeError(
                f"{exc}: degrees? give rad ({degrees:g} degrees = {math.radians(degrees):.6g} rad)"
            ) from None
        raise


def output_path(text: str) -> Path:
    """The argparse ``type`` of every option naming where a command writes (``--out``,
    ``--figure``, ``--log``, ...): the one path rule. The path is made absolute and normalized once,
    here (``..``, ``.``, repeated and trailing separators, ``~`` and symbolic links resolved:
    :func:`elastica_magnetic.io.normalized_path`), so every later check and every write sees the
    same folder however it was spelled (``DIR``, ``./DIR/``, ``DIR/missing/..``, a link to
    ``DIR``)."""
    from ..io import normalized_path, output_path_problem, remember_folder_spelling

    if not text.strip():
        raise argparse.ArgumentTypeError("expected a path, got an empty string")
    if "\0" in text:
        raise argparse.ArgumentTypeError(f"expected a path, got {text!r} (it holds a NUL character)")
    path = normalized_path(text)
    if (problem := output_path_problem(path)) is not None:
        raise argparse.ArgumentTypeError(f"{text}: {problem}")
    remember_folder_spelling(text, path)  # ``DIR/``: a writer of one file refuses it
    return path


#: The argparse types that mark an option as an output location (tests walk the parser for them).
OUTPUT_TYPES = (output_path,)


def add_old_option(parser: argparse.ArgumentParser, old: str, new: str, type: Any, dest: str) -> None:
    """Keep the earlier spelling ``old`` of option ``new`` working, hidden from the help: it stores
    into ``dest`` as ``new`` does and prints a one-line note naming ``new``."""

    class OldSpelling(argparse.Action):
        def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                     values: Any, option_string: str | None = None) -> None:
            print(f"{parser.prog}: note: {old} is now {new} (the old spelling works in this release)",
                  file=sys.stderr)
            setattr(namespace, self.dest, values)

    parser.add_argument(old, type=type, dest=dest, action=OldSpelling, help=argparse.SUPPRESS,
                        default=argparse.SUPPRESS)


def duration_option() -> Callable[[str], float]:
    """The argparse ``type`` of ``--duration`` (s) of the commands that simulate."""
    from ..openloop import MAX_DURATION_S
    from ..plausibility import judge, warn_implausible
    from ..robot_spec import ACTION_PERIOD

    bounded = number("s", ACTION_PERIOD, MAX_DURATION_S)

    def parse(text: str) -> float:
        value = bounded(text)
        finding = judge("simulated time", value)
        if finding is not None:  # e.g. milliseconds written for seconds
            warn_implausible(f"--duration = {finding.text}", "--duration")
        return value

    parse.__name__ = bounded.__name__
    return parse
