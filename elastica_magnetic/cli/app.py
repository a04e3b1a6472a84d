"""The ``msr`` command line: parses, calls library functions, prints (JSON with ``--json``).

Commands are grouped by noun, as ``git`` and ``docker`` group theirs (:data:`GROUPS`): ``msr case``,
``msr field`` (play fields on a robot), ``msr train`` and ``msr refine``, ``msr policy`` (what is
done with a trained policy), ``msr real`` (toward the real robot, the coils' board included),
``msr loop``, ``msr design``, ``msr validate``, ``msr bench``. Each area of the project registers
its own commands through a ``register(subparsers)`` function under their plain names;
:data:`COMMAND_HOMES` puts each into its group. Its earlier top-level spelling (``msr generate``
for ``msr policy generate``) keeps working, hidden from the help, with a one-line note naming the
new one; so do the spellings of a group merged into another
(:data:`~elastica_magnetic.command_names.FORMER_GROUPS`: ``msr real stream`` for ``msr real stream``):

- ``elastica_magnetic.cli.commands``: ``replay``, ``simulate``
- ``elastica_magnetic_validation.cli``: ``validate``
- ``elastica_magnetic_rl.cli.commands``: ``case``, ``bench``, ``figures``
- ``elastica_magnetic_rl.cli.rollout_commands``: ``generate``, ``baseline``, ``demo``
- ``elastica_magnetic_rl.cli.train_commands``: ``train``, ``refine``
- ``elastica_magnetic_rl.cli.policy_commands``: ``export-seeds``, ``seeds``, ``ship``, ``notes``, ``export``,
  ``diagnose``
- ``elastica_magnetic_rl.sim2real.cli``: ``robustness``, ``identify``
- ``elastica_magnetic.hardware.cli``: ``stream``, ``export-firmware``, ``calibrate``
- ``elastica_magnetic_rl.loop.cli``: ``loop``
- ``elastica_magnetic_rl.design.cli``: ``design``
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import json
import math
import re
import sys
import weakref
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

from ..command_names import COMMAND_HOMES, FORMER_GROUPS, spelling
from ..interrupts import signals_as_exceptions
from ..locks import release_claims
from .input_places import check_command_inputs, command_parser

# Modules that provide ``register(subparsers)``; missing optional areas are skipped.
COMMAND_MODULES = (
    "elastica_magnetic.cli.commands",
    "elastica_magnetic_validation.cli",
    "elastica_magnetic_rl.cli.commands",
    "elastica_magnetic_rl.cli.rollout_commands",
    "elastica_magnetic_rl.cli.train_commands",
    "elastica_magnetic_rl.cli.policy_commands",
    "elastica_magnetic_rl.sim2real.cli",
    "elastica_magnetic.hardware.cli",
    "elastica_magnetic_rl.loop.cli",
    "elastica_magnetic_rl.design.cli",
)


#: The groups of commands: name -> what the group is for (``msr --help``).
GROUPS: dict[str, str] = {
    "field": "play a field on a robot: a field CSV (replay), a rotating field (simulate), the "
             "hand-designed yardstick (baseline)",
    "policy": "use a trained policy: generate its waveform, ship, export, its seeds, figures, "
              "diagnose, the demo",
    "real": "toward the real robot: robustness to spec values, identify values from a measured "
            "trajectory; the coils' board: stream a waveform, the firmware's tables, calibrate "
            "the coils",
}

class CommandError(Exception):
    """An error to report to the user as one clear line (exit status 2)."""


def print_result(result: dict[str, Any], as_json: bool) -> None:
    """Print a command's result: JSON on one document with ``--json`` (paths absolute), else one
    ``key: value`` line per entry for people (:func:`human_lines`: nested tables indented, lists
    joined, numbers to 6 significant digits, paths relative to the current folder where they lie
    inside it; never a Python repr)."""
    if as_json:
        print(json.dumps(result, indent=2, default=str))
    else:
        for line in human_lines(result):
            print(line)


def human_lines(result: dict[str, Any], indent: str = "") -> list[str]:
    """``result`` as lines for people: ``key: value``, a table's entries indented under its key,
    a list of plain values joined by ``", "``, a list of tables as ``-`` items."""
    lines = []
    for key, value in result.items():
        if isinstance(value, dict) and value:
            lines.append(f"{indent}{key}:")
            lines.extend(human_lines(value, indent + "  "))
        elif isinstance(value, (list, tuple)) and any(isinstance(v, (dict, list, tuple)) for v in value):
            lines.append(f"{indent}{key}:")
            for item in value:
                if isinstance(item, dict):
                    item_lines = human_lines(item, indent + "    ")
                    lines.append(f"{indent}  - {item_lines[0].lstrip()}" if item_lines else
                                 f"{indent}  - (empty)")
                    lines.extend(item_lines[1:])
                else:
                    lines.append(f"{indent}  - {_human_value(item)}")
        else:
            lines.append(f"{indent}{key}: {_human_value(value)}")
    return lines


def _human_value(value: Any) -> str:
    """One value for people: a path relative where it can be, a number to 6 digits, ``none``."""
    from ..io import display_path

    if value is None:
        return "none"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, Path) or (isinstance(value, str) and value.startswith("/")):
        return display_path(value)
    if isinstance(value, dict):  # empty
        return "none"
    if isinstance(value, (list, tuple)):
        return ", ".join(_human_value(v) for v in value) if value else "none"
    return str(value)


class _Placement:
    """What ``register(subparsers)`` functions get instead of the subparsers: each plain command
    name goes to its group (:data:`COMMAND_HOMES`) or to the top level. With ``aliases`` only the
    grouped commands are added, hidden (no help): at the top level under their plain name, or,
    with ``former`` (an old group's name and its subparsers), those the old group had, under it."""

    def __init__(self, top: Any, groups: dict[str, Any], aliases: bool = False,
                 former: tuple[str, Any] | None = None) -> None:
        self.top, self.groups, self.aliases, self.former = top, groups, aliases, former
        self.alias_parsers: list[tuple[str, argparse.ArgumentParser]] = []

    def add_parser(self, name: str, **kwargs: Any) -> argparse.ArgumentParser:
        home = COMMAND_HOMES.get(name)
        if self.aliases:
            target, label = self.top, name
            if self.former is not None and home is not None:
                old_group, target = self.former
                group_now, names = FORMER_GROUPS[old_group]
                name = label = home[1]
                if home[0] != group_now or name not in names:
                    home = None
                label = f"{old_group} {name}"
            if home is None:  # registered elsewhere: a parser thrown away
                return argparse.ArgumentParser(add_help=False)
            kwargs.pop("help", None)  # a sub-parser without help is not listed
            kwargs.setdefault("prog", f"msr {label}")
            parser = target.add_parser(name, **kwargs)
            self.alias_parsers.append((label, parser))
            return parser
        if home is None:
            return self.top.add_parser(name, **kwargs)
        return self.groups[home[0]].add_parser(home[1], **kwargs)


def _noted(plain: str, func: Callable[[argparse.Namespace], Any]) -> Callable[[argparse.Namespace], Any]:
    def run(args: argparse.Namespace) -> Any:
        print(f"msr {plain}: note: this is now msr {spelling(plain)} (the old spelling works in "
              "this release)", file=sys.stderr)
        return func(args)

    return run


class _StoreOnce(argparse._StoreAction):
    """argparse's ``store``, saying when an option is given twice with different values
    (``--duration 0.1 --duration 0.2``, ``--file A --notes B`` of one option): the last is used, as
    argparse and most command lines do (a script's defaults overridden after them), but never
    without a word."""

    #: Per parse (its namespace, by id: namespaces are not hashable) the values given so far.
    _given: dict[int, tuple[weakref.ref, dict[str, tuple[str | None, Any]]]] = {}

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any,
                 option_string: str | None = None) -> None:
        entry = self._given.get(id(namespace))
        if entry is None or entry[0]() is not namespace:  # a new parse (an id of a gone one reused)
            for key in [k for k, (ref, _) in self._given.items() if ref() is None]:
                del self._given[key]
            entry = self._given[id(namespace)] = (weakref.ref(namespace), {})
        given = entry[1]
        if self.dest in given and given[self.dest][1] != values:
            first, value = given[self.dest]
            spelled = " and ".join(dict.fromkeys(f for f in (first, option_string) if f))
            print(f"{parser.prog}: note: {spelled} given twice ({_shown(value)}, then {_shown(values)}): "
                  f"the last, {_shown(values)}, is used", file=sys.stderr)
        given[self.dest] = (option_string, values)
        super().__call__(parser, namespace, values, option_string)


