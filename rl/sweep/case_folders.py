"""What a training output's case folder (``OUT/<case>/``) may hold before ``msr train`` writes into
it: only what msr train writes there (``summary.json`` of that case, ``seed<k>/`` folders, its
figures), and seeds of the same case spec. A user's file, a shipped policy's folder
(``rl/policies/<case>``) or the seeds of another spec under the same case name are refused by
name before any work."""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from elastica_magnetic.io import DamagedFileError, display_path, normalized_path, read_json
from elastica_magnetic.result_markers import MARKER, describe_result, read_marker

from ..cases.case import Case
from ..runfiles.rundir import CaseDir
from .run_records import first_difference, without_default_recipe

__all__ = ["check_case_folders", "check_not_in_a_result"]

#: Files msr writes into a case folder besides ``summary.json`` and the seed folders: the figures
#: of ``msr policy figures`` and ``msr policy seeds``.
CASE_FOLDER_FIGURE = re.compile(r"(learning_curves|seeds)(_[A-Za-z0-9._-]+)?\.(png|gif)")


def check_case_folders(out: str | Path, cases: Mapping[str, Case], seeds: Iterable[int]) -> None:
    """Refuse, before any work, a case folder of ``out`` holding anything msr train does not
    write, a ``summary.json`` that is not this case's, or seeds (other than ``seeds``) trained on
    another spec of the same case name (ValueError naming the folder and the file)."""
    seeds = set(seeds)
    for name, case in cases.items():
        folder = CaseDir.of(out, name)
        if not folder.path.is_dir():
            continue
        where = display_path(folder.path)
        foreign = sorted(p.name for p in folder.path.iterdir() if not _written_by_train(p))
        if foreign:
            raise ValueError(f"--out: {where} holds {', '.join(foreign)}, which msr train does not "
                             "write (a case folder holds summary.json and seed<k>/ folders): not a "
                             "training output; choose another --out")
        _check_summary(folder, name)
        _check_same_spec(folder, case, seeds)


def check_not_in_a_result(out: str | Path) -> None:
    """Refuse an ``out`` that is, or lies in, another command's result folder (its marker names
    the command): the runs would change that result, which then could not be replaced whole
    (``msr train``'s check; ``msr loop`` trains inside its own folder on purpose)."""
    out = normalized_path(out)
    for folder in (out, *out.parents):
        marker = read_marker(folder) if (folder / MARKER).is_file() else None
        if marker is not None:
            where = "is" if folder == out else f"lies in {display_path(folder)}, which holds"
            raise ValueError(f"--out {display_path(out)} {where} {describe_result(marker)}: msr train "
                             "writes its runs in a folder of their own; choose another --out")


def _written_by_train(path: Path) -> bool:
    if path.name.startswith("."):  # locks, markers, temporary files of msr's writers
        return True
    if path.is_dir():
        return CaseDir.seed_of(path.name) is not None
    return path.name == CaseDir.SUMMARY_JSON or CASE_FOLDER_FIGURE.fullmatch(path.name) is not None


def _check_summary(folder: CaseDir, name: str) -> None:
    if not folder.summary_json.exists():
        return
    where = display_path(folder.summary_json)
    try:
        summary = read_json(folder.summary_json)
    except DamagedFileError as exc:
        raise ValueError(f"--out: {exc}; msr train rewrites it, so it must be the case's own "
                         "(move it away if it is a file of yours)") from None
    if not isinstance(summary, dict) or summary.get("case") != name:
        found = summary.get("case") if isinstance(summary, dict) else None
        raise ValueError(f"--out: {where} is not the summary of case {name!r} (it names "
                         f"{found!r}): msr train would overwrite it; move it away or choose "
                         "another --out")


def _check_same_spec(folder: CaseDir, case: Case, seeds: set[int]) -> None:
    """The seeds already in ``folder`` (not retrained now) were trained on this case's spec: one
    case folder, one robot (its summary and exported seeds mean one case)."""
    spec = without_default_recipe(case.to_dict())
    for seed, run in folder.seeds():
        if seed in seeds or not run.run_json.is_file():
            continue
        try:
            record: Any = read_json(run.run_json)
        except DamagedFileError:
            continue  # named by the commands that read it; not this check's business
        theirs = record.get("case_spec") if isinstance(record, dict) else None
        if isinstance(theirs, dict) and without_default_recipe(theirs) != spec:
            raise ValueError(
                f"--out: {display_path(run.path)} was trained on another spec of case "
                f"{case.name!r} (they differ at {first_difference(without_default_recipe(theirs), spec)}): "
                "seeds of two robots in one case folder would be summarized and exported as one "
                "case; give this spec another name (name = \"...\" or its file name), or choose "
                "another --out")
