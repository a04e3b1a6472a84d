"""Ship a trained run as a policy folder in the shipped format (``msr policy ship``): ``actor.pt``,
``critic.pt``, ``policy.json`` (:data:`~elastica_magnetic_rl.shipping.policy_files.POLICY_FORMAT`), the
measured waveform ``fields.csv`` and ``MODEL_CARD.md``; and a shipped policy's notes (``msr policy notes``).

A *policy* argument is a run directory (holding ``checkpoint.pt``), a checkpoint file, a
shipped-format directory (``actor.pt`` + ``policy.json``), or the name of a shipped policy in
``rl/policies/`` (see :func:`~elastica_magnetic_rl.shipping.policy_files.resolve_policy`).
"""

from __future__ import annotations

import dataclasses
import io
import json
import re
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from elastica_magnetic.filesets import check_files, record_files, recorded_files, replace_files
from elastica_magnetic.io import (
    OutputPathError,
    atomic_write_bytes,
    atomic_write_json,
    atomic_write_text,
    display_path,
    normalized_path,
    read_json,
)
from elastica_magnetic.locks import FolderLock
from elastica_magnetic.plausibility import SettingNotAppliedWarning
from elastica_magnetic.result_markers import manifest_results_in
from elastica_magnetic.result_places import (
    ResultExistsError,
    check_enclosing,
    check_not_another_result,
    inside_result,
    result_above,
    training_run_in,
)

from ..cases.case import Case
from ..cases.tasks import RING_TARGETS, GotoTask, ReachTask
from ..envs.yardsticks import SteeringFieldPolicy
from ..runfiles.provenance import machine_fingerprint
from ..runfiles.rundir import CaseDir
from .generate import reach_metrics
from .goto import evaluate_ring, goto_result, goto_target, ring_summary
from .model_card import NOTES_SECTION, model_card, replace_card_section, seed_meets_target
from .policy_files import (
    ACTOR_ACTIVATION,
    ACTOR_OUTPUT,
    POLICIES_DIR,
    POLICY_FORMAT,
    POLICY_JSON,
    RING_PNG,
    SEEDS_FOLDER,
    SHIPPED_FILES,
    TIP_PATHS_PNG,
    LoadedPolicy,
    action_spec_of,
    case_spec_difference,
    case_spec_sha256,
    observation_spec_of,
    policy_holder,
    read_policy_json,
    resolve_policy,
    weights_sha256,
)
from .policy_runs import evaluate_seeds, node_dx, run_policy
from .seed_report import CARD_SECTION as SEEDS_CARD_SECTION
from .seed_report import SeedsOfAnotherSpec, case_seeds, seeds_markdown

__all__ = ["SHIPPED_FILES", "check_not_in_a_policy", "check_policy_name", "check_ship_target", "set_notes",
           "ship"]


def check_policy_name(name: str) -> str:
    """A policy name is one folder name: no separator, not ``.``/``..``, not hidden, printable;
    else a ``ValueError`` naming ``--name`` (a name must not write outside ``--out``)."""
    if not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9._-]{0,99}", name):
        raise ValueError(f"--name {name!r}: a policy name is one folder name of letters, digits, "
                         "'-', '_' and '.' (no space, no '/', not starting with '.' or '-', at most "
                         "100 characters), e.g. m1-4mT")
    return name


def check_ship_target(name: str, dest: str | Path | None) -> None:
    """``--name`` a plain name and ``--out`` a folder (or a path to one): checked before any
    measuring, else the named error."""
    check_policy_name(name)
    if dest is not None:
        check_not_in_a_policy(dest, (Path(dest), *Path(dest).parents))
        # nothing goes inside another command's result (a training's seed folder, a simulation)
        check_enclosing(normalized_path(Path(dest) / name), "--out")
    # nor onto another command's result or a training's case folder (a policy there replaced)
    target = normalized_path((Path(dest) if dest is not None else POLICIES_DIR) / name)
    check_not_another_result(target, "--out/--name", held_ok=True)
    for case_folder in sorted(p for p in target.iterdir() if p.is_dir()) if target.is_dir() else ():
        if (run := training_run_in(case_folder)) is not None:  # a training's --out: its policy.json
            raise ResultExistsError(  # would make that folder a shipped policy, refusing the next run
                f"--out/--name {display_path(target)}: holds the case folder {case_folder.name}/ of a "
                f"training ({run.name}, `msr train`): a policy there would make the training's folder a "
                "shipped policy; choose another --out/--name")


