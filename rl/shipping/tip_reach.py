"""Judging a tip-reach case (a clamped rod steered by a magnet on an arm or by fixed coils):
held-out targets drawn from the case's ``target_box`` with a seed no training uses, and the result
of a controller on them (a trained actor, or the yardstick: the bearing steering law of
:class:`~elastica_magnetic.steering.MagnetBearingSteering` for a magnet,
:class:`~elastica_magnetic.steering.CoilFieldSteering` for coils), all targets at once in one
batched environment. Lengths in m, times in s.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic import MagnetPose
from elastica_magnetic.steering import CoilFieldSteering, MagnetBearingSteering

from ..cases.case import Case
from ..envs.catheter_env import CatheterReachVectorEnv, make_catheter_env

__all__ = ["HELD_OUT_SEED", "HELD_OUT_TARGETS", "held_out_targets", "run_targets", "steering_controller"]

#: Seed of the held-out targets: training draws its targets with the run's seed plus small offsets
#: (episode numbers), never this one.
HELD_OUT_SEED = 53_000_053
#: How many held-out targets a tip-reach policy is judged on.
HELD_OUT_TARGETS = 20

#: A controller: given the environment and its observation ``(N, size)``, the actions ``(N, A)``.
Controller = Callable[[CatheterReachVectorEnv, NDArray[np.float32]], NDArray[np.float64]]


def held_out_targets(case: Case, n: int = HELD_OUT_TARGETS, seed: int = HELD_OUT_SEED) -> NDArray[np.float64]:
    """``(n, 3)`` targets drawn uniformly in the case's ``target_box`` (m) with ``seed``."""
    low, high = np.asarray(case.task.target_box, dtype=np.float64)
    return np.random.default_rng(seed).uniform(low, high, size=(int(n), 3))


#: 1/s: with an insertion stage, the yardstick commands its velocity as this gain times the gap
#: between the target's and the tip's distance from the base's start (m), over the stage's top speed.
INSERTION_GAIN = 5.0


#: The fraction of the coils' strongest field at the straight tip that the coils' yardstick asks
#: (headroom: a tip away from the start, where the coils give less, still gets the field asked).
COIL_FIELD_FRACTION = 0.5


def steering_controller(env: CatheterReachVectorEnv) -> Controller:
    """The yardstick of a tip-reach case: for a magnet arm, the bearing steering law, the magnet
    kept at its start distance from the straight tip; for coils, the same law choosing the field's
    direction at the tip and the least-norm currents making it (:data:`COIL_FIELD_FRACTION` of the
    strongest field at the straight tip); with an insertion stage, the stage pushed or pulled until
    the tip is as far from the base's start as the target (:data:`INSERTION_GAIN`)."""
    length = float(env.spec.length)
    if isinstance(env.actuators[0], MagnetPose):
        start = np.asarray(env.actuation.position, dtype=np.float64)
        distance = float(np.linalg.norm(start - np.array([length, 0.0, 0.0])))
        laws = [MagnetBearingSteering(arm, base=[0.0, 0.0, 0.0], distance=distance) for arm in env.actuators]
    else:
        field = COIL_FIELD_FRACTION * env.actuation.field_at_tip(length)
        laws = [CoilFieldSteering(coils, base=[0.0, 0.0, 0.0], field=field) for coils in env.actuators]

    def act(env: CatheterReachVectorEnv, obs: NDArray[np.float32]) -> NDArray[np.float64]:
        steer = np.stack([law.action(env.tip(i), env.targets[i], env.robots.robot_time(i), 0.01)
                          for i, law in enumerate(laws)])
        if not env.advancers:
            return steer
        gap = np.linalg.norm(env.targets, axis=1) - np.array([np.linalg.norm(env.tip(i))
                                                             for i in range(env.num_envs)])
        push = np.clip(INSERTION_GAIN * gap / env.advancers[0].max_speed, -1.0, 1.0)
        return np.concatenate([steer, push[:, None]], axis=1)

    return act


def run_targets(case: Case, targets: Any,
                make_controller: Callable[[CatheterReachVectorEnv], Controller],
                physics: str = "accurate", duration: float | None = None) -> dict[str, Any]:
    """Steer to every target at once (one episode each, ``duration`` s, default the task's), in
    ``physics``. ``make_controller``: makes the :data:`Controller` from the environment (as
    :func:`steering_controller`; an actor: ``lambda env: lambda env, obs: actor(obs)``). Returns
    ``targets_m``, per target ``final_distance_m``, ``closest_distance_m``, ``ended_by``
    (``"time"``, ``"collision"`` or ``"divergence"``) and ``success`` (ending within the
    tolerance, by time), and ``successes`` (their count)."""
    if case.field_actuated:
        raise ValueError(f"case {case.name!r} is not a tip-reach case (its actuation is a field)")
    targets = np.asarray(targets, dtype=np.float64).reshape(-1, 3)
    env = make_catheter_env(case, len(targets), physics, duration)
    obs, info = env.reset(seed=0, options={"target": targets})
    act = make_controller(env)
    n = len(targets)
    final, ended_by = np.full(n, np.nan), np.full(n, None, dtype=object)
    closest = info["distance_m"].copy()
    done = np.zeros(n, dtype=bool)
    while not done.all():
        obs, _, terminated, truncated, info = env.step(act(env, obs))
        ended = (terminated | truncated) & ~done
        if ended.any():
            last = info["final_info"]
            final[ended] = last["distance_m"][ended]
            ended_by[ended] = last["ended_by"][ended]
            closest[ended] = np.minimum(closest[ended], last["distance_m"][ended])
        closest[~done & ~ended] = np.minimum(closest[~done & ~ended], info["distance_m"][~done & ~ended])
        done |= ended
    success = (ended_by == "time") & case.task.within_tolerance(final)
    return {"targets_m": targets.tolist(), "final_distance_m": final.tolist(),
            "closest_distance_m": closest.tolist(), "ended_by": ended_by.tolist(),
            "success": success.tolist(), "successes": int(success.sum()), "physics": physics,
            "duration_s": env.task.episode_duration}
