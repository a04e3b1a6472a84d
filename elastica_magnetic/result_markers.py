"""What msr wrote: the marker of a result folder and the files no record says msr wrote.

Every result folder carries a marker, :data:`MARKER` (``.msr-result.json``: the command's kind,
its subject, the command line, time, host and the list of files written). A folder that holds
other things gets its record of shared files (``.msr-files.json``,
:mod:`elastica_magnetic.filesets`). A command that replaces or removes a folder asks
:func:`unrecorded_files` first: what is left is the user's, and is never touched.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .command_names import spelling
from .io import atomic_write_text, normalized_path
from .locks import command_line, host_name, utc_now

__all__ = ["HELD_RECOGNIZERS", "MANIFEST", "MARKER", "MAX_LISTED", "RESULT_RECOGNIZERS", "describe_result",
           "in_manifest", "list_files", "manifest_holder", "manifest_results_in", "manifest_writer",
           "mark_folder", "read_marker", "recognized_marker", "register_held_recognizer",
           "register_result_recognizer", "short_list", "unrecorded_files", "write_marker"]

#: The marker file of a result folder (JSON: kind, subject, command, time, host, files).
MARKER = ".msr-result.json"
#: The record of the files msr put into a folder that holds other things (figures into
#: ``docs/figures``): :mod:`elastica_magnetic.filesets` writes it; what it lists is msr's.
MANIFEST = ".msr-files.json"
MARKER_FORMAT = 1
#: Folders that hold more files than this are not listed in full (they are not a result).
MAX_LISTED = 10_000


def read_marker(folder: str | Path) -> dict[str, Any] | None:
    """The marker of a result folder (kind, subject, command, written_utc, host, files), or
    ``None`` when ``folder`` has none (or it is unreadable)."""
    try:
        data = json.loads((normalized_path(folder) / MARKER).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and isinstance(data.get("kind"), str) else None


#: Recognizers of results written before result folders carried a marker (the seed campaigns
#: committed with the shipped policies): each takes a folder and returns the marker it stands for
#: (``kind``, ``subject``) or ``None``. The package that writes such results registers one
#: (:func:`register_result_recognizer`; a seed export: ``elastica_magnetic_rl``).
RESULT_RECOGNIZERS: list[Callable[[Path], dict[str, Any] | None]] = []


def register_result_recognizer(recognizer: Callable[[Path], dict[str, Any] | None]) -> None:
    """Add a recognizer to :data:`RESULT_RECOGNIZERS` (once)."""
    if recognizer not in RESULT_RECOGNIZERS:
        RESULT_RECOGNIZERS.append(recognizer)


def recognized_marker(folder: str | Path) -> dict[str, Any] | None:
    """The marker of the result ``folder`` holds: its own (:func:`read_marker`), or for a result
    written before markers, what a registered recognizer tells from its files; ``None`` for a
    folder that holds no result."""
    folder = normalized_path(folder)
    if (folder / MARKER).is_file():
        return read_marker(folder)
    for recognizer in RESULT_RECOGNIZERS:
        if (found := recognizer(folder)) is not None:
            return found
    return None


def list_files(folder: Path) -> list[str] | None:
    """Every file (and link) under ``folder``, relative POSIX paths, sorted; ``None`` past
    :data:`MAX_LISTED`."""
    found: list[str] = []
    for root, dirs, names in os.walk(folder):
        base = Path(root).relative_to(folder)
        links = [d for d in dirs if os.path.islink(os.path.join(root, d))]
        for name in [*names, *links]:
            found.append((base / name).as_posix())
            if len(found) > MAX_LISTED:
                return None
    return sorted(found)


def unrecorded_files(folder: str | Path) -> list[str]:
    """The files under ``folder`` (relative POSIX paths) that no record says msr wrote: not
    listed by the marker of the nearest folder above them that has one (within ``folder``), nor
    by their folder's record of shared files (``.msr-files.json``), nor msr's own bookkeeping
    (names starting ``.msr``, lock files). A command about to remove ``folder`` (to write it
    anew) refuses when this is not empty: they are the user's."""
    root = normalized_path(folder)
    if not root.is_dir():
        return []
    listed = list_files(root)
    if listed is None:
        return [f"more than {MAX_LISTED} files"]
    markers: dict[str, set[str] | None] = {}

    def recorded_by_marker(path: str) -> bool:
        parts = path.split("/")
        for depth in range(len(parts) - 1, -1, -1):
            base = "/".join(parts[:depth])
            if base not in markers:
                marker = read_marker(root / base) if (root / base / MARKER).is_file() else None
                markers[base] = None if marker is None else set(marker.get("files") or ())
            if markers[base] is not None:
                return "/".join(parts[depth:]) in markers[base]
        return False

    out = []
    for path in listed:
        name = path.rsplit("/", 1)[-1]
        if name.startswith((".msr", MARKER)) or name.endswith(".msr-lock"):
            continue
        parent = root / path.rsplit("/", 1)[0] if "/" in path else root
        if recorded_by_marker(path) or in_manifest(parent, name):
            continue
        out.append(path)
    return out


