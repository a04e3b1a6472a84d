"""The output folders of ``msr real robustness`` and ``msr real identify``, through the package's one
mechanism for results (:mod:`elastica_magnetic.results`): built in a temporary sibling and swapped
in whole; an existing result replaced only with ``--force``, another command's never."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from elastica_magnetic.results import check_result_folder, result_folder

__all__ = ["prepare_output_folder", "write_folder_whole"]


def prepare_output_folder(out: str | Path, force: bool = False, option: str = "--out", *,
                          kind: str) -> Path:
    """Check, before any work, that ``out`` can take a ``kind`` result (``"robustness"``,
    ``"identify"``): see :func:`~elastica_magnetic.results.check_result_folder`."""
    check_result_folder(out, kind=kind, force=force, option=option)
    return Path(out)


def write_folder_whole(out: str | Path, fill: Callable[[Path], Any], force: bool = False, *,
                       kind: str) -> Any:
    """Build the ``kind`` result with ``fill(folder)`` in a temporary sibling, then swap it in as
    ``out`` (:func:`~elastica_magnetic.results.result_folder`). Returns what ``fill`` returns."""
    with result_folder(out, kind=kind, force=force) as folder:
        return fill(folder.path)
