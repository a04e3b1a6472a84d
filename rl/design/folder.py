"""A design folder (``msr design --out``): the names it holds, what may not be there (refused before
any work, never removed), a killed replacement's leftovers, and the record ``design.json`` a resume
reads back and checks (the same spec, the same settings). The search and the end that fill it:
:mod:`elastica_magnetic_rl.design.run`."""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from elastica_magnetic.io import OutputPathError, atomic_write_json, display_path, normalized_path, read_json
from elastica_magnetic.locks import claim
from elastica_magnetic.result_markers import read_marker, unrecorded_files
from elastica_magnetic.results import check_result_folder

from ..cases.design_space import DESIGN_TABLE

__all__ = ["DESIGN_JSON", "DESIGN_KIND", "DESIGN_NAMES", "DesignError", "END_STAGING", "HISTORY_CSV",
           "OUTPUT_FILES", "STATE_FILE", "check_folder", "copy_search", "design_files", "holds_design",
           "prepare_record", "recover_leftovers"]

#: The marker kind of a design folder.
DESIGN_KIND = "design"
DESIGN_JSON = "design.json"
STATE_FILE = "search/state.pkl"
HISTORY_CSV = "history.csv"
#: What the end of a design writes (:func:`~elastica_magnetic_rl.design.outputs.write_outputs`).
OUTPUT_FILES = ("best.toml", "final_sweep.csv", "summary.json", "convergence.png",
                "magnetization.png", "report.md", "gait")
#: Every name a design folder holds: anything else there is the user's (refused, never removed).
DESIGN_NAMES = frozenset((DESIGN_JSON, STATE_FILE.split("/")[0], HISTORY_CSV, *OUTPUT_FILES))
#: Where the end's files are written before they are moved into the design folder together.
END_STAGING = ".msr-end"
#: The command-line option behind each recorded setting (named when a resume differs).
SETTING_OPTIONS = {"objective": "--objective", "seed": "--seed", "popsize": "--popsize",
                   "sigma0": "the search's step size (another msr version)",
                   "search_duration": "--quick", "physics": "--search-physics", "finalists": "--finalists",
                   "final_duration": "--quick",
                   "final_physics": "--quick", "final_periods": "--quick"}


class DesignError(ValueError):
    """A design that cannot run as asked; the command line prints it as one line."""


def copy_search(folder: Path, into: Path) -> None:
    """The search of the design in ``folder`` (its record, checkpoint and history) copied into
    ``into``, to be continued there."""
    import shutil

    for name in (DESIGN_JSON, HISTORY_CSV):
        if (folder / name).is_file():
            shutil.copy2(folder / name, into / name)
    search = STATE_FILE.split("/")[0]
    if (folder / search).is_dir():
        shutil.copytree(folder / search, into / search)


def recover_leftovers(folder: Path) -> None:
    """Remove what a killed replacement (``--force``) left beside ``folder`` (its folder being
    built), saying so: every command on ``folder`` does, a resume in place too."""
    from elastica_magnetic.results import interrupted, recover

    if interrupted(folder):
        _say_leftovers(recover(folder, option="--out"))


def _say_leftovers(notes: list[str]) -> None:
    """Say what was cleaned up before the work (a killed run's leftovers, a stale lock taken over)."""
    import warnings

    from elastica_magnetic.results import LeftoverWarning

    for note in notes:
        warnings.warn(note, LeftoverWarning, stacklevel=4)


def holds_design(folder: str | Path) -> bool:
    """Whether ``folder`` holds a design (finished or not), by its marker."""
    path = normalized_path(folder)
    marker = read_marker(path) if path.is_dir() else None
    return marker is not None and marker.get("kind") == DESIGN_KIND


def design_files(folder: Path) -> list[str]:
    """The files of the design in ``folder`` (relative paths), as a replacement may remove them."""
    return [p.relative_to(folder).as_posix() for p in folder.rglob("*")
            if p.is_file() and (p.relative_to(folder).parts[0] in DESIGN_NAMES
                                or p.relative_to(folder).parts[0].startswith(".msr"))]


