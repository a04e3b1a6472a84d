"""Residual learning on a case's yardstick: the learner's action is a correction added to the command
of the case's hand-designed controller, not the command itself.

Residual policy learning (Silver et al. 2018, "Residual Policy Learning"; Johannink et al. 2019,
"Residual Reinforcement Learning for Robot Control") starts a learner at a controller that already
works: the action played is

    a_played = clip(a_yardstick(s) + residual * a_learner(s), -1, 1)      (normalised units)

with the learner's actor starting at ``a_learner = 0`` (its last layer zero,
:attr:`~elastica_magnetic_rl.td3.config.TD3Config.residual`), so its first policy *is* the
yardstick, and learning can only move it toward more return. The yardstick is the one the case is
judged against (:func:`residual_base`: a goto case's steering field with its memory of the manoeuvre,
a tip-reach case's steering law, a crawl case's rotating field), part of the environment the
learner sees (:class:`ResidualVectorEnv`, :class:`ResidualEnv`: Silver et al.'s framing; the
yardstick's memory is hidden state, as the law's is to any policy reading the observation), and
part of the policy a run ships (:class:`ResidualController`, what
:class:`~elastica_magnetic_rl.shipping.policy_files.LoadedPolicy` acts through).

``residual`` bounds how far the learner may move the yardstick's command: 0.5 lets it change an
axis's increment by half the largest one, in either direction.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from ..cases.case import Case
from ..cases.tasks import GotoTask
from .yardsticks import SteeringFieldPolicy, yardstick_controller

__all__ = ["ResidualController", "ResidualEnv", "ResidualVectorEnv", "residual_action", "residual_base",
           "residual_env", "residual_vector_env"]


def residual_action(command: NDArray[Any], correction: NDArray[Any], residual: float) -> NDArray[np.float64]:
    """The action played, ``clip(command + residual * correction, -1, 1)`` (normalised, float64: a
    zero correction plays the command exactly; any shape, the two of one shape): the yardstick's
    ``command`` corrected by the learner's ``correction``."""
    played = np.asarray(command, dtype=np.float64) + float(residual) * np.asarray(correction,
                                                                                  dtype=np.float64)
    return np.clip(played, -1.0, 1.0)


def residual_base(case: Case) -> Callable[[], Any]:
    """What makes the controller a residual learner of ``case`` corrects: the yardstick it is judged
    against (``act(obs)`` -> normalised ``(act_dim,)``, ``reset()``, ``state()``/``set_state()``).
    A goto case's :class:`~elastica_magnetic_rl.envs.yardsticks.SteeringFieldPolicy` with its memory
    (the law ``msr field baseline`` and the ring judge, not the memoryless one DAgger labels with);
    otherwise the warm-up's yardstick (:func:`~elastica_magnetic_rl.envs.yardsticks.yardstick_controller`).
    A ``ValueError`` names a case without one."""
    if isinstance(case.task, GotoTask) and case.field_actuated:
        return functools.partial(SteeringFieldPolicy, case)  # a partial: worker processes take it
    make = yardstick_controller(case)
    if make is None:
        raise ValueError(f"residual learning corrects the case's yardstick, and case {case.name!r} has none "
                         "(a crawl case needs a [yardstick] period; goto and tip-reach cases have theirs)")
    return make


class ResidualController:
    """A residual policy as one controller: ``act(obs)`` plays the yardstick's command at ``obs``
    corrected by ``correction(obs)`` (the learner's actor, normalised). ``obs`` may be one
    observation ``(obs_dim,)`` or a vector environment's rows ``(N, obs_dim)``, each row its own
    sub-environment with its own yardstick (made on first sight of ``N``); :meth:`reset` at each
    episode's start forgets the yardsticks' manoeuvres.

    Args:
        correction: observations ``(N, obs_dim)`` float32 -> corrections ``(N, act_dim)`` in [-1, 1].
        make_base: makes one yardstick (:func:`residual_base`).
        residual: the correction's weight (see the module docstring).
    """

    def __init__(self, correction: Callable[[NDArray[np.float32]], NDArray[Any]],
                 make_base: Callable[[], Any], residual: float) -> None:
        self.correction, self.make_base, self.residual = correction, make_base, float(residual)
        self.bases: list[Any] = []

    def reset(self) -> None:
        """New episodes in every sub-environment."""
        for base in self.bases:
            base.reset()

    def act(self, obs: NDArray[np.float32]) -> NDArray[np.float32]:
        rows = np.asarray(obs, dtype=np.float32)
        single = rows.ndim == 1
        rows = rows.reshape(1, -1) if single else rows
        if len(self.bases) != len(rows):
            self.bases = [self.make_base() for _ in rows]
        commands = np.stack([base.act(row) for base, row in zip(self.bases, rows, strict=True)])
        played = residual_action(commands, np.asarray(self.correction(rows)), self.residual)
        return played[0] if single else played


def _to_unit(action: NDArray[Any], space: gym.spaces.Box) -> NDArray[np.float64]:
    """An action of ``space`` in normalised units (the box onto [-1, 1])."""
    low, high = np.asarray(space.low, np.float64), np.asarray(space.high, np.float64)
    return (np.asarray(action, np.float64) - (high + low) / 2.0) / ((high - low) / 2.0)