def check_not_in_a_policy(dest: str | Path, folders: Sequence[Path]) -> None:
    """Refuse (:class:`OutputPathError`) ``--out dest`` where one of ``folders`` (``dest`` and its
    parents, or only its parents) is a file, or a shipped policy that ``dest`` lies in outside the
    subfolders it keeps open to other results (its ``seeds/``, where seed campaigns go)."""
    for parent in folders:
        if parent.exists() and not parent.is_dir():
            raise OutputPathError(f"--out {display_path(dest)}: {display_path(parent)} is a file, not a "
                                  "folder")
        inside = Path(dest).relative_to(parent).parts if parent != Path(dest) else ()
        open_to = manifest_results_in(parent)
        if (parent / POLICY_JSON).is_file() and not (inside and inside[0] in open_to):
            if (outer := result_above(parent)) is not None:  # a seed of a campaign: the campaign named
                raise OutputPathError(inside_result(normalized_path(dest), *outer, "--out"))
            seeds = f" (its {open_to[0]}/ holds its case's seed campaigns)" if open_to else ""
            raise OutputPathError(f"--out {display_path(dest)}: {display_path(parent)} is a shipped policy: "
                                  f"a policy goes beside another, not inside it{seeds}; choose another --out")


@dataclasses.dataclass(frozen=True)
class ShipOptions:
    """How :func:`ship` packs a policy: into ``dest/<name>/`` (``None``: ``rl/policies``),
    measuring it for ``duration`` s (``measure``), and every seed of its case
    (``evaluate_all_seeds``), with ``notes`` (Markdown) in its card, replacing a policy there
    (``overwrite``), with ``critic.pt`` (``with_critic``) and ``MODEL_CARD.md`` (``with_card``),
    under the folder's lock (``lock``), with ``progress`` bars."""

    dest: str | Path | None = None
    measure: bool = True
    duration: float = 10.0
    progress: bool = True
    overwrite: bool = False
    evaluate_all_seeds: bool = False
    notes: str | None = None
    with_critic: bool = True
    with_card: bool = True
    lock: bool = True


