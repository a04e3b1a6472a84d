"""A set of files put into a folder that holds other things, all of them or none.

A result folder (:mod:`elastica_magnetic.results`) is swapped whole; a folder shared with other
files (``docs/figures/physics``, a run folder that receives figures) cannot be. There the new
files are written into a temporary folder inside it, ``.msr-files-HOST-PID-RANDOM``, and moved
into place together::

    from elastica_magnetic.filesets import replace_files

    with replace_files(args.out, ["s2_end_to_end.png", "s2.json"], force=True) as files:
        ...                                         # the long work
        plot_s2(results, files.path / "s2_end_to_end.png")
        (files.path / "s2.json").write_text(text)
    # both files are in args.out now, or neither changed

On an exception, Ctrl-C, SIGTERM or SIGHUP in the block the temporary folder is removed and
nothing in the folder changed. On success a commit record (``.msr-commit``, the list of files) is
written into the temporary folder, then each file is renamed into place (each rename is atomic;
signals are held back meanwhile), the files the commit removes (``remove=``) are removed, then the
temporary folder is removed. A process killed
outright (SIGKILL, power loss) before the commit record leaves only the temporary folder, which
the next :func:`replace_files` (or :func:`recover_files`) on that folder removes; killed after
it, the folder may hold some new files beside some old ones until the next
:func:`replace_files` / :func:`recover_files` on it finishes the moves (roll forward); a reader
of such a folder checks :func:`interrupted_replacements` and calls :func:`recover_files` first
(a shipped policy: ``elastica_magnetic_rl.shipping.policy_files.resolve_policy``). Both run
under the folder's lock (:class:`~elastica_magnetic.locks.FolderLock`), so a second writer is
refused naming the first.

Existing files among ``names`` are replaced only with ``force=True``; files of the folder not
among them are never touched.

A single result file: :mod:`elastica_magnetic.result_file`.
"""

from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import NoReturn

from .interrupts import signals_as_exceptions, signals_held
from .io import (
    OutputPathError,
    atomic_write_text,
    display_path,
    normalized_path,
)
from .locks import (
    FolderLock,
    claim,
    host_name,
    name_tag,
    release_claim,
)
from .result_markers import (
    MANIFEST,
    MARKER,
    manifest_holder,
    manifest_results_in,
    read_marker,
)
from .result_places import ResultExistsError
from .results import fsync_tree, remove_tree

__all__ = ["FileSet", "check_files", "claim_pre_check", "interrupted_replacements", "not_recorded",
           "record_files", "recorded_files", "recover_files", "replace_files", "update_recorded_text"]

_PREFIX = ".msr-files-"
_COMMIT = ".msr-commit"


