"""Rolling a policy out, and the shipping criterion's evaluation of a case's seeds: one home for how a policy
is run (:func:`run_policy`), judged (:func:`evaluate_checkpoint`: 10 s in the accurate physics from a zero
field, against the case's yardstick) and cached per seed (:func:`evaluate_seeds`);
:mod:`~elastica_magnetic_rl.shipping.generate`, :mod:`~elastica_magnetic_rl.shipping.ship` and
:mod:`elastica_magnetic_rl.shipping.seed_export` build on it."""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from elastica_magnetic.io import atomic_write_json, missing_folder_hint

from ..cases.case import Case
from ..cases.tasks import GotoTask, ReachTask
from ..envs.env import make_env
from ..envs.waypoints import course_for_env
from ..envs.yardsticks import RotatingFieldPolicy
from ..runfiles.rundir import CaseDir, RunDir, being_written_hint
from .policy_files import LoadedPolicy, resolve_policy

__all__ = ["ActorChoice", "CHECKPOINT_CHOICES", "check_checkpoint_file", "choose_actor",
           "choose_tip_reach_actor",
           "evaluate_checkpoint", "evaluate_run", "evaluate_seeds", "node_dx", "prefer_best", "run_policy",
           "seed_run_dirs"]

#: ``--checkpoint`` values besides a path: ``auto`` (the farther of the two, :func:`prefer_best`),
#: ``final`` (``checkpoint.pt``), ``best`` (``best.pt``).
CHECKPOINT_CHOICES = ("auto", "final", "best")


def run_policy(
    policy: LoadedPolicy | RotatingFieldPolicy,
    duration: float = 10.0,
    physics: str = "accurate",
    initial_field: str = "zero",
    progress: bool = True,
    target: Any = None,
    waypoints: Any = None,
    heading: float | None = None,
):
    """Roll out ``policy`` deterministically for ``duration`` s; returns a
    :class:`~elastica_magnetic_rl.envs.rollout.Rollout`
    (stops early, with ``meta["diverged"]``, if the simulation blows up). ``target``: a goto
    case's target, (forward, left) in m from the start (default: drawn from the task's ring with
    seed 0); ``meta["target_xz_m"]`` then holds it in the floor's (x, z). ``waypoints`` ``(k, 2)``
    (forward, left; m from the start) instead: a path, each waypoint the target until the middle
    node comes within the task's tolerance of it, the last one to the end; ``meta["waypoints"]``
    then holds each one's place on the floor and the time it was reached (s, ``None``: never).
    ``heading`` (rad, counter-clockwise seen from above, 0 ahead) instead: crawl along the line
    from the start at that heading (:class:`~elastica_magnetic_rl.envs.waypoints.HeadingCourse`);
    ``meta["heading"]`` then holds how far along it and how far off it the middle node went."""
    import pandas as pd

    from elastica_magnetic.progress import progress_bar
    from elastica_magnetic.simulation import TRAJECTORY_COLUMNS

    from ..envs.rollout import Rollout

    env = make_env(policy.case, physics, initial_field, duration)
    if target is not None and not isinstance(policy.case.task, GotoTask):
        raise ValueError(f"a target is for a goto case; {policy.case.name!r} has the "
                         f"{policy.case.task.kind} task")
    path, _ = course_for_env(env, target, waypoints, heading)
    target = path.first_target if path is not None else target
    obs, _ = env.reset(seed=0, options=None if target is None else {"target": target})
    if path is not None:
        path.begin(env)
    if hasattr(policy, "reset"):  # a hand-designed policy with a memory
        policy.reset()
    if obs.shape[0] != policy.obs_dim:
        raise ValueError(f"policy expects {policy.obs_dim} observations, the environment gives "
                         f"{obs.shape[0]}")
    sim = env.simulation
    n = env.max_episode_steps
    times, positions, observations = [0.0], [sim.rod.position_collection.copy()], [obs]
    rows = [sim.markers()]
    fields, actions, rewards = [], [], []
    diverged = None
    start = time.perf_counter()
    with progress_bar(n, f"{policy.case.name} ({physics} physics)", "step", disable=not progress,
                      leave=False) as bar:
        for _ in range(n):
            action = policy.act(obs)
            obs, reward, terminated, truncated, info = env.step(action)
            if terminated:
                diverged = info.get("divergence", "diverged")
                break
            if path is not None:
                obs = path.advance(env, obs)
            fields.append(info["field_T"])
            actions.append(action)
            rewards.append(reward)
            times.append(sim.time)
            positions.append(sim.rod.position_collection.copy())
            observations.append(obs)
            rows.append(sim.markers())
            bar.update(1)
            if truncated:
                break
    wall = time.perf_counter() - start
    env.close()
    meta = _rollout_meta(policy, env, physics, initial_field, float(times[-1]), diverged, wall, len(actions))
    meta.update({} if path is None else {"waypoints" if heading is None else "heading": path.record()})
    return Rollout(
        times=np.asarray(times), positions=np.asarray(positions),
        fields=np.asarray(fields).reshape(-1, 3),
        actions=np.asarray(actions).reshape(-1, env.action_space.shape[0]),
        rewards=np.asarray(rewards), observations=np.asarray(observations, dtype=np.float32),
        trajectory=pd.DataFrame(rows, columns=list(TRAJECTORY_COLUMNS)), meta=meta,
    )