def check_folder(folder: Path, resume: bool, force: bool, subject: str) -> None:
    """Refuse, before any work, a folder that is not a design's (or not this request's: a design
    of another case is replaced by no ``--force``)."""
    if folder.parent.is_dir():  # a design being written is named first, before what it holds
        lock = claim(folder, option="--out")
        _say_leftovers(lock.notes)  # a killed design's stale lock taken over: said, as every command does
        lock.notes = []
    marker = read_marker(folder) if folder.is_dir() else None
    shown = display_path(folder)
    if marker is None or marker.get("kind") != DESIGN_KIND:
        if resume:
            if folder.exists() and any(folder.iterdir()):
                check_result_folder(folder, kind=DESIGN_KIND, force=True, option="--out")
            raise DesignError(f"--resume: {shown} holds no design to continue; leave out --resume "
                              "to start one")
        check_result_folder(folder, kind=DESIGN_KIND, force=True, option="--out")  # raises unless empty
        return
    foreign = _foreign_files(folder)
    if foreign:
        raise OutputPathError(f"--out {shown}: holds a design and files msr did not write "
                              f"({', '.join(sorted(foreign)[:5])}); move them away first")
    if resume and force:
        raise DesignError("--resume and --force: choose one (continue the design in "
                          f"{shown}, or replace it)")
    if force and marker.get("subject") not in (None, subject):
        raise OutputPathError(f"--out {shown} holds the design of {marker.get('subject')}, not of {subject}: "
                              "--force replaces only a design of the same case; choose another --out")
    if not resume and not force:
        raise OutputPathError(f"--out {shown} holds a design ({marker.get('subject')}): continue "
                              "it with --resume, or replace it with --force")


def _foreign_files(folder: Path) -> list[str]:
    """What in a design folder is not the design's: by the design's own names, not the marker's
    list (which lists what the folder held when it was marked: a user's file saved there during
    a run would pass for the design's); in ``search/`` only the checkpoint (and its temporary
    file), in ``gait/`` only what its own marker lists."""
    foreign = [p.name for p in folder.iterdir() if p.name not in DESIGN_NAMES
               and not p.name.startswith(".msr")]
    search = folder / STATE_FILE.split("/")[0]
    if search.is_dir():
        state = Path(STATE_FILE).name
        temporary = re.compile(rf"\.{re.escape(Path(STATE_FILE).stem)}\.tmp\d+\.pkl")
        foreign += [f"{search.name}/{p.name}" for p in search.iterdir()
                    if p.name != state and not temporary.fullmatch(p.name)]
    elif search.exists():
        foreign.append(search.name)
    gait = folder / "gait"
    if gait.is_dir():
        foreign += [f"gait/{name}" for name in unrecorded_files(gait)]
    return foreign


def prepare_record(folder: Path, design: Any, settings: Any, resume: bool) -> dict[str, Any]:
    """The design's record (``design.json``): read back and checked on a resume, else written
    anew (into a new or empty folder)."""
    spec = {**design.base, DESIGN_TABLE: design.space.to_dict()}
    if resume and (folder / DESIGN_JSON).exists():
        record = read_json(folder / DESIGN_JSON, fix="start the design afresh with --force")
        _check_same(record, spec, settings, folder, design.case.name)
        return record
    folder.mkdir(parents=True, exist_ok=True)
    record = {"format": "msr-design-v1", "case": design.case.name, "spec": spec,
              "settings": settings.recorded(), "start": None}
    atomic_write_json(folder / DESIGN_JSON, record)
    return record


def _check_same(record: Mapping[str, Any], spec: dict[str, Any], settings: Any,
                folder: Path, case: str) -> None:
    from ..sweep.run_records import first_difference

    shown = display_path(folder)
    old, new = _plain(record.get("spec")), _plain(spec)
    if old != new:
        cases = (f"case {case}" if record.get("case") == case else
                 f"case {record.get('case')} then, {case} now")
        where = _first_changed(old or {}, new, first_difference)
        advice = ("resume it with the same spec, or start afresh with --force" if record.get("case") == case
                  else f"resume it with its own spec (case {record.get('case')}), or choose another --out "
                       "for this one (--force replaces only a design of the same case)")
        raise DesignError(f"--resume: the design in {shown} was started from another spec ({cases}; "
                          f"first difference: {where}); {advice}")
    old, new = _plain(record.get("settings")), _plain(settings.recorded())
    if old != new:
        key = next(k for k in sorted(set(old or {}) | set(new)) if (old or {}).get(k) != new.get(k))
        option = SETTING_OPTIONS.get(key, key)
        def shown_value(value: Any) -> str:  # an option left out: its default (CMA-ES's for --popsize)
            return "the default" if value is None else repr(value)

        told = (f"{option}: given in one and not the other" if option == "--quick" else
                f"{option}: {shown_value((old or {}).get(key))} then, {shown_value(new.get(key))} now")
        raise DesignError(f"--resume: the design in {shown} was started with other options ({told}); "
                          "resume it with the same options, or start afresh with --force")


def _first_changed(old: Mapping[str, Any], new: Mapping[str, Any], first_difference: Any) -> str:
    """The first key where two specs differ, a value the user gave before the spec's name or
    description, and before the [design] table (derived from the robot when the spec has none)."""
    for skipped in (("design", "name", "description"), ("design",), ()):
        a, b = ({k: v for k, v in d.items() if k not in skipped} for d in (old, new))
        if a != b:
            return first_difference(a, b)
    return first_difference(old, new)


def _plain(data: Any) -> Any:
    """JSON's view of data (tuples as lists), so a record read back compares with a fresh one."""
    import json

    return json.loads(json.dumps(data))