def ship(run: str | Path, name: str, options: ShipOptions | None = None, /,
         **changes: Any) -> dict[str, Any]:
    """Pack a run's checkpoint into the shipped-policy format ``dest/<name>/`` (default
    ``rl/policies/<name>/``): ``actor.pt`` and ``critic.pt`` (state dicts of
    :class:`~elastica_magnetic_rl.td3.networks.Actor` /
    :class:`~elastica_magnetic_rl.td3.networks.TwinCritic`), ``policy.json`` (case, observation layout and
    scaling, action scaling, architecture, provenance) and ``MODEL_CARD.md``.

    With ``measure`` the policy is run for ``duration`` s in the accurate physics from a zero field
    (as :func:`generate`); the distance goes into the card and the waveform into ``fields.csv``.
    The success count over seeds comes from the case's ``summary.json`` when it is found; with
    ``evaluate_all_seeds`` every seed of the case is also run like this (:func:`evaluate_seeds`)
    and the card lists each seed's distance and how many reach the case's target (none are
    counted for a case without a yardstick: ``meeting_target`` is ``None``). ``notes``
    (Markdown) becomes the card's "Notes" section: what the numbers do not say. ``with_critic`` /
    ``with_card``: also write ``critic.pt`` / ``MODEL_CARD.md``.

    The policy's files are put into ``dest/<name>/`` all together or not at all
    (:func:`elastica_magnetic.filesets.replace_files`: the folder may hold other things, such as
    ``seeds/``), under its lock; ``lock=False`` writes them directly (for a caller that writes a
    temporary result folder of its own). ``dest`` and ``name`` are checked before any measuring.
    ``options`` (:class:`ShipOptions`) with ``changes`` (its fields by name) give these.
    """
    o = dataclasses.replace(options or ShipOptions(), **changes)
    dest, measure, duration, progress = o.dest, o.measure, o.duration, o.progress
    overwrite, notes, with_critic = o.overwrite, o.notes, o.with_critic
    check_ship_target(name, dest)
    policy = resolve_policy(run)
    if policy.kind != "checkpoint":
        raise ValueError(f"{run}: ship takes a run directory or checkpoint, not a shipped policy")
    target = (Path(dest) if dest is not None else POLICIES_DIR) / name
    present = [f for f in SHIPPED_FILES if (target / f).exists()]
    given = f"--out {display_path(dest)}, " if dest is not None else ""
    where = f"{display_path(target)} ({given}--name {name})"
    theirs = [f for f in present if not (f in recorded_files(target) or _holds_a_policy(target))]
    if theirs and not (target / POLICY_JSON).is_file():  # no policy there to replace: the user's files
        raise ResultExistsError(f"{where}: holds {', '.join(theirs)}, which msr did not write (no "
                                "policy.json beside them, no record of msr's): a policy's files would "
                                "replace the user's; move them away, or choose another --out or --name")
    if present and not overwrite:
        raise FileExistsError(f"{where}: already holds a policy ({', '.join(present)}); pass --force to "
                              "replace it")
    if present:
        _check_same_case(target, policy.case.name, policy.case.to_dict())
    if present and o.lock:  # a file edited since msr wrote it is refused now, before measuring
        check_files(target, present, force=True, option="--out", adopt=_holds_a_policy(target))
        _check_card_recorded(target)
        _warn_of_dropped_notes(target, notes)
    # Everything is computed before the folder is touched: a failed or interrupted measurement
    # leaves a policy being replaced (--force) as it was.
    case = policy.case
    summary = _find_summary(policy.source, case.name)
    measured = _measure(policy, duration, progress) if measure else Measured()
    seed_evaluations = None
    if o.evaluate_all_seeds:
        if summary is None:
            raise FileNotFoundError(f"{policy.source}: no summary.json of case {case.name} found "
                                    "above the run, so its seeds cannot be evaluated")
        seed_evaluations = evaluate_seeds(_find_case_dir(policy.source, case.name), duration,
                                          progress)
    info = _policy_info(policy, name, summary, seed_evaluations, measured.evaluation, notes)
    card = _ship_card(info, summary, case, target) if o.with_card else None
    if o.lock:
        written = _policy_files(policy, measured, card, with_critic)
        # the replaced policy's optional files this one lacks go in the same commit
        stale = [f for f in SHIPPED_FILES if f not in written]
        with replace_files(target, written, force=overwrite, option="--out", remove=stale,
                           adopt=_holds_a_policy(target), holder=policy_holder(case.name),
                           results_in=(SEEDS_FOLDER,)) as files:
            _write_policy_folder(files.path, policy, info, measured, card, with_critic)
        lock_notes = files.notes
    else:
        _write_policy_folder(target, policy, info, measured, card, with_critic)
        lock_notes = []
    return {"name": name, "dir": str(target), "case": case.name,
            "evaluation": measured.evaluation,
            "files": sorted(p.name for p in target.iterdir() if p.name in SHIPPED_FILES),
            "lock_notes": lock_notes}


