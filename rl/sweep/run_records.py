"""A run's record, ``run.json``: its settings (the case by name and complete, physics, episode
length, recipe, stop rule), the steps it has reached and how often it was resumed; and the check
that a resumed run keeps those settings (:func:`check_resume_settings`).
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from elastica_magnetic.io import atomic_write_json, canonical_sha256, display_path, read_json

from ..cases.case import Case
from ..runfiles.provenance import versions
from ..runfiles.rundir import RunDir

__all__ = ["check_resume_settings", "first_difference", "recorded_run_settings", "run_metadata",
           "without_default_recipe", "write_run_json"]


def run_metadata(case: Case, physics: str, duration: float, seed: int, **extra: Any) -> dict:
    """A run's record: the case by name and complete (``case_spec``: what ``msr policy generate``,
    ``refine``, ``ship`` and ``export`` rebuild it from, without the spec file), its settings."""
    limit = {"field_limit_T": case.field_limit} if case.field_actuated else {}
    return {"case": case.name, **limit, "task": case.task.kind,
            "physics": physics, "episode_duration_s": duration, "seed": int(seed), **extra,
            "case_spec": case.to_dict()}


#: Settings of a run that a resume must not change (they are the run's, in ``run.json``).
_RUN_SETTINGS = ("case", "case_spec", "physics", "episode_duration_s", "recipe", "stop_rule", "envs")
#: Values run.json repeats from elsewhere (what holds them), checked on resume.
_RECORD_COPIES = {"seed": "folder (seed<k>)", "field_limit_T": "case_spec ([actuation] field_limit)"}


#: Settings a resume takes from the runs' records when their options are left out (recorded key
#: -> the sweep setting).
RECORDED_WHEN_LEFT_OUT = {"recipe": "recipe", "episode_duration_s": "episode_duration"}


def recorded_run_settings(run_dirs: Iterable[Path]) -> dict[str, Any]:
    """The sweep settings (:data:`RECORDED_WHEN_LEFT_OUT`: recipe, episode length in s) the existing
    runs of ``run_dirs`` were trained with, each where every record that has it agrees: a resume
    that leaves the option out keeps the runs' value. Unreadable records are skipped (the resume's
    checks name them)."""
    found: dict[str, set[str]] = {key: set() for key in RECORDED_WHEN_LEFT_OUT}
    for run_dir in run_dirs:
        path = RunDir(run_dir).run_json
        try:
            record = read_json(path) if path.is_file() else {}
        except (OSError, ValueError):
            continue
        for key in found:
            if isinstance(record, dict) and key in record:
                found[key].add(json.dumps(record[key]))
    return {RECORDED_WHEN_LEFT_OUT[key]: json.loads(next(iter(values)))
            for key, values in found.items() if len(values) == 1}


def _randomized(randomize: Any) -> str:
    """A case's ``[training] randomize`` in words."""
    if not randomize:
        return "its nominal robot (no randomization)"
    return f"robots randomized per episode ({json.dumps(randomize)[:120]})"


def check_resume_settings(run_dir: Path, metadata: dict[str, Any],
                          checkpoint_metadata: dict[str, Any] | None = None) -> None:
    """A resumed run keeps its case, physics, episode length and crawlers per seed (``envs``: its
    checkpoint holds their state): refuse other values, naming the option and the run's value.
    ``checkpoint_metadata``: the settings the run's checkpoint holds; a ``run.json`` that
    disagrees with them was edited (also one whose hash was removed with the edit)."""
    run_json = RunDir(run_dir).run_json
    if not run_json.is_file():  # without it the resume would take today's options for the run's
        raise ValueError(f"cannot resume {display_path(run_dir)}: its {RunDir.RUN_JSON} (the record "
                         "of the run's case, physics and episode length) is missing, so the resume "
                         "cannot keep the run's settings; restore it (e.g. from a backup), or "
                         "train the seed afresh without --resume")
    record = read_json(run_json)
    options = {"case": "--case", "physics": "--physics", "episode_duration_s": "--episode-duration",
               "recipe": "--recipe", "stop_rule": "--stop-when", "envs": "--envs"}
    for key in _RUN_SETTINGS:
        if key == "case_spec" and key in record:
            run_spec, spec = without_default_recipe(record[key]), without_default_recipe(metadata[key])
            if run_spec != spec:
                where = first_difference(run_spec, spec)
                if "randomize" in where:  # --randomize (or the recipe's) sets it, not only the spec
                    given = (spec.get("training") or {}).get("randomize")
                    had = (run_spec.get("training") or {}).get("randomize")
                    raise ValueError(f"--randomize (or the spec's [training] randomize) gives case "
                                     f"{metadata['case']!r} {_randomized(given)}, and the run trained on "
                                     f"{_randomized(had)} ({run_json}): a resumed run keeps the robots it "
                                     "trains on; leave --randomize out (or give the run's), or train a "
                                     "new run (another --out)")
                raise ValueError(f"the spec of case {metadata['case']!r} differs from the run's at "
                                 f"{where} ({run_json}): a resumed run keeps its case")
        elif (key in record and isinstance(record[key], float)
              and not math.isfinite(record[key])):
            raise ValueError(f"{run_json}: {key} is {record[key]!r}, not a finite number: the "
                             "record was edited or damaged; restore it (e.g. from a backup)")
        elif key in record and key in metadata and not _same_kind(record[key], metadata[key]):
            raise ValueError(f"{run_json}: {key} is {record[key]!r} ({_kind(record[key])}), "
                             f"expected {_kind(metadata[key])} such as {metadata[key]!r}: the "
                             "record was edited or damaged; restore it (e.g. from a backup)")
        elif key in record and key in metadata and record[key] != metadata[key]:
            raise ValueError(f"{options[key]} {metadata[key]} differs from the run's {record[key]} "
                             f"({run_json}): a resumed run keeps its settings (give {options[key]} "
                             f"{record[key]}, or leave the option out)")
    for key, what in _RECORD_COPIES.items():  # values the record repeats: an edit would be lost
        if key in record and key in metadata and record[key] != metadata[key]:
            raise ValueError(f"{run_json}: {key} is {record[key]!r} but the run's {what} gives "
                             f"{metadata[key]!r}: the record was edited (a resume would ignore the "
                             "edit and write the run's value back); restore it (e.g. from a backup)")
    written = record.get(RECORD_HASH_KEY) if isinstance(record, dict) else None
    if written is not None and written != record_hash(record):
        raise ValueError(f"{run_json}: edited since msr wrote it (its {RECORD_HASH_KEY} no longer "
                         "matches): a resume takes the run's settings from its checkpoint and its "
                         "case, and would overwrite the edits without a word; restore the file "
                         "(e.g. from a backup), and change a setting with the command's option "
                         "instead (a resumed run keeps its settings)")
    if checkpoint_metadata and checkpoint_metadata.get("case") == metadata.get("case"):
        # an edit the above missed (another case's checkpoint is named by the checkpoint's check)
        _check_against_checkpoint(run_json, record, checkpoint_metadata)