def _rollout_meta(policy: Any, env: Any, physics: str, initial_field: str, duration: float,
                  diverged: str | None, wall: float, steps: int) -> dict[str, Any]:
    """A rollout's ``meta``: what ran (case, physics, robot, policy), how long and how fast, and a
    goto episode's target on the floor."""
    spec = env.robot_spec
    meta = {
        "case": policy.case.name, "physics": physics, "initial_field": initial_field,
        "duration_s": duration, "field_limit_T": env.field_limit,
        "max_increment_T": env.max_increment, "length_m": spec.length, "radius_m": spec.radius,
        "n_elements": spec.n_elements, "policy_source": str(policy.source),
        "policy_kind": policy.kind, "diverged": diverged, "wall_s": wall,
        "step_ms": 1e3 * wall / max(steps, 1),
    }
    if isinstance(policy.case.task, GotoTask):
        meta["target_xz_m"] = [float(v) for v in env.task.target(env.task_state)]
    return meta


def node_dx(rollout) -> float:
    """x displacement of the reward's middle node (node ``n // 2``) over a rollout, m."""
    mid = rollout.positions.shape[2] // 2
    return float(rollout.positions[-1, 0, mid] - rollout.positions[0, 0, mid])


def evaluate_checkpoint(path: Path, cached: dict[str, Any], duration: float,
                     progress: bool, target: tuple[float, float] | None = None,
                     physics: str = "accurate") -> dict[str, Any]:
    """The evaluation of one checkpoint file (in the accurate physics unless ``physics`` says
    otherwise: a smoke run's) with its ``meets_target`` verdict (left out where there is none: a case
    without a yardstick, a crawl run not 10 s long), reusing ``cached`` when it is of the same global
    step, duration and physics (its stored verdict is not reused: an older file's ``meets_target`` of
    a case without a yardstick is dropped). A goto policy goes to
    ``target`` (forward, left; m), default the task's distance straight ahead."""
    policy = resolve_policy(path)
    step = policy.meta.get("global_step")
    task = policy.case.task
    keys = ("global_step", "duration_s", "physics", "initial_field", "mid_dx_m", "node_dx_m",
            "diverged", *(("final_distance_to_target_m",) if isinstance(task, GotoTask) else ()))
    if (cached.get("global_step") == step and cached.get("duration_s") == float(duration)
            and cached.get("physics", "accurate") == physics
            and all(k in cached for k in keys)):
        entry = {k: cached[k] for k in keys}
    else:
        # a goto policy goes to the target asked, else the task's distance straight ahead
        target = (target or (task.distance, 0.0)) if isinstance(task, GotoTask) else None
        rollout = run_policy(policy, duration, physics, "zero", progress, target=target)
        entry = {"global_step": step, "duration_s": float(duration), "physics": physics,
                 "initial_field": "zero", "mid_dx_m": rollout.mid_dx,
                 "node_dx_m": node_dx(rollout), "diverged": rollout.meta["diverged"]}
        if target is not None:
            mid = rollout.positions.shape[2] // 2
            end = rollout.positions[-1, [0, 2], mid]
            entry["final_distance_to_target_m"] = float(np.hypot(*(end - rollout.meta["target_xz_m"])))
            entry["target_m"] = [float(v) for v in target]
    met = policy.case.meets_yardstick(entry["mid_dx_m"], entry["node_dx_m"], duration,
                                      entry["diverged"])
    if met is not None:
        entry["meets_target"] = met
    return entry