def _sha256(path: Path) -> str:
    import hashlib

    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _manifest(folder: Path) -> dict[str, str]:
    """The files msr recorded in ``folder`` (name -> sha256); empty without a readable record."""
    try:
        data = json.loads((folder / MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    files = data.get("files") if isinstance(data, dict) else None
    return {k: v for k, v in files.items() if isinstance(v, str)} if isinstance(files, dict) else {}


def recorded_files(folder: str | Path) -> dict[str, str]:
    """The files msr recorded writing in ``folder`` (name -> sha256 as written); empty without a
    record (a folder written before msr kept records, or whose record was removed)."""
    return _manifest(Path(folder))


def update_recorded_text(path: str | Path, text: str) -> None:
    """Write ``text`` into the file ``path`` atomically (an edit of a file in place, such as a
    section of a model card) and, if msr had recorded the file as it was, record it as it is now
    (a file someone changed since msr wrote it stays unrecorded: theirs)."""
    path = Path(path)
    was_msrs = path.is_file() and _manifest(path.parent).get(path.name) == _sha256(path)
    atomic_write_text(path, text)
    if was_msrs:
        record_files(path.parent, [path.name])


#: The writer recorded for the files of a set put into a shared folder (:func:`replace_files`
#: without a holder): no one-file result replaces them.
FILESET_WRITER = "a file msr put into this folder with others (a figure, a report)"


def record_files(folder: Path, written: Iterable[str], removed: Iterable[str] = (),
                  writer: str | None = None, holder: str | None = None,
                  results_in: Iterable[str] | None = None) -> None:
    """Add the files ``written`` (as they are now in ``folder``) to its record, with their
    ``writer`` (the kind of result, for :func:`check_result_file`), drop ``removed``; ``holder``:
    what holds the folder whole from now on (a shipped policy: :func:`replace_files`), and
    ``results_in``, its subfolders where other results may go; both kept when not given."""
    files = _manifest(folder)
    try:
        data = json.loads((folder / MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        data = {}
    writers = data.get("writers") if isinstance(data, dict) and isinstance(data.get("writers"), dict) else {}
    holder = holder or manifest_holder(folder)
    places = list(results_in) if results_in is not None else list(manifest_results_in(folder))
    for name in written:
        if (folder / name).is_file():
            files[name] = _sha256(folder / name)
            if writer is not None:  # else (a file edited in place) the writer recorded stays
                writers[name] = writer
    for name in removed:
        files.pop(name, None)
        writers.pop(name, None)
    record: dict[str, object] = {"files": dict(sorted(files.items()))}
    if writers:
        record["writers"] = dict(sorted((k, v) for k, v in writers.items() if k in files))
    if holder:
        record["holder"] = holder
        if places:
            record["results_in"] = sorted(set(places))
    temporary = folder / f"{MANIFEST}.tmp"
    temporary.write_text(json.dumps(record, indent=1), encoding="utf-8")
    os.replace(temporary, folder / MANIFEST)


def not_recorded(folder: Path, existing: Iterable[str]) -> list[str]:
    """Those of the ``existing`` files of ``folder`` that msr did not record, or that changed
    since (a file of the user's under a name msr writes). A file the folder's result marker lists
    (``msr policy generate``'s figures in its result) is msr's."""
    files = _manifest(folder)
    marker = read_marker(folder) if (folder / MARKER).is_file() else None
    listed = set(marker.get("files") or ()) if marker else set()
    return [n for n in existing if n not in listed and files.get(n) != _sha256(folder / n)]


def _refuse_unrecorded(folder: Path, existing: list[str], adopt: bool, option: str,
                       force_option: str) -> None:
    """With ``force``: refuse replacing a file msr did not write or that changed since (with
    ``adopt``, a folder the caller recognised as its own, e.g. a shipped policy written before
    records: only a recorded file changed since)."""
    if adopt:  # files without a record are adopted; a recorded one changed since is the user's
        files = _manifest(folder)
        foreign = [n for n in existing if n in files and files[n] != _sha256(folder / n)]
    else:
        foreign = not_recorded(folder, existing)
    if foreign:
        raise ResultExistsError(
            f"{option} {display_path(folder)}: {', '.join(foreign)}: not written by msr (no record "
            f"in {MANIFEST}) or changed since; {force_option} replaces only files msr wrote: move "
            f"them away, or choose another {option}")


@dataclass
class FileSet:
    """Files being written (see :func:`replace_files`): ``path`` is the temporary folder to write
    into (relative paths there are those in ``folder``), ``notes`` the recoveries done on entry."""

    folder: Path
    path: Path
    names: tuple[str, ...]
    notes: list[str] = field(default_factory=list)

    def final_path(self, path: str | Path) -> Path:
        """Where ``path`` (under :attr:`path`) will be once the files are in place."""
        path = Path(path)
        try:
            return self.folder / path.relative_to(self.path)
        except ValueError:
            return path


def _written(staging: Path) -> list[str]:
    found = []
    for root, _dirs, files in os.walk(staging):
        for name in files:
            relative = (Path(root) / name).relative_to(staging).as_posix()
            if relative != _COMMIT:
                found.append(relative)
    return sorted(found)


def _move_committed(staging: Path, folder: Path) -> int:
    """Rename every file listed in the commit record into ``folder``, then remove those it lists
    to remove; returns how many moved."""
    record = json.loads((staging / _COMMIT).read_text(encoding="utf-8"))
    if isinstance(record, list):  # the record of an earlier version: the files only
        record = {"files": record, "remove": []}
    moved = 0
    for name in record["files"]:
        source = staging / name
        if source.exists() or source.is_symlink():
            (folder / name).parent.mkdir(parents=True, exist_ok=True)
            os.replace(source, folder / name)
            moved += 1
    for name in record.get("remove") or ():
        with contextlib.suppress(FileNotFoundError):
            os.unlink(folder / name)
    record_files(folder, record["files"], record.get("remove") or (),
                  writer=record.get("holder") or FILESET_WRITER, holder=record.get("holder"),
                  results_in=record.get("results_in"))
    return moved


def interrupted_replacements(folder: str | Path) -> list[Path]:
    """The temporary folders a killed :func:`replace_files` left in ``folder`` (empty when none:
    the folder is consistent). A reader that finds one calls :func:`recover_files` first."""
    folder = normalized_path(folder)
    return sorted(folder.glob(f"{_PREFIX}*")) if folder.is_dir() else []


def _recover_locked(folder: Path) -> list[str]:
    notes = []
    for staging in interrupted_replacements(folder):
        if (staging / _COMMIT).is_file():
            try:
                moved = _move_committed(staging, folder)
            except (OSError, ValueError) as exc:
                raise OutputPathError(f"{display_path(folder)}: cannot finish the interrupted replacement of "
                                      f"files in {staging.name}: {exc}") from None
            notes.append(f"{display_path(folder)}: finished moving {moved} file(s) of a replacement that was "
                         f"killed after it was complete ({staging.name})")
        else:
            notes.append(f"{display_path(folder)}: removed {staging.name}, left by a run that was killed")
        remove_tree(staging)
    return notes


def recover_files(folder: str | Path, *, option: str = "--out") -> list[str]:
    """Finish or undo what a killed :func:`replace_files` left in ``folder`` (under its lock);
    returns what was done."""
    folder = normalized_path(folder)
    with FolderLock(folder, option=option) as lock:
        return lock.notes + _recover_locked(folder)


def check_files(folder: str | Path, names: Iterable[str], *, force: bool = False,
                option: str = "--out", force_option: str = "--force", adopt: bool = False) -> Path:
    """The check :func:`replace_files` makes, made before any long work: ``folder`` is not a
    file (nor under one) and holds none of ``names`` unless ``force`` (and then only files msr
    recorded, or any with ``adopt``). Returns it normalized."""
    folder = normalized_path(folder)
    for parent in (folder, *folder.parents):
        if parent.exists() and not parent.is_dir():
            raise OutputPathError(f"{option} {display_path(folder)}: {display_path(parent)} is a "
                                  "file, not a folder")
    claim_pre_check(folder, option)
    existing = [n for n in names if (folder / n).exists()]
    if existing and not force:
        release_claim(folder)
        raise ResultExistsError(f"{option} {display_path(folder)}: already holds "
                                f"{', '.join(existing)}; pass {force_option} to replace, or "
                                f"choose another {option}")
    try:
        _refuse_unrecorded(folder, existing, adopt, option, force_option)
    except ResultExistsError:
        release_claim(folder)
        raise
    return folder


@contextlib.contextmanager
def replace_files(
    folder: str | Path,
    names: Iterable[str],
    *,
    force: bool = False,
    option: str = "--out",
    force_option: str = "--force",
    remove: Iterable[str] = (),
    adopt: bool = False,
    holder: str | None = None,
    results_in: Iterable[str] = (),
) -> Iterator[FileSet]:
    """Put the files ``names`` (relative paths) into ``folder`` (created if absent) all together
    or not at all; write them under :attr:`FileSet.path` in the block. An existing one is
    replaced only with ``force`` (:class:`~elastica_magnetic.results.ResultExistsError` before
    the block otherwise); writing a file not in ``names`` is a :class:`ValueError` and nothing
    is moved. ``remove``: files of ``folder`` (not among ``names``) removed in the same commit,
    after the new ones are in place (those of a replaced set that the new one lacks). An
    existing file is replaced only when msr recorded it (:data:`MANIFEST`) unchanged, or with
    ``adopt`` (the caller recognised the folder as msr's own, written before records).
    ``holder``: the set is a result that holds ``folder`` whole (``"a shipped policy of case
    'm1-4mT' (msr policy ship)"``): recorded, and from then on no other writer puts a file there (a
    folder another holder holds is refused, naming it); other results go only into its subfolders
    ``results_in`` (a policy's ``seeds``)."""
    folder = normalized_path(folder)
    names = tuple(names)
    remove = tuple(sorted(set(remove)))
    results_in = tuple(results_in)
    if set(remove) & set(names):
        raise ValueError(f"replace_files({folder}): {', '.join(sorted(set(remove) & set(names)))} "
                         "both written and removed")
    _make_folder(folder, option)
    with signals_as_exceptions(), FolderLock(folder, option=option) as lock:
        notes = lock.notes + _recover_locked(folder)
        _check_replaceable(folder, names, remove, force=force, option=option, force_option=force_option,
                           adopt=adopt, holder=holder)
        staging = _make_staging(folder, option)
        files = FileSet(folder, staging, names, notes)
        try:
            yield files
            _commit(staging, folder, names, remove, holder, results_in)
        except BaseException as exc:
            _raise_failed_write(exc, staging, folder, option)
        finally:
            release_claim(folder)  # the pre-check's hold (the lock itself goes with this block)


def _make_folder(folder: Path, option: str) -> None:
    """Create ``folder`` and its parents, refusing a path through a file."""
    for parent in (folder, *folder.parents):
        if parent.exists() and not parent.is_dir():
            raise OutputPathError(f"{option} {display_path(folder)}: {parent} is a file, not a folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputPathError(f"{option} {display_path(folder)}: cannot create it: "
                              f"{exc.strerror or exc}") from None


def _check_replaceable(folder: Path, names: tuple[str, ...], remove: tuple[str, ...], *, force: bool,
                       option: str, force_option: str, adopt: bool, holder: str | None) -> None:
    """Refuse (under the folder's lock) a folder another result holds, existing files without
    ``force``, and files msr did not record (see :func:`replace_files`)."""
    held = manifest_holder(folder)
    if held is not None and held != holder:
        raise ResultExistsError(f"{option} {display_path(folder)}: holds {held}, whose files are its "
                                f"own: nothing else goes in that folder; choose another {option}")
    existing = [n for n in names if (folder / n).exists()]
    if existing and not force:
        raise ResultExistsError(f"{option} {display_path(folder)}: already holds "
                                f"{', '.join(existing)}; pass "
                                f"{force_option} to replace, or choose another {option}")
    # the files it removes are replaced too: a file of the user's among them is refused alike
    removing = [n for n in remove if (folder / n).exists()]
    _refuse_unrecorded(folder, existing + removing, adopt, option, force_option)


def _make_staging(folder: Path, option: str) -> Path:
    """A new staging folder inside ``folder``, named after this host and process."""
    staging = folder / f"{_PREFIX}{name_tag(host_name())}-{os.getpid()}-{os.urandom(3).hex()}"
    try:
        os.mkdir(staging)
    except OSError as exc:
        raise OutputPathError(f"{option} {display_path(folder)}: cannot write in it: "
                              f"{exc.strerror or exc}") from None
    return staging


def _commit(staging: Path, folder: Path, names: tuple[str, ...], remove: tuple[str, ...],
            holder: str | None, results_in: tuple[str, ...]) -> None:
    """Check what was written, then record the commit and move the files in: once the record is
    in place, an interrupted move is finished by the next run on the folder."""
    written = _written(staging)
    unexpected = sorted(set(written) - set(names))
    if unexpected:
        raise ValueError(f"replace_files({folder}): wrote {', '.join(unexpected)}, not "
                         f"among the declared names {', '.join(names)}")
    fsync_tree(staging)
    with signals_held():
        record = staging / f"{_COMMIT}.tmp"
        record.write_text(json.dumps({"files": written, "remove": list(remove), "holder": holder,
                                      "results_in": list(results_in)}), encoding="utf-8")
        os.replace(record, staging / _COMMIT)  # from here on, the next run rolls forward
        _move_committed(staging, folder)
        remove_tree(staging)


def _raise_failed_write(exc: BaseException, staging: Path, folder: Path, option: str) -> NoReturn:
    """After a failed write: drop an uncommitted staging folder and raise ``exc`` again, an
    ``OSError`` as an :class:`OutputPathError` saying what the folder holds now."""
    committed = (staging / _COMMIT).exists()
    if not committed:
        remove_tree(staging)
    then = ("the next run on it finishes the replacement" if committed
            else "nothing in it changed")
    if isinstance(exc, OSError) and not isinstance(exc, OutputPathError):
        raise OutputPathError(f"{option} {display_path(folder)}: cannot write the files: "
                              f"{exc.strerror or exc}; {then}") from exc
    if isinstance(exc, OutputPathError) and str(staging) in str(exc):
        # a writer named its temporary file: name the file the user will look for
        message = str(exc).replace(str(staging), str(folder))
        raise OutputPathError(f"{message}; {display_path(folder)}: {then}") from exc
    raise exc


def claim_pre_check(path: Path, option: str) -> list[str]:
    """Take the lock of ``path`` at a pre-check, held until its write (see
    :func:`~elastica_magnetic.locks.claim`); a folder still to be made is not claimed (no lock
    file where nothing exists yet). Returns the notes of a stale lock taken over."""
    if not path.parent.is_dir():
        return []
    lock = claim(path, option=option)
    notes, lock.notes = lock.notes, []
    return notes
