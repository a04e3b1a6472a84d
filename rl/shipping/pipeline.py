"""Generate, ship and export crawling policies (the library behind ``msr``); training and
refinement are :mod:`elastica_magnetic_rl.sweep.training`.

Workflow (paper "Miscellaneous training tips"):

1. :func:`elastica_magnetic_rl.sweep.training.train_case`: TD3 on one case (``m1-4mT``, ``m2-4mT``,
   ``m1-10mT``, ``m2-10mT``) for several seeds in parallel processes or Ray tasks
   (:mod:`elastica_magnetic_rl.sweep.backends`), in the mass-scaled *training* physics, random initial
   fields, 20 s episodes (truncated, not terminal). Each seed writes ``OUT/<case>/seed<k>/``
   (``episodes.csv``, TensorBoard scalars, ``checkpoint.pt``, ``run.json``); a ``summary.json`` per
   case collects every seed.
2. :func:`elastica_magnetic_rl.sweep.training.refine`: load a run's agent *and replay buffer* and keep
   training (~1000 steps) in the *accurate* physics (12.5x more substeps per step). Written to
   ``RUN/refined/``.
3. :func:`generate`: run the deterministic policy in the accurate physics with the field starting at
   zero; write the field CSV (mT, 100 Hz), ``trajectory.csv``, ``rollout.npz``, figures and a GIF.
4. :func:`ship`: pack a run into the shipped-policy format ``rl/policies/<name>/`` (``actor.pt``
   state dict, ``critic.pt``, ``policy.json``, ``MODEL_CARD.md``, and the generated
   ``fields.csv``).
5. :func:`export_policy`: the actor as TorchScript plus a JSON of the observation layout and
   scaling and the action scaling, to run without this package.

A *policy* argument is a run directory (holding ``checkpoint.pt``), a checkpoint file, a
shipped-format directory (``actor.pt`` + ``policy.json``), or the name of a shipped policy in
``rl/policies/`` (see :func:`resolve_policy`).
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from elastica_magnetic.io import (
    atomic_save,
    atomic_write,
    atomic_write_json,
    atomic_write_text,
    prepare_output_dir,
)
from elastica_magnetic.openloop import check_duration

from ..cases.case import Case
from ..cases.tasks import ReachTask
from ..envs.env import make_env, observation_spec
from ..runfiles.provenance import machine_fingerprint
from ..runfiles.rundir import CaseDir
from .baselines import RotatingFieldPolicy
from .model_card import NOTES_SECTION, model_card, replace_card_section, seed_meets_target
from .policy_files import (
    POLICIES_DIR,
    POLICY_FORMAT,
    POLICY_JSON,
    LoadedPolicy,
    PolicyNotFoundError,
    resolve_policy,
    weights_sha256,
)
from .policy_runs import evaluate_seeds, node_dx, run_policy
from .seed_report import CARD_SECTION as SEEDS_CARD_SECTION
from .seed_report import case_seeds, seeds_markdown

__all__ = [
    "demo",
    "export_policy",
    "generate",
    "reach_metrics",
    "set_notes",
    "ship",
]

#: Format of ``msr export``'s ``policy.json``.
EXPORT_FORMAT = "msr-exported-policy-v1"


# ----------------------------------------------------------------------------------------------
# Generating fields
# ----------------------------------------------------------------------------------------------
def reach_metrics(rollout, task: ReachTask) -> dict[str, Any]:
    """The reach task's result of a rollout: final signed error (m; the middle node's
    displacement minus the target), whether it ends within the tolerance, and the settling time
    (s): the first time after which the error stays within the tolerance to the end (``None`` if it
    never settles)."""
    mid = rollout.positions.shape[2] // 2
    error = rollout.positions[:, 0, mid] - rollout.positions[0, 0, mid] - task.target
    inside = task.within_tolerance(error)
    settle = None
    if inside[-1]:
        outside = np.flatnonzero(~inside)
        settle = float(rollout.times[outside[-1] + 1] if outside.size else rollout.times[0])
    return {"target_m": task.target, "tolerance_m": task.tolerance,
            "final_error_m": float(error[-1]), "success": bool(inside[-1]),
            "settle_time_s": settle, "max_overshoot_m": float(max(error.max(), 0.0))}


def generate(
    policy: str | Path | LoadedPolicy | RotatingFieldPolicy,
    duration: float = 10.0,
    out: str | Path = "out/generate",
    physics: str = "accurate",
    progress: bool = True,
    figures: bool = True,
    gif: bool = True,
) -> dict[str, Any]:
    """Generate a field waveform with a policy: accurate physics, field from zero, deterministic.

    ``policy`` is anything :func:`resolve_policy` accepts, a loaded policy, or a hand-designed
    baseline such as :class:`~elastica_magnetic_rl.shipping.baselines.RotatingFieldPolicy`.

    Writes into ``out``: ``fields.csv`` (paper format: index, mag_x, mag_y, mag_z in mT; row ``i``
    is the field held on ``[i/100, (i+1)/100)`` s), ``trajectory.csv`` (the columns of
    ``msr replay``, 100 Hz, first row t = 0), ``gait.csv`` (height, span and the contact strength
    of the back and front nodes, 100 Hz), ``rollout.npz`` (every node position, observation, action
    and field), ``generate.json`` (this result), the figures and ``gait.gif``.

    Returns a dict with at least ``mid_dx_m`` (x displacement of the middle, mean of the two central
    element centres as in ``trajectory.csv``, m), ``node32_dx_m`` (of the reward's middle node),
    ``fields_csv`` and ``trajectory_csv``.
    """
    import pandas as pd

    from elastica_magnetic import write_field_csv, write_trajectory_csv

    from ..reports.figures import rollout_figures

    check_duration(duration)
    loaded = resolve_policy(policy) if isinstance(policy, (str, Path)) else policy
    out = prepare_output_dir(out)
    rollout = run_policy(loaded, duration, physics, "zero", progress)
    fields_csv = write_field_csv(out / "fields.csv", rollout.fields) if rollout.n_steps else None
    trajectory_csv = write_trajectory_csv(rollout.trajectory, out / "trajectory.csv")
    rollout_npz = rollout.save(out)
    traj = rollout.trajectory
    contact = rollout.contact()
    gait_csv = out / "gait.csv"
    with atomic_write(gait_csv, "w", newline="") as handle:
        pd.DataFrame({
            "t_s": traj.t_s, "height_max_m": traj.height_max_m, "span_m": traj.span_m,
            "contact_back": contact[:, 0], "contact_front": contact[:, -1],
        }).to_csv(handle, index=False, float_format="%.9g")
    result: dict[str, Any] = {
        "case": loaded.case.name,
        "policy": str(loaded.source),
        "policy_kind": loaded.kind,
        "physics": physics,
        "duration_s": float(rollout.times[-1]),
        "mid_dx_m": rollout.mid_dx,
        "node32_dx_m": node_dx(rollout),
        "return": float(np.sum(rollout.rewards)),
        "max_height_m": float(traj.height_max_m.max()),
        "max_field_T": float(np.max(np.hypot(rollout.fields[:, 0], rollout.fields[:, 1])))
        if rollout.n_steps else 0.0,
        "authors_mid_dx_10s_m": loaded.case.yardstick.distance_10s or None,
        "meets_target": loaded.case.meets_yardstick(rollout.mid_dx, node_dx(rollout),
                                                    float(rollout.times[-1]), rollout.meta["diverged"]),
        "diverged": rollout.meta["diverged"],
        "fields_csv": str(fields_csv) if fields_csv else None,
        "trajectory_csv": str(trajectory_csv),
        "rollout_npz": str(rollout_npz),
        "gait_csv": str(gait_csv),
        "step_ms": rollout.meta["step_ms"],
    }
    if isinstance(loaded.case.task, ReachTask):
        result["reach"] = reach_metrics(rollout, loaded.case.task)
    if figures and rollout.n_steps:
        result["figures"] = rollout_figures(rollout, out, loaded.critic, loaded.actor, gif=gif)
    atomic_write_json(out / "generate.json", result)
    return result


def ship(
    run: str | Path,
    name: str,
    dest: str | Path | None = None,
    measure: bool = True,
    duration: float = 10.0,
    progress: bool = True,
    overwrite: bool = False,
    evaluate_all_seeds: bool = False,
    notes: str | None = None,
    with_critic: bool = True,
    with_card: bool = True,
) -> dict[str, Any]:
    """Pack a run's checkpoint into the shipped-policy format ``dest/<name>/`` (default
    ``rl/policies/<name>/``): ``actor.pt`` and ``critic.pt`` (state dicts of
    :class:`~elastica_magnetic_rl.td3.algorithm.Actor` /
    :class:`~elastica_magnetic_rl.td3.algorithm.TwinCritic`), ``policy.json`` (case, observation layout and
    scaling, action scaling, architecture, provenance) and ``MODEL_CARD.md``.

    With ``measure`` the policy is run for ``duration`` s in the accurate physics from a zero field
    (as :func:`generate`); the distance goes into the card and the waveform into ``fields.csv``.
    The success count over seeds comes from the case's ``summary.json`` when it is found; with
    ``evaluate_all_seeds`` every seed of the case is also run like this (:func:`evaluate_seeds`)
    and the card lists each seed's distance and how many reach the authors' distance. ``notes``
    (Markdown) becomes the card's "Notes" section: what the numbers do not say. ``with_critic`` /
    ``with_card``: also write ``critic.pt`` / ``MODEL_CARD.md``.
    """
    policy = resolve_policy(run)
    if policy.kind != "checkpoint":
        raise ValueError(f"{run}: ship takes a run directory or checkpoint, not a shipped policy")
    target = (Path(dest) if dest is not None else POLICIES_DIR) / name
    if (target / POLICY_JSON).exists() and not overwrite:
        raise FileExistsError(f"{target} already holds a policy (pass overwrite / --force)")
    # Everything is computed before the folder is touched: a failed or interrupted measurement
    # leaves a policy being replaced (--force) as it was.
    case = policy.case
    summary = _find_summary(policy.source, case.name)
    measured, fields = _measure(policy, duration, progress) if measure else (None, None)
    seed_evaluations = None
    if evaluate_all_seeds:
        if summary is None:
            raise FileNotFoundError(f"{policy.source}: no summary.json of case {case.name} found "
                                    "above the run, so its seeds cannot be evaluated")
        seed_evaluations = evaluate_seeds(_find_case_dir(policy.source, case.name), duration,
                                          progress)
    info = _policy_info(policy, name, summary, seed_evaluations, measured, notes)
    card = _ship_card(info, summary, case, target) if with_card else None
    _write_policy_folder(target, policy, info, fields, card, with_critic)
    return {"name": name, "dir": str(target), "case": case.name,
            "evaluation": measured, "files": sorted(p.name for p in target.iterdir())}


def _measure(policy: LoadedPolicy, duration: float,
             progress: bool) -> tuple[dict[str, Any], np.ndarray | None]:
    """The shipping criterion's run of a policy (``duration`` s, accurate physics, zero field):
    its ``evaluation`` entry of ``policy.json`` and its field waveform ``(steps, 3)`` (T; ``None``
    when it took no step)."""
    rollout = run_policy(policy, duration, "accurate", "zero", progress)
    measured = {"duration_s": float(rollout.times[-1]), "mid_dx_m": rollout.mid_dx,
                "node_dx_m": node_dx(rollout), "diverged": rollout.meta["diverged"],
                "machine": machine_fingerprint()}
    if isinstance(policy.case.task, ReachTask):
        measured["reach"] = reach_metrics(rollout, policy.case.task)
    return measured, (rollout.fields if rollout.n_steps else None)


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
        "field_limit_T": case.field_limit,
        "task": case.task.kind,
        "actor_sha256": weights_sha256(policy.actor.state_dict()),
        "architecture": {"type": "mlp", "obs_dim": policy.obs_dim, "act_dim": policy.act_dim,
                         "hidden_sizes": list(policy.hidden_sizes), "activation": "relu",
                         "output": "tanh",
                         "module": "elastica_magnetic_rl.td3.algorithm.Actor "
                                   "(net = Sequential of Linear/ReLU)",
                         "critic_layer_norm": bool((meta.get("config") or {}).get(
                             "critic_layer_norm", False))},
        "observation": _observation_spec(case),
        "action": _action_spec(case),
        "training": {
            "seed": meta.get("seed"),
            "training_steps": meta.get("training_steps", meta.get("global_step")),
            "refine_steps": meta.get("refine_steps", 0) if refined else 0,
            "global_step": meta.get("global_step"),
            "config": meta.get("config"),
            "source": _portable_source(policy.source, case.name),
            "best_evaluation": meta.get("checkpoint_kind") == "best",
        },
        "seeds": {"succeeded": summary.get("succeeded"), "total": len(summary.get("seeds", [])),
                  "success_threshold_return": summary.get("success_threshold_return"),
                  "evaluations": seed_evaluations,
                  "meeting_target": None if seed_evaluations is None
                  else sum(seed_meets_target(e) for e in seed_evaluations)}
        if summary else None,
        "evaluation": measured,
        "authors_mid_dx_10s_m": case.yardstick.distance_10s or None,
        "target": case.target_label,
        "notes": notes,
        "case_spec": case.to_dict(),
    }


def _ship_card(info: dict[str, Any], summary: dict[str, Any] | None, case: Case,
               target: Path) -> str:
    """The model card; the committed seeds' table (``msr seeds --card``) survives a re-ship."""
    card = model_card(info, summary, case)
    groups = case_seeds(case, target.parent)
    if groups:
        card = replace_card_section(card, SEEDS_CARD_SECTION, seeds_markdown(case, groups),
                                    before="## Evaluation")
    return card


