"""Every seed of a case as a checkable policy folder (``msr policy export-seeds``): each seed's actor (the
farther of its final checkpoint and its ``best.pt`` in the shipping criterion's evaluation,
:func:`~elastica_magnetic_rl.shipping.policy_runs.evaluate_seeds`) in the shipped-policy format, its training
logs, and ``seeds.json``; seeds of several runs collect in one folder."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path
from typing import Any

from elastica_magnetic.io import atomic_write_json, atomic_write_text, display_path
from elastica_magnetic.results import (
    ResultExistsError,
    check_result_folder,
    interrupted,
    recover,
    result_folder,
)

from ..runfiles.rundir import CaseDir, RunDir
from ..sweep.run_records import first_difference
from .policy_files import check_policy_case, resolve_policy
from .policy_runs import check_not_training, evaluate_seeds, prefer_best, seed_run_dirs
from .ship import check_not_in_a_policy, ship

__all__ = ["SEED_TRAINING_LOGS", "export_seeds"]


#: The training logs :func:`export_seeds` keeps beside each seed's actor (small CSVs: one row per
#: episode and per evaluation), so learning curves can be drawn from the committed seeds.
SEED_TRAINING_LOGS = RunDir.TRAINING_LOGS


def export_seeds(
    case_dir: str | Path,
    dest: str | Path,
    duration: float = 10.0,
    progress: bool = True,
    workers: int = 1,
    force: bool = False,
) -> dict[str, Any]:
    """Every seed of a case as a policy folder ``dest/seed<k>/`` (``actor.pt`` and
    ``policy.json``: what ``msr policy generate`` reads; no critic, no buffer; and the run's training
    logs, :data:`SEED_TRAINING_LOGS`) and ``dest/seeds.json``:
    one object per seed, ``{"seed", "steps", "distance_10s_m", "actor", "checkpoint",
    "meets_target"}``; ``meets_target`` is left out where there is no verdict (a case without a
    yardstick, another duration than 10 s).

    Each seed's actor is the farther in ``duration`` s (accurate physics, zero field:
    :func:`evaluate_seeds`) of its final checkpoint and its ``best.pt`` (for a reach task, the one
    that ends closer to the target); ``checkpoint`` says which,
    ``steps`` is that actor's training step and ``distance_10s_m`` its distance (m). Returns
    ``{"seeds": [...], "meeting_target": n, "total": n}``; ``meeting_target`` is ``None`` where no
    seed has a verdict (never a count of seeds that merely moved).

    Seeds trained in several runs collect in one ``dest``: the seeds already in
    ``dest/seeds.json`` that this ``case_dir`` does not have are kept (a seed it has is replaced),
    provided they were trained on the same case spec with the same hyperparameters; otherwise
    nothing is written and a ``ValueError`` names the first difference. A seed already in
    ``dest`` is replaced only with ``force``; a ``dest`` holding another case's seeds (or anything
    else) is refused even with it.

    ``dest`` is written whole or not at all (:func:`elastica_magnetic.results.result_folder`,
    ``--out``): an interruption or a failure leaves it as it was. Only ``duration`` = 10 s gives
    ``distance_10s_m``; another duration's distance is stored as ``distance_m`` with
    ``duration_s``.
    """
    case_dir, dest = Path(case_dir), Path(dest)
    seeds = seed_run_dirs(case_dir)
    for _, run in seeds:  # a seed still being trained has no final actor yet: refused, named
        check_not_training(Path(run))
    first = resolve_policy(RunDir(seeds[0][1]).checkpoint)
    case = first.case
    subject = f"case {case.name}"
    # an export killed between its renames left the earlier seeds aside: put them back before
    # they are read (else they would be neither kept nor protected by --force)
    recovered = recover(dest, option="--out") if interrupted(dest) else []
    new_seeds = {seed for seed, _ in seeds}
    try:  # checked before the long evaluations
        check_not_in_a_policy(dest, tuple(dest.parents))  # each seed is shipped there: a policy's seeds/
        check_policy_case(dest, case)
        known, earlier = _check_dest(dest, subject, new_seeds, first.meta, force)
    except (ValueError, OSError) as exc:
        for note in recovered:  # the command line prints them before the error
            exc.add_note(note)
        raise
    with result_folder(dest, kind="export-seeds", subject=subject, force=True, option="--out",
                       known_files=known, recognizes=_is_seed_export) as folder:
        for entry in earlier:  # the seeds of earlier runs that stay
            shutil.copytree(dest / str(entry["actor"]), folder.path / str(entry["actor"]))
        entries = _export_evaluated(case_dir, folder.path, case, duration, progress, workers)
        if not case.has_yardstick:  # an older export's verdicts of a case without a yardstick
            earlier = [{k: v for k, v in e.items() if k != "meets_target"} for e in earlier]
        entries = sorted(earlier + entries, key=lambda e: e["seed"])
        atomic_write_json(folder.path / "seeds.json", entries)
    verdicts = [e["meets_target"] for e in entries if isinstance(e.get("meets_target"), bool)]
    return {"seeds": entries, "total": len(entries), "notes": recovered + folder.notes,
            "meeting_target": sum(verdicts) if verdicts else None}


def _is_seed_export(folder: Path) -> bool:
    """Whether ``folder`` (without a marker: exported before markers, such as the committed
    ``rl/policies/<case>/seeds/<recipe>/``) is an export: its ``seeds.json`` a list of seed
    entries (each entry is checked later, naming a hand-edited one)."""
    try:
        entries = json.loads((folder / "seeds.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(entries, list) and bool(entries) and all(isinstance(e, dict) for e in entries)


def recognized_seed_export(folder: Path) -> dict[str, Any] | None:
    """A seed campaign written before result folders carried a marker (the committed
    ``rl/policies/<case>/seeds/<recipe>/``), as the marker it stands for (kind ``export-seeds``,
    subject its seeds' case), so that nothing is put inside it; ``None`` for another folder."""
    if not (folder / "seeds.json").is_file() or not _is_seed_export(folder):
        return None
    entries = json.loads((folder / "seeds.json").read_text(encoding="utf-8"))
    try:
        case = json.loads((folder / str(entries[0].get("actor")) / "policy.json").read_text())["case"]
    except (OSError, ValueError, KeyError, TypeError):
        case = None
    return {"kind": "export-seeds", "subject": f"case {case}" if isinstance(case, str) else None}


_SEED_FILE = re.compile(r"seed\d+/(actor\.pt|policy\.json|" + "|".join(
    re.escape(log) for log in SEED_TRAINING_LOGS) + ")")


def _check_dest(dest: Path, subject: str, new_seeds: set[int], meta: dict[str, Any],
                force: bool) -> tuple[list[str], list[dict[str, Any]]]:
    """``dest`` may receive the seeds ``new_seeds`` (another case's, or the same seeds without
    ``force``, are refused); returns its known files and the earlier seeds that stay."""
    known = _known_files(dest)
    try:
        check_result_folder(dest, kind="export-seeds", subject=subject, force=True,
                            option="--out", known_files=known, recognizes=_is_seed_export)
    except ResultExistsError as exc:
        raise ValueError(str(exc)) from None
    earlier = _earlier_exported_seeds(dest, new_seeds, meta)
    again = sorted(new_seeds & set(_exported_seed_numbers(dest)))
    if again and not force:
        raise ValueError(f"--out {display_path(dest)}: already holds seeds {', '.join(map(str, again))} "
                         "of case "
                         f"{subject.removeprefix('case ')}; pass --force to replace them, or "
                         "choose another --out")
    return known, earlier


def _known_files(dest: Path) -> list[str]:
    """The files of ``dest`` that ``export-seeds`` writes (recognises a folder written before
    result folders carried a marker, such as the committed seeds)."""
    if not dest.is_dir():
        return []
    found = ["seeds.json"]
    for path in dest.glob("seed*/*"):
        relative = path.relative_to(dest).as_posix()
        if _SEED_FILE.fullmatch(relative):
            found.append(relative)
    return found


def _exported_seed_numbers(dest: Path) -> list[int]:
    try:
        entries = json.loads((dest / "seeds.json").read_text())
    except (OSError, ValueError):
        return []
    return [e["seed"] for e in entries if isinstance(e, dict) and isinstance(e.get("seed"), int)]


def _export_evaluated(case_dir: Path, dest: Path, case, duration: float, progress: bool,
                      workers: int) -> list[dict[str, Any]]:
    """Evaluate every seed of ``case_dir`` and write each one's chosen actor into ``dest``."""
    evaluations = evaluate_seeds(case_dir, duration, progress, workers)
    entries = []
    for ev in evaluations:
        best = ev.get("best")
        use_best = prefer_best(case, ev, best)  # for a reach task, the closer to the target
        chosen = best if use_best else ev
        run = CaseDir(case_dir).seed(ev["seed"])
        source = run.best if use_best else run.checkpoint
        folder = CaseDir.seed_name(ev["seed"])
        ship(source, folder, dest=dest, measure=False, progress=False, overwrite=True,
             with_critic=False, with_card=False, lock=False)
        for log in SEED_TRAINING_LOGS:  # the learning curve stays with the actor
            if (run.path / log).is_file():
                atomic_write_text(dest / folder / log, (run.path / log).read_text())
        distance = ({"distance_10s_m": chosen["mid_dx_m"]} if duration == 10.0
                    else {"distance_m": chosen["mid_dx_m"], "duration_s": duration})
        verdict = ({"meets_target": chosen["meets_target"]} if "meets_target" in chosen else {})
        entries.append({"seed": ev["seed"], "steps": chosen["global_step"], **distance,
                        "actor": folder, "checkpoint": "best" if use_best else "final", **verdict})
    return entries


def _earlier_exported_seeds(dest: Path, replaced: set[int], meta: dict[str, Any]) -> list[dict[str, Any]]:
    """The entries of ``dest/seeds.json`` to keep beside a new export (seeds not in ``replaced``),
    after checking that their actors were trained on the same case spec with the same
    hyperparameters as the checkpoint whose metadata is ``meta``."""
    from ..td3.config import TD3Config

    path = dest / "seeds.json"
    if not path.is_file():
        return []
    try:
        earlier = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path}: unreadable ({exc}); move it away to start a new seeds.json") from exc
    if not isinstance(earlier, list) or not all(isinstance(e, dict) and "seed" in e and "actor" in e
                                                for e in earlier):
        raise ValueError(f"{path}: expected a JSON list of objects with 'seed' and 'actor'")
    for k, entry in enumerate(earlier):
        seed, actor = entry["seed"], entry["actor"]
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise ValueError(f"{path}: entry {k}: seed = {seed!r}, expected a seed number (an "
                             "integer >= 0); the file was edited by hand? restore it, or move it "
                             "away to start a new seeds.json")
        if not isinstance(actor, str) or not re.fullmatch(r"seed\d+", actor):
            raise ValueError(f"{path}: entry {k}: actor = {actor!r}, expected the folder name "
                             "seed<k>; restore the file, or move it away to start a new seeds.json")
    def as_json(x: Any) -> Any:  # checkpoints hold tuples where policy.json holds lists
        return json.loads(json.dumps(x, default=str))

    def settings(config: dict[str, Any]) -> dict[str, Any]:
        # a setting absent from an older run's config did not exist then: it ran as its default
        return {k: v for k, v in as_json({**TD3Config().to_dict(), **config}).items() if k != "seed"}

    def physical(spec: Any) -> Any:
        # a spec's [training] table holds the defaults a run started from; what the run really
        # used is its config (compared below) and each entry's steps, so a spec whose default
        # recipe changed still describes the same robot and task
        return {k: v for k, v in spec.items() if k != "training"} if isinstance(spec, dict) else spec

    config = settings(meta.get("config") or {})
    kept = []
    for entry in earlier:
        policy_json = dest / str(entry["actor"]) / "policy.json"
        try:
            other = json.loads(policy_json.read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise ValueError(f"{path}: seed {entry['seed']}: its actor's {policy_json} is unreadable "
                             f"({exc})") from exc
        if physical(other.get("case_spec")) != physical(as_json(meta.get("case_spec"))):
            theirs, mine = physical(other.get("case_spec")), physical(as_json(meta.get("case_spec")))
            raise ValueError(f"--out {display_path(dest)}: seed {entry['seed']} there was trained on another "
                             "spec of case "
                             f"{other.get('case')!r} than this run's {meta.get('case')!r} (they differ at "
                             f"{first_difference(theirs, mine)}); export into another folder (--force "
                             "replaces only seeds of the same case)")
        if entry["seed"] in replaced:
            continue
        other_config = settings((other.get("training") or {}).get("config") or {})
        if other_config != config:
            differing = sorted(k for k in set(config) | set(other_config)
                               if config.get(k) != other_config.get(k))
            raise ValueError(f"{display_path(dest)}: seed {entry['seed']} was trained with other "
                             "hyperparameters "
                             f"({', '.join(differing)} differ): export into another folder")
        kept.append(entry)
    return kept