def seed_run_dirs(case_dir: Path) -> list[tuple[int, Path]]:
    """``(seed, run_dir)`` of every ``case_dir/seed<k>/`` holding a checkpoint, ordered by seed."""
    present = CaseDir(case_dir).seeds()
    seeds = [(seed, run.path) for seed, run in present if run.has_checkpoint()]
    if not seeds:
        writing = [f"{run.path}: {hint}" for _, run in present if (hint := being_written_hint(run.path))]
        if writing:  # a seed another command trains, before its first checkpoint
            raise FileNotFoundError(f"{case_dir}: no {RunDir.CHECKPOINT} yet: {'; '.join(writing)}")
        raise FileNotFoundError(f"{case_dir}: no {CaseDir.SEED_PREFIX}<k>/{RunDir.CHECKPOINT} to "
                                "evaluate")
    return seeds


def evaluate_seeds(
    case_dir: str | Path,
    duration: float = 10.0,
    progress: bool = True,
    workers: int = 1,
    physics: str = "accurate",
) -> list[dict[str, Any]]:
    """Distance in ``duration`` s of every seed of a case, by the shipping criterion: the final
    checkpoint of ``case_dir/seed<k>/``, and its ``best.pt`` (best evaluation during training) when
    there is one, run deterministically in the accurate physics (``physics``: another, for a smoke
    run) from a zero field (as :func:`generate`).

    Each result is cached in the seed's folder (``evaluation.json``) and reused while the
    checkpoint's global step, the duration and the physics are the same. Returns one dict per seed, ordered by
    seed: ``seed``, ``global_step``, ``mid_dx_m`` (m), ``diverged``, ``meets_target`` (the case's
    yardstick met; absent for a case without one and for other durations than 10 s) of the final
    checkpoint, and ``best``: the same keys for ``best.pt``, or ``None``.
    """

    results = []
    seeds = seed_run_dirs(Path(case_dir))
    jobs = [(seed, run_dir, duration, progress and workers == 1, physics) for seed, run_dir in seeds]
    if workers > 1:  # each seed's rollouts in its own process
        from ..sweep.backends import run_in_processes

        # an evaluation loses nothing when ended: Ctrl-C ends the workers at once, quietly
        results = run_in_processes(_evaluate_seed, jobs, workers, stop_grace_s=0.0,
                                   quiet_interrupt=True)
    else:
        results = [_evaluate_seed(job) for job in jobs]
    return results


def _evaluate_seed(job: tuple[int, Path, float, bool, str]) -> dict[str, Any]:
    """The final and ``best.pt`` evaluations of one seed folder (cached in ``evaluation.json``)."""
    seed, run_dir, duration, progress, physics = job
    final, best = evaluate_run(run_dir, duration, progress, seed=seed, physics=physics)
    return {"seed": seed, **final, "best": best}


def evaluate_run(run_dir: str | Path, duration: float = 10.0, progress: bool = True,
                 seed: int | None = None, target: tuple[float, float] | None = None,
                 physics: str = "accurate") -> tuple[dict[str, Any], dict[str, Any] | None]:
    """The shipping criterion's evaluations (``duration`` s, accurate physics unless ``physics``
    says otherwise, field from zero) of a
    run folder's final checkpoint and of its ``best.pt`` (``None`` without one): each a dict of
    ``global_step``, ``duration_s``, ``physics``, ``initial_field``, ``mid_dx_m``, ``node_dx_m``
    (m), ``diverged`` and ``meets_target`` (absent without a verdict,
    :func:`evaluate_checkpoint`). Cached in the folder's ``evaluation.json`` and reused while the
    checkpoint's step, the duration and the physics are the same. A goto run's actors go to ``target``
    (forward, left; m) when given: evaluated afresh and not cached (the cache holds the task's
    own target's)."""
    run = RunDir(run_dir)
    cache_path = run.evaluation_json
    cache = _cached_evaluations(cache_path) if target is None else {}
    final = evaluate_checkpoint(run.checkpoint, cache, duration, progress, target, physics)
    best = None
    if run.best.is_file():
        # a best.pt holding the final actor (a seed stopped by its rule right after that
        # evaluation, or the last evaluation the best) has the final actor's evaluation
        prior = final if _same_actor(run.checkpoint, run.best) else cache.get("best") or {}
        best = evaluate_checkpoint(run.best, prior, duration, progress, target, physics)
    if target is not None:
        return final, best
    if seed is None:
        seed = cache.get("seed")
    atomic_write_json(cache_path, {"seed": seed, **final, "best": best})
    return final, best


