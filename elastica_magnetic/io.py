"""Output locations and atomic writes of result files.

Every result file is written under a temporary name in its own folder, then renamed over the
target (``os.replace``), so a failure (full disk, killed process) never leaves half a file and
never destroys what was there. Command-line tools check their output location with
:func:`prepare_output_dir` / :func:`prepare_output_file` before any long work starts.
:func:`byte_order_mark_problem` is the one message for an input document (a spec, a calibration)
saved with a byte-order mark.
"""

from __future__ import annotations

import contextlib
import errno
import json
import math
import os
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any

__all__ = [
    "DamagedFileError",
    "UnverifiedFileWarning",
    "OutputPathError",
    "UTF8_BOM",
    "atomic_save",
    "atomic_write",
    "atomic_write_bytes",
    "atomic_write_text",
    "byte_order_mark_problem",
    "display_path",
    "normalized_path",
    "prepare_output_dir",
    "prepare_output_file",
]


#: What Excel and Notepad put at the start of a file saved as "UTF-8 with BOM" (as decoded text).
UTF8_BOM = "\ufeff"


def byte_order_mark_problem(path: str | os.PathLike[str], text: str) -> str | None:
    """The message for a document whose ``text`` (decoded as UTF-8) starts with a byte-order mark,
    ``None`` otherwise. Documents (TOML specs, JSON calibrations) are refused with it: their
    formats have no byte-order mark and other readers (``tomllib``, ``json``) refuse it too. CSV
    tables skip it instead (``encoding="utf-8-sig"``): there it only hides the first header."""
    if not text.startswith(UTF8_BOM):
        return None
    return (f"{path} starts with a UTF-8 byte-order mark (saved by Excel/Notepad as 'UTF-8 with "
            "BOM'); save it as plain UTF-8")


class OutputPathError(OSError):
    """An output location that cannot be used; the message names the option or file."""

    def __str__(self) -> str:  # OSError's own formatting adds "[Errno ...]" noise
        return str(self.args[0]) if self.args else ""


class UnverifiedFileWarning(UserWarning):
    """A file msr reads whose record of itself (a hash of its settings) is missing, so a hand
    edit of it cannot be told from the original: used, with this warning."""


class DamagedFileError(ValueError):
    """A file the package wrote (or a user keeps) that cannot be read back: the message names it."""


def read_json(path: str | os.PathLike[str], fix: str = "restore it (e.g. from a backup or git)") -> Any:
    """The JSON document in ``path``; a file that is not JSON (cut short by a copy or a kill, edited
    by hand, not UTF-8) is a :class:`DamagedFileError` naming the file, the place and ``fix``."""
    path = Path(path)
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise DamagedFileError(f"{display_path(path)}: not readable as JSON (line {exc.lineno} column "
                               f"{exc.colno}: {exc.msg}): damaged or cut short; {fix}") from None
    except UnicodeDecodeError:
        raise DamagedFileError(f"{display_path(path)}: not readable as JSON (not UTF-8 text): "
                               f"damaged; {fix}") from None


def normalized_path(path: str | os.PathLike[str]) -> Path:
    """The one spelling of a location every check and every write uses: absolute, ``~`` expanded,
    ``.``, ``..``, repeated and trailing separators and symbolic links resolved (``DIR/missing/..``,
    ``./DIR/``, ``DIR`` and a link to ``DIR`` are all ``/abs/DIR``). ``..`` is resolved after the
    links before it, as the operating system does. Command-line options are parsed with it
    (:func:`elastica_magnetic.cli.output_path`), and the result-folder, lock and file-set
    mechanisms apply it again to whatever a library caller gives them."""
    return Path(os.path.realpath(os.path.expanduser(os.fspath(path))))


def missing_folder_hint(path: str | os.PathLike[str]) -> str:
    """For a file that could not be opened: ``" (the folder X does not exist ...)"`` naming the
    first folder of ``path`` as spelled that is missing (``./missing/../spec.toml``: the system
    follows ``..`` after ``missing``, so the file is not found even where ``spec.toml`` exists),
    or ``""`` when every folder exists."""
    parts = Path(os.path.expanduser(os.fspath(path))).parts
    for k in range(1, len(parts)):
        folder = Path(*parts[:k])
        if not folder.is_dir():
            through = ("; a path is followed folder by folder, so '..' after a missing folder does not "
                       "lead back" if ".." in parts[k:] else "")
            return f" (the folder {folder} does not exist{through})"
    return ""


