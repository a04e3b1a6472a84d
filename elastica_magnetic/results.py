"""Result folders replaced whole or not at all, and folders locked while a process writes them.

A command that writes a folder of results (``msr simulate --out X``) never writes into ``X``
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
- **One writer.** While the block runs, ``X`` is locked (:class:`FolderLock`, the lock file
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

This recovery runs at the start of the next :func:`result_folder` (or :func:`recover`) on the
same ``X``, under its lock, so a leftover is never one another live process is still writing;
what was done is in :attr:`ResultFolder.notes` (and returned by :func:`recover`). Files are
flushed to disk (``fsync``) before the swap.

**Folders written in place** (a training seed's folder, appended to for hours and resumed later)
are not swapped but locked: ``with FolderLock(seed_dir, option="--out"):``. The lock file names the
process (pid, host, command, start time). It is held with ``flock`` where the system has it, so a
process that dies (even by SIGKILL) releases it: the next process takes the lock over and
:attr:`FolderLock.notes` says whose stale lock it was. A lock naming another host is never taken
over automatically (whether that process still runs cannot be checked from here); the message
says which file to remove. Checkpoints inside such a folder are single files: write them with
:func:`elastica_magnetic.io.atomic_save`, which keeps the previous one until the new one is
complete.

Commands adopting this: enter :func:`result_folder` before the long work (the refusal and the
lock come first), write every file under :attr:`ResultFolder.path`, print paths mapped with
:meth:`ResultFolder.final_path`, add ``--force`` to the parser and pass ``force=args.force``.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import secrets
import shutil
import signal
import socket
import sys
import threading
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .io import OutputPathError

try:  # POSIX: the kernel releases the lock of a process that dies
    import fcntl
except ImportError:  # pragma: no cover - Windows: O_EXCL and a pid check instead
    fcntl = None  # type: ignore[assignment]

__all__ = [
    "MARKER",
    "FolderLock",
    "FolderLockedError",
    "Interrupted",
    "ResultExistsError",
    "ResultFolder",
    "aborted_results",
    "check_result_folder",
    "lock_path",
    "read_lock",
    "read_marker",
    "recover",
    "result_folder",
]

#: The marker file of a result folder (JSON: kind, subject, command, time, host, files).
MARKER = ".msr-result.json"
MARKER_FORMAT = 1
_LOCK_SUFFIX = ".msr-lock"
#: Folders that hold more files than this are not listed in full (they are not a result).
_MAX_LISTED = 10_000


class ResultExistsError(OutputPathError):
    """An output folder that holds something the command will not replace (another command's or
    another robot's result, files it did not write, or its own result without ``force``)."""


class FolderLockedError(OutputPathError):
    """A folder another process is writing; the message names that process."""


class Interrupted(KeyboardInterrupt):
    """SIGTERM or SIGHUP received while a result folder was being written (``signum``)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def _host() -> str:
    return socket.gethostname() or "localhost"


def _tag(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_-]", "_", text)[:40]


def _now() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())


def _command_line() -> str:
    argv = list(sys.argv) or ["python"]
    argv[0] = Path(argv[0]).name
    return " ".join(argv)


def _pid_alive(pid: int) -> bool:
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True  # exists (another user's) or cannot tell: assume alive
    return True


# -- locks ------------------------------------------------------------------------------------------


def lock_path(folder: str | Path) -> Path:
    """The lock file of ``folder``: ``.NAME.msr-lock`` beside it."""
    folder = Path(folder)
    return folder.parent / f".{folder.name}{_LOCK_SUFFIX}"


def read_lock(folder: str | Path) -> dict[str, Any] | None:
    """What the lock file of ``folder`` says (pid, host, command, started_utc), or ``None`` when
    there is none. A lock file present does not mean its process still runs (see
    :class:`FolderLock`)."""
    try:
        text = lock_path(folder).read_text(encoding="utf-8")
    except (FileNotFoundError, NotADirectoryError):
        return None
    except OSError:
        return {}
    try:
        data = json.loads(text)
    except ValueError:
        return {}
    return data if isinstance(data, dict) else {}


def _describe_owner(owner: dict[str, Any] | None) -> str:
    if not owner:
        return "another process (it is still writing its details)"
    return (f"pid {owner.get('pid', '?')} on {owner.get('host', '?')} "
            f"(`{owner.get('command', '?')}`, since {owner.get('started_utc', '?')})")


class FolderLock:
    """Exclusive right to write ``folder``, held by this process until :meth:`release`.

    ``with FolderLock(folder, option="--out"):`` creates the lock file ``.NAME.msr-lock`` beside
    ``folder`` (its parent is created) naming this process (pid, host, command, UTC start time).
    A second process is refused with :class:`FolderLockedError` naming the owner. A lock left by a
    process that died on this host is taken over and described in :attr:`notes`; one naming
    another host is refused (remove the file when that process is known to be gone).
    """

    def __init__(self, folder: str | Path, *, option: str = "--out") -> None:
        self.folder = Path(folder)
        self.path = lock_path(self.folder)
        self.option = option
        self.notes: list[str] = []
        self._fd: int | None = None

    def _refuse(self, owner: dict[str, Any] | None, why: str = "") -> FolderLockedError:
        return FolderLockedError(
            f"{self.option} {self.folder}: being written by {_describe_owner(owner)}{why}; wait "
            f"for it to finish or choose another {self.option}"
        )

    def _content(self) -> bytes:
        return (json.dumps({"pid": os.getpid(), "host": _host(), "command": _command_line(),
                            "started_utc": _now(), "folder": str(self.folder)}) + "\n").encode()

    def _stale(self, previous: dict[str, Any] | None, alive_unknown: bool) -> None:
        """Take over ``previous`` (a lock file whose process is gone) or refuse."""
        if not previous:
            return
        if previous.get("host") != _host():
            raise self._refuse(previous, f" (another host: whether it still runs cannot be checked "
                                         f"from here; if it does not, remove {self.path})")
        pid = previous.get("pid")
        if alive_unknown and isinstance(pid, int) and _pid_alive(pid):
            raise self._refuse(previous)
        self.notes.append(f"{self.folder}: took over the stale lock of {_describe_owner(previous)}, "
                          "which is no longer running")

    def acquire(self) -> FolderLock:
        """Take the lock or raise :class:`FolderLockedError`; returns ``self``."""
        if self._fd is not None:
            raise RuntimeError(f"{self.path}: already held by this FolderLock")
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._fd = self._acquire_flock() if fcntl is not None else self._acquire_exclusive()
        except OSError as exc:
            if isinstance(exc, OutputPathError):
                raise
            raise OutputPathError(f"{self.option} {self.folder}: cannot create the lock file "
                                  f"{self.path}: {exc.strerror or exc}") from None
        return self

    def _acquire_flock(self) -> int:
        for _ in range(100):
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                raise self._refuse(read_lock(self.folder)) from None
            except BaseException:
                os.close(fd)
                raise
            try:
                same = os.path.samestat(os.fstat(fd), os.stat(self.path))
            except FileNotFoundError:
                same = False
            if not same:  # the owner released (unlinked) it between our open and flock: retry
                os.close(fd)
                continue
            try:
                previous = read_lock(self.folder)
                # flock is held: whoever wrote ``previous`` on this host is gone.
                self._stale(previous, alive_unknown=False)
                content = self._content()
                os.ftruncate(fd, 0)
                os.pwrite(fd, content, 0)
            except BaseException:
                os.close(fd)
                raise
            return fd
        raise self._refuse(read_lock(self.folder))

    def _acquire_exclusive(self) -> int:  # pragma: no cover - exercised on systems without fcntl
        for _ in range(100):
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o644)
            except FileExistsError:
                previous = read_lock(self.folder)
                self._stale(previous, alive_unknown=True)
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(self.path)
                continue
            os.write(fd, self._content())
            return fd
        raise self._refuse(read_lock(self.folder))

    def release(self) -> None:
        """Remove the lock file and let go (a no-op when not held)."""
        if self._fd is None:
            return
        fd, self._fd = self._fd, None
        with contextlib.suppress(OSError):
            os.unlink(self.path)
        os.close(fd)

    @property
    def held(self) -> bool:
        return self._fd is not None

    def __enter__(self) -> FolderLock:
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()


# -- signals ---------------------------------------------------------------------------------------

_SIGNALS = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, n))
_signal_state: dict[str, Any] = {"depth": 0, "previous": {}, "deferring": 0, "pending": None}
_aborted: list[Path] = []


def _raise_for(signum: int) -> None:
    if signum == signal.SIGINT:
        raise KeyboardInterrupt
    raise Interrupted(signum)


def _handler(signum: int, frame: object) -> None:
    if _signal_state["deferring"]:
        _signal_state["pending"] = _signal_state["pending"] or signum
        return
    _raise_for(signum)


@contextlib.contextmanager
def _signals_raise() -> Iterator[None]:
    """SIGINT, SIGTERM and SIGHUP raise in the main thread while this is entered (where their
    handler was Python's default), so ``finally`` blocks run; nested uses share one installation."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    state = _signal_state
    if state["depth"] == 0:
        for signum in _SIGNALS:
            current = signal.getsignal(signum)
            if current in (signal.SIG_DFL, signal.default_int_handler):
                state["previous"][signum] = current
                signal.signal(signum, _handler)
    state["depth"] += 1
    try:
        yield
    finally:
        state["depth"] -= 1
        if state["depth"] == 0:
            for signum, previous in state["previous"].items():
                signal.signal(signum, previous)
            state["previous"] = {}


@contextlib.contextmanager
def _signals_deferred() -> Iterator[None]:
    """Hold SIGINT/SIGTERM/SIGHUP back (when our handler is installed) until the block is over."""
    _signal_state["deferring"] += 1
    try:
        yield
    finally:
        _signal_state["deferring"] -= 1
        pending = _signal_state["pending"]
        if not _signal_state["deferring"] and pending is not None:
            _signal_state["pending"] = None
            _raise_for(pending)


def aborted_results() -> list[Path]:
    """The result folders (as the caller named them) whose writing an exception or a signal
    stopped in this process, each left as it was; oldest first."""
    return list(_aborted)


# -- result folders --------------------------------------------------------------------------------


def read_marker(folder: str | Path) -> dict[str, Any] | None:
    """The marker of a result folder (kind, subject, command, written_utc, host, files), or
    ``None`` when ``folder`` has none (or it is unreadable)."""
    try:
        data = json.loads((Path(folder) / MARKER).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and isinstance(data.get("kind"), str) else None


def _files(folder: Path) -> list[str] | None:
    """Every file (and link) under ``folder``, relative POSIX paths, sorted; ``None`` past
    :data:`_MAX_LISTED`."""
    found: list[str] = []
    for root, dirs, names in os.walk(folder):
        base = Path(root).relative_to(folder)
        links = [d for d in dirs if os.path.islink(os.path.join(root, d))]
        for name in [*names, *links]:
            found.append((base / name).as_posix())
            if len(found) > _MAX_LISTED:
                return None
    return sorted(found)


def _what(marker: dict[str, Any]) -> str:
    subject = f" for {marker['subject']}" if marker.get("subject") else ""
    written = f", written {marker['written_utc']}" if marker.get("written_utc") else ""
    return f"a result of `msr {marker['kind']}`{subject}{written}"


def _list(names: list[str]) -> str:
    return ", ".join(names[:5]) + (f" and {len(names) - 5} more" if len(names) > 5 else "")


def check_result_folder(
    out: str | Path,
    *,
    kind: str,
    subject: str | None = None,
    force: bool = False,
    option: str = "--out",
    known_files: Iterable[str] = (),
    force_option: str = "--force",
) -> dict[str, Any] | None:
    """Check that ``out`` may receive a result of ``kind`` (the command's name, e.g.
    ``"simulate"``) for ``subject`` (e.g. ``"robot yao2023-m1"``; ``None``: any).

    Returns ``None`` when ``out`` is absent or an empty folder, else the marker of the result
    that will be replaced (``{"kind": kind, "legacy": True}`` for a folder written before markers,
    recognised by ``known_files``: relative paths the command writes). Raises
    :class:`OutputPathError` (a file, under a file, a mount point, not writable) or
    :class:`ResultExistsError` (another kind or subject, files the command did not write, or
    the same result without ``force``), naming ``option`` and the folder. Nothing is written.
    """
    final = Path(out)
    where = f"{option} {final}"
    _check_path(final, option)
    if not final.exists():
        return None
    if os.path.ismount(final):
        raise OutputPathError(f"{where}: is a mount point; a result folder is replaced by renaming "
                              "it, so give a folder inside it")
    if not os.access(final, os.W_OK | os.X_OK):
        raise OutputPathError(f"{where}: cannot write in {final}: Permission denied")
    listed = _files(final)
    if listed is None:
        raise ResultExistsError(f"{where}: holds more than {_MAX_LISTED} files, not a result of "
                                f"`msr {kind}`; choose a new or empty folder")
    marker = read_marker(final)
    files = [f for f in listed if f != MARKER]
    known = set(known_files)
    if marker is None:
        if not files and MARKER not in listed:
            return None
        unknown = [f for f in files if f not in known]
        if unknown or not files:
            raise ResultExistsError(f"{where}: holds files that `msr {kind}` does not write "
                                    f"({_list(unknown or [MARKER])}); choose a new or empty folder")
        marker = {"kind": kind, "subject": None, "legacy": True}
    else:
        if marker["kind"] != kind:
            raise ResultExistsError(
                f"{where}: holds {_what(marker)}, not of `msr {kind}`; choose another {option} "
                f"({force_option} replaces only a result of the same command"
                f"{' and subject' if subject else ''})")
        if subject is not None and marker.get("subject") not in (None, subject):
            raise ResultExistsError(
                f"{where}: holds {_what(marker)}, not for {subject}; choose another {option} "
                f"({force_option} replaces only a result for the same subject)")
        written = set(marker.get("files") or ()) | known
        unknown = [f for f in files if f not in written]
        if unknown:
            raise ResultExistsError(
                f"{where}: holds {_what(marker)} and files it did not write ({_list(unknown)}); "
                f"move them away or choose another {option} ({force_option} replaces only what "
                "msr wrote)")
    if not force:
        raise ResultExistsError(f"{where}: already holds {_what(marker)}; pass {force_option} to "
                                f"replace it, or choose another {option}")
    return marker


def _check_path(final: Path, option: str) -> None:
    for parent in (final, *final.parents):
        if parent.exists() and not parent.is_dir():
            raise OutputPathError(f"{option} {final}: {parent} is a file, not a folder")


def _leftovers(target: Path) -> dict[str, list[Path]]:
    prefix = f".{target.name}.msr-"
    found: dict[str, list[Path]] = {"new": [], "old": [], "trash": []}
    try:
        entries = list(target.parent.iterdir())
    except OSError:
        return found
    for entry in entries:
        if entry.name.startswith(prefix):
            stage = entry.name[len(prefix):].split("-", 1)[0]
            if stage in found:
                found[stage].append(entry)
    return found


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        with contextlib.suppress(FileNotFoundError):
            path.unlink()


def _recover_locked(target: Path, shown: Path) -> list[str]:
    """Clean up after processes killed while writing ``target`` (the caller holds its lock)."""
    notes: list[str] = []
    found = _leftovers(target)
    olds = sorted(found["old"], key=lambda p: p.stat().st_mtime if p.exists() else 0.0)
    if olds and not target.exists():
        restored = olds.pop()
        os.rename(restored, target)
        notes.append(f"{shown}: restored the previous result from {restored.name} (a replacement "
                     "was killed between its two renames)")
    for leftover in [*olds, *found["new"], *found["trash"]]:
        _remove(leftover)
        notes.append(f"{shown}: removed {leftover.name}, left by a run that was killed")
    return notes


def recover(out: str | Path, *, option: str = "--out") -> list[str]:
    """Finish the recovery of ``out`` after a killed writer (see the module docstring), under its
    lock; returns what was done (empty: nothing to do). Raises :class:`FolderLockedError` when a
    live process is writing ``out``."""
    final = Path(out)
    target = Path(os.path.realpath(final)) if final.is_symlink() else final
    with FolderLock(target, option=option) as lock:
        return lock.notes + _recover_locked(target, final)


def _fsync_tree(folder: Path) -> None:
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
    return target.with_name(f".{target.name}.msr-{stage}-{_tag(_host())}-{os.getpid()}-"
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
    _remove(trash)


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
) -> Iterator[ResultFolder]:
    """Write a result folder whole or not at all: ``with result_folder(out, kind=...) as r:``
    write into ``r.path``; on a normal exit the new folder replaces ``out`` (see the module
    docstring for the checks, the lock, signals and crash recovery).

    ``kind`` names the command (``"simulate"``), ``subject`` what the result is about
    (``"robot yao2023-m1"``, ``"case m1-4mT"``; ``None``: not checked), ``force`` allows replacing
    a result of the same kind and subject, ``option`` is the command-line option named in
    messages, ``known_files`` the relative paths the command writes (recognises results written
    before markers), ``info`` extra data for the marker. Raises :class:`OutputPathError`,
    :class:`ResultExistsError` or :class:`FolderLockedError` before the block runs.
    """
    final = Path(out)
    known = tuple(known_files)
    _check_path(final, option)
    target = Path(os.path.realpath(final)) if final.is_symlink() else final
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputPathError(f"{option} {final}: cannot create {target.parent}: "
                              f"{exc.strerror or exc}") from None
    with _signals_raise(), FolderLock(target, option=option) as lock:
        notes = lock.notes + _recover_locked(target, final)
        try:
            replaced = check_result_folder(final, kind=kind, subject=subject, force=force,
                                           option=option, known_files=known,
                                           force_option=force_option)
        except OutputPathError as exc:
            for note in notes:  # the command line prints them before the error
                exc.add_note(note)
            raise
        staging = _sibling(target, "new")
        try:
            os.mkdir(staging)  # the umask's permissions, as a folder made by the user
        except OSError as exc:
            raise OutputPathError(f"{option} {final}: cannot write in {target.parent}: "
                                  f"{exc.strerror or exc}") from None
        result = ResultFolder(final, staging, kind, subject, replaced, notes, dict(info or {}))
        swapped = False
        try:
            yield result
            _write_marker(result)
            _fsync_tree(staging)
            with _signals_deferred():
                _swap(staging, target)
                swapped = True
        except BaseException as exc:
            _remove(staging)
            if not swapped:
                _aborted.append(final)
            if isinstance(exc, OutputPathError):  # name the files where the user will look
                text = str(exc).replace(str(staging), str(final))
                raise type(exc)(f"{text}; {final} is left as it was") from exc
            if isinstance(exc, OSError):
                raise OutputPathError(f"{option} {final}: cannot write the result: "
                                      f"{exc.strerror or exc}; {final} is left as it was") from exc
            raise


def _write_marker(result: ResultFolder) -> None:
    files = _files(result.path) or []
    data = {"format": MARKER_FORMAT, "kind": result.kind, "subject": result.subject,
            "command": _command_line(), "written_utc": _now(), "host": _host(),
            "files": [f for f in files if f != MARKER], **result.info}
    (result.path / MARKER).write_text(json.dumps(data, indent=2, default=str) + "\n",
                                      encoding="utf-8")