def _same_actor(a: Path, b: Path) -> bool:
    """Whether two checkpoint files hold the same actor: same global step, equal weights."""
    import torch

    pa, pb = resolve_policy(a), resolve_policy(b)
    if pa.meta.get("global_step") != pb.meta.get("global_step"):
        return False
    sa, sb = pa.actor.state_dict(), pb.actor.state_dict()
    return sa.keys() == sb.keys() and all(torch.equal(sa[k], sb[k]) for k in sa)


def prefer_best(case: Case, final: dict[str, Any], best: dict[str, Any] | None) -> bool:
    """The one rule for which of a run's two actors to use: ``best.pt`` when it did not diverge
    and either the final actor diverged or ``best.pt`` is better in the same evaluation (farther:
    larger ``mid_dx_m``; for a reach task, ending closer to the target by ``node_dx_m``; for a goto
    task, ending closer to the target straight ahead, ``final_distance_to_target_m``); never by
    ``meets_target``. ``final`` and ``best``: :func:`evaluate_checkpoint` entries (``best``
    ``None``: no ``best.pt``)."""
    if best is None or best["diverged"]:
        return False
    if final["diverged"]:
        return True
    if isinstance(case.task, ReachTask):
        return abs(best["node_dx_m"] - case.task.target) < abs(final["node_dx_m"] - case.task.target)
    if isinstance(case.task, GotoTask):
        return best["final_distance_to_target_m"] < final["final_distance_to_target_m"]
    return best["mid_dx_m"] > final["mid_dx_m"]


@dataclass(frozen=True)
class ActorChoice:
    """Which actor of a run a command uses, and why.

    ``path``: the checkpoint file used; ``which``: ``"final"`` (``checkpoint.pt``), ``"best"``
    (``best.pt``) or ``"given"`` (a file named with ``--checkpoint PATH``); ``rule``: ``"farther"``
    (:func:`prefer_best` on both evaluations), ``"asked"``, ``"only"`` (the run has no
    ``best.pt``), ``"training"`` (a tip-reach run's ``best.pt``, the training's best evaluation,
    not evaluated again: :func:`choose_tip_reach_actor`) or ``"unmeasured"`` (the final actor
    ``msr policy ship --no-measure`` takes without evaluating either); ``final`` / ``best``: their
    :func:`evaluate_run` entries when both were evaluated (else ``None``)."""

    path: Path
    which: str
    rule: str
    final: dict[str, Any] | None = None
    best: dict[str, Any] | None = None

    def to_dict(self) -> dict[str, Any]:
        return {"checkpoint": str(self.path), "actor": self.which, "rule": self.rule,
                "final": self.final, "best": self.best}

    def describe(self) -> str:
        """One line: the actor used and, when both were evaluated, both distances with their
        physics, duration and initial field."""
        name = {"final": f"the final actor ({RunDir.CHECKPOINT})", "best": RunDir.BEST,
                "given": str(self.path)}[self.which]
        if self.rule == "only":
            return f"{name} (the run has no {RunDir.BEST})"
        if self.rule == "training":
            return f"{name} (the training's best evaluation; --checkpoint final for the final actor)"
        if self.rule == "unmeasured":
            return f"{name} (--no-measure: not compared with {RunDir.BEST})"
        if self.rule == "asked" or self.final is None:
            return f"{name} (as asked)"
        goto = "final_distance_to_target_m" in self.final

        def one(label: str, e: dict[str, Any] | None) -> str:
            if e is None:
                return f"{label}: none"
            moved = ("diverged" if e["diverged"]
                     else f"{1e3 * e['final_distance_to_target_m']:.3g} mm from it" if goto
                     else f"{1e3 * e['mid_dx_m']:+.3g} mm")
            return f"{label} (step {e['global_step']}) {moved}"
        e = self.final
        rule = "the farther of the two"
        if goto and "target_m" in e:
            forward, left = (1e3 * v for v in e["target_m"])
            rule = (f"the nearer of the two to the target ({forward:+.3g}, {left:+.3g}) mm (ahead, left) "
                    "at the end")
        elif goto:  # an evaluation cached before targets were recorded: the task's own
            rule = "the nearer of the two to the task's target straight ahead at the end"
        return (f"{name}, {rule} in {e['duration_s']:g} s of {e['physics']} physics "
                f"from a {e['initial_field']} field: {one('final', self.final)}, "
                f"{one('best.pt', self.best)}")


