"""Folders locked while a process writes them: one writer at a time, named to the others.

``with FolderLock(folder, option="--out"):`` creates the lock file ``.NAME.msr-lock`` beside
``folder`` naming this process (pid, host, command line, UTC start time). Another process that
wants the same folder gets :class:`FolderLockedError` naming the owner. The lock is held with
``flock`` where the system has it, so a process that dies (even by SIGKILL) releases it: the next
process takes it over and :attr:`FolderLock.notes` says whose stale lock it was. A lock file
naming another host is never taken over automatically (whether that process still runs cannot be
checked from here); the message says which file to remove. Without ``flock`` (Windows) the file is
created exclusively and a lock of a dead process on this host is recognised by its pid.

Result folders (:func:`elastica_magnetic.results.result_folder`) take this lock themselves. A
folder written in place for a long time (a training seed's folder, resumed later) holds it for
the whole run::

    from elastica_magnetic.locks import FolderLock

    with FolderLock(seed_dir, option="--out") as lock:
        for note in lock.notes:
            print("note:", note)
        ...  # train; write checkpoints with elastica_magnetic.io.atomic_save
"""

from __future__ import annotations

import atexit
import contextlib
import errno
import json
import os
import re
import socket
import stat
import sys
import time
from pathlib import Path
from typing import Any

from .io import OutputPathError, display_path, normalized_path

try:  # POSIX: the kernel releases the lock of a process that dies
    import fcntl
except ImportError:  # pragma: no cover - Windows: O_EXCL and a pid check instead
    fcntl = None  # type: ignore[assignment]

__all__ = ["LOCK_SUFFIX", "FolderLock", "FolderLockedError", "check_lock_name", "claim", "command_line",
           "describe_owner", "held_here",
           "host_name", "killed_writers_temporary", "live_owner", "lock_path", "name_tag", "read_lock",
           "release_claim", "release_claims", "utc_now"]

#: The end of a lock file's name: ``.NAME.msr-lock`` beside the folder ``NAME`` it locks.
LOCK_SUFFIX = ".msr-lock"

#: Open flag that refuses a symbolic link at the lock file's name (a link planted or left there
#: would make msr overwrite the file it points to); 0 where the system has none.
_NO_FOLLOW = getattr(os, "O_NOFOLLOW", 0)

#: Open flag that keeps opening a FIFO (named pipe) found at the lock file's name from waiting
#: for a writer forever; 0 where the system has none.
_NO_BLOCK = getattr(os, "O_NONBLOCK", 0)


def _kind_of(mode: int) -> str | None:
    """What a file of ``mode`` is when it is not a regular file (for messages), else ``None``."""
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISLNK(mode):
        return "a symbolic link"
    return "not a regular file"


class FolderLockedError(OutputPathError):
    """A folder another process is writing; the message names that process."""


def host_name() -> str:
    """This machine's host name (as lock files and result markers record it)."""
    return socket.gethostname() or "localhost"


def name_tag(text: str) -> str:
    """``text`` reduced to characters safe in a file name (at most 40)."""
    return re.sub(r"[^A-Za-z0-9_-]", "_", text)[:40]


def utc_now() -> str:
    """The time now, UTC, ISO 8601 to the second."""
    return time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())


def command_line() -> str:
    """This process's command line, the program's name without its folder."""
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
    return not _zombie(pid)


