"""The goto task's results: one target (:func:`goto_result`, what ``msr policy generate --target``
reports) and a ring of them (:func:`evaluate_ring`, how a goto policy or the steering yardstick is
judged: :data:`~elastica_magnetic_rl.cases.tasks.RING_TARGETS` targets evenly spaced on the
task's ring, each from the nominal start and a zero field, success when the middle node ends
within the task's tolerance).

Targets are given as (forward, left) in m from the start in the robot's start frame: +x ahead and
its left, which is -z (y is up; see :mod:`elastica_magnetic_rl.cases.tasks`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..cases.case import Case
from ..cases.tasks import RING_TARGETS, GotoTask, goto_metrics, ring_targets
from .policy_files import check_policy_case
from .policy_runs import run_policy

__all__ = ["RING_FILES", "evaluate_ring", "goto_result", "goto_target", "goto_target_notes",
           "goto_waypoints", "ring_summary", "write_ring"]

#: A target farther than this many of the case's own scale (its task's distance or its robot's
#: length, the larger) is far past any episode's reach: a unit slip (cm for m) more likely than meant.
FAR_TARGET_SCALES = 10.0


def goto_target(case: Case, target: Any) -> tuple[float, float] | None:
    """The target of a rollout of ``case``: ``target`` (forward, left; m) checked, or for a goto
    case without one the task's ``distance`` straight ahead; ``None`` for other tasks (a target
    given to them is refused)."""
    task = case.task
    if not isinstance(task, GotoTask):
        if target is not None:
            raise ValueError(f"a target is for a goto case; case {case.name!r} has the {task.kind} "
                             "task (it goes where its task says)")
        return None
    if target is None:
        return (task.distance, 0.0)
    forward, left = (float(v) for v in np.asarray(target, dtype=np.float64).reshape(2))
    if not (math.isfinite(forward) and math.isfinite(left)):
        raise ValueError(f"the target must be finite (forward, left) in m, got {target!r}")
    return forward, left


def goto_waypoints(case: Case, waypoints: Any) -> list[tuple[float, float]]:
    """A path's waypoints for ``case`` (a goto case): ``(k, 2)`` (forward, left; m from the start,
    in its start frame), each checked as :func:`goto_target` checks a target, at least one."""
    if not isinstance(case.task, GotoTask):
        raise ValueError(f"waypoints are for a goto case; case {case.name!r} has the {case.task.kind} "
                         "task (it goes where its task says)")
    points = np.asarray(waypoints, dtype=np.float64)
    if points.size == 0 or points.size % 2:
        raise ValueError(f"waypoints are (forward, left) pairs in m, at least one; got {waypoints!r}")
    return [goto_target(case, point) for point in points.reshape(-1, 2)]


def goto_target_notes(case: Case, target: Any, what: str = "--target") -> list[str]:
    """What to know about a goto ``target`` (forward, left; m) given by hand: one farther than
    :data:`FAR_TARGET_SCALES` of the case's scale (its task's distance or its robot's length),
    which no crawler of the case covers in a run, is named (as ``what``: the option, or a path's
    waypoint) with the unit slip it likely is."""
    task = case.task
    if not isinstance(task, GotoTask) or target is None:
        return []
    distance = float(np.hypot(*np.asarray(target, dtype=np.float64).reshape(2)))
    length = case.robot_spec("accurate").length
    scale = max(task.distance, length)
    if distance <= FAR_TARGET_SCALES * scale:
        return []
    shown = ",".join(f"{float(v):g}" for v in np.asarray(target).reshape(2))
    # the slip whose reading lands nearest the task's own distance (ratio on a log scale)
    unit, factor = min((("mm", 1e-3), ("cm", 1e-2)),
                       key=lambda slip: abs(math.log(distance * slip[1] / task.distance)))
    meant = ",".join(f"{float(v) * factor:g}" for v in np.asarray(target).reshape(2))
    return [f"{what} {shown} is {distance:g} m from the start: {distance / task.distance:.0f}x the "
            f"{1e3 * task.distance:g} mm target of case {case.name!r} and {distance / length:.0f} lengths of "
            f"its {1e3 * length:g} mm robot, beyond any run's reach ({unit} written for m? {what} "
            f"{meant} is {distance:g} {unit})"]


def _pose(rollout) -> np.ndarray:
    """The middle node's floor position ``(T, 3)``: x, z (m) and a zero heading column (the
    metrics read only the position)."""
    mid = rollout.positions.shape[2] // 2
    xz = rollout.positions[:, [0, 2], mid]
    return np.column_stack([xz, np.zeros(len(xz))])


def goto_result(rollout, task: GotoTask, target: tuple[float, float]) -> dict[str, Any]:
    """One goto rollout's result: the target (forward, left in the start frame and x, z on the
    floor; m), the task's tolerance (m) and :func:`~elastica_magnetic_rl.cases.tasks.goto_metrics`
    (``final_distance_to_target_m``, ``success``, ``time_to_target_s``, ``settle_time_s``,
    ``closest_distance_m``)."""
    target_xz = rollout.meta["target_xz_m"]
    return {"target_forward_m": float(target[0]), "target_left_m": float(target[1]),
            "target_x_m": float(target_xz[0]), "target_z_m": float(target_xz[1]),
            "tolerance_m": task.tolerance,
            **goto_metrics(rollout.times, _pose(rollout), target_xz, task.tolerance)}


def _ring_one(job: tuple[Any, tuple[float, float], float, str, bool]) -> tuple[dict[str, Any], Any]:
    """One target of a ring (in a worker or here): its row and the middle's path ``(T, 2)``."""
    policy, point, duration, physics, progress = job
    rollout = run_policy(policy, duration, physics, "zero", progress, target=point)
    row = {**goto_result(rollout, policy.case.task, point), "diverged": rollout.meta["diverged"],
           "duration_s": float(rollout.times[-1]), "physics": physics}
    return row, _pose(rollout)[:, :2]