def _why_no_best(run_files: RunDir) -> str:
    """Why a run has no ``best.pt``, from its ``evaluations.csv`` (every evaluation writes one)."""
    from ..runfiles.logs import read_log

    if not run_files.evaluations_csv.is_file():
        return "(the run made no evaluation during training)"
    try:
        evaluated = len(read_log(run_files.evaluations_csv, ("global_step",), whole_rows_only=True))
    except ValueError as exc:  # a damaged log: say so rather than guess
        return f"(and its evaluations cannot be counted: {exc})"
    if not evaluated:
        return "(the run made no evaluation during training)"
    return (f"(best.pt is missing though the run evaluated {evaluated} times (deleted or moved?), "
            f"see {run_files.evaluations_csv}; --checkpoint final takes the final actor)")


def check_checkpoint_file(run: str | Path, checkpoint: str) -> Path:
    """``--checkpoint PATH`` (not auto, final, best) of ``run``: the file, or a
    ``FileNotFoundError`` naming what it is instead (a folder, nothing there, a path through a
    missing folder, the run's own ``best.pt`` meant as ``best``)."""
    path = Path(run)
    run_dir = path if path.is_dir() else path.parent
    given = Path(checkpoint)
    if given.is_dir():
        raise FileNotFoundError(f"--checkpoint {checkpoint}: a folder; give one of the run's checkpoint "
                                f"files ({RunDir.CHECKPOINT}, {RunDir.BEST}) or auto, final, best")
    if not given.is_file():
        own = {RunDir.BEST: "best", RunDir.CHECKPOINT: "final"}.get(str(checkpoint))
        hint = (f"; the run's own {checkpoint} is --checkpoint {own}"
                if own is not None and (run_dir / checkpoint).is_file() else "")
        raise FileNotFoundError(f"--checkpoint {checkpoint}: no such checkpoint file (or auto, "
                                f"final, best){hint}{missing_folder_hint(checkpoint)}")
    return given


def choose_actor(run: str | Path, checkpoint: str = "auto", duration: float = 10.0,
                 progress: bool = True, target: tuple[float, float] | None = None) -> ActorChoice | None:
    """The actor of a run to use: ``run`` is a run folder or its ``checkpoint.pt``; ``checkpoint``
    is ``"auto"`` (both actors evaluated, :func:`evaluate_run`, toward ``target`` for a goto run,
    and the better by :func:`prefer_best`), ``"final"``, ``"best"`` or a checkpoint file's path.
    Returns ``None`` when ``run`` is not a run (a shipped policy, a ``best.pt`` named directly)
    and ``checkpoint`` is ``"auto"``. Raises ``FileNotFoundError`` naming what is missing."""
    path = Path(run)
    run_dir = path if path.is_dir() else path.parent
    is_run = (path.is_dir() and RunDir(path).has_checkpoint()) or (
        path.is_file() and path.name == RunDir.CHECKPOINT)
    if checkpoint not in CHECKPOINT_CHOICES:
        given = check_checkpoint_file(run, checkpoint)
        if not is_run:  # a shipped policy has one actor: the checkpoint would be played in its place
            raise ValueError(f"--checkpoint {checkpoint}: {run} is not a run folder (a shipped policy or an "
                             "actor file): it has no checkpoints to choose among; leave --checkpoint out"
                             + _checkpoint_itself(given, run))
        own, other = resolve_policy(run).case.name, resolve_policy(given).case.name
        if own != other:  # another case's actor would be played on this run's robot
            raise ValueError(f"--checkpoint {checkpoint}: a checkpoint of case {other!r}, not of "
                             f"{run}'s case {own!r}: give one of this run's checkpoints (or auto, "
                             "final, best), or play that checkpoint itself")
        if given.resolve().parent != run_dir.resolve():  # another run's: this run would not be played
            raise ValueError(f"--checkpoint {checkpoint}: not one of {run}'s checkpoints (another run's "
                             f"actor would be played in its place): give one of this run's checkpoints "
                             f"(or auto, final, best), or play that checkpoint itself (msr policy "
                             f"generate {checkpoint})")
        return ActorChoice(given, "given", "asked")
    if not is_run:
        if checkpoint == "auto":
            return None
        raise FileNotFoundError(f"--checkpoint {checkpoint}: {run} is not a run folder (or its "
                                f"{RunDir.CHECKPOINT})")
    run_files = RunDir(run_dir)
    check_not_training(run_dir)
    if checkpoint == "final":
        return ActorChoice(run_files.checkpoint, "final", "asked")
    if checkpoint == "best":
        if not run_files.best.is_file():
            raise FileNotFoundError(f"--checkpoint best: {run_files.best}: no such file "
                                    f"{_why_no_best(run_files)}")
        return ActorChoice(run_files.best, "best", "asked")
    if not run_files.best.is_file():
        return ActorChoice(run_files.checkpoint, "final", "only")
    final, best = evaluate_run(run_dir, duration, progress, target=target)
    case = resolve_policy(run_files.checkpoint).case
    if prefer_best(case, final, best):
        return ActorChoice(run_files.best, "best", "farther", final, best)
    return ActorChoice(run_files.checkpoint, "final", "farther", final, best)


