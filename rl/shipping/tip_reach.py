"""Judging a tip-reach case (a clamped rod steered by a magnet on an arm or by fixed coils):
held-out targets drawn from the case's ``target_box`` with a seed no training uses (they judge a
policy), validation targets drawn with another such seed (they choose among seeds and checkpoints,
so that the held-out ones never do), and the result
of a controller on them (a trained actor, or the yardstick: the bearing steering law of
:class:`~elastica_magnetic.steering.MagnetBearingSteering` for a magnet,
:class:`~elastica_magnetic.steering.CoilFieldSteering` for coils), all targets at once in one
batched environment. Lengths in m, times in s.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic.robot_spec import ACTION_PERIOD

from ..cases.case import Case
from ..envs.catheter_env import CatheterReachVectorEnv, make_catheter_env
from ..envs.steering_yardstick import insertion_command, steering_law
from .policy_files import check_policy_case

__all__ = ["HELD_OUT_SEED", "HELD_OUT_TARGETS", "TARGET_FILES", "VALIDATION_SEED", "actor_controller",
           "held_out_targets", "judge_held_out", "run_targets", "Steering", "steering_controller",
           "target_notes", "validation_targets", "write_targets"]

#: Seed of the held-out targets: training draws its targets with the run's seed plus small offsets
#: (episode numbers), never this one.
HELD_OUT_SEED = 53_000_053
#: How many held-out targets a tip-reach policy is judged on.
HELD_OUT_TARGETS = 20
#: Seed of the validation targets (as many as the held-out ones): choosing a seed or a checkpoint
#: by its count on the held-out targets would make that count an optimistic judge of it.
VALIDATION_SEED = 53_000_054

#: A controller: given the environment and its observation ``(N, size)``, the actions ``(N, A)``.
Controller = Callable[[CatheterReachVectorEnv, NDArray[np.float32]], NDArray[np.float64]]


def held_out_targets(case: Case, n: int = HELD_OUT_TARGETS, seed: int = HELD_OUT_SEED) -> NDArray[np.float64]:
    """``(n, 3)`` targets drawn uniformly in the case's ``target_box`` (m) with ``seed``."""
    low, high = np.asarray(case.task.target_box, dtype=np.float64)
    return np.random.default_rng(seed).uniform(low, high, size=(int(n), 3))


def validation_targets(case: Case, n: int = HELD_OUT_TARGETS) -> NDArray[np.float64]:
    """``(n, 3)`` validation targets (m): drawn as :func:`held_out_targets` with
    :data:`VALIDATION_SEED`, for choosing among a case's seeds and checkpoints."""
    return held_out_targets(case, n, VALIDATION_SEED)


def _target_set(case: Case, targets: Any) -> tuple[NDArray[np.float64], str]:
    """The targets ``(n, 3)`` m that ``targets`` names (``None``: the held-out ones, ``"validation"``:
    the validation ones, else the points themselves) and their source as results name it."""
    if targets is None:
        return held_out_targets(case), f"held out (seed {HELD_OUT_SEED})"
    if isinstance(targets, str):
        if targets != "validation":
            raise ValueError(f"targets: {targets!r} names no target set (None: the held-out targets, "
                             "'validation': the validation targets, or points (n, 3) m)")
        return validation_targets(case), f"validation (seed {VALIDATION_SEED})"
    return np.asarray(targets, dtype=np.float64).reshape(-1, 3), "given"


def steering_controller(env: CatheterReachVectorEnv) -> Controller:
    """The yardstick of a tip-reach case on the environment's own state: for a magnet arm, the
    bearing steering law, the magnet kept at its start distance from the straight tip; for coils,
    the same law choosing the field's direction at the tip and the least-norm currents making it;
    with an insertion stage, the stage pushed or pulled until the tip is as far from the base's
    start as the target (:func:`~elastica_magnetic_rl.envs.steering_yardstick.steering_law`,
    :func:`~elastica_magnetic_rl.envs.steering_yardstick.insertion_command`)."""
    length = float(env.spec.length)
    laws = [steering_law(env.actuation, length, actuator) for actuator in env.actuators]

    def act(env: CatheterReachVectorEnv, obs: NDArray[np.float32]) -> NDArray[np.float64]:
        steer = np.stack([law.action(env.tip(i), env.targets[i], env.robots.robot_time(i), ACTION_PERIOD)
                          for i, law in enumerate(laws)])
        if not env.advancers:
            return steer
        tips = np.stack([env.tip(i) for i in range(env.num_envs)])
        push = insertion_command(env.targets, tips, env.advancers[0].max_speed)
        return np.concatenate([steer, push[:, None]], axis=1)

    return act


