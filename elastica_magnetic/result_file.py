"""One result file, written whole or not at all.

A single result file (``msr real calibrate --out cal.json``, ``msr real stream --log``) goes through
:func:`result_file`: refused when it exists unless ``force``, written beside itself under a
temporary name, flushed and renamed over it in one step, under a lock beside it
(``.NAME.msr-lock``), so two processes never write it and an interruption leaves the old file. It
is recorded in its folder's ``.msr-files.json``: ``force`` replaces only a file msr recorded
writing there, unchanged since, never the user's own file of that name.
"""

from __future__ import annotations

import contextlib
import os
import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from .filesets import claim_pre_check, not_recorded, record_files
from .interrupts import signals_as_exceptions, signals_held
from .io import (
    OutputPathError,
    display_path,
    normalized_path,
    output_path_problem,
    spelled_as_folder,
    unwritable_reason,
)
from .locks import (
    FolderLock,
    host_name,
    killed_writers_temporary,
    lock_path,
    name_tag,
    release_claim,
)
from .result_markers import (
    MANIFEST,
    manifest_holder,
    manifest_writer,
)
from .result_places import UNSAID, ResultExistsError, check_enclosing
from .results import remove_tree

__all__ = ["FileKind", "ResultFile", "check_result_file", "result_file"]

_NEW_FILE = ".msr-new-"


@dataclass
class ResultFile:
    """One result file being written (see :func:`result_file`): write :attr:`path` (a temporary
    file beside :attr:`final`); ``notes``: recoveries done on entry."""

    final: Path
    path: Path
    notes: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class FileKind:
    """What a result file is, so that ``--force`` replaces only a file of that kind (an earlier
    result), never a file of the user's that happens to have the name: ``description`` for the
    message (``"a calibration JSON"``), ``recognizes(path)`` whether an existing file is one;
    ``of_no_case``: a result about no case (a calibration, a board log), which has no place where a
    shipped policy keeps its own case's results (its ``seeds/``)."""

    description: str
    recognizes: Callable[[Path], bool]
    of_no_case: bool = False

    def __post_init__(self) -> None:
        _FILE_KINDS.append(self)


#: Every :class:`FileKind` made: a file one of them recognizes is that command's result, which
#: ``--force`` of another kind's command never replaces (a calibration JSON is no board log).
_FILE_KINDS: list[FileKind] = []


def check_result_file(path: str | Path, *, force: bool = False, option: str = "--out",
                      force_option: str = "--force", kind: FileKind | None = None) -> Path:
    """Check, before any long work, that the file ``path`` may be written: not a folder, not under
    a file, its folder writable, and absent unless ``force`` (and then a file msr recorded in
    :data:`MANIFEST`, unchanged since: a file of the user's is never replaced; ``kind`` names what
    an unrecorded file is not). Returns the normalized path."""
    final = normalized_path(path)
    if spelled_as_folder(path):
        raise OutputPathError(f"{option} {display_path(final)}/: ends with a separator, so it names "
                              f"a folder; {option} here is one file: give its name (e.g. "
                              f"{display_path(final)}/result{final.suffix or '.json'})")
    claimed = claim_pre_check(final, option)
    notes = claimed + _recover_file(final, option)
    try:
        _check_file(final, force, option, force_option, kind)
    except OutputPathError as exc:
        release_claim(final)
        for note in notes:  # the command line prints them before the error
            exc.add_note(note)
        raise
    _recovered_file_notes.setdefault(str(final), []).extend(notes)
    return final


#: Notes of recoveries done by :func:`check_result_file`, for the :func:`result_file` that follows.
_recovered_file_notes: dict[str, list[str]] = {}


def _recover_file(final: Path, option: str) -> list[str]:
    """Remove, under the lock, the temporary files of a writer of ``final`` that was killed."""
    if not final.parent.is_dir() or not (_new_files(final) or lock_path(final).exists()):
        return []
    with FolderLock(final, option=option) as lock:
        return lock.notes + _remove_new_files(final)


def _new_files(final: Path) -> list[Path]:
    """The temporary files that killed writers of ``final`` left, and the temporaries of an atomic
    write (:func:`elastica_magnetic.io.atomic_write`) into one of those: plain files named as msr
    names them, of a process that is gone (a user's file or folder named like one is left alone)."""
    prefix = f".{final.stem}{_NEW_FILE}"
    found = []
    for path in {*final.parent.glob(prefix + "*"), *final.parent.glob(f".{prefix}*")}:
        inner = path.name.startswith("." + prefix)
        tail = path.name[len(prefix) + inner:]
        if inner:  # an atomic write's temporary of one: ...RANDOM.tmpPID{suffix}
            tail = re.sub(r"\.tmp[0-9]+(?=" + re.escape(final.suffix) + "$)", "", tail)
        if path.is_file() and not path.is_symlink() and killed_writers_temporary(tail, final.suffix):
            found.append(path)
    return sorted(found)