def _check_same_case(target: Path, case: str, spec: dict[str, Any]) -> None:
    """Refuse to replace a shipped policy of another case (``--force`` replaces only a result for the
    same subject, as ``msr policy export`` and ``generate``): a name reused by mistake must not
    remove another robot's policy. The same name with another spec (a user's file named as a
    shipped case) is another case: its differing keys are named."""
    try:
        meta = read_policy_json(target / POLICY_JSON)
    except (OSError, ValueError):  # no readable policy.json: the file checks judge the folder
        return
    shipped = meta.get("case")
    if shipped != case:
        raise ResultExistsError(
            f"--out {display_path(target)}: holds the shipped policy of case {shipped!r}, and this run is "
            f"of case {case!r}; choose another --name or --out (--force replaces only a policy of the "
            "same case)")
    differ = case_spec_difference(meta.get("case_spec"), spec)
    if differ is not None:
        raise ResultExistsError(
            f"--out {display_path(target)}: holds the shipped policy of case {case!r} with another spec "
            f"(they differ at {differ}): a case of the same name, not the same "
            "case; choose another --name or --out (--force replaces only a policy of the same case)")


def _check_card_recorded(target: Path, option: str = "--out", again: str = "ship again") -> None:
    """Refuse to replace a ``MODEL_CARD.md`` msr has no record of writing (a policy shipped before
    msr kept records, or whose ``.msr-files.json`` was removed): the card is the file people edit,
    and without the record msr cannot tell an edited one from its own. The other files of such a
    policy are adopted as msr's (nobody edits weights or ``policy.json`` by hand). ``option`` names
    the folder's argument, ``again`` what to do once the card is moved away."""
    card = target / "MODEL_CARD.md"
    if card.is_file() and "MODEL_CARD.md" not in recorded_files(target):
        raise ResultExistsError(
            f"{option} {display_path(target)}: MODEL_CARD.md has no record of being written by msr "
            "(.msr-files.json lacks it), so it may hold your edits: msr does not replace it; move "
            f"it away (or delete it) and {again}")


def _holds_a_policy(folder: Path) -> bool:
    """Whether ``folder`` holds a shipped policy written before msr recorded the files it writes (a
    readable ``policy.json`` and no record): its files are then adopted as msr's own (``--force``
    replaces them). A folder with a record is judged by it: a file it does not list is the user's."""
    if recorded_files(folder):
        return False
    try:
        read_policy_json(folder / POLICY_JSON)
    except (OSError, ValueError):
        return False
    return True


def _measure(policy: LoadedPolicy, duration: float, progress: bool) -> Measured:
    """The shipping criterion's run of a policy (``duration`` s, accurate physics, zero field):
    its ``evaluation`` entry of ``policy.json`` and its field waveform ``(steps, 3)`` (T; ``None``
    when it took no step). A tip-reach policy: :func:`_measure_tip_reach`, no waveform."""
    if not policy.case.field_actuated:
        return _measure_tip_reach(policy, duration)
    goto = isinstance(policy.case.task, GotoTask)
    target = goto_target(policy.case, None)
    rollout = run_policy(policy, duration, "accurate", "zero", progress, target=target)
    measured = {"duration_s": float(rollout.times[-1]), "physics": "accurate",
                "initial_field": "zero", "mid_dx_m": rollout.mid_dx,
                "node_dx_m": node_dx(rollout), "diverged": rollout.meta["diverged"],
                "machine": machine_fingerprint()}
    if isinstance(policy.case.task, ReachTask):
        measured["reach"] = reach_metrics(rollout, policy.case.task)
    if goto:  # its waveform to the target ahead, and the judge: the ring, beside the yardstick's
        measured["goto"] = goto_result(rollout, policy.case.task, target)
        if progress:  # minutes of work whatever --duration: said before it starts
            episode = policy.case.task.episode_duration
            print(f"ship: measuring the goto ring: {RING_TARGETS} targets for the policy and "
                  f"{RING_TARGETS} for the steering yardstick, {episode:g} s each in the accurate "
                  "physics (the judge of a goto policy; --duration sets the rollout above only)",
                  file=sys.stderr, flush=True)
        paths: dict[str, list] = {"this policy": [], "the steering yardstick": []}
        measured["ring"] = _ring_entry(policy, progress, paths["this policy"])
        measured["yardstick_ring"] = _ring_entry(SteeringFieldPolicy(policy.case), progress,
                                                 paths["the steering yardstick"])
        figure = _ring_figure(policy.case, measured["ring"], measured["yardstick_ring"], paths)
        return Measured(measured, rollout.fields if rollout.n_steps else None, figure, RING_PNG)
    return Measured(measured, rollout.fields if rollout.n_steps else None)