def actor_controller(actor: Any) -> Callable[[CatheterReachVectorEnv], Controller]:
    """A trained actor (a ``torch.nn.Module`` mapping observations ``(N, size)`` float32 to
    normalised actions ``(N, A)``) or a loaded policy (its actor; a residual policy's yardstick
    corrected by it, a new yardstick per sub-environment of each environment) as a controller maker
    for :func:`run_targets` and :func:`write_targets`: deterministic, no exploration noise."""
    import torch

    if getattr(actor, "residual", 0.0):
        def residual(env: CatheterReachVectorEnv) -> Controller:
            controller = actor.residual_controller()
            return lambda env, obs: controller.act(obs).astype(np.float64)

        return residual
    actor = getattr(actor, "actor", actor)  # a loaded policy's network

    def act(env: CatheterReachVectorEnv, obs: NDArray[np.float32]) -> NDArray[np.float64]:
        with torch.no_grad():
            return actor(torch.as_tensor(np.asarray(obs, dtype=np.float32))).numpy().astype(np.float64)

    return lambda env: act


def target_notes(case: Case, targets: Any) -> list[str]:
    """What to know about targets given by hand (m, ``(n, 3)``): those within the tolerance of the
    straight tip at the start (a catheter left alone succeeds there), those beyond the tip's reach
    (farther from the base's start than the rod's length and its stage's travel: no steering gets
    there), and those outside the case's ``target_box``, where its policies were not trained (they
    may still reach them, or not)."""
    low, high = np.asarray(case.task.target_box, dtype=np.float64)
    stage = case.actuation.insertion
    length = case.robot_spec("accurate").length
    reach = length + (stage[1] if stage else 0.0)
    start_tip = np.array([length, 0.0, 0.0])  # the straight rod from the base at the origin, along +x
    notes = []
    for target in np.asarray(targets, dtype=np.float64).reshape(-1, 3):
        shown = ", ".join(f"{v:g}" for v in target)
        if case.task.within_tolerance(float(np.linalg.norm(target - start_tip))):
            notes.append(f"the target ({shown}) m lies within the {1e3 * case.task.tolerance:g} mm tolerance "
                         f"of the straight tip at the start ({length:g}, 0, 0) m: a catheter left alone "
                         "succeeds there, so its success says nothing of the steering (mm written as m?)")
        elif float(np.linalg.norm(target)) > reach:
            notes.append(f"the target ({shown}) m is {float(np.linalg.norm(target)):g} m from the clamped "
                         f"base's start, beyond any tip's reach ({reach:g} m: the rod's length"
                         f"{' and its stage' if stage else ''}): no steering gets there (mm written as m?)")
        elif np.any(target < low) or np.any(target > high):
            notes.append(f"the target ({shown}) m lies outside case "
                         f"{case.name!r}'s target_box {np.stack([low, high]).tolist()} m: its policies "
                         "trained on targets inside it")
    return notes


