"""Generate a field waveform with a policy (``msr policy generate``, ``msr field baseline``, ``msr
policy demo``): run it deterministically in the accurate physics with the field starting at zero and
write the field CSV (mT, 100 Hz), ``trajectory.csv``, ``rollout.npz``, ``generate.json``, the
figures and a GIF."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from elastica_magnetic.io import atomic_write, atomic_write_json, read_json
from elastica_magnetic.openloop import check_duration
from elastica_magnetic.results import ResultExistsError, check_result_folder, result_folder

from ..cases.tasks import GotoTask, ReachTask
from ..envs.waypoints import Heading, Waypoints
from ..envs.yardsticks import RotatingFieldPolicy
from ..reports.figures import ROLLOUT_FIGURES
from ..reports.goto_figures import TOP_VIEW
from .goto import goto_result, goto_target, goto_waypoints
from .policy_files import (
    POLICIES_DIR,
    POLICY_JSON,
    LoadedPolicy,
    PolicyNotFoundError,
    check_policy_case,
    resolve_policy,
)
from .policy_runs import choose_actor, node_dx, run_policy

__all__ = ["GENERATE_FILES", "MID_NODE_KEY", "Pictures", "demo", "generate", "reach_metrics",
           "read_generate_json"]

#: The files ``msr policy generate`` (``baseline``, ``demo``) writes: recognises an output folder written
#: before result folders carried a marker.
GENERATE_FILES = ("fields.csv", "trajectory.csv", "gait.csv", "rollout.npz", "generate.json",
                  *ROLLOUT_FIGURES, TOP_VIEW)


@dataclass(frozen=True)
class Pictures:
    """The pictures a rollout result gets: its figures (PNG) and, with them, the gait's GIF
    (``gif`` has no effect without ``figures``)."""

    figures: bool = True
    gif: bool = True


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
    pictures: Pictures = Pictures(),
    checkpoint: str = "auto",
    force: bool = False,
    kind: str = "generate",
    target: Any = None,
) -> dict[str, Any]:
    """Generate a field waveform with a policy: accurate physics, field from zero, deterministic.

    ``policy`` is anything :func:`resolve_policy` accepts, a loaded policy, or a hand-designed
    baseline such as :class:`~elastica_magnetic_rl.envs.yardsticks.RotatingFieldPolicy`.
    For a run folder (or its ``checkpoint.pt``), ``checkpoint`` picks the actor
    (:func:`~elastica_magnetic_rl.shipping.policy_runs.choose_actor`): ``"auto"`` evaluates the final
    actor and ``best.pt`` for ``duration`` s in the accurate physics from a zero field and uses the
    farther; ``"final"``, ``"best"`` or a checkpoint path choose it. The result's ``actor_choice``
    says which and gives both distances.

    Writes into ``out``: ``fields.csv`` (paper format: index, mag_x, mag_y, mag_z in mT; row ``i``
    is the field held on ``[i/100, (i+1)/100)`` s), ``trajectory.csv`` (the columns of
    ``msr field replay``, 100 Hz, first row t = 0), ``gait.csv`` (height, span and the contact strength
    of the back and front nodes, 100 Hz), ``rollout.npz`` (every node position, observation, action
    and field), ``generate.json`` (this result), the figures and ``gait.gif``.

    ``out`` is written whole or not at all (:func:`elastica_magnetic.results.result_folder`, as
    the result of ``msr <kind>`` for the policy's case): an existing result of the same command and
    case is replaced only with ``force``; another command's or case's result is refused before the
    actors' evaluation and the rollout; an interruption leaves ``out`` as it was. ``notes`` in the
    result: what was recovered on entry (a stale lock, a killed run's leftovers).

    Returns a dict with at least ``physics``, ``duration_s`` and ``initial_field`` (what every
    distance in it was measured in), ``mid_dx_m`` (x displacement of the middle, mean of the two
    central element centres as in ``trajectory.csv``, m), ``mid_dz_m`` (its sideways
    displacement, m: 0 for planar motion), ``mid_node_dx_m`` (of the reward's middle
    node, node ``n // 2``), ``target``, ``fields_csv`` and ``trajectory_csv``; ``yardstick_10s_m``
    when the case has one and ``meets_target`` only for a 10 s run in the accurate physics of a
    case with a target. For a goto case, ``target`` (forward, left; m from the start, in the
    robot's start frame: +x ahead, left is -z) is where it is sent (default: the task's
    ``distance`` straight ahead) and ``goto`` holds :func:`goto_result`; a
    :class:`~elastica_magnetic_rl.envs.waypoints.Waypoints` ``target`` (the same frame) sends it
    along a path, each waypoint its target until it comes within the task's tolerance
    (:func:`~elastica_magnetic_rl.shipping.policy_runs.run_policy`): ``goto`` is then of the last
    one, ``waypoints`` holds each one's place and the time it was reached, and a run's actor is
    chosen on the last one. A :class:`~elastica_magnetic_rl.envs.waypoints.Heading` ``target``
    sends it along the line from the start at that heading and on
    (:class:`~elastica_magnetic_rl.envs.waypoints.HeadingCourse`): ``heading`` then holds
    ``distance_along_m``, ``cross_track_m`` and the heading of its travel, there is no ``goto``
    block (its target moves with it), and a run's actor is chosen on the task's distance along the
    heading. A goto result's figures include ``top_view.png``.
    """



    check_duration(duration)
    loaded = resolve_policy(policy) if isinstance(policy, (str, Path)) else policy
    target, course = _destination(loaded.case, target)
    subject = f"case {loaded.case.name}"
    check_policy_case(out, loaded.case)
    check_result_folder(out, kind=kind, subject=subject, force=force, known_files=GENERATE_FILES)
    choice = None
    if isinstance(policy, (str, Path)):
        choice = choose_actor(policy, checkpoint, duration, progress, target)
        if choice is not None:
            loaded = resolve_policy(choice.path)
    with result_folder(out, kind=kind, subject=subject, force=force,
                       known_files=GENERATE_FILES) as folder:
        result = _write_rollout(loaded, folder.path, duration, physics, progress, pictures, choice,
                                target, course)
        result = _final_paths(result, folder)  # generate.json names where the files will be
        atomic_write_json(folder.path / "generate.json", result)
    return result | {"notes": folder.notes}


def _destination(case: Any, target: Any) -> tuple[Any, Any]:
    """``generate``'s ``target`` checked: the point a rollout is judged on (a path's last
    waypoint; a heading's: the task's distance along it, on which a run's actor is chosen) and
    the course (a path's waypoints, or the :class:`Heading`; ``None`` for one target); a target
    within the tolerance of the start warned of."""
    course = None
    if isinstance(target, Waypoints):
        course = goto_waypoints(case, target.points)
        target = course[-1]
    elif isinstance(target, Heading):
        if not isinstance(case.task, GotoTask):
            raise ValueError(f"a heading is for a goto case; case {case.name!r} has the {case.task.kind} "
                             "task (it goes where its task says)")
        course = target
        distance = case.task.distance
        return (distance * math.cos(target.angle), distance * math.sin(target.angle)), course
    target = goto_target(case, target)
    task = case.task
    if target is not None and float(np.hypot(*target)) <= task.tolerance:
        from elastica_magnetic.plausibility import warn_implausible

        warn_implausible(f"--target {1e3 * target[0]:g},{1e3 * target[1]:g} mm lies within the "
                         f"{1e3 * task.tolerance:g} mm tolerance of the start: a robot that stays put "
                         "succeeds there (mm written as m?)", "target")
    return target, course


def _write_rollout(loaded: LoadedPolicy, out: Path, duration: float, physics: str, progress: bool,
                   pictures: Pictures, choice, target: Any = None,
                   course: Any = None) -> dict[str, Any]:
    """Run ``loaded`` and write the files of :func:`generate` into ``out``; its result."""
    import pandas as pd

    from elastica_magnetic import write_field_csv, write_trajectory_csv

    from ..reports.figures import rollout_figures

    if isinstance(course, Heading):
        rollout = run_policy(loaded, duration, physics, "zero", progress, heading=course.angle)
    elif course is not None:
        rollout = run_policy(loaded, duration, physics, "zero", progress, waypoints=course)
    else:
        rollout = run_policy(loaded, duration, physics, "zero", progress, target=target)
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
        "initial_field": "zero",
        "mid_dx_m": rollout.mid_dx,
        "mid_dz_m": float(traj.mid_z_m.iloc[-1] - traj.mid_z_m.iloc[0]),
        MID_NODE_KEY: node_dx(rollout),
        "return": float(np.sum(rollout.rewards)),
        "max_height_m": float(traj.height_max_m.max()),
        "max_field_T": float(np.max(np.hypot(np.hypot(rollout.fields[:, 0], rollout.fields[:, 1]),
                                                 rollout.fields[:, 2])))
        if rollout.n_steps else 0.0,
        **_verdict(loaded.case, rollout, physics),
        "diverged": rollout.meta["diverged"],
        "fields_csv": str(fields_csv) if fields_csv else None,
        "trajectory_csv": str(trajectory_csv),
        "rollout_npz": str(rollout_npz),
        "gait_csv": str(gait_csv),
        "step_ms": rollout.meta["step_ms"],
    }
    if choice is not None:
        result["actor_choice"] = {**choice.to_dict(), "summary": choice.describe()}
    if isinstance(loaded.case.task, ReachTask):
        result["reach"] = reach_metrics(rollout, loaded.case.task)
    if isinstance(course, Heading):
        result["heading"] = rollout.meta["heading"]
        result["target"] = (f"along the heading {course.angle:.4g} rad ({_bearing_words(course.angle)}) "
                            f"for {result['duration_s']:g} s")
    elif isinstance(loaded.case.task, GotoTask):
        task = loaded.case.task
        result["goto"] = goto_result(rollout, task, target)
        # the target and the time played, not the task's default (15 mm ahead in 30 s)
        result["target"] = (f"within {1e3 * task.tolerance:.1f} mm of the target "
                            f"({1e3 * target[0]:+.1f}, {1e3 * target[1]:+.1f}) mm (ahead, left) "
                            f"in {result['duration_s']:g} s")
        result.update({k: result["goto"][k] for k in ("final_distance_to_target_m",
                                                       "time_to_target_s")})
        if course is not None:
            result["waypoints"] = rollout.meta["waypoints"]
            result["waypoints_reached"] = sum(w["reached_s"] is not None for w in result["waypoints"])
            result["target"] = (f"{len(course)} waypoints in order, then "
                                f"{result['target'][:1].lower()}{result['target'][1:]}")
    if pictures.figures and rollout.n_steps:
        result["figures"] = rollout_figures(rollout, out, loaded.critic, loaded.actor, gif=pictures.gif)
        if isinstance(loaded.case.task, GotoTask):
            result["figures"]["top_view"] = str(_top_view(rollout, loaded.case.task, result, out / TOP_VIEW))
    return result


def _bearing_words(angle: float) -> str:
    """A heading (rad, counter-clockwise seen from above, 0 ahead) in words: "straight ahead", "90
    degrees to the left", "45 degrees to the right", "straight behind"."""
    degrees = math.degrees(math.remainder(angle, 2.0 * math.pi))  # within half a turn of ahead
    if abs(degrees) < 0.05:
        return "straight ahead"
    if abs(abs(degrees) - 180.0) < 0.05:
        return "straight behind"
    return f"{abs(degrees):.4g} degrees to the {'left' if degrees > 0 else 'right'}"


def _top_view(rollout, task: GotoTask, result: dict[str, Any], path: Path) -> Path:
    """A goto rollout's top view: its path and its target (or waypoints, or commanded heading)."""
    from ..reports.goto_figures import plot_heading_view, plot_top_view

    mid = rollout.positions.shape[2] // 2
    if "heading" in result:
        course = result["heading"]
        start = rollout.positions[0]
        start_heading = math.atan2(-(start[2, -1] - start[2, 0]), start[0, -1] - start[0, 0])
        return plot_heading_view(
            rollout.positions[:, [0, 2], mid], start_heading, course["heading_rad"], path,
            title=f"{result['case']}: {1e3 * course['distance_along_m']:.1f} mm along the heading, "
                  f"{1e3 * course['cross_track_m']:+.1f} mm off it\n({result['physics']} physics, "
                  f"{result['duration_s']:g} s)")
    goto = result["goto"]
    targets = result.get("waypoints") or [{"x_m": goto["target_x_m"], "z_m": goto["target_z_m"],
                                           "reached_s": goto["time_to_target_s"]}]
    reached = sum(t["reached_s"] is not None for t in targets)
    what = f"{reached} of {len(targets)} waypoints reached" if "waypoints" in result else (
        f"{1e3 * goto['final_distance_to_target_m']:.2f} mm from the target at the end")
    return plot_top_view(rollout.positions[:, [0, 2], mid], targets, task.tolerance, path,
                         title=f"{result['case']}: {what}\n({result['physics']} physics, "
                               f"{result['duration_s']:g} s)")  # two lines: one overran the figure


def _final_paths(result: dict[str, Any], folder) -> dict[str, Any]:
    """``result`` with the paths under the temporary folder replaced by where they are now."""
    staged = str(folder.path)
    text = json.dumps(result, default=str).replace(staged, str(folder.final))
    return json.loads(text)


#: ``generate.json``'s key of the reward's middle node's displacement (node ``n // 2``, m), and
#: the names older files gave it and the yardstick (read by :func:`read_generate_json`).
MID_NODE_KEY = "mid_node_dx_m"
OLD_KEYS = {"node32_dx_m": MID_NODE_KEY, "authors_mid_dx_10s_m": "yardstick_10s_m"}


def _verdict(case, rollout, physics: str) -> dict[str, Any]:
    """The yardstick and whether the rollout meets it, only where both mean something: a crawl
    case with a yardstick (or a reach task), a 10 s run in the accurate physics from a zero field.
    A case without a yardstick gives neither (not a success for any forward motion)."""
    duration = float(rollout.times[-1])
    out: dict[str, Any] = {"target": case.target_label}
    if case.yardstick.distance_10s > 0.0:
        out["yardstick_10s_m"] = case.yardstick.distance_10s
    if physics == "accurate" and abs(duration - 10.0) < 1e-9:
        met = case.meets_yardstick(rollout.mid_dx, node_dx(rollout), duration,
                                   rollout.meta["diverged"])
        if met is not None:  # None: the case has no yardstick
            out["meets_target"] = met
    return out


def read_generate_json(path: str | Path) -> dict[str, Any]:
    """A ``generate.json`` (:func:`generate`'s result), older files' key names mapped to today's
    (:data:`OLD_KEYS`)."""
    data = read_json(path)
    for old, new in OLD_KEYS.items():
        if old in data and new not in data:
            data[new] = data.pop(old)
    return data


def demo(out: str | Path = "out/demo", duration: float = 10.0, progress: bool = True,
         name: str = "m1-4mT") -> dict[str, Any]:
    """``msr policy demo``: generate with the shipped pattern-1 4 mT policy ``m1-4mT``. The demo replaces
    its own earlier demo in ``out`` without being asked (the README's first command stays
    re-runnable); any other folder's content is refused as by :func:`generate`."""
    folder = POLICIES_DIR / name
    missing = [f for f in ("actor.pt", POLICY_JSON) if not (folder / f).is_file()]
    if missing:
        raise PolicyNotFoundError(
            f"no shipped policy {name!r}: {folder} lacks {', '.join(missing)}. Train and ship it "
            f"first: `msr train --case {name} --seeds 8 --steps 100000 --out runs`, "
            f"`msr refine runs/{name}/seed<best>`, `msr policy ship runs/{name}/seed<best>/refined "
            f"--name {name}`"
        )
    try:
        return generate(name, duration=duration, out=out, progress=progress, force=True, kind="demo")
    except ResultExistsError as exc:  # the demo has no --force: say what it does replace
        raise ResultExistsError(str(exc).replace("--force replaces only", "msr policy demo "
                                                 "replaces only its own earlier demo and")) from None