def _checkpoint_itself(given: Path, run: str | Path) -> str:
    """The rest of the advice for ``--checkpoint FILE`` on a policy ``run`` (a name or a folder)
    that has one actor: FILE given in the policy's place where it is a training checkpoint, else
    nothing more (a shipped policy's own files, a field CSV: only leaving the option out plays
    anything)."""
    from ..runfiles.checkpoint import load_checkpoint

    if Path(run).is_dir() and given.resolve().parent == Path(run).resolve():
        return f" ({run} plays its own actor)"
    try:
        load_checkpoint(given, with_buffer=False)
    except (ValueError, OSError):
        return f" ({given} is no training checkpoint)"
    return f", or give that checkpoint itself in place of {run}"


def check_not_training(run_dir: Path) -> None:
    """Refuse a run another live process is still training (its folder's lock): its checkpoints
    are a step of the training, not its final or best actor yet."""
    from elastica_magnetic.locks import describe_owner, held_here, live_owner

    if not held_here(run_dir) and (owner := live_owner(run_dir)) is not None:
        raise ValueError(f"{run_dir}: is being trained by {describe_owner(owner)}: its checkpoints are a "
                         "step of that training, not its final or best actor yet; wait until it ends "
                         "(or stop it: Ctrl-C keeps its checkpoints), then choose")


def choose_tip_reach_actor(run: str | Path, checkpoint: str = "auto") -> ActorChoice | None:
    """The actor of a tip-reach run (a catheter steered by a source): as :func:`choose_actor`,
    except that ``"auto"`` takes ``best.pt`` (the training's best evaluation) when the run has one,
    without evaluating the two again: a tip-reach policy is judged on the case's held-out targets,
    which must not choose it."""
    path = Path(run)
    run_dir = path if path.is_dir() else path.parent
    is_run = (path.is_dir() and RunDir(path).has_checkpoint()) or (
        path.is_file() and path.name == RunDir.CHECKPOINT)
    if checkpoint != "auto" or not is_run:
        return choose_actor(run, checkpoint, progress=False)
    run_files = RunDir(run_dir)
    check_not_training(run_dir)
    if run_files.best.is_file():
        return ActorChoice(run_files.best, "best", "training")
    return ActorChoice(run_files.checkpoint, "final", "only")


def _cached_evaluations(path: Path) -> dict[str, Any]:
    """The evaluations cached in ``path`` (``evaluation.json``); a damaged cache (a kill while it
    was written by an older version) is evaluated again, as if absent: it holds only results."""
    try:
        cache = json.loads(path.read_text(encoding="utf-8")) if path.is_file() else {}
    except (ValueError, UnicodeDecodeError):
        return {}
    return cache if isinstance(cache, dict) else {}
