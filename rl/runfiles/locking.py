"""Who writes a run folder: a seed's folder is locked for as long as a process trains in it
(:class:`elastica_magnetic.locks.FolderLock`, the lock file ``.seed<k>.msr-lock`` beside it) and
carries a marker (:func:`elastica_magnetic.result_markers.mark_folder`) naming the command that owns it,
so that another command (``msr refine RUN --out RUN``, ``msr policy generate --out RUN``) is refused
there; a case folder is locked only for the moment its ``summary.json`` is read and rewritten."""

from __future__ import annotations

import contextlib
import json
import sys
import time
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

from elastica_magnetic.io import display_path, normalized_path
from elastica_magnetic.locks import FolderLock, FolderLockedError
from elastica_magnetic.result_markers import MARKER, mark_folder, read_marker

from .rundir import RunDir

__all__ = ["check_not_owned", "check_unlocked", "held_run_folders", "is_run_file", "mark_run_folder",
           "briefly_locked", "remove_leftovers"]


def check_unlocked(folders: Iterable[str | Path], option: str = "--out") -> list[str]:
    """Refuse, naming the owner (pid, host, command), a folder another live process is writing
    (:class:`~elastica_magnetic.locks.FolderLockedError`). A stale lock of a process that died
    (killed, power loss) is taken over and removed: each is reported on stderr (``note: ...``,
    naming the dead process, its host and command) and returned. Nothing is written when no
    lock exists."""
    notes: list[str] = []
    for folder in folders:
        folder = Path(folder)
        if not folder.parent.is_dir():
            continue
        with FolderLock(folder, option=option) as lock:
            notes += lock.notes
    for note in notes:  # the command's own pre-check: the user sees it before any work
        print(f"note: {note}", file=sys.stderr)
    return notes


@contextlib.contextmanager
def held_run_folders(folders: Iterable[str | Path], option: str = "--out") -> Iterator[list[str]]:
    """Hold the lock of every run folder (created if absent) for the block; yields the notes
    (stale locks taken over, temporary files of a writer killed mid-write removed: the
    checkpoint it was writing, ``checkpoint.pt.tmp``; the previous ``checkpoint.pt`` is intact).
    Raises :class:`~elastica_magnetic.locks.FolderLockedError` naming the process that holds
    one, before any is written."""
    notes: list[str] = []
    with contextlib.ExitStack() as stack:
        for folder in folders:
            folder = Path(folder)
            folder.parent.mkdir(parents=True, exist_ok=True)
            notes += stack.enter_context(FolderLock(folder, option=option)).notes
            notes += remove_leftovers(folder)
        yield notes


def remove_leftovers(folder: str | Path) -> list[str]:
    """Remove the temporary files a writer killed mid-write left in the run folder ``folder``
    (:meth:`RunDir.leftover_temporaries`; call it holding the folder's lock); returns a note per
    file removed."""
    notes = []
    for path in RunDir(folder).leftover_temporaries():
        path.unlink(missing_ok=True)
        notes.append(f"{folder}: removed {path.name}, the unfinished file of a run that was killed "
                     "while writing it (the previous complete file is kept)")
    return notes


def mark_run_folder(folder: str | Path, kind: str, case: str) -> None:
    """The marker of a run folder (``kind``: ``"train"`` or ``"refine"``) for ``case``."""
    Path(folder).mkdir(parents=True, exist_ok=True)
    mark_folder(folder, kind=kind, subject=f"case {case}")


def check_not_owned(out: str | Path, kind: str, option: str = "--out") -> None:
    """Refuse an ``out`` folder that belongs to another command: a marker of another kind, or,
    for a folder written before markers, a ``run.json`` of another command (a training run's
    folder). ``ValueError`` naming the owner."""
    out = normalized_path(out)
    marker = read_marker(out)
    owner: dict[str, Any] | None = None
    if marker is not None and marker["kind"] != kind:
        owner = marker
    elif marker is None and RunDir(out).run_json.is_file():
        try:
            command = json.loads(RunDir(out).run_json.read_text()).get("command") or "train"
        except (OSError, ValueError, AttributeError):
            command = "train"
        if command != kind:
            owner = {"kind": command, "subject": None}
    if owner is not None:
        subject = f" for {owner['subject']}" if owner.get("subject") else ""
        raise ValueError(f"{option} {display_path(out)}: is the folder of a `msr {owner['kind']}` "
                         f"run{subject} ({MARKER if marker else 'run.json'}); `msr {kind}` never "
                         f"writes into a folder another command owns: choose another {option}")
    if marker is None and not RunDir(out).run_json.is_file():
        foreign = _foreign_entries(out)
        if foreign:  # a folder of the user's: a run would write its files among theirs
            raise ValueError(f"{option} {display_path(out)}: holds files that `msr {kind}` does not "
                             f"write ({', '.join(foreign[:5])}{' ...' if len(foreign) > 5 else ''}); "
                             "choose a new or empty folder")


def _foreign_entries(folder: Path) -> list[str]:
    """What a run folder without marker holds besides a run's own files (those a run killed
    during start-up may have left, and their temporaries)."""
    if not folder.is_dir():
        return []
    temporaries = {p.name for p in RunDir(folder).leftover_temporaries()}
    return sorted(p.name for p in folder.iterdir()
                  if not is_run_file(p.name) and p.name not in temporaries and p.name != MARKER)


#: The files a training run writes into its folder (``refined`` is the default place of ``msr refine``).
RUN_FILES = frozenset({RunDir.CHECKPOINT, RunDir.BEST, RunDir.REPLAY, RunDir.EPISODES_CSV,
                       RunDir.EVALUATIONS_CSV, RunDir.RUN_JSON, RunDir.EVALUATION_JSON, RunDir.REFINED})


def is_run_file(name: str) -> bool:
    """Whether ``name`` (a file in a run's folder) is one a training writes, or the temporary of
    one a killed writer left (``*.tmp``)."""
    return name in RUN_FILES or name.endswith(".tmp")


@contextlib.contextmanager
def briefly_locked(folder: str | Path, timeout_s: float = 60.0,
                   option: str = "--out") -> Iterator[FolderLock]:
    """Hold ``folder``'s lock for a short read-modify-write (a case's ``summary.json``), waiting up
    to ``timeout_s`` s for another process holding it for the same reason."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            lock = FolderLock(folder, option=option).acquire()
            break
        except FolderLockedError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.1)
    try:
        yield lock
    finally:
        lock.release()