def _ring_figure(case: Case, ring: dict[str, Any], yardstick: dict[str, Any],
                 paths: dict[str, list]) -> bytes:
    """The top view of a goto policy's ring beside its yardstick's (PNG bytes)."""
    from ..reports.goto_figures import plot_rings_beside

    runs = dict(zip(paths, (ring["targets_table"], yardstick["targets_table"]), strict=True))
    return _png(plot_rings_beside, runs, paths,
                title=f"{case.name}: the middle's paths to the ring's {len(ring['targets_table'])} targets "
                      f"({ring['duration_s']:g} s each, accurate physics)")


def _png(plot: Any, runs: dict[str, Any], paths: dict[str, Any], title: str) -> bytes:
    """``plot(runs, paths, file, title=)``'s figure as PNG bytes, drawn in a scratch folder before
    the policy's folder is touched."""
    import tempfile

    with tempfile.TemporaryDirectory() as scratch:
        return plot(runs, paths, Path(scratch) / "figure.png", title=title).read_bytes()


def _measure_tip_reach(policy: LoadedPolicy, duration: float) -> Measured:
    """A tip-reach policy judged as the case is (:func:`~.tip_reach.judge_held_out`): its case's
    held-out targets in the accurate physics, each for the task's episode (``duration`` s at
    most), beside the case's yardstick on the same targets; the tip's paths of both drawn."""
    from ..reports.goto_figures import plot_tip_paths_beside
    from .tip_reach import judge_held_out

    paths: dict[str, np.ndarray] = {}
    judged = judge_held_out(policy.case, policy, duration, with_yardstick=True, paths=paths)
    seconds = judged.pop("duration_s")
    figure = _png(plot_tip_paths_beside,
                  {"this policy": judged["policy"], "the steering yardstick": judged["yardstick"]},
                  {"this policy": paths["policy"], "the steering yardstick": paths["yardstick"]},
                  title=f"{policy.case.name}: the tip's paths to the {len(judged['policy']['targets_m'])} "
                        f"held-out targets ({seconds:g} s, accurate physics)")
    return Measured({"duration_s": seconds, "physics": "accurate", "machine": machine_fingerprint(),
                     "tip_reach": judged}, figure=figure)


@dataclasses.dataclass(frozen=True)
class Measured:
    """What :func:`_measure` gives a policy's files: the ``evaluation`` entry of ``policy.json``,
    the field waveform ``(steps, 3)`` T for ``fields.csv`` (``None``: none, a tip-reach policy or no
    step taken), and a figure of the paths to the policy's targets (PNG bytes; ``None``: none)
    written as ``figure_name``: a tip-reach policy's :data:`TIP_PATHS_PNG`, a goto policy's
    :data:`RING_PNG`."""

    evaluation: dict[str, Any] | None = None
    fields: np.ndarray | None = None
    figure: bytes | None = None
    figure_name: str = TIP_PATHS_PNG


def _ring_entry(policy, progress: bool, paths: list | None = None) -> dict[str, Any]:
    """A goto policy's ring of targets in the accurate physics, each for the task's episode from
    a zero field, every core at work: the summary and the rows (``paths`` receives the middle's
    path ``(T, 2)``, m, to each target)."""
    import os

    rows = evaluate_ring(policy, None, "accurate", progress=progress, paths=paths,
                         workers=os.cpu_count() or 1)
    source = policy.source  # a file (this machine's folders left out) or the yardstick's words
    label = _portable_source(source, policy.case.name) if isinstance(source, Path) else str(source)
    return {"policy": label, "physics": "accurate",
            "duration_s": policy.case.task.episode_duration, **ring_summary(rows),
            "targets_table": rows}