def _write_policy_folder(target: Path, policy: LoadedPolicy, info: dict[str, Any],
                         fields: np.ndarray | None, card: str | None, with_critic: bool) -> None:
    """Each file atomically; ``policy.json``, which names the actor's checksum, after the weights;
    the optional files a replaced policy had and this one has not are removed."""
    import torch

    from elastica_magnetic import write_field_csv

    target.mkdir(parents=True, exist_ok=True)
    atomic_save(target / "actor.pt", lambda tmp: torch.save(policy.actor.state_dict(), tmp))
    written = {"actor.pt", POLICY_JSON}
    if policy.critic is not None and with_critic:
        atomic_save(target / "critic.pt", lambda tmp: torch.save(policy.critic.state_dict(), tmp))
        written.add("critic.pt")
    if fields is not None:
        write_field_csv(target / "fields.csv", fields)
        written.add("fields.csv")
    atomic_write_json(target / POLICY_JSON, info)
    if card is not None:
        atomic_write_text(target / "MODEL_CARD.md", card)
        written.add("MODEL_CARD.md")
    for stale in {"critic.pt", "fields.csv", "MODEL_CARD.md"} - written:
        (target / stale).unlink(missing_ok=True)  # the replaced policy's, not this one's


def set_notes(policy: str | Path, notes: str | None,
              policies_dir: str | Path | None = None) -> dict[str, Any]:
    """Replace a shipped policy's notes (Markdown: what the numbers do not say; None or blank
    removes them). Their one home is ``policy.json``'s ``notes``; the model card's "Notes" section
    is rendered from it, so the two never disagree. ``policy``: a shipped-policy folder or name.
    Both files are written atomically, policy.json first; the actor is not touched."""
    resolved = resolve_policy(policy, policies_dir)
    if resolved.kind != "shipped":
        raise ValueError(f"{policy}: notes belong to a shipped policy (a folder with policy.json), "
                         "not to a run or checkpoint")
    folder = resolved.source
    notes = notes.strip() if notes and notes.strip() else None
    info = json.loads((folder / POLICY_JSON).read_text()) | {"notes": notes}
    card_path = folder / "MODEL_CARD.md"
    card = None
    if card_path.is_file():
        card = replace_card_section(card_path.read_text(), NOTES_SECTION, notes,
                                    before="## Limitations")
    atomic_write_json(folder / POLICY_JSON, info)
    if card is not None:
        atomic_write_text(card_path, card)
    return {"name": info.get("name", folder.name), "dir": str(folder), "notes": notes,
            "card_updated": card is not None}