def _from_unit(action: NDArray[Any], space: gym.spaces.Box) -> NDArray[np.float64]:
    """A normalised action in ``space``'s units (float64, as the yardsticks' commands)."""
    low, high = np.asarray(space.low, np.float64), np.asarray(space.high, np.float64)
    return (high + low) / 2.0 + (high - low) / 2.0 * np.asarray(action, np.float64)


class ResidualVectorEnv(gym.vector.VectorEnv):
    """A vector environment whose actions are corrections of the case's yardstick (one yardstick per
    sub-environment, reading the observation its sub-environment last gave): spaces, rewards,
    autoreset and infos are the wrapped ``env``'s (``infos["played_action"]`` ``(N, act_dim)``: what
    was played); :meth:`get_state`/:meth:`set_state` save the yardsticks' memories with the
    environment's state; other attributes are the wrapped environment's."""

    def __init__(self, env: gym.vector.VectorEnv, make_base: Callable[[], Any], residual: float) -> None:
        self.env, self.residual = env, float(residual)
        self.num_envs = env.num_envs
        self.metadata = env.metadata
        self.observation_space, self.action_space = env.observation_space, env.action_space
        self.single_observation_space = env.single_observation_space
        self.single_action_space = env.single_action_space
        self.bases = [make_base() for _ in range(self.num_envs)]
        self._obs: NDArray[np.float32] | None = None

    def __getattr__(self, name: str) -> Any:
        if name == "env":  # before __init__ set it (unpickling)
            raise AttributeError(name)
        return getattr(self.env, name)

    def reset(self, *, seed: Any = None, options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        obs, info = self.env.reset(seed=seed, options=options)
        mask = (options or {}).get("reset_mask")
        mask = np.ones(self.num_envs, dtype=bool) if mask is None else np.asarray(mask, dtype=bool)
        if self._obs is None:
            self._obs = np.array(obs, dtype=np.float32)
        self._obs[mask] = np.asarray(obs, dtype=np.float32)[mask]
        for i in np.flatnonzero(mask):
            self.bases[i].reset()
        return obs, info

    def step(self, actions: NDArray[Any]) -> tuple[Any, ...]:
        if self._obs is None:
            raise RuntimeError("call reset() before step()")
        space = self.single_action_space
        unit = _to_unit(np.asarray(actions).reshape(self.num_envs, -1), space)
        commands = np.stack([base.act(row) for base, row in zip(self.bases, self._obs, strict=True)])
        played = residual_action(commands, unit, self.residual)
        obs, rewards, terminated, truncated, infos = self.env.step(_from_unit(played, space))
        infos = dict(infos)
        infos["played_action"] = played
        for i in np.flatnonzero(np.asarray(terminated) | np.asarray(truncated)):
            self.bases[i].reset()  # SAME_STEP autoreset: obs[i] starts a new episode
        self._obs = np.array(obs, dtype=np.float32)
        return obs, rewards, terminated, truncated, infos

    def get_state(self) -> dict[str, Any]:
        return {"env": self.env.get_state(), "yardsticks": [base.state() for base in self.bases],
                "obs": None if self._obs is None else self._obs.copy()}

    def set_state(self, state: dict[str, Any]) -> None:
        self.env.set_state(state["env"])
        for base, saved in zip(self.bases, state["yardsticks"], strict=True):
            base.set_state(saved)
        self._obs = None if state["obs"] is None else np.array(state["obs"], dtype=np.float32)

    def close(self, **kwargs: Any) -> None:
        self.env.close(**kwargs)


class ResidualEnv(gym.Wrapper):
    """One environment whose action is a correction of the case's yardstick (as
    :class:`ResidualVectorEnv`, one sub-environment): for the evaluations that run a single
    environment."""

    def __init__(self, env: gym.Env, make_base: Callable[[], Any], residual: float) -> None:
        super().__init__(env)
        self.base, self.residual = make_base(), float(residual)
        self._obs: NDArray[np.float32] | None = None

    def reset(self, **kwargs: Any) -> tuple[Any, dict]:
        obs, info = self.env.reset(**kwargs)
        self.base.reset()
        self._obs = np.asarray(obs, dtype=np.float32)
        return obs, info

    def step(self, action: NDArray[Any]) -> tuple[Any, ...]:
        if self._obs is None:
            raise RuntimeError("call reset() before step()")
        space = self.env.action_space
        played = residual_action(self.base.act(self._obs), _to_unit(action, space), self.residual)
        obs, reward, terminated, truncated, info = self.env.step(_from_unit(played, space))
        info = dict(info)
        info["played_action"] = played
        self._obs = np.asarray(obs, dtype=np.float32)
        return obs, reward, terminated, truncated, info


def residual_vector_env(make: Callable[..., gym.vector.VectorEnv], case: Case, residual: float,
                        *args: Any, **kwargs: Any) -> ResidualVectorEnv:
    """``make(*args, **kwargs)`` (a vector environment of ``case``) whose actions are corrections of
    the case's yardstick (module level: a ``functools.partial`` of it pickles)."""
    return ResidualVectorEnv(make(*args, **kwargs), residual_base(case), residual)


def residual_env(make: Callable[..., gym.Env], case: Case, residual: float, *args: Any,
                 **kwargs: Any) -> ResidualEnv:
    """``make(*args, **kwargs)`` (one environment of ``case``) whose action is a correction of the
    case's yardstick."""
    return ResidualEnv(make(*args, **kwargs), residual_base(case), residual)