def _policy_info(policy: LoadedPolicy, name: str, summary: dict[str, Any] | None,
                 seed_evaluations: list[dict[str, Any]] | None, measured: dict[str, Any] | None,
                 notes: str | None) -> dict[str, Any]:
    """The shipped policy's ``policy.json`` (format :data:`POLICY_FORMAT`)."""
    meta, case = policy.meta, policy.case
    refined = meta.get("command") == "refine"
    return {
        "format": POLICY_FORMAT,
        "name": name,
        "case": case.name,
        "robot": case.robot.name,
        "magnetization": case.robot.tables["robot"]["magnetization"]["kind"],
        "field_limit_T": case.field_limit if case.field_actuated else None,
        "task": case.task.kind,
        "actor_sha256": weights_sha256(policy.actor.state_dict()),
        "case_spec_sha256": case_spec_sha256(case.to_dict()),
        "architecture": {"type": "mlp", "obs_dim": policy.obs_dim, "act_dim": policy.act_dim,
                         "hidden_sizes": list(policy.hidden_sizes), "activation": ACTOR_ACTIVATION,
                         "output": ACTOR_OUTPUT,
                         "module": "elastica_magnetic_rl.td3.networks.Actor "
                                   "(net = Sequential of Linear/ReLU)",
                         "critic_layer_norm": bool((meta.get("config") or {}).get(
                             "critic_layer_norm", False)),
                         "actor_input": str((meta.get("config") or {}).get("actor_input", "observation")),
                         # a mirror-symmetric steering actor (td3.steering_inputs.mirror_symmetric)
                         **({"actor_mirror": True} if (meta.get("config") or {}).get("actor_mirror") else {}),
                         # a residual policy: the actor corrects the case's yardstick (envs.residual)
                         "residual": float((meta.get("config") or {}).get("residual", 0.0)),
                         **_critic_widths(meta.get("config") or {})},
        "observation": observation_spec_of(case),
        "action": action_spec_of(case),
        "training": {
            "seed": meta.get("seed"),
            "training_steps": meta.get("training_steps", meta.get("global_step")),
            "refine_steps": meta.get("refine_steps", 0) if refined else 0,
            # a refinement ran in the accurate physics unless its run says otherwise
            **({"refine_physics": meta.get("physics", "accurate")} if refined else {}),
            "global_step": meta.get("global_step"),
            "config": meta.get("config"),
            "source": _portable_source(policy.source, case.name),
            "best_evaluation": meta.get("checkpoint_kind") == "best",
            # the run's recipe and the precision its updates ran in (a CPU without bfloat16 units
            # trains fp32 where bf16 was asked, and the two are different runs of one seed)
            **{key: meta[key] for key in ("recipe", "precision") if meta.get(key)},
        },
        "seeds": {"succeeded": summary.get("succeeded"), "total": len(summary.get("seeds", [])),
                  "success_threshold_return": summary.get("success_threshold_return"),
                  "evaluations": seed_evaluations,
                  "meeting_target": _meeting_target(seed_evaluations, case)}
        if summary else None,
        "evaluation": measured,
        **_yardstick_info(case),
        "target": case.target_label,
        "notes": notes,
        "case_spec": case.to_dict(),
    }


def _meeting_target(seed_evaluations: list[dict[str, Any]] | None, case: Case) -> int | None:
    """How many seeds reach the target (:func:`seed_meets_target`); ``None`` where no seed has a
    verdict (a case without a yardstick, evaluations not 10 s long, none made)."""
    verdicts = [seed_meets_target(e, case) for e in seed_evaluations or []]
    verdicts = [v for v in verdicts if v is not None]
    return sum(verdicts) if verdicts else None


