"""N clamped catheters, each steered by its own magnet on an arm or its own currents in fixed coils:
a Gymnasium 1.x vector environment (``CatheterReachVectorEnv``) of the tip-reach task.

Each sub-environment ``i`` is a rod clamped at its first node and element (a catheter held at its
base, straight along +x from the origin at the start) in the field of a permanent magnet that a
robot arm carries (:class:`~elastica_magnetic.MagnetPose`) or of fixed coils
(:class:`~elastica_magnetic.CoilCurrents`): the policy's action moves and turns the magnet, or
sets the currents; the task (:class:`~elastica_magnetic_rl.cases.tasks.TipReachTask`) rewards
bringing the tip to a target drawn per episode. All N rods live in one
:class:`~elastica_magnetic.batch.BatchedRobots` (``clamp=True``), every arm's magnet (or coil set)
applied by one kernel, bit for bit the per-rod simulation of the same commands.

Spaces (float32), for a magnet arm: action ``Box([-1, 1])`` of shape ``(N, 5)``: the magnet's
velocity (3, up to the arm's ``max_speed`` m/s as a vector) and its moment's turn rate about the
two directions across it (2, up to ``max_turn_rate`` rad/s), followed continuously over the 0.01 s
control step; for ``C`` coils, ``(N, C)``: each current over its limit, ramped at most at
``max_slew``. With an insertion stage, one more component (its velocity). Observation
``(N, 3 (n + 1) + 12)`` for a rod of ``n`` elements (see :func:`catheter_observation_layout`), every
length relative to the clamped base and scaled by 100 per m (10 mm reads 1.0):

=======================  =========  ==========================================================
block                    size       value
=======================  =========  ==========================================================
``node_positions``       3 (n + 1)  ``100 * (x_k - base)`` per node, m: the rod's shape
``tip_velocity``         3          ``10 * v_tip``, m/s (0.1 m/s reads 1.0): where it is going
``magnet_position``      3          ``100 * (p - base)``, m: the arm's state
``magnet_direction``     3          the moment's unit direction
``target_offset``        3          ``100 * (target - tip)``, m: the task's
=======================  =========  ==========================================================

For coils, a ``coil_currents`` block (C: the currents over their limit) and a ``tip_field`` block
(3: ``100 * B_tip``, T, the coils' field at the tip from those currents, 10 mT reads 1.0) stand
where the magnet's two are. The field at the tip is the coils' counterpart of the magnet's
direction: what a steering law turns, here read directly instead of computed from the currents
through the coils' field map (a lab computes it the same way, from its coil model and the tracked
tip). The shape and the magnet's pose (or the currents) are what decide the next field at
every element; the tip's velocity carries the rod's momentum (the dynamics of a scaled mass); the
offset says where to go in the frame a policy steers in (the spec's: the base moves only along x).

Episode end: the time limit (``task.episode_duration``) truncates. An episode terminates, with
reward ``divergence_penalty``, when the simulation blows up or a magnet comes within
``min_clearance`` m of a node of the rod (an arm must not touch the catheter; near the magnet the
gradient force grows as ``1 / r^4``). Autoreset ``SAME_STEP`` with ``final_obs`` / ``final_info``,
seeding ``s + i`` and :meth:`get_state` / :meth:`set_state` follow
:class:`~elastica_magnetic_rl.envs.vector_env.MagneticCrawlerVectorEnv`.

Units: SI (m, s, T, A m^2).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numpy.typing import NDArray

from elastica_magnetic import CoilCurrents, MagnetPose, RobotSpec
from elastica_magnetic.batch import BatchedRobots, BatchedSimulationDivergedError
from elastica_magnetic.robot_spec import ACTION_PERIOD

from ..cases.arm_actuation import MAGNET_ARM_OBSERVATION
from ..cases.case import Case
from ..cases.steered import SteeringActuation
from ..cases.tasks import TipReachTask
from .vector_reset import reseed

__all__ = ["CATHETER_OBSERVATION_SCALES", "CatheterReachVectorEnv", "catheter_observation_layout",
           "make_catheter_env"]

STATE_FORMAT = "msr-catheter-vector-state-v2"

#: Scale factors of the observation, SI input units (see the module docstring).
CATHETER_OBSERVATION_SCALES: dict[str, float] = {
    "node_positions": 100.0,  # per m
    "tip_velocity": 10.0,  # per m/s
    "magnet_position": 100.0,  # per m
    "magnet_direction": 1.0,
    "coil_currents": 1.0,  # over the current limit
    "tip_field": 100.0,  # per T (the coils' field at the tip: 10 mT reads 1.0)
    "insertion": 100.0,  # per m
    "target_offset": 100.0,  # per m (the task's)
}


def catheter_observation_layout(n_elements: int, blocks: Sequence[tuple[str, int]] = MAGNET_ARM_OBSERVATION
                                ) -> dict[str, slice]:
    """Index slices of each observation block for a rod of ``n_elements`` elements: its node
    positions, the actuation's ``blocks`` (name, size; its ``observation_blocks``, default a magnet
    arm's without a stage), then the target's offset."""
    sizes = (("node_positions", 3 * (int(n_elements) + 1)), *blocks, ("target_offset", 3))
    out, start = {}, 0
    for name, size in sizes:
        out[name] = slice(start, start + size)
        start += size
    return out


class CatheterReachVectorEnv(VectorEnv):
    """``num_envs`` catheters with their actuators, stepped together (see the module docstring).

    Parameters
    ----------
    num_envs : int
        Number of sub-environments ``N`` >= 1.
    spec : RobotSpec
        The rod, in SI, in the physics it trains in (its first node and element are clamped).
    actuation : MagnetArm or CoilArray
        What steers each rod (:class:`~elastica_magnetic_rl.cases.arm_actuation.MagnetArm`: a magnet
        on an arm, which every episode starts at its start pose and which ends an episode when it
        comes within its ``min_clearance`` m of a node; or
        :class:`~elastica_magnetic_rl.cases.coil_actuation.CoilArray`: fixed coils, every episode
        starting from zero currents), with its insertion stage if it has one (the action's last
        component, the observation's ``insertion`` block, ``100 * s``, m).
    task : TipReachTask
        Targets, tolerance, reward and episode duration.
    divergence_penalty : float
        Reward of a step that ends an episode by a blow-up or a collision.
    """

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": []}

    def __init__(self, num_envs: int, spec: RobotSpec, actuation: SteeringActuation,
                 task: TipReachTask | None = None, divergence_penalty: float = -10.0) -> None:
        if int(num_envs) != num_envs or num_envs < 1:
            raise ValueError(f"num_envs must be a positive integer, got {num_envs!r}")
        if not isinstance(actuation, SteeringActuation):
            raise TypeError(f"actuation: a MagnetArm or a CoilArray (a case's actuation), got "
                            f"{type(actuation).__name__}")
        self.num_envs = int(num_envs)
        self.spec, self.task = spec, task if task is not None else TipReachTask()
        self.actuation = actuation
        self.actuators: list[MagnetPose | CoilCurrents] = [actuation.actuator() for _ in range(self.num_envs)]
        self.advancers = [actuation.advancer() for _ in range(self.num_envs)] if actuation.insertion else []
        self.action_size, self.command_size = actuation.action_size, actuation.actuator_size
        self.min_clearance = getattr(actuation, "min_clearance", None)  # a magnet's; coils have none
        self.divergence_penalty = float(divergence_penalty)
        self.max_episode_steps = max(1, round(self.task.episode_duration / ACTION_PERIOD))
        self.layout = catheter_observation_layout(spec.n_elements, actuation.observation_blocks)
        size = self.layout["target_offset"].stop
        self.render_mode = None
        self.single_observation_space = spaces.Box(-np.inf, np.inf, (size,), np.float32)
        self.single_action_space = spaces.Box(-1.0, 1.0, (self.action_size,), np.float32)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.robots: BatchedRobots | None = None
        self.steps = np.zeros(self.num_envs, dtype=np.int64)
        self._obs = np.zeros((self.num_envs, size), dtype=np.float32)
        self._targets = np.zeros((self.num_envs, 3))
        self._rngs: list[np.random.Generator | None] = [None] * self.num_envs

    # -- helpers ------------------------------------------------------------------------------------
    def tip(self, i: int) -> NDArray[np.float64]:
        """The tip (last node) of robot ``i``, m, ``(3,)``."""
        return self.task.position(self.robots.rods[i])

    @property
    def targets(self) -> NDArray[np.float64]:
        """``(N, 3)``: each sub-environment's target, m."""
        return self._targets

    def _base(self, i: int) -> NDArray[np.float64]:
        return self.robots.rods[i].position_collection[:, 0]

    def insertion(self, i: int) -> float:
        """m: how far robot ``i``'s base has been pushed (0 without an insertion stage)."""
        return self.advancers[i].insertion_at(self.robots.robot_time(i)) if self.advancers else 0.0

    def _observe(self, i: int) -> NDArray[np.float32]:
        rod, actuator, time = self.robots.rods[i], self.actuators[i], self.robots.robot_time(i)
        base, tip = self._base(i), self.tip(i)
        scales, layout = CATHETER_OBSERVATION_SCALES, self.layout
        obs = np.empty(layout["target_offset"].stop)
        obs[layout["node_positions"]] = (scales["node_positions"]
                                         * (rod.position_collection - base[:, None])).T.reshape(-1)
        obs[layout["tip_velocity"]] = scales["tip_velocity"] * rod.velocity_collection[:, -1]
        if isinstance(actuator, MagnetPose):
            position, direction = np.split(actuator.state(time), 2)
            obs[layout["magnet_position"]] = scales["magnet_position"] * (position - base)
            obs[layout["magnet_direction"]] = direction
        else:
            obs[layout["coil_currents"]] = scales["coil_currents"] * actuator.state(time)
            obs[layout["tip_field"]] = scales["tip_field"] * (actuator.field_matrix(tip, time)
                                                              @ actuator.currents_at(time))
        if self.advancers:
            obs[layout["insertion"]] = scales["insertion"] * self.insertion(i)
        obs[layout["target_offset"]] = self.task.observe(tip, self._targets[i])
        return obs.astype(np.float32)

    def clearance(self, i: int) -> float:
        """Distance from robot ``i``'s magnet to the nearest node of its rod, m (infinite for coils)."""
        actuator = self.actuators[i]
        if not isinstance(actuator, MagnetPose):
            return math.inf
        magnet = actuator.position_at(self.robots.robot_time(i))
        nodes = self.robots.rods[i].position_collection
        return float(np.sqrt(((nodes - magnet[:, None]) ** 2).sum(axis=0)).min())

    def _rng(self, i: int) -> np.random.Generator:
        if self._rngs[i] is None:
            self._rngs[i], _ = seeding.np_random(None)
        return self._rngs[i]

    def _reset_one(self, i: int, target: Any = None) -> None:
        """Robot ``i`` back straight at rest, its actuator at its start, a new target."""
        self.robots.reset_robot(i)
        self.actuators[i].reset()
        if self.advancers:
            self.advancers[i].reset()
        self.steps[i] = 0
        self._targets[i] = self.task.start(self.tip(i), self._rng(i), target)
        self._obs[i] = self._observe(i)

    def _healthy(self, i: int) -> bool:
        rod = self.robots.rods[i]
        v, x = rod.velocity_collection, rod.position_collection
        return bool(np.all(np.einsum("ij,ij->j", v, v) <= self.robots.max_speed ** 2)
                    and np.all(np.isfinite(x)))

    def _info(self) -> dict[str, Any]:
        n = self.num_envs
        tips = np.stack([self.tip(i) for i in range(n)])
        info = {"time_s": self.steps * ACTION_PERIOD, "tip_m": tips, "target_m": self._targets.copy(),
                "distance_m": np.linalg.norm(tips - self._targets, axis=1)}
        for key in list(info):
            info[f"_{key}"] = np.ones(n, dtype=bool)
        return info

    # -- Gymnasium API -----------------------------------------------------------------------------
    def reset(self, *, seed: int | list[int | None] | None = None,
              options: dict[str, Any] | None = None) -> tuple[NDArray[np.float32], dict[str, Any]]:
        """Reset all sub-environments (or those of ``options["reset_mask"]``, a bool ``(N,)``).
        ``seed``: ``s`` seeds sub-environment ``i`` with ``s + i``; a list, one each.
        ``options["target"]``: ``(x, y, z)`` m, the target of every reset episode, or ``(N, 3)``
        one per sub-environment (else drawn)."""
        options = dict(options or {})
        if isinstance(seed, (int, np.integer)):
            super().reset(seed=int(seed))
        mask = reseed(self._rngs, seed, options, first=self.robots is None)
        if self.robots is None:
            self.robots = BatchedRobots(self.spec, self.num_envs, sources=[a.source for a in self.actuators],
                                        clamp=True, advancers=self.advancers or None)
        targets = options.get("target")
        if targets is not None and np.ndim(targets) == 2:  # one target per sub-environment
            if np.shape(targets) != (self.num_envs, 3):
                raise ValueError(f"target: one (x, y, z) in m, or one per sub-environment "
                                 f"({self.num_envs}, 3); got shape {np.shape(targets)}")
        for i in np.flatnonzero(mask):
            self._reset_one(int(i), targets[i] if targets is not None and np.ndim(targets) == 2 else targets)
        return self._obs.copy(), self._info()

    def step(self, actions: NDArray[np.float32]) -> tuple[
            NDArray[np.float32], NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_], dict[str, Any]]:
        """Command every actuator for 0.01 s and simulate it. Returns ``obs`` ``(N, size)`` float32 (the
        first of a new episode where one ended), ``rewards`` ``(N,)``, ``terminated``,
        ``truncated`` ``(N,)`` bool and the info dict (``final_obs`` / ``final_info`` where an
        episode ended, ``ended_by`` there: ``"time"``, ``"collision"`` or ``"divergence"``)."""
        if self.robots is None:
            raise RuntimeError("call reset() before step()")
        n, robots = self.num_envs, self.robots
        a = np.asarray(actions, dtype=np.float64).reshape(n, self.action_size)
        if not np.all(np.isfinite(a)):
            raise ValueError(f"actions must be finite, got {actions!r}")
        before = [self.tip(i) for i in range(n)]
        for i, actuator in enumerate(self.actuators):
            actuator.apply(a[i, :self.command_size], robots.robot_time(i), ACTION_PERIOD)
            if self.advancers:
                self.advancers[i].apply(np.clip(a[i, self.command_size:], -1.0, 1.0),
                                        robots.robot_time(i), ACTION_PERIOD)
        diverged = np.zeros(n, dtype=bool)
        try:
            robots.step(self.spec.steps_per_action)
        except BatchedSimulationDivergedError:
            diverged = np.array([not self._healthy(i) for i in range(n)])
        collided = np.array([not diverged[i] and self.min_clearance is not None
                             and self.clearance(i) < self.min_clearance for i in range(n)])
        rewards = np.full(n, self.divergence_penalty)
        for i in np.flatnonzero(~diverged):
            obs = self._observe(i)
            if not np.all(np.isfinite(obs)):
                diverged[i] = True
                continue
            self._obs[i] = obs
            if not collided[i]:
                rewards[i] = self.task.reward(before[i], self.tip(i), self._targets[i])
        self.steps += 1
        terminated = diverged | collided
        truncated = ~terminated & (self.steps >= self.max_episode_steps)
        info = self._info()
        ended = np.flatnonzero(terminated | truncated)
        if ended.size:
            info.update(self._end_episodes(info, ended, diverged, collided))
        return self._obs.copy(), rewards, terminated, truncated, info

    def _end_episodes(self, info: dict[str, Any], ended: NDArray[np.int64], diverged: NDArray[np.bool_],
                      collided: NDArray[np.bool_]) -> dict[str, Any]:
        """Record the ended episodes' last observation and info, reset them (same step), and
        return the info entries of the new episodes with ``final_obs`` / ``final_info``."""
        n = self.num_envs
        final_obs = np.full(n, None, dtype=object)
        final_info: dict[str, Any] = {}
        keys = ("time_s", "tip_m", "target_m", "distance_m")
        for key in keys:
            final_info[key] = info[key].copy()
            final_info[f"_{key}"] = np.zeros(n, dtype=bool)
        ended_by = np.full(n, None, dtype=object)
        for i in ended:
            final_obs[i] = self._obs[i].copy()
            for key in keys:
                final_info[f"_{key}"][i] = True
            ended_by[i] = "divergence" if diverged[i] else "collision" if collided[i] else "time"
        final_info["ended_by"], final_info["_ended_by"] = ended_by, np.isin(np.arange(n), ended)
        for i in ended:
            self._reset_one(int(i))
        fresh = self._info()
        return {**{key: fresh[key] for key in keys}, "final_obs": final_obs,
                "_final_obs": np.isin(np.arange(n), ended), "final_info": final_info,
                "_final_info": np.isin(np.arange(n), ended)}

    # -- state -------------------------------------------------------------------------------------
    def get_state(self) -> dict[str, Any]:
        """Everything that determines the future of all sub-environments: the memory block's base
        arrays, each actuator's motion (an arm's ``(16,)``, coils' ramp), the step counters,
        observations, targets ``(N, 3)`` m and the generators' states (restore with
        :meth:`set_state`)."""
        if self.robots is None:
            raise RuntimeError("call reset() before get_state()")
        if any(r is None for r in self._rngs):
            raise RuntimeError("every sub-environment needs a generator (reset with a seed)")
        return {"format": STATE_FORMAT, "num_envs": self.num_envs,
                "block": {name: value.copy() for name, value in self.robots.base_arrays().items()},
                "motions": np.stack([_motion(actuator) for actuator in self.actuators]),
                "stages": np.array([stage.motion() for stage in self.advancers]).reshape(-1, 4),
                "steps": self.steps.copy(), "robot_step_count": self.robots.robot_step_count.copy(),
                "step_count": int(self.robots.step_count), "obs": self._obs.copy(),
                "targets": self._targets.copy(), "rngs": [r.bit_generator.state for r in self._rngs]}

    def set_state(self, state: dict[str, Any]) -> None:
        """Restore a :meth:`get_state` snapshot (arrays may be numpy arrays or CPU tensors)."""
        if state.get("format") != STATE_FORMAT or int(state["num_envs"]) != self.num_envs:
            raise ValueError("not a state of this vector environment (format or num_envs differ)")
        if self.robots is None:
            self.reset(seed=0)
        arrays = self.robots.base_arrays()
        if set(arrays) != set(state["block"]):
            raise ValueError("the saved simulator block does not match this environment")
        for name, value in arrays.items():
            value[...] = np.asarray(state["block"][name])
        motions = np.asarray(state["motions"], dtype=np.float64)
        for actuator, motion in zip(self.actuators, motions, strict=True):
            _set_motion(actuator, motion)
        for stage, saved in zip(self.advancers, np.asarray(state.get("stages", np.zeros((0, 4)))),
                                strict=True):
            stage.set_motion(saved)
        self.steps[:] = np.asarray(state["steps"])
        self.robots.robot_step_count[:] = np.asarray(state["robot_step_count"])
        self.robots.step_count = int(state["step_count"])
        self._obs[...] = np.asarray(state["obs"])
        self._targets[...] = np.asarray(state["targets"])
        for i, rng_state in enumerate(state["rngs"]):
            rng, _ = seeding.np_random(0)
            rng.bit_generator.state = rng_state
            self._rngs[i] = rng

    def close_extras(self, **kwargs: Any) -> None:
        self.robots = None


