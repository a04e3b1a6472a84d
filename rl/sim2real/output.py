"""Output folders written whole: built in a temporary sibling, then renamed into place."""

from __future__ import annotations

import os
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ["prepare_output_folder", "write_folder_whole"]


def prepare_output_folder(out: str | Path, force: bool = False, option: str = "--out") -> Path:
    """Check, before any work, that ``out`` can be written whole: it must not exist (unless
    ``force``: it is then replaced once the new folder is complete) and its parent must be a
    writable folder."""
    from elastica_magnetic.io import prepare_output_dir

    out = Path(out)
    if out.exists() and not force:
        raise FileExistsError(f"{option} {out}: already exists (pass --force to replace it)")
    if out.exists() and not out.is_dir():
        raise FileExistsError(f"{option} {out}: is a file, expected a folder")
    prepare_output_dir(out.parent if str(out.parent) else Path("."), option)
    return out


def write_folder_whole(out: str | Path, fill: Callable[[Path], Any], force: bool = False) -> Any:
    """Build a folder in a temporary sibling with ``fill(folder)``, then rename it to ``out`` (an
    existing ``out`` is replaced only with ``force``, and only once the new one is complete).
    Returns what ``fill`` returns."""
    out = prepare_output_folder(out, force)
    building = out.parent / f".{out.name}.building-{os.getpid()}"
    shutil.rmtree(building, ignore_errors=True)
    building.mkdir(parents=True)
    try:
        result = fill(building)
    except BaseException:
        shutil.rmtree(building, ignore_errors=True)
        raise
    old = out.parent / f".{out.name}.old-{os.getpid()}"
    if out.exists():
        out.rename(old)
    building.rename(out)
    shutil.rmtree(old, ignore_errors=True)
    return result