def _yardstick_info(case: Case) -> dict[str, Any]:
    """``policy.json``'s yardstick: ``yardstick_10s_m`` (m in 10 s, accurate physics, field from
    zero) and its ``yardstick_source`` (the authors' policy, a baseline sweep, ...); nothing for a
    case without one (older files named it ``authors_mid_dx_10s_m`` whatever the case)."""
    if case.yardstick.distance_10s <= 0.0:
        return {}
    return {"yardstick_10s_m": case.yardstick.distance_10s,
            "yardstick_source": case.yardstick.source}


def _warn_of_dropped_notes(target: Path, notes: str | None) -> None:
    """A replaced policy's notes are not carried over to the new one: said, not done silently."""
    try:
        old = json.loads((target / POLICY_JSON).read_text(encoding="utf-8")).get("notes")
    except (OSError, ValueError, AttributeError):
        return
    if old and notes is None:
        warnings.warn(SettingNotAppliedWarning(
            f"{display_path(target)}: the replaced policy's notes (policy.json) are not carried over "
            f"to the new one: give them with --notes, or afterwards with msr policy notes "
            f"{target.name if target.parent.resolve() == POLICIES_DIR.resolve() else display_path(target)} "
            "--file F"),
            stacklevel=3)


def _ship_card(info: dict[str, Any], summary: dict[str, Any] | None, case: Case,
               target: Path) -> str:
    """The model card; the committed seeds' table (``msr policy seeds --card``) survives a re-ship."""
    card = model_card(info, summary, case)
    try:
        groups = case_seeds(case, target.parent)
    except SeedsOfAnotherSpec as exc:  # the case's name, another robot: its seeds are not this one's
        warnings.warn(SettingNotAppliedWarning(f"{exc}; the model card carries no seeds table"), stacklevel=3)
        groups = []
    if groups:
        card = replace_card_section(card, SEEDS_CARD_SECTION, seeds_markdown(case, groups),
                                    before="## Evaluation")
    return card


def _policy_files(policy: LoadedPolicy, measured: Measured, card: str | None,
                  with_critic: bool) -> list[str]:
    """The files :func:`_write_policy_folder` writes."""
    return ["actor.pt", POLICY_JSON, *(["critic.pt"] if policy.critic is not None and with_critic
                                      else []),
            *(["fields.csv"] if measured.fields is not None else []),
            *([measured.figure_name] if measured.figure is not None else []),
            *(["MODEL_CARD.md"] if card else [])]


def _write_policy_folder(target: Path, policy: LoadedPolicy, info: dict[str, Any],
                         measured: Measured, card: str | None, with_critic: bool) -> None:
    """Each file atomically; ``policy.json``, which names the actor's checksum, after the weights;
    the optional files a replaced policy had and this one has not are removed."""
    import torch

    from elastica_magnetic import write_field_csv

    def save_weights(name: str, network: Any) -> None:
        # saved to memory, then written by Python: on a full disk torch's own file writer aborts
        # with "unexpected pos" instead of an error naming the file
        buffer = io.BytesIO()
        torch.save(network.state_dict(), buffer)
        atomic_write_bytes(target / name, buffer.getvalue())

    target.mkdir(parents=True, exist_ok=True)
    save_weights("actor.pt", policy.actor)
    written = {"actor.pt", POLICY_JSON}
    if policy.critic is not None and with_critic:
        save_weights("critic.pt", policy.critic)
        written.add("critic.pt")
    if measured.fields is not None:
        write_field_csv(target / "fields.csv", measured.fields)
        written.add("fields.csv")
    if measured.figure is not None:
        atomic_write_bytes(target / measured.figure_name, measured.figure)
        written.add(measured.figure_name)
    atomic_write_json(target / POLICY_JSON, info)
    if card is not None:
        atomic_write_text(target / "MODEL_CARD.md", card)
        written.add("MODEL_CARD.md")
    for stale in set(SHIPPED_FILES) - {"actor.pt", POLICY_JSON} - written:  # the optional ones
        (target / stale).unlink(missing_ok=True)  # the replaced policy's, not this one's