def _shown(value: Any) -> str:
    return repr(str(value)) if isinstance(value, (str, Path)) else repr(value)


class _Parser(argparse.ArgumentParser):
    """argparse's parser, taking a value that starts with a negative number for a value, also a
    list of numbers (``--target -0.015,0``), where argparse takes any word starting with ``-``
    but a lone number for an option, and a whole number written as a float (``1e5``) for an
    integer option. Its sub-parsers are of this class too."""

    #: No option of msr starts with a digit: a word that does is a value (``-0.015,0``, ``-15mm,0``:
    #: the option's own reader then names what is wrong with it)
    _NEGATIVE_VALUE = re.compile(r"^-\.?\d")

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = self._NEGATIVE_VALUE
        self.register("action", None, _StoreOnce)
        self.register("action", "store", _StoreOnce)

    def _get_value(self, action: argparse.Action, arg_string: str) -> Any:
        """The value as the option's type reads it; a whole number written as a float (``--steps
        1e5``, ``--ring 12.0``) that an integer option refuses is read as that integer, as ``--set``
        takes it."""
        try:
            return super()._get_value(action, arg_string)
        except argparse.ArgumentError as refused:
            whole = _whole_number(arg_string)
            if whole is None or action.type in (None, str, float):
                raise
            try:
                return super()._get_value(action, whole)
            except argparse.ArgumentError:
                raise refused from None