def _portable_source(path: Path, case: str) -> str:
    """Where a shipped policy came from, without this machine's folders: the path from the case's
    training folder on (``m1-4mT/seed3/refined/checkpoint.pt``), else the file's name."""
    parts = Path(path).parts
    if case in parts:
        return "/".join(parts[len(parts) - 1 - parts[::-1].index(case):])
    return Path(path).name


def _find_case_dir(source: Path, case: str) -> Path | None:
    """The case folder of a run (``<case>/seed<k>[/refined]/checkpoint.pt``): the nearest parent
    holding the ``summary.json`` of ``case``."""
    for parent in list(source.parents)[:4]:
        summary_json = CaseDir(parent).summary_json
        if summary_json.is_file():
            summary = json.loads(summary_json.read_text())
            if summary.get("case") == case:
                return parent
    return None


def _find_summary(source: Path, case: str) -> dict[str, Any] | None:
    """``summary.json`` of the case folder of a run, if there is one."""
    case_dir = _find_case_dir(source, case)
    return json.loads(CaseDir(case_dir).summary_json.read_text()) if case_dir else None


def _observation_spec(case: Case) -> dict[str, Any]:
    ground = case.robot_spec("training").ground
    return observation_spec(case.n_elements, ground.surface_tolerance, case.task)