#: Output paths the command line was given with a trailing separator (``DIR/``: a folder meant),
#: normalized; a writer of one file refuses them (:func:`spelled_as_folder`).
_FOLDER_SPELLINGS: set[str] = set()


def remember_folder_spelling(text: str, path: str | os.PathLike[str]) -> None:
    """Note that ``path`` (normalized) was written as ``text``, ending with a separator or not."""
    if text.rstrip().endswith(("/", os.sep)):
        _FOLDER_SPELLINGS.add(os.fspath(path))


def spelled_as_folder(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` was given ending with a separator (a folder meant): as a string here, or
    on the command line (:func:`remember_folder_spelling`)."""
    text = os.fspath(path)
    return text.endswith(("/", os.sep)) or os.fspath(normalized_path(text)) in _FOLDER_SPELLINGS


def canonical_sha256(data: Any) -> str:
    """The SHA-256 of ``data`` as canonical JSON (keys sorted, no spaces, ``str`` for what JSON
    lacks): the fingerprint a record carries of what msr wrote, to refuse hand edits."""
    import hashlib

    text = json.dumps(data, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def output_path_problem(path: str | os.PathLike[str]) -> str | None:
    """Why a normalized output ``path`` (:func:`normalized_path`) can never be written, or ``None``:
    a symbolic link in a loop (still a link once resolved: writing would replace the link) or a
    name longer than the file system allows."""
    path = Path(path)
    for part in (path, *path.parents):
        if os.path.islink(part):
            return (f"{part} is a symbolic link that leads back to itself (a loop); give a folder "
                    "or a file name that is not such a link")
    try:
        longest = os.pathconf(next(p for p in path.parents if p.exists()), "PC_NAME_MAX")
    except (OSError, ValueError, StopIteration):
        longest = 255
    long_names = [part for part in path.parts if len(os.fsencode(part)) > longest]
    if long_names:
        return (f"the name {long_names[0][:40]}... is {len(os.fsencode(long_names[0]))} bytes long; "
                f"the file system allows at most {longest}")
    size = len(os.fsencode(path.name))
    if size > longest - MSR_NAME_ROOM:
        return (f"the name {path.name[:40]}... is {size} bytes long; msr writes beside it under "
                f"longer names of its own (.NAME.msr-new-HOST-PID-..., .NAME.msr-lock), which the "
                f"file system's {longest}-byte limit must hold: give a name of at most "
                f"{longest - MSR_NAME_ROOM} bytes")
    return None


#: Bytes an output's name must leave free under the file system's limit: the temporary, old and
#: lock names msr gives its siblings (``.NAME.msr-trash-HOST-PID-RANDOM``, the host at most 40).
MSR_NAME_ROOM = 70


def display_path(path: str | os.PathLike[str]) -> str:
    """``path`` as a person reads it: relative to the current folder when it lies inside it
    (``out/sim``), else absolute."""
    absolute = normalized_path(path)
    try:
        here = Path(os.path.realpath(os.getcwd()))
    except OSError:  # the current folder was removed
        return str(absolute)
    if absolute == here:
        return "."
    if here in absolute.parents:
        return str(absolute.relative_to(here))
    return str(absolute)


def unwritable_reason(folder: str | os.PathLike[str]) -> str | None:
    """Why no file can be made in the existing ``folder`` (a read-only file system, or the
    folder's permissions), or None where one can. A read-only mount is named as such: to the
    user "Permission denied" there suggests a chmod that cannot help."""
    if os.access(folder, os.W_OK | os.X_OK):
        return None
    with contextlib.suppress(OSError):
        if os.statvfs(folder).f_flag & os.ST_RDONLY:
            return "the file system is mounted read-only"
    try:  # the system's own reason: permissions, or a folder made immutable (chattr +i)
        with tempfile.TemporaryFile(dir=folder):
            pass  # made all the same (root): the permissions' verdict is kept
    except PermissionError as exc:
        if exc.errno == errno.EPERM:
            return ("Operation not permitted (the folder is immutable, chattr +i, or locked by the system: "
                    "not its permissions)")
    except OSError as exc:
        return exc.strerror or str(exc)
    return "Permission denied (the folder's permissions do not let you write in it)"


def _temporary_name(path: Path) -> Path:
    # Same folder (os.replace stays atomic) and same suffix (savefig and np.savez use it).
    return path.with_name(f".{path.stem}.tmp{os.getpid()}{path.suffix}")


def atomic_save(path: str | Path, write: Callable[[Path], Any]) -> Path:
    """Call ``write(temporary_path)``, then rename the temporary file to ``path``.

    For writers that take a path (``savefig``, ``np.savez``, ``torch.save``). On any failure the
    temporary file is removed, ``path`` is left as it was and :class:`OutputPathError` (for
    ``OSError``) or the writer's own exception is raised.
    """
    path = Path(path)
    tmp = _temporary_name(path)
    try:
        write(tmp)
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise OutputPathError(f"{path}: cannot write: {exc.strerror or exc}") from exc
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


@contextlib.contextmanager
def atomic_write(path: str | Path, mode: str = "w", **open_kwargs: Any) -> Iterator[IO[Any]]:
    """``with atomic_write(path) as handle:`` writes to a temporary file renamed to ``path`` on
    success (removed on failure; ``path`` is then untouched)."""
    path = Path(path)
    tmp = _temporary_name(path)
    try:
        with open(tmp, mode, **open_kwargs) as handle:
            yield handle
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise OutputPathError(f"{path}: cannot write: {exc.strerror or exc}") from exc
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically; returns ``path``."""
    with atomic_write(path, "w", newline="") as handle:
        handle.write(text)
    return Path(path)


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically; returns ``path``. For files that a library writes
    with its own C++ writer (``torch.jit.save``, ``torch.export.save``): saved to memory first
    (``io.BytesIO``) and written here, a full disk is an :class:`OutputPathError` naming the file,
    not an abort of the process in the writer's destructor."""
    with atomic_write(path, "wb") as handle:
        handle.write(data)
    return Path(path)


def strict_json(data: Any) -> Any:
    """``data`` with every float that JSON lacks (NaN, +-inf, numpy's included) made ``None``
    (``null``), through dicts, lists and tuples: a value that was not measured, in a file that
    strict readers (JavaScript's ``JSON.parse``, Go's ``encoding/json``) accept."""
    if isinstance(data, dict):
        return {key: strict_json(value) for key, value in data.items()}
    if isinstance(data, (list, tuple)):
        return [strict_json(value) for value in data]
    scalar_float = isinstance(data, float) or (getattr(data, "ndim", None) == 0 and data.dtype.kind == "f")
    if scalar_float and not math.isfinite(float(data)):
        return None
    return data


def atomic_write_json(path: str | Path, data: Any) -> Path:
    """Write ``data`` as indented strict JSON (:func:`strict_json`: ``null`` for NaN and
    infinities; ``str`` for what JSON lacks) to ``path`` atomically, creating its folder;
    returns ``path``."""
    import json

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(strict_json(data), indent=2, default=str, allow_nan=False)
    return atomic_write_text(path, text + "\n")


def prepare_output_dir(path: str | Path, option: str = "--out", given: str | Path | None = None) -> Path:
    """Create the output folder ``path`` (and its parents) and check that files can be created in
    it. Raises :class:`OutputPathError` naming ``option`` (with ``given``, the path the user gave,
    where ``path`` is a folder made inside it) when it is a file, lies under a file, or cannot be
    created or written."""
    path = Path(path)
    _writable_folder(path, f"{option} {display_path(given if given is not None else path)}")
    return path


def prepare_output_file(path: str | Path, option: str = "--out") -> Path:
    """Check that the file ``path`` can be written (its folder is created); an existing file is
    replaced only when the write succeeds (see :func:`atomic_write`)."""
    path = Path(path)
    if path.is_dir():
        raise OutputPathError(f"{option} {display_path(path)}: is a folder, expected a file name")
    _writable_folder(path.parent, f"{option} {display_path(path)}")
    return path


def _writable_folder(folder: Path, what: str) -> None:
    for parent in (folder, *folder.parents):
        if parent.exists() and not parent.is_dir():
            raise OutputPathError(f"{what}: {display_path(parent)} is a file, not a folder")
    # the folder that refuses: the nearest existing one when the folder cannot be made
    existing = next((p for p in (folder, *folder.parents) if p.exists()), folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        existing = folder
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        raise OutputPathError(f"{what}: cannot write in {display_path(existing)}: "
                              f"{exc.strerror or exc}") from None
