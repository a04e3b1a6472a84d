"""One TD3 agent: a one-seed :class:`~elastica_magnetic_rl.td3.algorithm.TD3` (held, not subclassed) with
the conveniences of a single agent (``act``, ``for_env``, ``from_checkpoint``, standalone copies of its
networks).

The algorithm itself (config, buffer, networks, the update) is :mod:`elastica_magnetic_rl.td3.algorithm`; an
agent trains exactly as seed 0 of a K-seed learner.
"""

from __future__ import annotations

import os
from typing import Any

import gymnasium as gym
import numpy as np
import torch

from ..runfiles.checkpoint import load_checkpoint, refuse_networks_only
from .algorithm import TD3
from .config import TD3Config
from .networks import Actor, ScaledPolicy, TwinCritic, actor_from_state
from .replay_buffer import Batch
from .stacked import StackedMLP

__all__ = ["TD3Agent"]


class TD3Agent:
    """One seed of TD3 with the conveniences of a single agent, by composition: :attr:`learner` is
    a one-seed :class:`TD3` that does the work (an agent trains exactly as seed 0 of a K-seed
    learner); this class adds the single-agent view (one action, one batch, floats).

    ``actor``, ``critic``, ``actor_target`` and ``critic_target`` are standalone copies of the
    current networks as plain modules (reading them does not change the agent).
    """

    def __init__(self, obs_dim: int, act_dim: int, action_low: np.ndarray, action_high: np.ndarray,
                 config: TD3Config | None = None) -> None:
        self.learner = TD3(obs_dim, act_dim, action_low, action_high,
                           [config if config is not None else TD3Config()])

    @classmethod
    def for_env(cls, env: gym.Env, config: TD3Config | None = None) -> TD3Agent:
        """Build an agent for a Gymnasium env with a flat Box observation and Box action space."""
        obs_space, act_space = env.observation_space, env.action_space
        if not isinstance(act_space, gym.spaces.Box) or not isinstance(obs_space, gym.spaces.Box):
            raise TypeError("TD3 needs Box observation and action spaces")
        return cls(int(np.prod(obs_space.shape)), int(np.prod(act_space.shape)),
                   act_space.low.reshape(-1), act_space.high.reshape(-1), config)

    @classmethod
    def from_checkpoint(cls, path: str | os.PathLike, device: str | None = None) -> TD3Agent:
        """Rebuild an agent (networks, optimisers, RNGs, counters) from a training checkpoint."""
        ckpt = load_checkpoint(path)
        refuse_networks_only(ckpt, path)
        cfg = TD3Config.from_dict(ckpt["config"])
        if device is not None:
            cfg.device = device
        return cls.from_seed_state(ckpt["obs_dim"], ckpt["act_dim"], ckpt["action_low"].numpy(),
                                   ckpt["action_high"].numpy(), cfg, ckpt["agent"])

    @classmethod
    def from_seed_state(cls, obs_dim: int, act_dim: int, action_low: np.ndarray,
                        action_high: np.ndarray, config: TD3Config, state: dict[str, Any]) -> TD3Agent:
        """An agent holding ``state`` (:meth:`TD3.seed_state` of some seed)."""
        agent = cls(obs_dim, act_dim, action_low, action_high, config)
        agent.load_state_dict(state)
        return agent

    # -- the one seed's view of the learner ------------------------------------------------------
    @property
    def config(self) -> TD3Config:
        return self.learner.config

    @property
    def obs_dim(self) -> int:
        return self.learner.obs_dim

    @property
    def act_dim(self) -> int:
        return self.learner.act_dim

    @property
    def action_low(self) -> np.ndarray:
        return self.learner.action_low

    @property
    def action_high(self) -> np.ndarray:
        return self.learner.action_high

    @property
    def num_updates(self) -> int:
        """Critic updates made so far."""
        return self.learner.num_updates

    @property
    def actor_net(self) -> StackedMLP:
        """The learner's actor (a stack of one): its parameters are the agent's."""
        return self.learner.actor_net

    @property
    def critic_net(self) -> StackedMLP:
        """The learner's twin critic (a stack of one)."""
        return self.learner.critic_net

    @property
    def rng(self) -> np.random.Generator:
        return self.learner.rngs[0]

    @property
    def torch_rng(self) -> torch.Generator:
        return self.learner.torch_rngs[0]

    @property
    def actor(self) -> Actor:
        return self.learner.actor_module(0)

    @property
    def critic(self) -> TwinCritic:
        return self.learner.critic_module(0)

    @property
    def actor_target(self) -> Actor:
        state = self.learner.actor_state(0, target=True)
        actor = actor_from_state(self.obs_dim, self.act_dim, self.config.actor_widths, state)
        actor.load_state_dict(state)
        return actor.eval().requires_grad_(False)

    @property
    def critic_target(self) -> TwinCritic:
        return self.learner.critic_module(0, target=True)

    def policy_module(self) -> ScaledPolicy:
        """The actor mapped onto the environment's action box, as a standalone module (export)."""
        return self.learner.policy_module(0)

    # -- acting and learning --------------------------------------------------------------------
    def scale_action(self, action: np.ndarray) -> np.ndarray:
        """A normalised action in [-1, 1] mapped onto the environment's action box."""
        return self.learner.scale_action(action)

    def select_action(self, obs: np.ndarray, explore: bool) -> np.ndarray:
        """Normalised action ``mu(s)`` ``(act_dim,)``, plus noise when exploring."""
        obs = np.asarray(obs, dtype=np.float32).reshape(1, 1, -1)
        return self.learner.select_actions(obs, explore)[0, 0]

    def random_action(self) -> np.ndarray:
        return self.learner.random_actions(0, 1)[0]

    def act(self, obs: np.ndarray, explore: bool = False) -> np.ndarray:
        """Action in environment units for ``obs`` (deterministic unless ``explore``)."""
        return self.scale_action(self.select_action(obs, explore))

    def update(self, batch: Batch | list[Batch]) -> dict[str, float]:
        """:meth:`TD3.update` of the one seed on ``batch``, the losses as floats."""
        batches = batch if isinstance(batch, list) else [batch]
        return {k: float(v[0]) for k, v in self.learner.update(batches).items()}

    @torch.no_grad()
    def compute_target(self, rewards: torch.Tensor, next_obs: torch.Tensor,
                       terminated: torch.Tensor) -> torch.Tensor:
        """:meth:`TD3.compute_target` of the one seed: ``(B, 1)`` from ``(B, ...)`` inputs (or
        ``(1, B, 1)`` from ``(1, B, ...)``)."""
        if next_obs.dim() == 2:
            return self.learner.compute_target(rewards[None], next_obs[None], terminated[None])[0]
        return self.learner.compute_target(rewards, next_obs, terminated)

    def state_dict(self) -> dict[str, Any]:
        """The seed's whole state (:meth:`TD3.seed_state`)."""
        return self.learner.seed_state(0)

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.learner.load_seed_state(0, state)