def _whole_number(text: str) -> str | None:
    """``"200"`` for a whole number written as a float (``"2e2"``, ``"200.0"``), else ``None``."""
    try:
        value = float(text)
    except ValueError:
        return None
    if not math.isfinite(value) or not value.is_integer() or text.strip().lstrip("+-").isdigit():
        return None
    return str(int(value))


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="msr",
        description="Magnetic soft robots on PyElastica (Yao et al. 2023).",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    modules = []
    for name in COMMAND_MODULES:
        try:
            modules.append(importlib.import_module(name))
        except ModuleNotFoundError as exc:
            if exc.name is not None and name.startswith(exc.name):
                continue  # that area is not part of this checkout
            raise
    groups = {}
    for group, what in GROUPS.items():
        group_parser = sub.add_parser(group, help=what, description=what[0].upper() + what[1:] + ".")
        groups[group] = group_parser.add_subparsers(dest="subcommand", metavar="COMMAND")
        groups[group].required = True
    for module in modules:
        module.register(_Placement(sub, groups))
    placements = [_Placement(sub, groups, aliases=True)]
    for old_group in FORMER_GROUPS:
        group_now, names = FORMER_GROUPS[old_group]
        old = sub.add_parser(old_group, description=(  # no help: not listed
            f"The earlier spelling of msr {group_now} {', '.join(names)} (it works in this "
            f"release): see msr {group_now} --help."))
        old_commands = old.add_subparsers(dest="subcommand", metavar="COMMAND")
        old_commands.required = True
        placements.append(_Placement(sub, groups, aliases=True, former=(old_group, old_commands)))
    for aliases in placements:
        for module in modules:
            module.register(aliases)
        for plain, alias in aliases.alias_parsers:
            alias.set_defaults(func=_noted(plain, alias.get_default("func")), plain_command=plain)
    _sort_listing(sub)
    return parser


def _sort_listing(sub: Any) -> None:
    """List the top level as :data:`TOP_LEVEL_ORDER` (the order a newcomer meets them)."""
    order = {name: k for k, name in enumerate(TOP_LEVEL_ORDER)}
    sub._choices_actions.sort(key=lambda action: order.get(action.dest, len(order)))