def _action_spec(case: Case) -> dict[str, Any]:
    increment = case.actuation.max_increment
    return {
        "shape": [2],
        "low": -1.0,
        "high": 1.0,
        "meaning": "field increment (dB_x, dB_y) = field_increment_T_per_unit * action",
        "field_increment_T_per_unit": increment,
        "field_increment_mT_per_unit": increment * 1e3,
        "field_limit_T": case.field_limit,
        "field_rule": f"B += clip(dB, -{1e3 * increment:g} mT, {1e3 * increment:g} mT); clip each "
                      "component to +-limit; if |B| > limit scale B to |B| = limit; hold for 0.01 s "
                      "(100 Hz)",
        "control_period_s": 0.01,
    }


def export_policy(policy: str | Path, out: str | Path = "out/export") -> dict[str, Any]:
    """Export the actor as TorchScript (``policy.ts.pt``, traced: float32 ``(N, 260)`` observations
    -> ``(N, 2)`` actions in [-1, 1]), as a ``torch.export`` program (``policy.pt2``, dynamic batch;
    torch 2.13 deprecates TorchScript), and ``policy.json`` (observation layout and scaling, action
    scaling and field rule, case). Both files are checked by reloading them with plain torch
    (``torch.jit.load``, ``torch.export.load``).

    Returns the paths, ``max_abs_diff`` / ``max_abs_diff_pt2`` between the reloaded modules and the
    agent's actor on a batch of observations, and the sizes.
    """
    import torch

    from ..td3.algorithm import ScaledPolicy

    loaded = resolve_policy(policy)
    out = prepare_output_dir(out)
    module = ScaledPolicy(loaded.actor, np.full(loaded.act_dim, -1.0), np.full(loaded.act_dim, 1.0))
    module.eval().requires_grad_(False)
    example = torch.zeros(2, loaded.obs_dim)
    ts_path = out / "policy.ts.pt"
    pt2_path = out / "policy.pt2"
    with warnings.catch_warnings():
        # torch 2.13 deprecates torch.jit (trace, save, load) in favour of torch.export; TorchScript
        # is still what C++/LibTorch and older runtimes load, so both formats are written.
        warnings.simplefilter("ignore", DeprecationWarning)
        with torch.no_grad():
            traced = torch.jit.trace(module, example, check_trace=True)
        atomic_save(ts_path, lambda tmp: traced.save(str(tmp)))
        reloaded = torch.jit.load(str(ts_path))
    batch_dim = torch.export.Dim("batch", min=1)
    exported = torch.export.export(module, (example,), dynamic_shapes=({0: batch_dim},))
    atomic_save(pt2_path, lambda tmp: torch.export.save(exported, str(tmp)))
    reloaded_pt2 = torch.export.load(str(pt2_path)).module()

    # Check: the reloaded modules give the agent's actions on real and random observations.
    env = make_env(loaded.case, "training", "random", 0.05)  # a few real observations
    obs, _ = env.reset(seed=0)
    batch = [obs]
    for _ in range(3):
        obs, *_ = env.step(env.action_space.sample())
        batch.append(obs)
    env.close()
    rng = np.random.default_rng(0)
    batch = np.concatenate([np.asarray(batch, dtype=np.float32),
                            rng.normal(0.0, 1.0, (12, loaded.obs_dim)).astype(np.float32)])
    with torch.no_grad():
        x = torch.from_numpy(batch)
        reference = loaded.actor(x)
        diff = float((reloaded(x) - reference).abs().max())
        diff_pt2 = float((reloaded_pt2(x) - reference).abs().max())
    case = loaded.case
    info = {
        "format": EXPORT_FORMAT,
        "case": case.name,
        "case_spec": case.to_dict(),
        "torchscript": ts_path.name,
        "torch_export": pt2_path.name,
        "input": {"shape": ["N", loaded.obs_dim], "dtype": "float32"},
        "output": {"shape": ["N", loaded.act_dim], "dtype": "float32", "range": [-1.0, 1.0]},
        "observation": _observation_spec(case),
        "action": _action_spec(case),
        "usage": "m = torch.jit.load('policy.ts.pt')  # or torch.export.load('policy.pt2').module(); "
                 "a = m(torch.tensor(obs[None], dtype=torch.float32))[0]; "
                 f"dB_T = {case.actuation.max_increment:g} * a",
        "source": str(loaded.source),
    }
    json_path = atomic_write_json(out / "policy.json", info)
    return {"torchscript": str(ts_path), "torch_export": str(pt2_path), "json": str(json_path),
            "case": case.name, "max_abs_diff": diff, "max_abs_diff_pt2": diff_pt2,
            "obs_dim": loaded.obs_dim, "act_dim": loaded.act_dim}


def demo(out: str | Path = "out/demo", duration: float = 10.0, progress: bool = True,
         name: str = "m1-4mT") -> dict[str, Any]:
    """``msr demo``: generate with the shipped pattern-1 4 mT policy ``m1-4mT``."""
    folder = POLICIES_DIR / name
    missing = [f for f in ("actor.pt", POLICY_JSON) if not (folder / f).is_file()]
    if missing:
        raise PolicyNotFoundError(
            f"no shipped policy {name!r}: {folder} lacks {', '.join(missing)}. Train and ship it "
            f"first: `msr train --case {name} --seeds 8 --steps 100000 --out runs`, "
            f"`msr refine runs/{name}/seed<best>`, `msr ship runs/{name}/seed<best>/refined "
            f"--name {name}`"
        )
    return generate(name, duration=duration, out=out, progress=progress)