def _motion(actuator: MagnetPose | CoilCurrents) -> NDArray[np.float64]:
    """What decides an actuator's future: an arm's motion row, coils' current ramp."""
    return actuator.motion.copy() if isinstance(actuator, MagnetPose) else actuator.motion()


def _set_motion(actuator: MagnetPose | CoilCurrents, motion: NDArray[np.float64]) -> None:
    if isinstance(actuator, MagnetPose):
        actuator.motion[:] = motion
    else:
        actuator.set_motion(motion)


def make_catheter_env(case: Case, num_envs: int, physics: str = "training", duration: float | None = None,
                      randomize: Sequence[Any] | None = None) -> CatheterReachVectorEnv:
    """The vector environment of a case steered by a source (a magnet arm, coil currents;
    ``duration``, s: the episodes', default the task's); its robots and actuators are the case's,
    in ``physics``."""
    if case.field_actuated:
        raise ValueError(f"case {case.name!r} is actuated by a uniform field, not steered by a source")
    if randomize:
        raise ValueError(f"case {case.name!r}: domain randomization ([training.randomize], --randomize) "
                         "varies a crawler's robot; the catheter cases train on their nominal robot")
    task = case.task if duration is None else dataclasses.replace(case.task, episode_duration=float(duration))
    return CatheterReachVectorEnv(num_envs, case.robot_spec(physics), case.actuation, task)