#: The order of ``msr --help``: the path of a new user, then the tools.
TOP_LEVEL_ORDER = ("case", "field", "train", "refine", "policy", "real", "loop", "design",
                   "validate", "bench")


def listed_commands(parser: argparse.ArgumentParser | None = None) -> dict[str, argparse.ArgumentParser]:
    """Every command of ``msr`` as written today (``"policy generate"``, ``"case show"``, the groups
    themselves), with its parser; the hidden old spellings left out. For tests that walk the
    command line."""
    found: dict[str, argparse.ArgumentParser] = {}

    def walk(node: argparse.ArgumentParser, prefix: str) -> None:
        for action in node._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    if not prefix and (name in COMMAND_HOMES or name in FORMER_GROUPS):
                        continue  # an old spelling
                    full = f"{prefix} {name}".strip()
                    found[full] = sub
                    walk(sub, full)

    walk(parser if parser is not None else build_parser(), "")
    return found


def command_name(args: argparse.Namespace) -> str:
    """The command as the user wrote it: ``"policy generate"``, ``"generate"`` (the old spelling),
    ``"train"``; for messages (``msr policy generate: error: ...``)."""
    if getattr(args, "plain_command", None):
        return str(args.plain_command)
    sub = getattr(args, "subcommand", None) if args.command in GROUPS else None
    sub = sub or getattr(args, "case_command", None)  # msr case list|show|check
    return f"{args.command} {sub}" if sub else str(args.command)


@contextlib.contextmanager
def _plausibility_warnings(command: Callable[[], str]) -> Iterator[None]:
    """Show each unusual value (:class:`~elastica_magnetic.plausibility.ImplausibleValueWarning`)
    once, and each leftover that could not be removed
    (:class:`~elastica_magnetic.results.LeftoverWarning`) and each default left off
    (:class:`~elastica_magnetic.plausibility.SettingNotAppliedWarning`), as one line ``msr CMD: warning: ...``
    on stderr rather than Python's ``file:line`` form."""
    import warnings

    from ..io import UnverifiedFileWarning
    from ..plausibility import ImplausibleValueWarning, SettingNotAppliedWarning
    from ..results import LeftoverWarning

    with warnings.catch_warnings():
        warnings.simplefilter("once", ImplausibleValueWarning)
        original = warnings.showwarning
        shown: set[str] = set()  # a spec read twice (parsed, then checked) warns once

        def show(message, category, filename, lineno, file=None, line=None):
            if issubclass(category, (ImplausibleValueWarning, LeftoverWarning,
                                     SettingNotAppliedWarning, UnverifiedFileWarning)):
                if issubclass(category, ImplausibleValueWarning) and str(message) in shown:
                    return
                shown.add(str(message))
                print(f"msr {command()}: warning: {message}", file=sys.stderr)
            else:
                original(message, category, filename, lineno, file, line)

        warnings.showwarning = show
        yield


class StandardOutputError(OSError):
    """Standard output cannot be written (a full disk it is redirected to, an I/O error)."""


class _StandardOutputClosed(Exception):
    """The reader of standard output went away (``msr ... | head``)."""


class _CheckedStandardOutput:
    """``sys.stdout`` whose write failures say they are standard output's: "[Errno 28] No space
    left on device" alone reads as if a result could not be written."""

    def __init__(self, stream: Any) -> None:
        self._stream = stream

    def _call(self, method: str, *args: Any) -> Any:
        try:
            return getattr(self._stream, method)(*args)
        except BrokenPipeError:
            raise _StandardOutputClosed from None
        except OSError as exc:
            raise StandardOutputError(f"cannot write to standard output: {exc.strerror or exc} "
                                      "(where it is redirected to)") from None

    def write(self, text: str) -> int:
        return self._call("write", text)

    def flush(self) -> None:
        self._call("flush")

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


def _stop_writing_standard_output() -> None:
    """After the reader went away: later writes (Python's own flush at exit) go nowhere."""
    import os

    with contextlib.suppress(OSError, ValueError):
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.__stdout__.fileno())


