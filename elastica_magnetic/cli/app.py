"""The ``msr`` command line: parses, calls library functions, prints (JSON with ``--json``).

Each area of the project registers its own sub-commands through a ``register(subparsers)``
function, so this file stays a thin dispatcher:

- ``elastica_magnetic.cli.commands``: ``replay``, ``simulate``
- ``elastica_magnetic_validation.cli``: ``validate``
- ``elastica_magnetic_rl.cli.commands``: ``case``, ``bench``, ``generate``, ``baseline``, ``figures``,
  ``demo``
- ``elastica_magnetic_rl.cli.train_commands``: ``train``, ``refine``
- ``elastica_magnetic_rl.cli.policy_commands``: ``export-seeds``, ``seeds``, ``ship``, ``notes``, ``export``,
  ``diagnose``
- ``elastica_magnetic.hardware.cli``: ``stream``, ``export-firmware``, ``calibrate``
"""

from __future__ import annotations

import argparse
import importlib
import json
import math
import sys
from collections.abc import Callable, Sequence
from typing import Any

# Modules that provide ``register(subparsers)``; missing optional areas are skipped.
COMMAND_MODULES = (
    "elastica_magnetic.cli.commands",
    "elastica_magnetic_validation.cli",
    "elastica_magnetic_rl.cli.commands",
    "elastica_magnetic_rl.cli.train_commands",
    "elastica_magnetic_rl.cli.policy_commands",
    "elastica_magnetic.hardware.cli",
    "elastica_magnetic_rl.sim2real.cli",
)


class CommandError(Exception):
    """An error to report to the user as one clear line (exit status 2)."""


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
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}")
        return value

    parse.__name__ = f"number ({unit})" if unit else "number"
    return parse


def duration_option() -> Callable[[str], float]:
    """The argparse ``type`` of ``--duration`` (s) of the commands that simulate."""
    from ..openloop import MAX_DURATION_S
    from ..robot_spec import ACTION_PERIOD

    return number("s", ACTION_PERIOD, MAX_DURATION_S)


def print_result(result: dict[str, Any], as_json: bool) -> None:
    """Print a command's result: JSON on one document with ``--json``, else ``key: value`` lines."""
    if as_json:
        print(json.dumps(result, indent=2, default=str))
    else:
        for key, value in result.items():
            print(f"{key}: {value}")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="msr",
        description="Magnetic soft robots on PyElastica (Yao et al. 2023).",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMAND_MODULES:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name is not None and name.startswith(exc.name):
                continue  # that area is not part of this checkout
            raise
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    from ..results import aborted_results
    from ..simulation import SimulationDiverged

    parser = build_parser()
    args = parser.parse_args(argv)
    already_aborted = len(aborted_results())
    try:
        status = args.func(args)
    except (CommandError, ValueError, OSError, SimulationDiverged) as exc:
        print_notes(getattr(exc, "__notes__", ()))  # e.g. a killed run's leftovers cleaned first
        print(f"msr {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM/SIGHUP while a result was written
        print(interrupted_message(args.command, exc, aborted_results()[already_aborted:]),
              file=sys.stderr)
        return 128 + getattr(exc, "signum", 2)
    return int(status or 0)


def interrupted_message(command: str, exc: BaseException, kept: Sequence[object] = ()) -> str:
    """The one line printed when ``msr COMMAND`` is interrupted: the signal and, for every result
    folder in ``kept`` (those the interruption stopped), that it was left as it was."""
    name = "SIGINT" if isinstance(exc, KeyboardInterrupt) and not hasattr(exc, "signum") else str(exc)
    left = "".join(f"; {folder} was left as it was (a result folder is replaced whole or not at "
                   "all)" for folder in kept)
    return f"msr {command}: interrupted ({name}){left}"


def print_notes(notes: Sequence[str]) -> None:
    """Print recoveries done before a command's work (a stale lock, a killed run's leftovers)."""
    for note in notes:
        print(f"note: {note}", file=sys.stderr)