def in_manifest(folder: Path, name: str) -> bool:
    """Whether ``folder``'s record of shared files lists ``name`` (written by msr) with the
    content it has now (a file the user changed since is the user's)."""
    try:
        data = json.loads((folder / MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    files = data.get("files") if isinstance(data, dict) else None
    if not isinstance(files, dict) or name not in files:
        return False
    recorded = files[name]
    if not isinstance(recorded, str):
        return True  # a record without a checksum: listed is all it says
    try:
        return hashlib.sha256((folder / name).read_bytes()).hexdigest() == recorded
    except OSError:
        return False


#: Recognizers of folders held whole whose record does not say so (written before records named
#: a holder, or lost, or copied without it): each takes a folder and returns its holder and the
#: subfolders open to other results, or ``None``. The package whose results hold folders registers
#: one (:func:`register_held_recognizer`; a shipped policy: ``elastica_magnetic_rl``).
HELD_RECOGNIZERS: list[Callable[[Path], tuple[str, tuple[str, ...]] | None]] = []


def register_held_recognizer(recognizer: Callable[[Path], tuple[str, tuple[str, ...]] | None]) -> None:
    """Add a recognizer to :data:`HELD_RECOGNIZERS` (once)."""
    if recognizer not in HELD_RECOGNIZERS:
        HELD_RECOGNIZERS.append(recognizer)


def _record(folder: str | Path) -> dict[str, Any]:
    try:
        data = json.loads((Path(folder) / MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def _recognized(folder: str | Path) -> tuple[str, tuple[str, ...]] | None:
    for recognizer in HELD_RECOGNIZERS:
        found = recognizer(Path(folder))
        if found is not None:
            return found
    return None


def manifest_holder(folder: str | Path) -> str | None:
    """What holds ``folder`` whole, as its record of files says (``"holder"`` of :data:`MANIFEST`,
    e.g. a shipped policy: its files are its own, and no other command puts a file there), or as
    a registered recognizer tells from its files (:data:`HELD_RECOGNIZERS`: a policy whose record
    predates holders, or that has none), or ``None``: a folder of shared files (figures of several
    commands) or of none recorded."""
    holder = _record(folder).get("holder")
    if isinstance(holder, str) and holder:
        return holder
    found = _recognized(folder)
    return None if found is None else found[0]


def manifest_results_in(folder: str | Path) -> tuple[str, ...]:
    """The subfolders of a held folder (:func:`manifest_holder`) where other results may go
    (``"results_in"`` of :data:`MANIFEST`: a shipped policy's ``seeds``; for a folder whose record
    names no holder, its recognizer's); empty when none, and for a held folder that itself lies in
    such a subfolder of another (a seed of a campaign in a policy's ``seeds/``: a result inside it
    would be inside that campaign, which is replaced whole)."""
    if _in_results_of_a_holder(Path(folder)):
        return ()
    data = _record(folder)
    places = data.get("results_in")
    if isinstance(places, list):
        return tuple(p for p in places if isinstance(p, str))
    if isinstance(data.get("holder"), str) and data.get("holder"):
        return ()
    found = _recognized(folder)
    return () if found is None else found[1]


def _in_results_of_a_holder(folder: Path) -> bool:
    """Whether ``folder`` lies in a subfolder for other results of the nearest held folder above it."""
    folder = Path(os.path.abspath(folder))
    for above in folder.parents:
        if manifest_holder(above) is not None:
            return folder.relative_to(above).parts[0] in manifest_results_in(above)
    return False


def manifest_writer(folder: str | Path, name: str) -> str | None:
    """Which kind of writer recorded ``name`` in ``folder`` (``"writers"`` of :data:`MANIFEST`: a
    result file's kind, a holder), or ``None`` when the record does not say (written before msr
    recorded writers)."""
    try:
        data = json.loads((Path(folder) / MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    writers = data.get("writers") if isinstance(data, dict) else None
    writer = writers.get(name) if isinstance(writers, dict) else None
    return writer if isinstance(writer, str) else None


def describe_result(marker: dict[str, Any]) -> str:
    subject = f" for {marker['subject']}" if marker.get("subject") else ""
    written = f", written {marker['written_utc']}" if marker.get("written_utc") else ""
    return f"a result of `msr {spelling(str(marker['kind']))}`{subject}{written}"


def short_list(names: list[str]) -> str:
    return ", ".join(names[:5]) + (f" and {len(names) - 5} more" if len(names) > 5 else "")


def write_marker(folder: Path, kind: str, subject: str | None, info: dict[str, Any]) -> Path:
    files = list_files(folder) or []
    data = {"format": MARKER_FORMAT, "kind": kind, "subject": subject,
            "command": command_line(), "written_utc": utc_now(), "host": host_name(),
            "files": [f for f in files if f != MARKER], **info}
    return atomic_write_text(folder / MARKER, json.dumps(data, indent=2, default=str) + "\n")


def mark_folder(folder: str | Path, *, kind: str, subject: str | None = None,
                info: dict[str, Any] | None = None) -> Path:
    """Write (or rewrite) the marker of a folder written in place, such as a training seed's
    folder held with :class:`~elastica_magnetic.locks.FolderLock`: ``kind`` and ``subject`` as
    in :func:`result_folder`, the files it holds now. Another command's
    :func:`check_result_folder` then refuses the folder naming it. Call it under the folder's
    lock, after each set of files (a checkpoint and its logs) is written. Returns the marker."""
    return write_marker(normalized_path(folder), kind, subject, dict(info or {}))