def main(argv: Sequence[str] | None = None) -> int:
    stdout = sys.stdout
    sys.stdout = _CheckedStandardOutput(stdout)
    try:
        status = _main(argv)
        sys.stdout.flush()
        return status
    except _StandardOutputClosed:  # quietly, as a Unix tool killed by SIGPIPE
        _stop_writing_standard_output()
        return 128 + 13
    except StandardOutputError as exc:
        print(f"msr: error: {exc}", file=sys.stderr)
        return 2
    finally:
        sys.stdout = stdout
        release_claims()  # output folders its pre-checks locked (the writes release their own)


def _main(argv: Sequence[str] | None = None) -> int:
    from ..results import aborted_results
    from ..simulation import SimulationDivergedError

    already_aborted = len(aborted_results())
    command = _command_word(sys.argv[1:] if argv is None else argv)  # until parsed
    swallowed: list[KeyboardInterrupt] = []
    try:
        # parsing imports the command modules and loads --case specs: Ctrl-C may come there too
        # SIGTERM/SIGHUP as Ctrl-C in every command: its clean-up runs (locks, temporaries)
        with signals_as_exceptions(), _interruptions_not_swallowed(swallowed), \
                _plausibility_warnings(lambda: command):
            parser = build_parser()
            args, extras = parser.parse_known_args(argv)
            command = args.command_name = command_name(args)
            if extras:  # said by the command's own parser, with its usage, not the top level's
                _unrecognized(parser, command, extras)
            check_command_inputs(parser, command, args)  # no input inside what --force replaces
            status = args.func(args)
    except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM/SIGHUP while a result was written
        return _interrupted(command, exc, aborted_results()[already_aborted:])
    except _StandardOutputClosed:
        raise
    except Exception as exc:
        if swallowed:  # the error is the interruption's consequence (numba's compiler cut short)
            return _interrupted(command, swallowed[0], aborted_results()[already_aborted:])
        if not isinstance(exc, (CommandError, ValueError, OSError, SimulationDivergedError)):
            raise
        print_notes(getattr(exc, "__notes__", ()))  # e.g. a killed run's leftovers cleaned first
        print(f"msr {command}: error: {exc}", file=sys.stderr)
        return 2
    if swallowed:  # the compilation survived it: say why the command did not stop
        print(f"msr {command}: note: a Ctrl-C came where it cannot stop the command (in a callback "
              "from C, such as numba's compiler); it ran to its end", file=sys.stderr)
    return int(status or 0)


#: Options of earlier releases that were removed, by (command, option): why, for the error
#: (``msr design --finalists`` was one until ``--search-physics training`` gave it a use again).
REMOVED_OPTIONS: dict[tuple[str, str], str] = {}


def _unrecognized(parser: argparse.ArgumentParser, command: str, extras: list[str]) -> None:
    """Exit with the command's own usage and error for arguments it does not take."""
    parser = command_parser(parser, command)
    options = {o for a in parser._actions for o in a.option_strings}
    hint = ""
    if "--case" in extras and "--robot" in options:
        hint = ("; this command takes the robot as --robot (a preset name, or a spec file: msr case "
                "show CASE --toml > my.toml writes a case's)")
    removed = [REMOVED_OPTIONS[(command, x.split("=", 1)[0])] for x in extras
               if (command, x.split("=", 1)[0]) in REMOVED_OPTIONS]
    if removed:
        hint += "; " + "; ".join(removed)
    parser.error(f"unrecognized arguments: {' '.join(extras)}{hint}")


def _command_word(argv: Sequence[str]) -> str:
    """The command named in ``argv`` before it is parsed: its first word not starting with
    ``-``, and the second too for a group (``"policy generate"``, ``"case check"``), or ``""``."""
    words = [str(a) for a in argv if not str(a).startswith("-")][:2]
    if len(words) == 2 and (words[0] in GROUPS or words[0] == "case"):
        return " ".join(words)
    return words[0] if words else ""