def set_notes(policy: str | Path, notes: str | None,
              policies_dir: str | Path | None = None) -> dict[str, Any]:
    """Replace a shipped policy's notes (Markdown: what the numbers do not say; None or blank
    removes them). Their one home is ``policy.json``'s ``notes``; the model card's "Notes" section
    is rendered from it, so the two never disagree. ``policy``: a shipped-policy folder or name.
    Both files are replaced together (:func:`elastica_magnetic.filesets.replace_files`); the actor
    is not touched."""
    resolved = resolve_policy(policy, policies_dir)
    if resolved.kind != "shipped":
        raise ValueError(f"{policy}: notes belong to a shipped policy (a folder with policy.json), "
                         "not to a run or checkpoint")
    folder = resolved.source
    _check_card_recorded(folder, option="policy", again="set the notes again: they go into policy.json, "
                                                        "from which msr policy notes then writes a new card")
    unrecorded = not recorded_files(folder)  # a policy copied without its record: its files adopted
    notes = notes.strip() if notes and notes.strip() else None
    info = json.loads((folder / POLICY_JSON).read_text()) | {"notes": notes}
    card_path = folder / "MODEL_CARD.md"
    anew = not card_path.is_file()
    old_card = None if anew else card_path.read_text()
    if old_card is not None:
        card = replace_card_section(old_card, NOTES_SECTION, notes, before="## Limitations")
    else:  # moved away or lost: a new one from policy.json, as ship writes it
        card = _ship_card(info, None, resolved.case, folder)
    names = [POLICY_JSON, "MODEL_CARD.md"]
    with replace_files(folder, names, force=True, option="policy", adopt=True,
                       force_option="msr policy notes", holder=policy_holder(resolved.case.name),
                       results_in=(SEEDS_FOLDER,)) as files:
        atomic_write_json(files.path / POLICY_JSON, info)
        atomic_write_text(files.path / "MODEL_CARD.md", card)
    lock_notes = files.notes
    if unrecorded:  # the record now names the policy's other files too, as ship's would
        with FolderLock(folder, option="policy"):
            record_files(folder, [f for f in SHIPPED_FILES if f not in names and (folder / f).is_file()])
    return {"name": info.get("name", folder.name), "dir": str(folder), "notes": notes,
            "card_updated": card != old_card, "card_written_anew": anew, "lock_notes": lock_notes}


def _portable_source(path: Path, case: str) -> str:
    """Where a shipped policy came from, without this machine's folders: the path from the case's
    training folder on (``m1-4mT/seed3/refined/checkpoint.pt``), else the file's name."""
    parts = Path(path).parts
    if case in parts:
        return "/".join(parts[len(parts) - 1 - parts[::-1].index(case):])
    return Path(path).name


#: What to do about a damaged ``summary.json`` of a case folder.
_SUMMARY_FIX = ("restore it (e.g. from a backup); it is the case's summary of msr train (the seeds' "
                "own folders are not affected)")


def _find_case_dir(source: Path, case: str) -> Path | None:
    """The case folder of a run (``<case>/seed<k>[/refined]/checkpoint.pt``): the nearest parent
    holding the ``summary.json`` of ``case``."""
    for parent in list(source.parents)[:4]:
        summary_json = CaseDir(parent).summary_json
        if summary_json.is_file():
            summary = read_json(summary_json, _SUMMARY_FIX)
            if summary.get("case") == case:
                return parent
    return None


def _find_summary(source: Path, case: str) -> dict[str, Any] | None:
    """``summary.json`` of the case folder of a run, if there is one."""
    case_dir = _find_case_dir(source, case)
    return read_json(CaseDir(case_dir).summary_json, _SUMMARY_FIX) if case_dir else None




def _critic_widths(config: dict[str, Any]) -> dict[str, Any]:
    """``critic_hidden_sizes`` of a policy whose actor is narrower or wider than its critics (the
    architecture's ``hidden_sizes`` are the actor's); nothing when they agree."""
    if not config.get("actor_hidden_sizes"):
        return {}
    return {"critic_hidden_sizes": [int(h) for h in config["hidden_sizes"]]}
