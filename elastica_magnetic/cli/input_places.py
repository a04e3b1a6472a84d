"""No command deletes its own input: every file or folder named on a writer's command line is
checked against the folder that the command replaces (``--out``, with ``--force``) before any work.

One check for every command, from its parser: each argument whose value names an existing path
is an input (positional or option, a list of them, or a loaded spec's source file), so an option
added later is covered without a list to update. A command declares only what differs, with
``parser.set_defaults``: :data:`REPLACED_FOLDER` (a function of the arguments giving the folder
replaced, when it is not ``--out`` itself; :func:`no_folder_replaced_whole` for a command whose
``--force`` replaces only its own files there, :func:`out_file` for one whose ``--out`` is a file),
:data:`INPUTS_ALWAYS` (a command that writes into its folder on every run, as ``msr loop`` does,
checked with or without ``--force``) and :data:`INPUTS_HOW` (what it does to a file there, for the
message).
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from ..result_places import REPLACED_WHOLE, check_inputs_outside

__all__ = ["INPUTS_ALWAYS", "INPUTS_HOW", "REPLACED_FOLDER", "check_command_inputs", "command_parser",
           "input_arguments", "no_folder_replaced_whole", "out_file"]

#: ``set_defaults`` key: a function ``(args) -> folder or None`` for the folder the command replaces.
REPLACED_FOLDER = "replaced_folder"
#: ``set_defaults`` key: ``True`` for a command that writes into its folder on every run.
INPUTS_ALWAYS = "inputs_always_checked"
#: ``set_defaults`` key: what the command does to a file inside its folder (the message's words).
INPUTS_HOW = "inputs_replaced_how"

#: Actions that name no input: flags, help, the output itself.
_NOT_INPUTS = (argparse._HelpAction, argparse._StoreTrueAction, argparse._StoreFalseAction,
               argparse._StoreConstAction, argparse._CountAction, argparse._VersionAction,
               argparse._SubParsersAction)


def no_folder_replaced_whole(args: argparse.Namespace) -> None:
    """:data:`REPLACED_FOLDER` of a command whose ``--force`` replaces only its own files in
    ``--out`` (other files stay): no input is deleted with a folder; its own checks guard the files
    it writes."""
    return None


def out_file(args: argparse.Namespace) -> Path | None:
    """:data:`REPLACED_FOLDER` of a command whose ``--out`` is one file (``msr real calibrate``):
    that file, which ``--force`` replaces; ``None`` where ``--out`` names a folder (the command
    refuses it itself: it replaces no folder)."""
    out = getattr(args, "out", None)
    return None if out is None or Path(out).is_dir() else Path(out)


def command_parser(parser: argparse.ArgumentParser, command: str) -> argparse.ArgumentParser:
    """The parser of ``command`` (``"policy generate"``, ``"train"``) under the top-level ``parser``;
    as far as its words lead."""
    for word in command.split():
        actions = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        if not actions or word not in actions[0].choices:
            break
        parser = actions[0].choices[word]
    return parser


def _out_action(parser: argparse.ArgumentParser) -> argparse.Action | None:
    return next((a for a in parser._actions if "--out" in a.option_strings), None)


def _paths(value: Any) -> Iterator[str | os.PathLike]:
    """The paths a parsed value names: itself, each of a list, or a loaded spec's source file."""
    if isinstance(value, (list, tuple)):
        for item in value:
            yield from _paths(item)
    elif isinstance(value, (str, os.PathLike)):
        yield value
    elif isinstance(getattr(value, "source", None), (str, os.PathLike)):
        yield value.source


def input_arguments(parser: argparse.ArgumentParser, args: argparse.Namespace
                    ) -> list[tuple[str, str | os.PathLike]]:
    """``(label, path)`` of every argument of a command's ``parser`` whose parsed value (in
    ``args``) names a path: the option (``--robot``) or the positional's metavar (``FIELD_CSV``).
    Whether it exists is :func:`~elastica_magnetic.result_places.check_inputs_outside`'s to ask."""
    out = _out_action(parser)
    found = []
    for action in parser._actions:
        if isinstance(action, _NOT_INPUTS) or action.choices is not None or (
                out is not None and action.dest == out.dest):  # flags, choices, the output
            continue
        label = action.option_strings[0] if action.option_strings else (
            action.metavar if isinstance(action.metavar, str) else action.dest.upper())
        found += [(label, path) for path in _paths(getattr(args, action.dest, None)) if str(path)]
    return found


def check_command_inputs(parser: argparse.ArgumentParser, command: str, args: argparse.Namespace) -> None:
    """Refuse (:class:`~elastica_magnetic.result_places.OutputPathError`) an input of ``command``
    that lies in the folder it replaces, before any work: with ``--force`` (or always, for a
    command that writes into its folder on every run). A command without ``--out`` writes no
    folder it replaces."""
    mine = command_parser(parser, command)
    out = _out_action(mine)
    if out is None:
        return
    replaced_of = getattr(args, REPLACED_FOLDER, None)
    replaced = replaced_of(args) if replaced_of is not None else getattr(args, out.dest, None)
    if replaced is None or not str(replaced):
        return
    force = bool(getattr(args, INPUTS_ALWAYS, False) or getattr(args, "force", False))
    check_inputs_outside(Path(replaced), input_arguments(mine, args), force=force,
                         how=getattr(args, INPUTS_HOW, REPLACED_WHOLE))