def _check_file(final: Path, force: bool, option: str, force_option: str,
                kind: FileKind | None = None) -> None:
    where = f"{option} {display_path(final)}"
    if (problem := output_path_problem(final)) is not None:
        raise OutputPathError(f"{where}: {problem}")
    if final.is_dir():
        raise OutputPathError(f"{where}: is a folder, expected a file name")
    if final.exists() and not final.is_file():  # a device, a pipe, a socket: never replaced
        kind = ("a character device" if final.is_char_device() else "a block device"
                if final.is_block_device() else "a named pipe" if final.is_fifo()
                else "a socket" if final.is_socket() else "not a regular file")
        raise OutputPathError(f"{where}: is {kind}, not a regular file; a result file is replaced "
                              "by renaming a new one over it, so give a file name")
    for parent in final.parents:
        if parent.exists() and not parent.is_dir():
            raise OutputPathError(f"{where}: {display_path(parent)} is a file, not a folder")
    check_enclosing(final, option, None if kind is not None and kind.of_no_case else UNSAID)
    if (held := manifest_holder(final.parent)) is not None:
        raise ResultExistsError(f"{where}: lies in {display_path(final.parent)}, which holds {held}, "
                                "whose files are its own: nothing else goes in that folder; choose "
                                f"another {option}")
    _check_replaceable(final, where, option, force_option, kind)  # first: --force would not help
    if final.exists() and not force:
        raise ResultExistsError(f"{where}: already exists; pass {force_option} to replace it, or "
                                f"choose another {option}")
    if final.parent.exists() and (reason := unwritable_reason(final.parent)) is not None:
        raise OutputPathError(f"{where}: cannot write in {display_path(final.parent)}: {reason}")


def _check_replaceable(final: Path, where: str, option: str, force_option: str,
                       kind: FileKind | None) -> None:
    """Refuse an existing ``final`` that ``force_option`` may not replace (another command's
    result, a file msr did not write or that changed since), with or without it: advising
    ``force_option`` for it would be advice that is refused when followed."""
    recorded_by = manifest_writer(final.parent, final.name) if final.is_file() else None
    if kind is not None and recorded_by is not None and recorded_by != kind.description:
        raise ResultExistsError(f"{where}: is {recorded_by} (msr recorded writing it there), another "
                                f"command's result; {force_option} replaces only {kind.description}: move "
                                f"it away or choose another {option}")
    if final.is_file() and kind is not None and not _recognized(kind, final):
        other = next((k for k in _FILE_KINDS if k is not kind and _recognized(k, final)), None)
        if other is not None:  # msr's own, recorded or not: another command's result
            raise ResultExistsError(f"{where}: is {other.description}, another command's result; "
                                    f"{force_option} replaces only {kind.description}: move it away or "
                                    f"choose another {option}")
    # a file msr recorded, unchanged since, is its own whatever it holds (the log of a failed
    # connection holds no firmware line); another must look like the kind it is replaced by
    if (final.is_file() and kind is not None and not_recorded(final.parent, [final.name])
            and not _recognized(kind, final)):
        raise ResultExistsError(f"{where}: is not {kind.description} (a file msr did not write?); "
                                f"{force_option} replaces only {kind.description}: move it away "
                                f"or choose another {option}")
    if final.is_file() and not_recorded(final.parent, [final.name]):
        raise ResultExistsError(f"{where}: was not written by msr (no record in "
                                f"{display_path(final.parent / MANIFEST)}) or changed since: it may "
                                f"be yours, and {force_option} replaces only a file msr wrote; move it "
                                f"away or choose another {option}")


def _recognized(kind: FileKind, path: Path) -> bool:
    try:
        return bool(kind.recognizes(path))
    except (OSError, ValueError, UnicodeDecodeError):
        return False


def _remove_new_files(final: Path) -> list[str]:
    notes = []
    for leftover in _new_files(final):
        remove_tree(leftover)
        notes.append(f"{display_path(final)}: removed {leftover.name}, left by a run that was killed")
    return notes


@contextlib.contextmanager
def result_file(path: str | Path, *, force: bool = False, option: str = "--out",
                force_option: str = "--force", kind: FileKind | None = None) -> Iterator[ResultFile]:
    """Write one result file whole or not at all: ``with result_file(out, force=...) as f:``
    write ``f.path``; on a normal exit it is flushed and renamed over ``out`` in one step. The
    checks of :func:`check_result_file` come first (an existing file without ``force`` is a
    :class:`~elastica_magnetic.results.ResultExistsError`), then the lock beside ``out``; an
    exception, Ctrl-C, SIGTERM or SIGHUP in the block removes the temporary file and leaves
    ``out`` as it was."""
    final = check_result_file(path, force=force, option=option, force_option=force_option, kind=kind)
    shown = display_path(final)
    try:
        final.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputPathError(f"{option} {shown}: cannot create {display_path(final.parent)}: "
                              f"{exc.strerror or exc}") from None
    try:
        with signals_as_exceptions(), FolderLock(final, option=option) as lock:
            notes = (_recovered_file_notes.pop(str(final), []) + lock.notes
                     + _remove_new_files(final))
            _check_file(final, force, option, force_option, kind)
            # same folder (the rename is atomic) and same suffix (writers such as savefig read it)
            temporary = final.parent / (f".{final.stem}{_NEW_FILE}{name_tag(host_name())}-"
                                        f"{os.getpid()}-{os.urandom(3).hex()}{final.suffix}")
            try:
                yield ResultFile(final, temporary, notes)
                with open(temporary, "rb+") as handle:
                    os.fsync(handle.fileno())
                with signals_held():
                    os.replace(temporary, final)
                    # what --force may replace later, and by which kind of result
                    record_files(final.parent, [final.name],
                                  writer=kind.description if kind is not None else None)
            except BaseException as exc:
                remove_tree(temporary)
                if isinstance(exc, OSError) and not isinstance(exc, OutputPathError):
                    raise OutputPathError(f"{option} {shown}: cannot write it: {exc.strerror or exc}; "
                                          f"{shown} is left as it was") from exc
                if isinstance(exc, OutputPathError):
                    text = str(exc).replace(str(temporary), shown)
                    raise OutputPathError(f"{text}; {shown} is left as it was") from exc
                raise
    finally:
        release_claim(final)  # the pre-check's hold (the lock itself goes with this block)