def run_targets(case: Case, targets: Any,
                make_controller: Callable[[CatheterReachVectorEnv], Controller],
                physics: str = "accurate", duration: float | None = None,
                paths: list[NDArray[np.float64]] | None = None,
                record: Callable[[CatheterReachVectorEnv, int], Any] | None = None,
                drives: list[list[Any]] | None = None) -> dict[str, Any]:
    """Steer to every target at once (one episode each, ``duration`` s, default the task's), in
    ``physics``. ``make_controller``: makes the :data:`Controller` from the environment (as
    :func:`steering_controller`; an actor: ``lambda env: lambda env, obs: actor(obs)``). Returns
    ``targets_m``, per target ``final_distance_m``, ``closest_distance_m``, ``ended_by``
    (``"time"``, ``"collision"`` or ``"divergence"``), ``success`` (ending within the
    tolerance, by time) and ``time_to_target_s`` (when the tip first came within the tolerance, s;
    ``None`` if never), and ``successes`` (their count). ``paths``: given a list, the tips at every
    control step are appended to it, ``(T, N, 3)`` m. ``record`` and ``drives``: given both, each
    target's ``record(env, i)`` (its actuator's state) after the reset and after every step before
    its episode's last (whose end resets the actuator) is appended to ``drives``, a list per target
    (row k at k x 0.01 s, as the tips)."""
    if case.field_actuated:
        raise ValueError(f"case {case.name!r} is not a tip-reach case (its actuation is a field)")
    targets = np.asarray(targets, dtype=np.float64).reshape(-1, 3)
    env = make_catheter_env(case, len(targets), physics, duration)
    obs, info = env.reset(seed=0, options={"target": targets})
    act = make_controller(env)
    n = len(targets)
    final, ended_by = np.full(n, np.nan), np.full(n, None, dtype=object)
    closest = info["distance_m"].copy()
    reached = np.full(n, np.nan)
    done = np.zeros(n, dtype=bool)
    tips = [info["tip_m"].copy()]
    recorded = [[record(env, i)] for i in range(n)] if record is not None else None
    while not done.all():
        obs, _, terminated, truncated, info = env.step(act(env, obs))
        ended = (terminated | truncated) & ~done
        for i in np.flatnonzero(~done & ~ended) if recorded is not None else ():
            recorded[i].append(record(env, i))
        if ended.any():
            last = info["final_info"]
            final[ended] = last["distance_m"][ended]
            ended_by[ended] = last["ended_by"][ended]
            closest[ended] = np.minimum(closest[ended], last["distance_m"][ended])
        closest[~done & ~ended] = np.minimum(closest[~done & ~ended], info["distance_m"][~done & ~ended])
        step_tips = np.where(ended[:, None], info["final_info"]["tip_m"] if ended.any() else info["tip_m"],
                             info["tip_m"])
        distance = np.linalg.norm(step_tips - targets, axis=1)
        first = ~done & np.isnan(reached) & case.task.within_tolerance(distance)
        reached[first] = len(tips) * ACTION_PERIOD
        tips.append(np.where(done[:, None], tips[-1], step_tips))
        done |= ended
    success = (ended_by == "time") & case.task.within_tolerance(final)
    if paths is not None:
        paths.append(np.stack(tips))
    if recorded is not None and drives is not None:
        drives.extend(recorded)
    return {"targets_m": targets.tolist(), "final_distance_m": final.tolist(),
            "closest_distance_m": closest.tolist(), "ended_by": ended_by.tolist(),
            "success": success.tolist(), "successes": int(success.sum()), "physics": physics,
            "time_to_target_s": [None if np.isnan(t) else float(t) for t in reached],
            "duration_s": env.task.episode_duration}


def judge_held_out(case: Case, actor: Any, duration: float, with_yardstick: bool = False,
                   paths: dict[str, NDArray[np.float64]] | None = None) -> dict[str, Any]:
    """How a tip-reach policy is judged (``msr policy ship``, ``msr validate shipped``): ``actor``
    (as :func:`actor_controller`'s) on the case's held-out targets in the accurate physics, each for
    ``duration`` s at most the task's episode, and with ``with_yardstick`` the case's yardstick on
    the same targets. Returns ``duration_s`` (s, as run), ``policy`` (:func:`run_targets`' result)
    and ``yardstick`` (the same, when run); ``paths``: given a dict, the tips ``(T, N, 3)`` m of each
    go in under the same labels."""
    seconds = min(float(duration), case.task.episode_duration)
    targets = held_out_targets(case)
    controllers = {"policy": actor_controller(actor)}
    if with_yardstick:
        controllers["yardstick"] = steering_controller
    judged: dict[str, Any] = {"duration_s": seconds}
    for label, make_controller in controllers.items():
        tips: list[NDArray[np.float64]] | None = [] if paths is not None else None
        judged[label] = run_targets(case, targets, make_controller, "accurate", seconds, paths=tips)
        if paths is not None and tips:
            paths[label] = tips[0]
    return judged


#: The files of a tip-reach result folder (``msr field baseline`` of a steered case).
TARGET_FILES = ("targets.csv", "targets.json", "targets.png")


@dataclass(frozen=True)
class Steering:
    """What steers the tip in :func:`write_targets`: ``make`` makes the :data:`Controller` from the
    environment (:func:`steering_controller`, :func:`actor_controller`'s), ``label`` names it in the
    results (``"yardstick"``, ``"policy <source>"``)."""

    make: Callable[[CatheterReachVectorEnv], Controller]
    label: str = "yardstick"