def _zombie(pid: int) -> bool:
    """Whether ``pid`` is a process that has ended and not been reaped (state ``Z`` in Linux's
    ``/proc/PID/stat``): a writer killed with SIGKILL under a parent that does not reap it (some
    containers' PID 1) still answers ``kill(pid, 0)``, but writes nothing any more."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False  # not Linux, or gone: kill() above has the say
    return stat[stat.rfind(")") + 2:].startswith("Z")  # after "pid (command) "


#: How the temporaries of a writer are named after their stage: ``HOST-PID-RANDOM`` (host tag as
#: :func:`name_tag` makes it, pid, 6 hexadecimal digits), then an optional suffix.
_TEMPORARY_TAIL = re.compile(r"(?P<host>[A-Za-z0-9_-]{1,40})-(?P<pid>[0-9]+)-[0-9a-f]{6}(?P<suffix>\.[^/]*)?")


def killed_writers_temporary(name_tail: str, suffix: str = "") -> bool:
    """Whether ``name_tail`` (a temporary's name after ``.msr-STAGE-``) is the ``HOST-PID-RANDOM``
    tag a writer gives its temporaries (then ``suffix``), of a process that is no longer running:
    one of this host whose pid is alive, or a name that only looks like one, is not a leftover to
    remove (it may be the user's)."""
    match = _TEMPORARY_TAIL.fullmatch(name_tail)
    if match is None or (match.group("suffix") or "") != suffix:
        return False
    pid = int(match.group("pid"))
    if match.group("host") == name_tag(host_name()):  # this process's own (held by its lock) or gone
        return pid == os.getpid() or not _pid_alive(pid)
    return True  # another host's: the lock, held while recovering, says no writer is there


def lock_path(folder: str | Path) -> Path:
    """The lock file of ``folder``: ``.NAME.msr-lock`` beside it."""
    folder = normalized_path(folder)
    return folder.parent / f".{folder.name}{LOCK_SUFFIX}"


def read_lock(folder: str | Path) -> dict[str, Any] | None:
    """What the lock file of ``folder`` says (pid, host, command, started_utc), or ``None`` when
    there is none. A lock file present does not mean its process still runs (see
    :class:`FolderLock`)."""
    path = lock_path(folder)
    try:
        fd = os.open(path, os.O_RDONLY | _NO_FOLLOW | _NO_BLOCK)
    except (FileNotFoundError, NotADirectoryError):
        return None
    except OSError:
        return {}
    try:  # a FIFO or device at the name is not read (it could wait forever)
        if _kind_of(os.fstat(fd).st_mode) is not None:
            return {}
        with os.fdopen(fd, "rb", closefd=False) as handle:
            text = handle.read().decode("utf-8")
    except (OSError, UnicodeDecodeError):
        return {}
    finally:
        os.close(fd)
    try:
        data = json.loads(text)
    except ValueError:
        return {}
    return data if isinstance(data, dict) else {}


def live_owner(folder: str | Path) -> dict[str, Any] | None:
    """What the lock file of ``folder`` says when its process may still run (this host's live
    pid, or another host's, which cannot be checked), else ``None`` (no lock, or a stale one)."""
    owner = read_lock(folder)
    if owner is None:
        return None
    pid = owner.get("pid")
    if owner.get("host") == host_name() and isinstance(pid, int) and not _pid_alive(pid):
        return None
    return owner


def describe_owner(owner: dict[str, Any] | None) -> str:
    """``pid 123 on host (`msr ...`, since ...)``: a lock's owner, for messages."""
    return _describe_owner(owner)


def _describe_owner(owner: dict[str, Any] | None) -> str:
    if not owner:
        return "another process (it is still writing its details)"
    return (f"pid {owner.get('pid', '?')} on {owner.get('host', '?')} "
            f"(`{owner.get('command', '?')}`, since {owner.get('started_utc', '?')})")


class _Held:
    """A lock file this process holds: its descriptor and how many :class:`FolderLock` share it."""

    def __init__(self, fd: int) -> None:
        self.fd = fd
        self.count = 1
        self.pid = os.getpid()  # a forked child inherits the table, not the right to unlink


#: The lock files this process holds, by path: a second :class:`FolderLock` on the same folder in
#: the same process shares the first one's hold (re-entrant) instead of refusing itself, so a
#: command can take the lock at its pre-check (:func:`claim`) and keep it through its write.
_held: dict[str, _Held] = {}


def held_here(folder: str | Path) -> bool:
    """Whether this process holds ``folder``'s lock (a command writing into a folder of its own,
    as ``msr loop`` writes its steps' results into its folder)."""
    return str(lock_path(folder)) in _held


def check_lock_name(folder: str | Path, option: str = "--out") -> None:
    """Refuse now what sits at ``folder``'s lock file's name when it is not a lock file (a FIFO, a
    folder, a device), as taking the lock later would: for a folder a command locks only at its
    end (a training's case folder, for its summary), so that the refusal comes before the work."""
    FolderLock(folder, option=option)._refuse_odd_file()


class FolderLock:
    """Exclusive right to write ``folder``, held by this process until :meth:`release`.

    ``with FolderLock(folder, option="--out"):`` creates the lock file ``.NAME.msr-lock`` beside
    ``folder`` (its parent is created) naming this process (pid, host, command, UTC start time).
    A second process is refused with :class:`FolderLockedError` naming the owner. A lock left by a
    process that died on this host is taken over and described in :attr:`notes`; one naming
    another host is refused (remove the file when that process is known to be gone). Within one
    process the lock is re-entrant: a second ``FolderLock`` on a folder this process already
    holds shares the hold, and the lock file goes when the last of them is released.
    """

    def __init__(self, folder: str | Path, *, option: str = "--out") -> None:
        self.folder = normalized_path(folder)
        self.path = lock_path(self.folder)
        self.option = option
        self.notes: list[str] = []
        self._fd: int | None = None

    def _refuse(self, owner: dict[str, Any] | None, why: str = "") -> FolderLockedError:
        return FolderLockedError(
            f"{self.option} {display_path(self.folder)}: being written by "
            f"{_describe_owner(owner)}{why}; wait for it to finish or choose another {self.option}"
        )

    def _content(self) -> bytes:
        return (json.dumps({"pid": os.getpid(), "host": host_name(), "command": command_line(),
                            "started_utc": utc_now(), "folder": str(self.folder)}) + "\n").encode()

    def _stale(self, previous: dict[str, Any] | None, alive_unknown: bool) -> None:
        """Take over ``previous`` (a lock file whose process is gone) or refuse."""
        if not previous:
            return
        if previous.get("host") != host_name():
            raise self._refuse(previous, f" (another host: whether it still runs cannot be checked "
                                         f"from here; if it does not, remove {self.path})")
        pid = previous.get("pid")
        if alive_unknown and isinstance(pid, int) and _pid_alive(pid):
            raise self._refuse(previous)
        self.notes.append(f"{display_path(self.folder)}: took over the stale lock of "
                          f"{_describe_owner(previous)}, "
                          "which is no longer running")

    def acquire(self) -> FolderLock:
        """Take the lock or raise :class:`FolderLockedError`; returns ``self``."""
        if self._fd is not None:
            raise RuntimeError(f"{self.path}: already held by this FolderLock")
        shared = _held.get(str(self.path))
        if shared is not None and shared.pid != os.getpid():  # inherited by fork: not ours
            _held.clear()
            _claims.clear()
            shared = None
        if shared is not None:  # this process holds it already
            shared.count += 1
            self._fd = shared.fd
            return self
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._refuse_odd_file()
            self._fd = self._acquire_flock() if fcntl is not None else self._acquire_exclusive()
        except OSError as exc:
            if isinstance(exc, OutputPathError):
                raise
            if exc.errno == errno.ELOOP or self.path.is_symlink():
                raise OutputPathError(
                    f"{self.option} {display_path(self.folder)}: the lock file's name {self.path} is a "
                    f"symbolic link (to {os.readlink(self.path)}), not msr's lock file: msr does not "
                    "follow it (the file it points to is left as it is); remove the link") from None
            raise OutputPathError(f"{self.option} {display_path(self.folder)}: cannot create the lock file "
                                  f"{self.path}: {exc.strerror or exc}") from None
        _held[str(self.path)] = _Held(self._fd)
        return self

    def _refuse_odd_file(self, mode: int | None = None) -> None:
        """Refuse what is at the lock file's name when it is neither absent nor a regular file
        (a FIFO would make opening or reading it wait forever; a device would be written to);
        ``mode`` is that of a file already opened, else the name is looked at (not followed)."""
        if mode is None:
            try:
                mode = os.lstat(self.path).st_mode
            except (FileNotFoundError, NotADirectoryError):
                return
            if stat.S_ISLNK(mode):  # refused by the open (O_NOFOLLOW), naming where it points
                return
        kind = _kind_of(mode)
        if kind is not None:
            raise OutputPathError(
                f"{self.option} {display_path(self.folder)}: the lock file's name {self.path} is "
                f"{kind}, not msr's lock file: msr does not open it; remove it")

    def _acquire_flock(self) -> int:
        for _ in range(100):
            created = not os.path.lexists(self.path)  # a lock file made here goes again on a failure
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT | _NO_FOLLOW | _NO_BLOCK, 0o644)
            try:
                self._refuse_odd_file(os.fstat(fd).st_mode)
            except BaseException:
                os.close(fd)
                raise
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
            if os.fstat(fd).st_nlink > 1:  # a hard link to someone's file: writing would change it
                os.close(fd)
                raise OutputPathError(
                    f"{self.option} {display_path(self.folder)}: the lock file {self.path} has other "
                    "names (hard links): it is another file's, not msr's lock file; msr leaves it as it "
                    "is; remove that name")
            try:
                previous = read_lock(self.folder)
                # flock is held: whoever wrote ``previous`` on this host is gone.
                self._stale(previous, alive_unknown=False)
                if not previous and os.fstat(fd).st_size > 0:
                    self.notes.append(f"{display_path(self.folder)}: took over the lock file "
                                      f"{self.path.name}, whose content is not an msr lock's "
                                      "(cut short by a crash, or written by something else)")
                content = self._content()
                os.ftruncate(fd, 0)
                os.pwrite(fd, content, 0)
            except BaseException:
                if created:  # e.g. a full disk: no empty lock file is left beside the user's files
                    with contextlib.suppress(OSError):
                        os.unlink(self.path)
                os.close(fd)
                raise
            return fd
        raise self._refuse(read_lock(self.folder))

    def _acquire_exclusive(self) -> int:  # pragma: no cover - exercised on systems without fcntl
        for _ in range(100):
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_EXCL | _NO_FOLLOW, 0o644)
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
        shared = _held.get(str(self.path))
        if shared is not None and shared.pid != os.getpid():  # inherited by fork: the parent's
            return
        if shared is not None and shared.count > 1:  # another FolderLock of this process holds on
            shared.count -= 1
            return
        _held.pop(str(self.path), None)
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


#: Locks taken by :func:`claim` (a command's pre-check), by lock file, until the write is done.
_claims: dict[str, FolderLock] = {}


def claim(folder: str | Path, *, option: str = "--out") -> FolderLock:
    """Take the lock of ``folder`` for the rest of this command: its pre-check calls this before
    any long work, so a second process writing the same folder is refused at once (naming this
    one) instead of after its own work. Held until :func:`release_claim` (the write is done) or
    :func:`release_claims` (the command ends; also at interpreter exit). Claiming a folder this
    process has claimed already is a no-op. Raises :class:`FolderLockedError`."""
    lock = FolderLock(folder, option=option)
    key = str(lock.path)
    if key not in _claims:
        _claims[key] = lock.acquire()
    return _claims[key]


def release_claim(folder: str | Path) -> None:
    """Let go of the claim on ``folder`` (a no-op when there is none)."""
    lock = _claims.pop(str(lock_path(folder)), None)
    if lock is not None:
        lock.release()


def release_claims() -> None:
    """Let go of every claim of this process (the command line calls this when a command ends)."""
    while _claims:
        _claims.popitem()[1].release()


atexit.register(release_claims)
