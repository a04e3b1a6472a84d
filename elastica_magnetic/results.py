"""Result folders replaced whole or not at all, by one process at a time.

A command that writes a folder of results (``msr field simulate --out X``) never writes into ``X``
itself. It builds the new content in a temporary sibling ``.X.msr-new-HOST-PID-RANDOM`` (same
parent, so the same filesystem and renames are atomic) and swaps it in only when everything was
written::

    from elastica_magnetic.results import result_folder

    with result_folder(args.out, kind="simulate", subject=f"robot {spec.name}",
                       force=args.force, known_files=("trajectory.csv", "shapes.png")) as result:
        ...                                     # the long work
        write_trajectory_csv(traj, result.path / "trajectory.csv")   # write into result.path
    print(result.final_path(result.path / "trajectory.csv"))          # == args.out / "trajectory.csv"

What is guaranteed:

- **Whole or nothing.** On any exception in the block (a full disk, a bad value), on Ctrl-C
  (SIGINT), SIGTERM or SIGHUP, the temporary folder is removed and ``X`` keeps its old content
  byte for byte (or stays absent). The signals are turned into exceptions while the block runs
  (SIGINT: :class:`KeyboardInterrupt`; SIGTERM, SIGHUP: :class:`Interrupted`, a subclass), in the
  main thread and only where no other handler was installed; during the swap itself they are held
  back until it is over. :func:`aborted_results` lists the folders an interruption left as they
  were (the command line's message uses it).
- **Replaced only when asked.** An existing ``X`` is checked before any work
  (:func:`check_result_folder`): a result of another ``kind`` (another command), of another
  ``subject`` (another robot or case, when the caller names one) or a folder holding files the
  command did not write is refused, naming it, even with ``force``; a result of the same kind and
  subject is replaced only with ``force=True`` (``--force``). An empty folder is used as is. Each
  result carries a marker file, :data:`MARKER` (``.msr-result.json``: kind, subject, command,
  time, host and the list of files written); a folder written before markers existed is
  recognised by ``known_files`` (every file in it must be one the command writes).
- **One writer.** While the block runs, ``X`` is locked
  (:class:`~elastica_magnetic.locks.FolderLock`, the lock file
  ``.X.msr-lock`` beside it): a second process that wants to write ``X`` is refused, naming the
  first one's pid, host, command and start time.

The swap is two renames (``X`` -> ``.X.msr-old-...``, the new folder -> ``X``), then the old one
is renamed to ``.X.msr-trash-...`` and removed. A process killed outright (SIGKILL, power loss)
can leave, beside ``X``:

- ``.X.msr-new-...`` (killed while building): ``X`` is intact; the leftover is removed;
- ``.X.msr-old-...`` with ``X`` absent (killed between the two renames): the old content is
  renamed back to ``X`` (the new result was never reported, so it is dropped);
- ``.X.msr-old-...`` with ``X`` present (killed after the new folder went in), or
  ``.X.msr-trash-...`` (killed while removing the old one): the leftover is removed.

A leftover is recognised by its name (``HOST-PID-RANDOM`` as msr writes it) and its process being
gone; anything else beside ``X`` (a folder of the user's named ``.X.msr-new-backup``, a name
carrying a live process's pid) is left alone. This recovery runs at the start of the next
:func:`result_folder`, :func:`check_result_folder` (a command's pre-check) or :func:`recover` on
the same ``X``, under its lock, so a leftover is never one another live process is still writing;
what was done is in :attr:`ResultFolder.notes` (and returned by :func:`recover`). Files are
flushed to disk (``fsync``) before the swap. The signal handling is
:mod:`elastica_magnetic.interrupts`; the marker and the question "which files did msr write here"
are :mod:`elastica_magnetic.result_markers`.

**Folders written in place** (a training seed's folder, appended to for hours and resumed later)
are not swapped but locked for the whole run: :class:`elastica_magnetic.locks.FolderLock`; their
checkpoints are single files written with :func:`elastica_magnetic.io.atomic_save`, which keeps
the previous one until the new one is complete, and :func:`mark_folder` gives them a marker so that
another command (``refine --out RUN``) is refused there. **A set of files put into a folder that holds
other things** (figures into ``docs/figures``) goes through
:func:`elastica_magnetic.filesets.replace_files`.

Commands adopting this: enter :func:`result_folder` before the long work (the refusal and the
lock come first), print :attr:`ResultFolder.notes` (``elastica_magnetic.cli.print_notes``), write
every file under :attr:`ResultFolder.path`, print paths mapped with
:meth:`ResultFolder.final_path`, add ``--force`` to the parser and pass ``force=args.force``.
A command that writes into a folder another command owns (``refine --out RUN``) is refused by
the ``kind`` check. Worker processes write their files into :attr:`ResultFolder.path` as well;
only the parent process enters the block (signals are handled in its main thread), and the pool
is entered inside it (``with result_folder(...) as r, Pool(...) as pool:``), so that the workers
are ended before the temporary folder is removed.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import shutil
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .command_names import spelling
from .interrupts import signals_as_exceptions, signals_held
from .io import (
    OutputPathError,
    display_path,
    normalized_path,
    unwritable_reason,
)
from .locks import (
    LOCK_SUFFIX,
    FolderLock,
    claim,
    describe_owner,
    host_name,
    killed_writers_temporary,
    live_owner,
    name_tag,
    release_claim,
)
from .result_markers import (
    MANIFEST,
    MARKER,
    MAX_LISTED,
    describe_result,
    in_manifest,
    list_files,
    read_marker,
    short_list,
    write_marker,
)
from .result_places import (
    ResultExistsError,
    building,
    check_creatable,
    check_output_path,
    inside_building,
    swap_target,
)

__all__ = [
    "LeftoverWarning",
    "ResultExistsError",
    "ResultFolder",
    "aborted_results",
    "remove_tree",
    "fsync_tree",
    "check_result_folder",
    "interrupted",
    "recover",
    "result_folder",
]


class LeftoverWarning(UserWarning):
    """Something beside a result folder that could not be removed (an earlier result renamed
    aside, a killed run's temporary folder): the result itself is whole; the message names the
    leftover and why it stayed."""


_aborted: list[Path] = []
def aborted_results() -> list[Path]:
    """The result folders (as the caller named them) whose writing an exception or a signal
    stopped in this process, each left as it was; oldest first. msr's own temporary folders (a
    result written inside another's while it is built) are not among them."""
    return list(_aborted)


# -- result folders --------------------------------------------------------------------------------


def check_result_folder(
    out: str | Path,
    *,
    kind: str,
    subject: str | None = None,
    force: bool = False,
    option: str = "--out",
    known_files: Iterable[str] = (),
    force_option: str = "--force",
    recognizes: Callable[[Path], bool] | None = None,
) -> dict[str, Any] | None:
    """Check that ``out`` may receive a result of ``kind`` (the command's name, e.g.
    ``"simulate"``) for ``subject`` (e.g. ``"robot yao2023-m1"``; ``None``: any).

    Returns ``None`` when ``out`` is absent or an empty folder, else the marker of the result
    that will be replaced (``known_files``: relative paths the command writes; a folder holding
    only such names but no marker is refused even with ``force``, nothing saying msr wrote them,
    unless ``recognizes(out)`` (the command recognises its own result from before markers by its
    content, e.g. a seeds.json that parses as one). Raises
    :class:`OutputPathError` (a file, under a file, a mount point, not writable) or
    :class:`ResultExistsError` (another kind or subject, files the command did not write, or
    the same result without ``force``), naming ``option`` and the folder.

    Nothing is written, except when a writer of ``out`` was killed and left something beside it
    (:func:`interrupted`): that is recovered first, as the next :func:`result_folder` would (under
    the lock: a live writer is refused, naming it), so the check sees the result the user has
    (a command's pre-check before long work, too). What was done goes into the notes of an
    error raised here, or of the next :func:`result_folder` on ``out`` in this process.
    """
    final = normalized_path(out)
    check_output_path(final, option, subject)
    target = swap_target(final, option)
    check_creatable(target, option)
    claimed = target.parent.is_dir()  # no lock file in a folder this check would have to create
    notes: list[str] = []
    if claimed:  # held until the write: a second writer of ``out`` is refused now, not after its work
        lock = claim(target, option=option)
        notes, lock.notes = lock.notes, []  # a stale lock taken over: said once
    notes += recover(final, option=option) if interrupted(final) else []
    if notes:
        _recovered_notes.setdefault(os.path.realpath(final), []).extend(notes)
    try:
        return _check_result_folder(final, kind, subject, force, option, known_files, force_option,
                                    recognizes)
    except OutputPathError as exc:
        if claimed:
            release_claim(target)
        for note in notes:  # the command line prints them before the error
            exc.add_note(note)
        raise


#: Notes of recoveries done by :func:`check_result_folder` (a command's pre-check), by folder,
#: for the :func:`result_folder` that follows to report.
_recovered_notes: dict[str, list[str]] = {}


def _check_result_folder(final: Path, kind: str, subject: str | None, force: bool, option: str,
                         known_files: Iterable[str], force_option: str,
                         recognizes: Callable[[Path], bool] | None = None) -> dict[str, Any] | None:
    where = f"{option} {display_path(final)}"
    if not final.exists():
        return None
    if os.path.ismount(final):
        raise OutputPathError(f"{where}: is a mount point; a result folder is replaced by renaming "
                              "it, so give a folder inside it")
    if (reason := unwritable_reason(final)) is not None:
        raise OutputPathError(f"{where}: cannot write in {display_path(final)}: {reason}")
    listed = list_files(final)
    if listed is None:
        raise ResultExistsError(f"{where}: holds more than {MAX_LISTED} files, not a result of "
                                f"`msr {spelling(kind)}`; choose a new or empty folder")
    marker = read_marker(final)
    # msr's record of files it put there (figures re-drawn into a result) and what it lists are msr's
    recorded = [f for f in listed if f not in (MARKER, MANIFEST) and "/" not in f and in_manifest(final, f)]
    files = [f for f in listed if f not in (MARKER, MANIFEST) and f not in recorded]
    files = _without_stale_locks(final, files, where)
    known = set(known_files)
    others = [f for f in recorded if f not in known]
    if marker is None and others:  # a shipped policy, a calibration JSON: another command's files
        raise ResultExistsError(
            f"{where}: holds files another msr command wrote there ({short_list(others)}), not a result "
            f"of `msr {spelling(kind)}`; choose a new or empty folder ({force_option} replaces only a "
            "result of the same command)")
    if marker is None and MARKER in listed:
        raise ResultExistsError(
            f"{where}: its {MARKER}, msr's record of the files it wrote there, is damaged (not "
            "readable as that record), so msr cannot tell its files from yours and replaces "
            "nothing, not even with --force; move the folder away or choose another "
            f"{option}")
    if marker is None:
        if not files and MARKER not in listed:
            return None
        unknown = [f for f in files if f not in known]
        if unknown or not files:
            raise ResultExistsError(f"{where}: holds files that `msr {spelling(kind)}` does not write "
                                    f"({short_list(unknown or [MARKER])}); choose a new or empty folder")
        # named like this command's files, but nothing records that msr wrote them: a user's
        # files under the same names (a hand-tuned header) are never replaced, not even by --force
        if recognizes is not None and recognizes(final):
            marker = {"kind": kind, "subject": None, "legacy": True}
        else:
            raise ResultExistsError(
                f"{where}: holds files named like those `msr {spelling(kind)}` writes "
                f"({short_list(files)}) but no record that msr wrote them (no {MARKER}): they may be "
                f"yours, and {force_option} replaces only a result msr recorded; move them away or "
                "choose a new or empty folder")
    else:
        if marker["kind"] != kind:
            raise ResultExistsError(
                f"{where}: holds {describe_result(marker)}, not of `msr {spelling(kind)}`; "
                f"choose another {option} "
                f"({force_option} replaces only a result of the same command"
                f"{' and subject' if subject else ''})")
        if subject is not None and marker.get("subject") not in (None, subject):
            raise ResultExistsError(
                f"{where}: holds {describe_result(marker)}, not for {subject}; choose another {option} "
                f"({force_option} replaces only a result for the same subject)")
        written = set(marker.get("files") or ()) | known
        unknown = [f for f in files if f not in written]
        if unknown:
            raise ResultExistsError(
                f"{where}: holds {describe_result(marker)} and files it did not write "
                f"({short_list(unknown)}); "
                f"move them away or choose another {option} ({force_option} replaces only what "
                "msr wrote)")
    if not force:
        raise ResultExistsError(f"{where}: already holds {describe_result(marker)}; pass {force_option} to "
                                f"replace it, or choose another {option}")
    return marker


def _without_stale_locks(final: Path, files: list[str], where: str) -> list[str]:
    """``files`` without the lock files of folders inside ``final`` (``.sub.msr-lock``, msr's
    own); one whose process still writes that folder is refused, naming it."""
    out = []
    for name in files:
        if "/" in name or not (name.startswith(".") and name.endswith(LOCK_SUFFIX)):
            out.append(name)
            continue
        inner = final / name[1:-len(LOCK_SUFFIX)]
        owner = live_owner(inner)
        if owner is not None:
            raise OutputPathError(f"{where}: another msr command is writing {display_path(inner)} "
                                  f"inside it: {describe_owner(owner)}; wait for it to finish")
    return out


def interrupted(out: str | Path) -> bool:
    """Whether a writer of ``out`` was killed and left something beside it (a temporary folder,
    an aside to restore, one being removed) that :func:`recover` cleans up."""
    return any(_leftovers(normalized_path(out)).values())


def _mtime(path: Path) -> float:
    return path.stat().st_mtime if path.exists() else 0.0


def _leftovers(target: Path) -> dict[str, list[Path]]:
    prefix = f".{target.name}.msr-"
    found: dict[str, list[Path]] = {"new": [], "old": [], "trash": []}
    try:
        entries = list(target.parent.iterdir())
    except OSError:
        return found
    for entry in entries:
        if entry.name.startswith(prefix):
            stage, _, tail = entry.name[len(prefix):].partition("-")
            # only what a killed writer left: named exactly as msr names it, its process gone (a
            # folder of the user's under a name like it is never touched)
            if stage in found and killed_writers_temporary(tail) and not entry.is_symlink():
                found[stage].append(entry)
    return found


def remove_tree(path: Path) -> None:
    """Remove a folder (or file, or link) and everything under it; a missing one is fine."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        with contextlib.suppress(FileNotFoundError):
            path.unlink()


def _recover_locked(target: Path, final: Path) -> list[str]:
    """Clean up after processes killed while writing ``target`` (the caller holds its lock)."""
    notes: list[str] = []
    shown = display_path(final)
    found = _leftovers(target)
    olds = sorted(found["old"], key=_mtime)
    if olds and not target.exists():
        restored = olds.pop()
        os.rename(restored, target)
        notes.append(f"{shown}: restored the previous result from {restored.name} (a replacement "
                     "was killed between its two renames)")
    for leftover in [*olds, *found["new"], *found["trash"]]:
        remove_tree(leftover)
        if leftover.exists():  # e.g. an immutable or read-only file in it
            notes.append(f"{shown}: could not remove {leftover.name}, left beside it by an earlier "
                         f"run (killed, or its old result could not be deleted: "
                         f"{_why_not_removed(leftover)}); remove it by hand")
        elif leftover in found["trash"]:
            notes.append(f"{shown}: removed {leftover.name}, an earlier result that an earlier run "
                         "replaced but could not delete (killed while deleting it, or a file in "
                         "it could not be removed then)")
        else:
            notes.append(f"{shown}: removed {leftover.name}, left by a run that was killed")
    return notes


def recover(out: str | Path, *, option: str = "--out") -> list[str]:
    """Finish the recovery of ``out`` after a killed writer (see the module docstring), under its
    lock; returns what was done (empty: nothing to do). Raises
    :class:`~elastica_magnetic.locks.FolderLockedError` when a live process is writing ``out``."""
    final = normalized_path(out)
    target = swap_target(final, option)
    with FolderLock(target, option=option) as lock:
        return lock.notes + _recover_locked(target, final)


def fsync_tree(folder: Path) -> None:
    """Flush every file and folder under ``folder`` to disk (best effort where unsupported)."""
    for root, _dirs, names in os.walk(folder):
        for name in names:
            path = os.path.join(root, name)
            if os.path.islink(path):
                continue
            with contextlib.suppress(OSError):
                fd = os.open(path, os.O_RDONLY)
                try:
                    os.fsync(fd)
                finally:
                    os.close(fd)
        _fsync_dir(Path(root))


def _fsync_dir(folder: Path) -> None:
    with contextlib.suppress(OSError, AttributeError):
        fd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def _sibling(target: Path, stage: str) -> Path:
    return target.with_name(f".{target.name}.msr-{stage}-{name_tag(host_name())}-{os.getpid()}-"
                            f"{secrets.token_hex(3)}")


def _swap(staging: Path, target: Path) -> None:
    """Put ``staging`` at ``target`` (two renames when ``target`` exists), then drop the old."""
    if not target.exists():
        os.rename(staging, target)
        _fsync_dir(target.parent)
        return
    aside = _sibling(target, "old")
    os.rename(target, aside)
    try:
        os.rename(staging, target)
    except BaseException:
        os.rename(aside, target)
        raise
    _fsync_dir(target.parent)
    trash = _sibling(target, "trash")
    try:
        os.rename(aside, trash)
    except OSError:  # pragma: no cover - the next run removes a leftover aside anyway
        trash = aside
    remove_tree(trash)
    if trash.exists():  # the new result is in place; say what stayed, and why
        import warnings

        warnings.warn(f"{display_path(target)}: the new result is in place, but the earlier one, "
                      f"renamed {trash.name} beside it, could not be deleted "
                      f"({_why_not_removed(trash)}); remove it by hand (the next run on "
                      f"{display_path(target)} tries again)", LeftoverWarning, stacklevel=2)


def _why_not_removed(path: Path) -> str:
    """The error that keeps ``path`` (a folder) from being removed, for a message."""
    for root, dirs, files in os.walk(path):
        for name in [*files, *dirs]:
            try:
                os.lstat(os.path.join(root, name))
                if name in files:
                    os.unlink(os.path.join(root, name))
            except OSError as exc:
                return f"{os.path.relpath(os.path.join(root, name), path.parent)}: {exc.strerror}"
    return "unknown reason"


@dataclass
class ResultFolder:
    """A result folder being written (see :func:`result_folder`).

    ``path``: the temporary folder to write into; ``final``: the folder as the caller named it
    (where the result will be); ``replaced``: the marker of the result this one replaces
    (``None``: none); ``notes``: recoveries done on entry (a stale lock taken over, leftovers
    removed, an old result restored); ``info``: extra JSON-able data stored in the marker (the
    caller may add to it until the block ends).
    """

    final: Path
    path: Path
    kind: str
    subject: str | None
    replaced: dict[str, Any] | None
    notes: list[str] = field(default_factory=list)
    info: dict[str, Any] = field(default_factory=dict)

    def final_path(self, path: str | Path) -> Path:
        """Where ``path`` (under :attr:`path`) will be once the result is in place; other paths
        are returned unchanged."""
        path = Path(path)
        try:
            return self.final / path.relative_to(self.path)
        except ValueError:
            return path


@contextlib.contextmanager
def result_folder(
    out: str | Path,
    *,
    kind: str,
    subject: str | None = None,
    force: bool = False,
    option: str = "--out",
    known_files: Iterable[str] = (),
    info: dict[str, Any] | None = None,
    force_option: str = "--force",
    recognizes: Callable[[Path], bool] | None = None,
) -> Iterator[ResultFolder]:
    """Write a result folder whole or not at all: ``with result_folder(out, kind=...) as r:``
    write into ``r.path``; on a normal exit the new folder replaces ``out`` (see the module
    docstring for the checks, the lock, signals and crash recovery).

    ``kind`` names the command (``"simulate"``), ``subject`` what the result is about
    (``"robot yao2023-m1"``, ``"case m1-4mT"``; ``None``: not checked), ``force`` allows replacing
    a result of the same kind and subject, ``option`` is the command-line option named in
    messages, ``known_files`` the relative paths the command writes, ``recognizes`` (as in
    :func:`check_result_folder`) a result of the command from before markers, ``info`` extra data
    for the marker. Raises :class:`OutputPathError`,
    :class:`ResultExistsError` or :class:`~elastica_magnetic.locks.FolderLockedError` before the block runs.
    """
    final = normalized_path(out)
    shown = display_path(final)
    known = tuple(known_files)
    check_output_path(final, option, subject)
    target = swap_target(final, option)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputPathError(f"{option} {shown}: cannot create {display_path(target.parent)}: "
                              f"{exc.strerror or exc}") from None
    try:
        with signals_as_exceptions(), FolderLock(target, option=option) as lock:
            notes = (_recovered_notes.pop(str(target), []) + lock.notes
                     + _recover_locked(target, final))
            try:
                replaced = _check_result_folder(final, kind, subject, force, option, known,
                                                force_option, recognizes)
            except OutputPathError as exc:
                for note in notes:  # the command line prints them before the error
                    exc.add_note(note)
                raise
            checked = _tree_state(target)  # what the swap may replace: nothing else
            staging = _sibling(target, "new")
            try:
                os.mkdir(staging)  # the umask's permissions, as a folder made by the user
            except OSError as exc:
                raise OutputPathError(f"{option} {shown}: cannot write in {display_path(target.parent)}: "
                                      f"{exc.strerror or exc}") from None
            result = ResultFolder(final, staging, kind, subject, replaced, notes, dict(info or {}))
            swapped = False
            with building(staging):
                try:
                    yield result
                    _write_marker(result)
                    fsync_tree(staging)
                    with signals_held():
                        _check_unchanged(target, checked, staging, option, shown)
                        _swap(staging, target)
                        swapped = True
                except BaseException as exc:
                    remove_tree(staging)
                    if not swapped and not inside_building(target):
                        _aborted.append(Path(shown))
                    if isinstance(exc, OutputPathError):  # name the files where the user will look
                        text = str(exc).replace(str(staging), shown)
                        raise type(exc)(f"{text}; {shown} is left as it was") from exc
                    if isinstance(exc, OSError):
                        raise OutputPathError(f"{option} {shown}: cannot write the result: "
                                              f"{exc.strerror or exc}; {shown} is left as it was") from exc
                    raise
    finally:
        release_claim(target)  # the pre-check's hold (the lock itself goes with this block)


def _tree_state(folder: Path) -> dict[str, tuple[int, int]] | None:
    """What ``folder`` holds: every entry (relative path -> size and modification time in ns,
    folders with size -1); ``None`` when it does not exist."""
    if not os.path.lexists(folder):
        return None
    state: dict[str, tuple[int, int]] = {}
    for root, dirs, names in os.walk(folder):
        base = Path(root).relative_to(folder)
        for name in [*dirs, *names]:
            info = os.lstat(os.path.join(root, name))
            state[(base / name).as_posix()] = (-1 if name in dirs else info.st_size, info.st_mtime_ns)
    return state


def _check_unchanged(target: Path, checked: dict[str, tuple[int, int]] | None, staging: Path,
                     option: str, shown: str) -> None:
    """Refuse the swap when ``target`` changed since it was checked (a file the user put there,
    another command's result written inside it): nothing there is replaced, and the new result
    is kept beside it, under a name of its own, named in the error."""
    now = _tree_state(target)
    if now == checked:
        return
    before, after = checked or {}, now or {}
    changed = sorted(p for p in after if before.get(p) != after[p]) + sorted(
        p for p in before if p not in after)
    kept = target.with_name(f"{target.name}-new-{time.strftime('%Y%m%dT%H%M%S')}")
    while os.path.lexists(kept):
        kept = kept.with_name(kept.name + "-1")
    os.rename(staging, kept)
    what = f"new or changed: {short_list(changed)}" if changed else "it appeared"
    raise OutputPathError(f"{option} {shown}: changed while the command ran ({what}); it was not "
                          f"replaced: the new result is in {display_path(kept)}")


def _write_marker(result: ResultFolder) -> None:
    write_marker(result.path, result.kind, result.subject, result.info)
