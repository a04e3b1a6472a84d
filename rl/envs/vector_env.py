"""N crawlers in one simulator: a Gymnasium 1.x vector environment (``MagneticCrawlerVectorEnv``).

Each sub-environment ``i`` is the task of :class:`~elastica_magnetic_rl.envs.env.MagneticCrawlerEnv` (same
observation,
action, reward, truncation and blow-up rules, same options), but all N robots live in one
:class:`~elastica_magnetic.batch.BatchedRobots` simulator: one PyElastica memory block, all forcing
and contact in one numba call per time step, each robot driven by its own
:class:`~elastica_magnetic.ControlledField`. The batched physics is bit-for-bit the per-rod physics,
so sub-environment ``i`` reproduces a single environment exactly (see *Seeding*).

Spaces (float32): ``observation_space`` ``Box`` of shape ``(N, 4 n + 4)`` (``(N, 260)`` for the
paper's robot), ``action_space`` ``Box([-1, 1])`` of shape ``(N, 2)``; ``single_observation_space``
and ``single_action_space`` are those of the single environment. Rewards ``(N,)`` float64,
``terminated``/``truncated`` ``(N,)`` bool.

Autoreset: ``AutoresetMode.SAME_STEP``
--------------------------------------
``metadata["autoreset_mode"] = gymnasium.vector.AutoresetMode.SAME_STEP``. When sub-environment
``i`` ends on a ``step`` (time limit: ``truncated[i]``; blow-up: ``terminated[i]``), it is reset
*within the same call*:

- ``obs[i]`` returned by that ``step`` is the **first observation of the new episode**;
- the true last observation of the ended episode is ``infos["final_obs"][i]`` (an object array of
  length N, ``None`` where nothing ended; ``infos["_final_obs"]`` is the bool mask), and its info
  dict is ``infos["final_info"]`` (arrays masked by ``infos["final_info"]["_<key>"]``);
- ``reward[i]``, ``terminated[i]``, ``truncated[i]`` are those of the ended episode's last step.

So a learner stores ``(obs[i], action[i], reward[i], final_obs[i], terminated[i])`` for an ended
sub-environment and never a transition across a reset (unlike ``NEXT_STEP``, there is no dummy
step whose action is ignored). These keys are present only on steps where some sub-environment
ended, as in :class:`gymnasium.vector.SyncVectorEnv`.

Seeding
-------
Every sub-environment has its own numpy ``Generator`` (used only to draw its random initial
fields). ``reset(seed=s)`` seeds sub-environment ``i`` with ``s + i`` (the Gymnasium convention,
as ``SyncVectorEnv``); ``reset(seed=[s_0, ..., s_{N-1}])`` seeds each explicitly; ``seed=None``
leaves the generators as they are (fresh entropy on the very first reset). An autoreset draws from
the sub-environment's generator, exactly as ``MagneticCrawlerEnv.reset()`` without a seed does.
Hence, with the same actions, sub-environment ``i`` after ``reset(seed=s)`` produces exactly the
observations, rewards and flags of ``MagneticCrawlerEnv`` after ``reset(seed=s + i)`` and then
``reset()`` (no seed) after each of its episodes.

State
-----
:meth:`get_state` / :meth:`set_state` save and restore everything that determines the future of
all sub-environments (the simulator's memory block, every field, the step counters, the last
observations and the generators), as numpy arrays and plain data: used by
:func:`elastica_magnetic_rl.runner.loop.train_vector` for checkpoints at any vector step.

Units: SI (m, s, T) as the single environment.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any, Literal

import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numpy.typing import NDArray

from elastica_magnetic import ControlledField, RobotSpec
from elastica_magnetic.batch import BatchedRobots, BatchedSimulationDivergedError
from elastica_magnetic.robot_spec import ACTION_PERIOD

from ..cases.case import Case, load_case
from ..cases.tasks import Task
from ..cases.variations import Variation
from .crawler_observation import crawler_observation
from .env import (
    action_space,
    adopt_setup,
    crawler_setup,
    initial_field_value,
    new_field,
)
from .randomization import RobotRandomizer
from .vector_reset import reseed

__all__ = ["MagneticCrawlerVectorEnv", "make_vector_env"]

STATE_FORMAT = "msr-crawler-vector-state-v1"


class MagneticCrawlerVectorEnv(VectorEnv):
    """``num_envs`` crawlers stepped together in one batched simulator (see the module docstring).

    Parameters
    ----------
    num_envs : int
        Number of sub-environments (robots) ``N`` >= 1.
    case, pattern, field_limit, physics, initial_field, duration, spec, max_increment, task
        As :class:`~elastica_magnetic_rl.envs.env.MagneticCrawlerEnv` (``field_limit`` in T,
        ``duration`` in s, ``max_increment`` in T per unit action), the same for every
        sub-environment.
        ``reset(options={"initial_field": ...})`` overrides ``initial_field`` for the episodes
        started by that reset (not for later autoresets).
    divergence_penalty : float
        Reward of a step on which a robot's simulation blows up (as the single environment).
    randomize : sequence of Variation, optional
        Domain randomization (needs ``case``): each episode of each sub-environment runs on a
        robot whose ``[robot]`` values are drawn anew from these variations
        (:class:`~elastica_magnetic_rl.envs.randomization.RobotRandomizer`, drawn with the
        sub-environment's generator); training passes the case's ``[training.randomize]``.
        Default: the case's nominal robot in every episode. :attr:`robot_settings` holds each
        sub-environment's current draw.
    """

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": []}

    def __init__(
        self,
        num_envs: int = 4,
        pattern: int | None = None,
        field_limit: float | None = None,
        physics: Literal["training", "accurate"] = "training",
        initial_field: Literal["random", "zero"] | None = None,
        duration: float | None = None,
        spec: RobotSpec | None = None,
        max_increment: float | None = None,
        divergence_penalty: float = -10.0,
        case: str | Case | None = None,
        task: Task | None = None,
        randomize: Sequence[Variation] | None = None,
    ) -> None:
        if int(num_envs) != num_envs or num_envs < 1:
            raise ValueError(f"num_envs must be a positive integer, got {num_envs!r}")
        setup = crawler_setup(case, pattern=pattern, field_limit=field_limit, physics=physics,
                              initial_field=initial_field, duration=duration, spec=spec,
                              max_increment=max_increment, task=task)
        self.num_envs = int(num_envs)
        self.single_observation_space = adopt_setup(self, setup, physics, divergence_penalty)
        self.render_mode = None
        self.single_action_space = action_space(setup)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)

        self.robots: BatchedRobots | None = None
        self.fields: list[ControlledField] = []
        self.steps = np.zeros(self.num_envs, dtype=np.int64)  # steps of each current episode
        self._obs = np.zeros((self.num_envs,) + self.single_observation_space.shape, dtype=np.float32)
        # the task's per-episode state (start or target)
        self._task_state = np.zeros((self.num_envs, *self.task.state_shape))
        self._rngs: list[np.random.Generator | None] = [None] * self.num_envs
        self.randomizer: RobotRandomizer | None = None
        if randomize:
            if setup.case is None:
                raise ValueError("randomize needs a case (its [robot] values are what is varied)")
            self.randomizer = RobotRandomizer(setup.case.robot.tables, randomize, physics)
        self.robot_settings: list[dict[str, float] | None] = [None] * self.num_envs

    # -- helpers ------------------------------------------------------------------------------------
    def _mid_x(self, i: int) -> float:
        return float(self.robots.rods[i].position_collection[0, self.middle_node])

    def _observe(self, i: int) -> NDArray[np.float32]:
        extra = None
        if self.task.extra_observation:
            extra = self.task.observe(self._task_position(i), self._task_state[i],
                                      self.steps[i] * ACTION_PERIOD)
        return crawler_observation(self.robots.rods[i], self.fields[i].value, self.layout,
                                   self.surface_tolerance, extra)

    def _task_position(self, i: int) -> Any:
        """What the task reads of robot ``i`` (the middle's x; the floor pose for goto)."""
        return self.task.position(self.robots.rods[i], self.middle_node)

    def _rng(self, i: int) -> np.random.Generator:
        if self._rngs[i] is None:
            self._rngs[i], _ = seeding.np_random(None)
        return self._rngs[i]

    def _reset_one(self, i: int, initial: Any, target: Any = None) -> None:
        """Put robot ``i`` back at rest, straight, with a new initial field; new episode."""
        value = initial_field_value(initial, self.field_limits, self._rng(i), self.axes)
        self.fields[i] = new_field(self, value)
        if self.randomizer is not None:
            self._set_robot(i, self.randomizer.draw(self._rng(i)))
        self.robots.reset_robot(i)
        self.robots.fields[i] = self.fields[i].value
        self.steps[i] = 0
        self._task_state[i] = self.task.start(self._task_position(i), self._rng(i), target)
        self._obs[i] = self._observe(i)

    def _set_robot(self, i: int, settings: dict[str, float]) -> None:
        """Make robot ``i`` the randomized robot of ``settings`` (in its initial state)."""
        self.robots.set_robot(i, self.randomizer.robot(settings))
        self.robot_settings[i] = dict(settings)

    def _healthy(self, i: int) -> bool:
        """Robot ``i`` finite and no node faster than ``max_speed`` (the single env's rule)."""
        rod = self.robots.rods[i]
        v, x = rod.velocity_collection, rod.position_collection
        speed2 = np.einsum("ij,ij->j", v, v)
        return bool(np.all(speed2 <= self.robots.max_speed ** 2) and np.all(np.isfinite(x)))

    def _info(self) -> dict[str, Any]:
        """Per-sub-environment info arrays (all present, masks all True)."""
        n = self.num_envs
        info = {
            "time_s": self.steps * ACTION_PERIOD,
            "field_T": np.stack([f.value.copy() for f in self.fields]),
            "mid_x_m": np.array([self._mid_x(i) for i in range(n)]),
        }
        for key in list(info):
            info[f"_{key}"] = np.ones(n, dtype=bool)
        return info

    def _observe_and_reward(self, before: list[Any], diverged: NDArray[np.bool_],
                            messages: dict[int, str]) -> NDArray[np.float64]:
        """After a simulated step: each robot's observation and reward (from the task positions
        ``before`` it), the task's moving target followed; a robot whose observation is not finite
        is marked in ``diverged`` (with its ``messages`` entry) and gets the divergence penalty."""
        rewards = np.empty(self.num_envs, dtype=np.float64)
        for i in range(self.num_envs):
            if not diverged[i]:
                obs = self._observe(i)
                if np.all(np.isfinite(obs)):
                    after = self._task_position(i)
                    rewards[i] = self.task.reward(before[i], after, self._task_state[i])
                    if self.moving_target:  # the next target, which the policy sees next
                        self._task_state[i] = self.task.follow(self._task_state[i], after)
                        obs = self._observe(i)
                    self._obs[i] = obs
                    continue
                diverged[i] = True
                messages.setdefault(i, f"robot {i}: non-finite observation")
            rewards[i] = self.divergence_penalty  # obs[i] stays the last finite observation
        return rewards

    # -- Gymnasium API -----------------------------------------------------------------------------
    def reset(
        self,
        *,
        seed: int | list[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        """Reset all sub-environments (or those of ``options["reset_mask"]``, a bool ``(N,)``).

        Args:
            seed: ``int`` s: sub-environment ``i`` is seeded with ``s + i``; a list: one seed (or
                ``None``) per sub-environment; ``None``: keep the generators.
            options: ``{"initial_field": "random" | "zero" | (Bx, By[, Bz]) in T,
                "reset_mask": bool array (N,), "target": (forward, left) in m}`` (``target``: the
                goto task's target in each reset robot's start frame, instead of a drawn one).

        Returns:
            ``obs`` float32 ``(N, 4 n + 4)`` and the info dict of arrays.
        """
        options = dict(options or {})
        if isinstance(seed, (int, np.integer)):
            super().reset(seed=int(seed))
        mask = reseed(self._rngs, seed, options, first=self.robots is None)
        if self.robots is None:
            self.robots = BatchedRobots(self.robot_spec, self.num_envs)
            self.fields = [new_field(self, (0.0, 0.0, 0.0)) for _ in range(self.num_envs)]
        initial = options.get("initial_field", self.initial_field)
        for i in np.flatnonzero(mask):
            self._reset_one(int(i), initial, options.get("target"))
        return self._obs.copy(), self._info()

    def step(
        self, actions: NDArray[np.float32]
    ) -> tuple[NDArray[np.float32], NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_],
               dict[str, Any]]:
        """Apply the field increments ``0.3 mT * actions[i]`` and simulate 0.01 s for all robots.

        Args:
            actions: ``(N, k)`` in ``[-1, 1]`` (clipped), one row per sub-environment (``k``:
                the controlled axes, 2 or 3).

        Returns:
            ``obs`` float32 ``(N, 4 n + 4)`` (first observation of a new episode where one ended),
            ``rewards`` float64 ``(N,)``, ``terminated`` and ``truncated`` bool ``(N,)``, ``infos``
            (``final_obs`` / ``final_info`` where an episode ended: see the module docstring).
        """
        if self.robots is None:
            raise RuntimeError("call reset() before step()")
        n = self.num_envs
        a = np.clip(np.asarray(actions, dtype=np.float64).reshape(n, len(self.axes)), -1.0, 1.0)
        if not np.all(np.isfinite(a)):
            raise ValueError(f"actions must be finite, got {actions!r}")
        robots = self.robots
        before = []
        for i in range(n):
            robots.fields[i] = self.fields[i].apply_increment(a[i] * self.field_increments)
            before.append(self._task_position(i))
        diverged = np.zeros(n, dtype=bool)
        messages: dict[int, str] = {}
        try:
            robots.step(self.robot_spec.steps_per_action)
        except BatchedSimulationDivergedError as exc:
            diverged = np.array([not self._healthy(i) for i in range(n)])
            messages[exc.robot] = str(exc)
        self.steps += 1  # before the observations: their clock reads the time the step ends at
        rewards = self._observe_and_reward(before, diverged, messages)
        terminated = diverged
        truncated = ~terminated & (self.steps >= self.max_episode_steps)
        info = self._info()
        info["diverged"] = diverged.copy()
        info["_diverged"] = np.ones(n, dtype=bool)
        ended = np.flatnonzero(terminated | truncated)
        if ended.size:
            final_obs = np.full(n, None, dtype=object)
            final_info: dict[str, Any] = {}
            for key in ("time_s", "field_T", "mid_x_m", "diverged"):
                final_info[key] = info[key].copy()
                final_info[f"_{key}"] = np.zeros(n, dtype=bool)
            divergence = np.full(n, None, dtype=object)
            for i in ended:
                final_obs[i] = self._obs[i].copy()
                for key in ("time_s", "field_T", "mid_x_m", "diverged"):
                    final_info[f"_{key}"][i] = True
                if terminated[i]:
                    divergence[i] = messages.get(int(i), "diverged")
            if terminated.any():
                final_info["divergence"] = divergence
                final_info["_divergence"] = terminated.copy()
            for i in ended:
                self._reset_one(int(i), self.initial_field)
            # the info of the new episodes (time 0, new field) replaces those entries
            fresh = self._info()
            for key in ("time_s", "field_T", "mid_x_m"):
                info[key] = fresh[key]
            info["final_obs"] = final_obs
            info["_final_obs"] = np.isin(np.arange(n), ended)
            info["final_info"] = final_info
            info["_final_info"] = info["_final_obs"].copy()
        return self._obs.copy(), rewards, terminated.copy(), truncated, info

    # -- state -------------------------------------------------------------------------------------
    def get_state(self) -> dict[str, Any]:
        """Everything that determines the future of all sub-environments (numpy arrays and plain
        data; restore with :meth:`set_state` on an environment built with the same arguments).

        Keys: ``block`` (the memory block's base arrays, float64: positions, directors, rates,
        loads and derived geometry of every robot), ``fields`` ``(N, 3)`` T, ``steps`` ``(N,)``,
        ``robot_step_count`` ``(N,)``, ``step_count``, ``obs`` float32 ``(N, 4 n + 4 + k)``,
        ``task_state`` ``(N, *task.state_shape)`` (the task's per-episode state, m), ``rngs``
        (each generator's ``bit_generator.state``); with randomization, ``robot_settings``
        ``(N, k)`` (each robot's draw, in ``randomizer.names`` order).
        """
        if self.robots is None:
            raise RuntimeError("call reset() before get_state()")
        if any(r is None for r in self._rngs):
            raise RuntimeError("every sub-environment needs a generator (reset with a seed)")
        state = {
            "format": STATE_FORMAT,
            "num_envs": self.num_envs,
            "block": {name: value.copy() for name, value in self.robots.base_arrays().items()},
            "fields": np.stack([f.value.copy() for f in self.fields]),
            "steps": self.steps.copy(),
            "robot_step_count": self.robots.robot_step_count.copy(),
            "step_count": int(self.robots.step_count),
            "obs": self._obs.copy(),
            "task_state": self._task_state.copy(),
            "rngs": [r.bit_generator.state for r in self._rngs],
        }
        if self.randomizer is not None:
            state["robot_settings"] = np.stack([self.randomizer.as_array(s) for s in self.robot_settings])
        return state

    def set_state(self, state: dict[str, Any]) -> None:
        """Restore a :meth:`get_state` snapshot (arrays may be numpy arrays or CPU tensors)."""
        if state.get("format") != STATE_FORMAT or int(state["num_envs"]) != self.num_envs:
            raise ValueError("not a state of this vector environment (format or num_envs differ)")
        if self.robots is None:
            self.reset(seed=0)
        if self.randomizer is not None:  # each robot's own values first, its state below
            if "robot_settings" not in state:
                raise ValueError("the saved state has no robot settings: it was not saved by an "
                                 "environment with the same randomization")
            for i, row in enumerate(np.asarray(state["robot_settings"], dtype=np.float64)):
                self._set_robot(i, self.randomizer.from_array(row))
        elif "robot_settings" in state:
            raise ValueError("the saved state comes from a randomized environment, this one is not")
        arrays = self.robots.base_arrays()
        if set(arrays) != set(state["block"]):
            raise ValueError("the saved simulator block does not match this environment")
        for name, value in arrays.items():
            value[...] = np.asarray(state["block"][name])
        fields = np.asarray(state["fields"], dtype=np.float64)
        for i in range(self.num_envs):
            self.fields[i].value[:] = fields[i]
            self.robots.fields[i] = self.fields[i].value
        self.steps[:] = np.asarray(state["steps"])
        self.robots.robot_step_count[:] = np.asarray(state["robot_step_count"])
        self.robots.step_count = int(state["step_count"])
        self._obs[...] = np.asarray(state["obs"])
        if "task_state" in state:
            self._task_state[:] = np.asarray(state["task_state"])
        elif self.task.kind != "crawl":  # states from before tasks: crawling, which needs none
            raise ValueError("the saved state has no task state (it predates the reach task)")
        for i, rng_state in enumerate(state["rngs"]):
            rng, _ = seeding.np_random(0)
            rng.bit_generator.state = rng_state
            self._rngs[i] = rng

    def close_extras(self, **kwargs: Any) -> None:
        self.robots = None



def make_vector_env(
    case: str | Path | Case,
    num_envs: int,
    physics: str = "training",
    initial_field: str | None = None,
    duration: float | None = None,
    randomize: Sequence[Variation] | None = None,
) -> VectorEnv:
    """The vector environment of a case (a name, a spec file or a
    :class:`~elastica_magnetic_rl.cases.case.Case`; module level so that ``functools.partial`` of it
    pickles): the crawlers', or for a case steered by a source (``[actuation] kind =
    "magnet-pose"`` or ``"coil-currents"``) the catheters'
    (:func:`~elastica_magnetic_rl.envs.catheter_env.make_catheter_env`)."""
    loaded = load_case(case)
    if not loaded.field_actuated:
        from .catheter_env import make_catheter_env

        return make_catheter_env(loaded, num_envs, physics, duration, randomize)
    return MagneticCrawlerVectorEnv(num_envs, case=loaded, physics=physics,
                                    initial_field=initial_field, duration=duration,
                                    randomize=randomize)