def _check_against_checkpoint(run_json: Path, record: Any, saved: dict[str, Any] | None) -> None:
    """``run.json``'s settings against the copy the checkpoint holds (written together by msr)."""
    if not isinstance(record, dict) or not saved:
        return
    for key in (*_RUN_SETTINGS, *_RECORD_COPIES):
        mine, theirs = record.get(key), saved.get(key)
        if key == "case_spec":  # the spec's default recipe is not the run's (see above)
            mine, theirs = without_default_recipe(mine), without_default_recipe(theirs)
        if key in record and key in saved and mine != theirs:
            where = first_difference(mine, theirs) if key == "case_spec" else key
            raise ValueError(f"{run_json}: {where} differs from the run's checkpoint (run.json: "
                             f"{_shown(record[key], key)}, checkpoint: {_shown(saved[key], key)}): "
                             "the record was edited; a resume keeps the run's settings, so restore "
                             "it (e.g. from a backup) and change a setting with the command's "
                             "option instead")


def _shown(value: Any, key: str) -> str:
    return "its case spec" if key == "case_spec" else repr(value)


def _kind(value: Any) -> str:
    """The JSON kind of a record's value, in words."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true/false"
    if isinstance(value, (int, float)):
        return "a number"
    return {str: "a string", dict: "a table", list: "a list"}.get(type(value), type(value).__name__)


def _same_kind(a: Any, b: Any) -> bool:
    """Two values a record and today's settings can compare (a string "20" is not 20.0)."""
    return a is None or b is None or _kind(a) == _kind(b)


def without_default_recipe(spec: Any) -> Any:
    """A case spec without its ``[training] recipe``: the recipe a run really used is its own
    setting (``recipe``, compared on its own), so a spec whose default recipe changed since the
    run started still resumes it."""
    if not isinstance(spec, dict) or not isinstance(spec.get("training"), dict):
        return spec
    return {**spec, "training": {k: v for k, v in spec["training"].items() if k != "recipe"}}


def first_difference(a: Any, b: Any, path: str = "") -> str:
    """The first key (``[table] key``) where two spec dicts differ."""
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b)):
            if a.get(key) != b.get(key):
                return first_difference(a.get(key), b.get(key), f"{path}.{key}" if path else key)
    if "." in path:
        table, key = path.rsplit(".", 1)
        return f"[{table}] {key}"
    return path or "the top level"


def write_run_json(run_dir: Path, config, metadata: dict[str, Any], steps: int, threads: int,
                    resumed_now: bool) -> None:
    """``run.json``: the run's settings, the steps it has reached and how often it was resumed
    (written when a new run starts, with 0 steps, and when a training call has finished)."""
    record = {}
    run_json = RunDir(run_dir).run_json
    if run_json.is_file():
        record = read_json(run_json)
    record.pop(RECORD_HASH_KEY, None)
    data = json.loads(json.dumps({
        **record, **metadata, "steps": int(steps), "config": config.to_dict(),
        "torch_threads": int(threads), "versions": versions(),
        "resumed": int(record.get("resumed", 0)) + int(resumed_now)}, default=str))
    atomic_write_json(run_json, {**data, RECORD_HASH_KEY: record_hash(data)})


#: The key of ``run.json`` holding the hash of the rest of it as msr wrote it: a resume refuses a
#: record edited by hand (its edits would be ignored and overwritten without a word).
RECORD_HASH_KEY = "record_sha256"


def record_hash(record: dict[str, Any]) -> str:
    """The SHA-256 of ``record`` (without :data:`RECORD_HASH_KEY`) in a canonical JSON form."""
    return canonical_sha256({k: v for k, v in record.items() if k != RECORD_HASH_KEY})