def evaluate_ring(policy, duration: float | None = None, physics: str = "accurate",
                  n_targets: int | None = None, targets: Any = None, progress: bool = False,
                  paths: list | None = None, workers: int = 1) -> list[dict[str, Any]]:
    """Roll ``policy`` (a loaded goto policy or
    :class:`~elastica_magnetic_rl.envs.yardsticks.SteeringFieldPolicy`) out to each target,
    from the nominal start and a zero field, deterministically.

    Args:
        duration: s per target (default the task's ``episode_duration``).
        physics: ``"accurate"`` (the judge) or ``"training"``.
        n_targets: targets evenly spaced on the task's ring (default
            :data:`~elastica_magnetic_rl.cases.tasks.RING_TARGETS`); or
        targets: ``(k, 2)`` (forward, left) m, any points.

        paths: a list that receives each rollout's middle-node path ``(T, 2)`` (x, z; m).
        workers: processes running targets side by side (1: here, one after the other).

    Returns:
        one :func:`goto_result` per target, with ``diverged``; see :func:`ring_summary`.
    """
    task = policy.case.task
    if not isinstance(task, GotoTask):
        raise ValueError(f"a ring of targets is for a goto case; case {policy.case.name!r} has the "
                         f"{task.kind} task")
    duration = task.episode_duration if duration is None else float(duration)
    if targets is None:
        targets = ring_targets(task.distance, n_targets or RING_TARGETS)
    jobs = [(policy, goto_target(policy.case, target), duration, physics, progress and workers == 1)
            for target in np.asarray(targets, dtype=np.float64).reshape(-1, 2)]
    if workers > 1 and len(jobs) > 1:
        from ..sweep.backends import run_in_processes

        done = run_in_processes(_ring_one, jobs, min(workers, len(jobs)), quiet_interrupt=True)
    else:
        done = [_ring_one(job) for job in jobs]
    if paths is not None:
        paths.extend(path for _, path in done)
    return [row for row, _ in done]


#: The files :func:`write_ring` writes.
RING_FILES = ("ring.csv", "ring.json", "ring.png")


def write_ring(policy, out: str | Path, duration: float | None = None, physics: str = "accurate",
               n_targets: int | None = None, force: bool = False, progress: bool = True,
               workers: int = 1, actor: dict[str, Any] | None = None,
               figures: bool = True) -> dict[str, Any]:
    """:func:`evaluate_ring` written whole into the result folder ``out`` (as ``msr field
    baseline``'s result for the steering yardstick, else ``msr policy generate``'s, for the
    policy's case; replaced only with ``force``): ``ring.csv`` (one row per
    target), ``ring.json`` (the summary and the rows) and ``ring.png`` (the top view), the targets
    run in ``workers`` processes. Returns the summary with ``policy``, ``physics``, ``duration_s``
    and the files; ``actor`` (a run's actor choice, which ``policy`` is) is recorded in it. Without
    ``figures``, no ``ring.png``."""
    import pandas as pd

    from elastica_magnetic.io import atomic_write, atomic_write_json
    from elastica_magnetic.results import result_folder

    from ..reports.goto_figures import plot_ring

    kind = "baseline" if policy.kind == "baseline" else "generate"
    subject = check_ring_out(policy.case, out, kind, force)
    paths: list = []
    rows = evaluate_ring(policy, duration, physics, n_targets, progress=progress, paths=paths,
                         workers=workers)
    summary = {"policy": str(policy.source), "policy_kind": policy.kind, "case": policy.case.name,
               "physics": physics, "duration_s": rows[0]["duration_s"] if rows else None,
               "initial_field": "zero", **ring_summary(rows),
               **({} if actor is None else {"actor": actor})}
    with result_folder(out, kind=kind, subject=subject, force=force,
                       known_files=RING_FILES) as folder:
        with atomic_write(folder.path / "ring.csv", "w", newline="") as handle:
            pd.DataFrame(rows).to_csv(handle, index=False, float_format="%.9g")
        if figures:
            plot_ring(rows, paths, folder.path / "ring.png",
                      title=f"{policy.case.name}: {summary['successes']} of {len(rows)} targets "
                            f"({physics} physics, {summary['duration_s']:g} s)")
        atomic_write_json(folder.path / "ring.json", {**summary, "targets_table": rows})
    files = {name: str(folder.final / name) for name in RING_FILES if figures or name != "ring.png"}
    return {**summary, "files": files, "notes": folder.notes}


def check_ring_out(case: Case, out: str | Path, kind: str, force: bool) -> str:
    """Refuse, before any rollout, a ring's ``out`` that :func:`write_ring` may not write (another
    case's result, an existing one without ``force``); returns the result's subject."""
    from elastica_magnetic.results import check_result_folder

    subject = f"case {case.name}"
    check_policy_case(out, case)
    check_result_folder(out, kind=kind, subject=subject, force=force, known_files=RING_FILES)
    return subject


def ring_summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Successes of a ring (``successes`` of ``targets``) and the mean ``time_to_target_s`` of
    the successful targets (s; ``None`` without one)."""
    reached = [r for r in rows if r["success"] and not r["diverged"]]
    times = [r["time_to_target_s"] for r in reached]
    return {"targets": len(rows), "successes": len(reached),
            "mean_time_to_target_s": float(np.mean(times)) if times else None,
            "mean_final_distance_m": float(np.mean([r["final_distance_to_target_m"] for r in rows]))}