def _interrupted(command: str, exc: KeyboardInterrupt, kept: Sequence[object]) -> int:
    """Print the one line of an interruption; the exit status, 128 + the signal's number."""
    print(interrupted_message(command, exc, kept), file=sys.stderr)
    return 128 + getattr(exc, "signum", 2)


@contextlib.contextmanager
def _interruptions_not_swallowed(swallowed: list[KeyboardInterrupt]) -> Iterator[None]:
    """Keep a Ctrl-C that lands in Python code called back from C. A signal that comes while
    numba's compiler runs LLVM is handled in the first Python code run after it: llvmlite's
    object-cache hook, called through ctypes, which cannot pass an exception on. It prints
    "Exception ignored on calling ctypes callback function", and the compilation then fails with
    an unrelated ``RuntimeError`` ("no compiled object yet", the cached kernels' object was lost).
    While this is entered, such a :class:`KeyboardInterrupt` is appended to ``swallowed`` instead
    of printed, and the signal is sent again (:func:`_redeliver`) until one lands outside such a
    callback and stops the command; :func:`main` reports the error that follows as the
    interruption, or, where none came, says why the command ran to its end."""
    import threading

    previous = sys.unraisablehook
    ended = threading.Event()

    def hook(unraisable: Any) -> None:
        if isinstance(unraisable.exc_value, KeyboardInterrupt):
            swallowed.append(unraisable.exc_value)
            if len(swallowed) == 1:
                threading.Thread(target=_redeliver, args=(swallowed, ended), daemon=True,
                                 name="msr-redeliver-interrupt").start()
        else:
            previous(unraisable)

    sys.unraisablehook = hook
    try:
        yield
    finally:
        ended.set()
        sys.unraisablehook = previous


#: Seconds between the signals :func:`_redeliver` sends; one not swallowed within it has landed.
REDELIVERY_S = 1.0


def _redeliver(swallowed: list[KeyboardInterrupt], ended: Any) -> None:
    """Send the swallowed interruption's signal to this process again, once a callback from C has
    returned, until one is not swallowed (it then stops the command as any Ctrl-C does) or the
    command has ended."""
    import os
    import signal

    number = getattr(swallowed[0], "signum", signal.SIGINT)
    seen = len(swallowed)
    while not ended.wait(REDELIVERY_S / 10):
        os.kill(os.getpid(), number)
        if ended.wait(REDELIVERY_S) or len(swallowed) == seen:
            return
        seen = len(swallowed)


#: The name msr gives its own temporary folders beside a result ``X`` (``.X.msr-new-HOST-PID-RANDOM``,
#: ``-old-``, ``-trash-``): never the user's output, so never named as one left as it was.
_MSR_TEMPORARY = re.compile(r"\..+\.msr-(?:new|old|trash)-[A-Za-z0-9_-]{1,40}-[0-9]+-[0-9a-f]{6}")


def _users_folder(folder: object) -> bool:
    """Whether ``folder`` (as a message shows it) is not one of msr's temporaries or inside one."""
    return not any(_MSR_TEMPORARY.fullmatch(part) for part in Path(str(folder)).parts)


def interrupted_message(command: str, exc: BaseException, kept: Sequence[object] = ()) -> str:
    """The one line printed when ``msr COMMAND`` is interrupted: the signal and, for every result
    folder in ``kept`` (those the interruption stopped), that it was left as it was; msr's own
    temporary folders (``.X.msr-new-...``, removed by then) are not named, and each folder once."""
    name = "SIGINT" if isinstance(exc, KeyboardInterrupt) and not hasattr(exc, "signum") else str(exc)
    shown = dict.fromkeys(str(folder) for folder in kept if _users_folder(folder))
    left = "".join(f"; {folder} was left as it was (a result folder is replaced whole or not at "
                   "all)" for folder in shown)
    return f"{f'msr {command}' if command else 'msr'}: interrupted ({name}){left}"


def print_notes(notes: Sequence[str]) -> None:
    """Print recoveries done before a command's work (a stale lock, a killed run's leftovers)."""
    for note in notes:
        print(f"note: {note}", file=sys.stderr)