def write_targets(case: Case, out: Any, steering: Steering, physics: str = "accurate",
                  duration: float | None = None, force: bool = False, kind: str = "baseline",
                  figures: bool = True, targets: Any = None, drive: Any = None) -> dict[str, Any]:
    """:func:`run_targets` on ``targets`` (m, ``(n, 3)``; default the case's held-out targets;
    ``"validation"``: its validation targets),
    written whole into the result folder ``out`` (as ``msr <kind>``'s result for the case;
    replaced only with ``force``): ``targets.csv`` (one row per target), ``targets.json`` (the
    summary and the rows) and, with ``figures``, ``targets.png`` (the tip's paths), ``steering``
    steering. Returns the summary (``controller``: its label) and the files;
    for a single target given, also ``target_m`` and ``tip_error_m`` (the tip's distance from it
    at the end, m). ``drive`` (a :class:`~elastica_magnetic_rl.sim2real.recorded_paths.DriveRecorder`,
    with a single target): the drive as played and the tip's path are written too (the files
    ``msr real identify`` reads: play the drive on the hardware, track the tip, identify)."""
    import pandas as pd

    from elastica_magnetic.io import atomic_write, atomic_write_json
    from elastica_magnetic.results import check_result_folder, result_folder

    from ..reports.goto_figures import plot_tip_paths

    subject = f"case {case.name}"
    check_policy_case(out, case)
    targets, source = _target_set(case, targets)
    if drive is not None and len(targets) != 1:
        raise ValueError(f"a drive is recorded for one target; got {len(targets)}")
    known = TARGET_FILES + (drive.file_names if drive is not None else ())
    check_result_folder(out, kind=kind, subject=subject, force=force, known_files=known)
    with result_folder(out, kind=kind, subject=subject, force=force, known_files=known) as folder:
        # inside the result folder: an interruption while steering says so, leaves no lock
        drives: list[list[Any]] = []
        summary, rows, paths = _steer_to(case, targets, source, steering.make, physics, duration,
                                         steering.label, drive.row if drive is not None else None, drives)
        with atomic_write(folder.path / "targets.csv", "w", newline="") as handle:
            pd.DataFrame(rows).to_csv(handle, index=False, float_format="%.9g")
        if figures:
            plot_tip_paths(rows, paths[0], folder.path / "targets.png",
                           title=f"{case.name}, {steering.label}: {summary['successes']} of {len(rows)} "
                                 f"targets ({physics} physics, {summary['duration_s']:g} s)")
        atomic_write_json(folder.path / "targets.json", {**summary, "targets_table": rows})
        written = drive.write(folder.path, drives[0], paths[0][:, 0]) if drive is not None else {}
    files = {name: str(folder.final / name) for name in TARGET_FILES if figures or name != "targets.png"}
    files |= {name: str(folder.final / name) for name in written}
    return {**summary, "files": files, "notes": folder.notes}


def _steer_to(case: Case, targets: NDArray[np.float64], source: str,
              make_controller: Callable[[CatheterReachVectorEnv], Controller], physics: str,
              duration: float | None, controller: str, record: Any = None, drives: list | None = None
              ) -> tuple[dict[str, Any], list[dict[str, Any]], list]:
    """:func:`run_targets` for :func:`write_targets`: its summary, one row per target and the tip's
    paths (``record`` and ``drives`` as :func:`run_targets`'; ``source``: where the targets come
    from, as :func:`_target_set` names it)."""
    paths: list[NDArray[np.float64]] = []
    result = run_targets(case, targets, make_controller, physics, duration, paths=paths, record=record,
                         drives=drives)
    rows = [{"target_x_m": t[0], "target_y_m": t[1], "target_z_m": t[2], "final_distance_m": final,
             "closest_distance_m": closest, "time_to_target_s": reached, "ended_by": ended, "success": ok}
            for t, final, closest, reached, ended, ok in zip(
                result["targets_m"], result["final_distance_m"], result["closest_distance_m"],
                result["time_to_target_s"], result["ended_by"], result["success"], strict=True)]
    times = [r["time_to_target_s"] for r in rows if r["success"] and r["time_to_target_s"] is not None]
    summary = {"case": case.name, "controller": controller, "physics": physics,
               "duration_s": result["duration_s"],
               "target_source": source,
               "targets": len(rows), "successes": result["successes"], "tolerance_m": case.task.tolerance,
               "mean_time_to_target_s": float(np.mean(times)) if times else None,
               "largest_final_distance_m": float(max(result["final_distance_m"]))}
    if source == "given" and len(rows) == 1:
        summary |= {"target_m": result["targets_m"][0], "tip_error_m": float(result["final_distance_m"][0])}
    return summary, rows, paths
