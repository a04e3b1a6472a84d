"""TD3 (Twin Delayed DDPG), a single-file implementation in the style of CleanRL.

Reference: S. Fujimoto, H. van Hoof, D. Meger, "Addressing Function Approximation Error in
Actor-Critic Methods", ICML 2018 (https://arxiv.org/abs/1802.09477).

The three ingredients of TD3, all in :meth:`TD3Agent.update`:

1. **Clipped double-Q learning.** Two critics ``Q1, Q2`` and their targets; the TD target uses
   the smaller target value::

       y = r + gamma * (1 - terminated) * min(Q1'(s', a'), Q2'(s', a'))

2. **Target policy smoothing.** The target action is the target actor's action plus clipped
   Gaussian noise, drawn independently per action dimension::

       a' = clip(mu'(s') + clip(eps, -c, c), -1, 1),   eps ~ N(0, sigma_target^2 I)

3. **Delayed policy updates.** Every ``policy_delay`` critic updates the actor ascends
   ``Q1(s, mu(s))`` and the targets follow by Polyak averaging::

       theta' <- tau * theta + (1 - tau) * theta'

Conventions of this implementation
----------------------------------
* Actions are handled in **normalised units** ``[-1, 1]^d`` everywhere inside the agent: the actor
  ends in ``tanh``, the critics see normalised actions, the replay buffer stores them, and all noise
  scales (exploration ``sigma``, target noise and its clip) are fractions of the half-range of the
  action box. Only the action sent to the environment is mapped affinely onto
  ``[low, high]`` (:meth:`TD3Agent.scale_action`). For symmetric bounds ``[-m, m]`` this is exactly
  Fujimoto's ``max_action * sigma`` convention.
* Exploration noise is drawn **per action dimension** (the authors' released code added one scalar
  sample to every dimension; see ``DESIGN.md`` section 5).
* The buffer stores ``terminated``, not ``done``: a time-limit truncation still bootstraps, and the
  stored ``next_obs`` of a truncated step is the real final observation returned by ``step()``
  (Gymnasium 1.x single envs are reset by the caller, so nothing is lost).
* ``target_noise_clip`` defaults to Fujimoto's 0.5; the authors of the magnetic-crawler paper used
  0.8 (``TD3Config(target_noise_clip=0.8)``).

Exact resume
------------
:func:`train` writes checkpoints (atomically) that hold everything needed to continue bit-for-bit:
networks, target networks, both Adam optimisers, the replay buffer (contents, pointer, size), every
RNG state (Python ``random``, the agent's numpy ``Generator``, the agent's torch ``Generator``, the
global torch CPU RNG) and the counters. The environment's internal state cannot be saved in general,
so checkpoints are taken **only at episode boundaries**, and each episode ``k`` starts with
``env.reset(seed=episode_seed(config.seed, k))`` -- a deterministic seed sequence. Together this
makes a run killed after a checkpoint and resumed end with bit-identical weights to an uninterrupted
run on the CPU (same thread count; ``torch.use_deterministic_algorithms`` is switched on during
training when ``config.torch_deterministic``). The one checkpoint that may fall inside an episode
is the final one written when ``steps`` is reached; continuing such a run to a larger ``steps``
abandons that partial episode (its transitions stay in the buffer) and starts the next one.

Evaluation during training
--------------------------
With ``TD3Config.eval_every > 0`` and an evaluation environment, the deterministic policy is
evaluated periodically (``evaluations.csv``, TensorBoard ``eval/``) and the best networks so far
are kept in ``best.pt`` (a networks-only checkpoint), as Stable-Baselines3's ``EvalCallback``
does: a policy that finds a gait and later loses it is not lost. Evaluation uses no RNG of the
training, so the weights are bit-identical with or without it.

Vector environments
-------------------
:func:`train_vector` trains with a Gymnasium vector environment whose ``autoreset_mode`` is
``SAME_STEP`` (e.g. :class:`rl.vector_env.MagneticCrawlerVectorEnv`, N crawlers in one batched
simulator): N transitions per vector step, one TD3 update per transition, the real final
observation ``infos["final_obs"][i]`` stored for ended sub-environments (no transition across a
reset), and checkpoints at vector-step boundaries that include the environment's full state
(``env.get_state()``), so resume is exact at any checkpoint.

:func:`train_shared` is the other use of a vector environment: K independent seeds, one crawler
each, in one simulator. Every seed is trained exactly as :func:`train` trains it alone (same
episodes, updates and checkpoints, bit for bit); only the cost of the simulation is shared.
"""

from __future__ import annotations

import copy
import csv
import dataclasses
import math
import os
import random
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import gymnasium as gym
import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F

CHECKPOINT_NAME = "checkpoint.pt"
EPISODES_CSV = "episodes.csv"
CHECKPOINT_FORMAT = "td3-checkpoint-v1"
BEST_NAME = "best.pt"
EVALUATIONS_CSV = "evaluations.csv"
EVALUATION_FIELDS = ("global_step", "mean_return", "std_return", "mean_length", "best_mean_return",
                     "wall_time_s")
#: Fields of :class:`TD3Config` that a resumed run takes from the config passed (they change no
#: weight: when to checkpoint, log and evaluate); every other field comes from the checkpoint.
RESUMABLE_SETTINGS = ("checkpoint_every", "log_every", "eval_every", "eval_episodes")
#: Evaluation episode ``i`` is reset with seed ``EVAL_SEED + i``: the same episodes at every
#: evaluation and for every seed of a sweep, so their returns compare.
EVAL_SEED = 1_000_000
EPISODE_FIELDS = (
    "episode",
    "global_step",
    "return",
    "length",
    "terminated",
    "truncated",
    "wall_time_s",
)


# ----------------------------------------------------------------------------------------------
# Hyperparameters
# ----------------------------------------------------------------------------------------------
@dataclass
class TD3Config:
    """All TD3 hyperparameters and run settings (defaults: the paper's / Fujimoto's values).

    Noise scales are in normalised action units (fractions of the action half-range).
    """

    # networks and optimisation
    hidden_sizes: tuple[int, ...] = (256, 256)
    """Hidden layer widths (ReLU) of the actor and of each critic."""
    actor_lr: float = 3e-4
    critic_lr: float = 3e-4
    gamma: float = 0.99
    tau: float = 0.005
    """Polyak coefficient of the target networks."""
    batch_size: int = 256
    # replay and exploration
    buffer_size: int = 1_000_000
    """Upper bound on the replay capacity; the buffer actually allocated holds
    ``min(buffer_size, total steps of the run)`` transitions."""
    learning_starts: int = 2500
    """Warm-up: steps of uniform random actions before the policy acts and learning begins."""
    exploration_noise: float = 0.2
    """Std of the Gaussian exploration noise, drawn independently per action dimension."""
    # TD3 specifics
    policy_noise: float = 0.2
    """Std of the target policy smoothing noise."""
    target_noise_clip: float = 0.5
    """Clip of the target policy noise: 0.5 as Fujimoto et al.; the crawler paper's authors
    used 0.8."""
    policy_delay: int = 2
    """Actor and target networks are updated once every ``policy_delay`` critic updates."""
    updates_per_step: int = 1
    """Gradient steps per environment step (after warm-up)."""
    # run settings
    seed: int = 0
    device: str = "cpu"
    torch_deterministic: bool = True
    """Switch on ``torch.use_deterministic_algorithms`` while training (restored afterwards)."""
    checkpoint_every: int = 10_000
    """A checkpoint is written at the first episode boundary after every multiple of this many
    steps, and at the end of the run."""
    log_every: int = 100
    """TensorBoard loss scalars every this many gradient updates."""
    eval_every: int = 0
    """Evaluate the deterministic policy at the first episode boundary after every multiple of
    this many steps (and at the end of the run) in the evaluation environment given to the
    training function, keeping the best actor in ``best.pt`` (Stable-Baselines3's
    ``EvalCallback``); 0: never."""
    eval_episodes: int = 1
    """Episodes per evaluation (episode ``i`` reset with seed ``EVAL_SEED + i``)."""

    def __post_init__(self) -> None:
        self.hidden_sizes = tuple(int(h) for h in self.hidden_sizes)
        if not 0.0 < self.tau <= 1.0:
            raise ValueError(f"tau must be in (0, 1], got {self.tau}")
        if not 0.0 <= self.gamma <= 1.0:
            raise ValueError(f"gamma must be in [0, 1], got {self.gamma}")
        for name in ("batch_size", "buffer_size", "policy_delay", "checkpoint_every", "log_every"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        if self.eval_episodes < 1:
            raise ValueError(f"eval_episodes must be >= 1, got {self.eval_episodes}")
        for name in ("learning_starts", "updates_per_step", "eval_every"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        for name in ("exploration_noise", "policy_noise", "target_noise_clip"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> TD3Config:
        names = {f.name for f in dataclasses.fields(cls)}
        return cls(**{k: v for k, v in d.items() if k in names})


def episode_seed(base_seed: int, episode: int) -> int:
    """Seed of ``env.reset`` for episode ``episode`` of a run with seed ``base_seed``.

    Derived with ``numpy.random.SeedSequence`` so that runs with neighbouring seeds do not share
    episodes (``base_seed + episode`` would make episode 1 of seed 0 equal episode 0 of seed 1).
    """
    return int(np.random.SeedSequence([int(base_seed), int(episode)]).generate_state(1)[0])


# ----------------------------------------------------------------------------------------------
# Replay buffer
# ----------------------------------------------------------------------------------------------
class Batch(NamedTuple):
    """A minibatch of transitions (numpy arrays; actions normalised to [-1, 1])."""

    obs: np.ndarray  # (B, obs_dim) float32
    actions: np.ndarray  # (B, act_dim) float32
    rewards: np.ndarray  # (B,) float32
    next_obs: np.ndarray  # (B, obs_dim) float32
    terminated: np.ndarray  # (B,) float32, 1.0 where s' is terminal (not on truncation)


class ReplayBuffer:
    """Fixed-capacity ring buffer of transitions, stored as float32 numpy arrays.

    It stores ``terminated`` (a true terminal state) rather than ``done``: transitions cut by a time
    limit are stored with ``terminated=0`` and so bootstrap from ``next_obs``.
    """

    def __init__(self, capacity: int, obs_dim: int, act_dim: int) -> None:
        if capacity < 1:
            raise ValueError(f"capacity must be >= 1, got {capacity}")
        self.capacity = int(capacity)
        self.obs_dim = int(obs_dim)
        self.act_dim = int(act_dim)
        self.obs = np.zeros((self.capacity, self.obs_dim), dtype=np.float32)
        self.next_obs = np.zeros((self.capacity, self.obs_dim), dtype=np.float32)
        self.actions = np.zeros((self.capacity, self.act_dim), dtype=np.float32)
        self.rewards = np.zeros(self.capacity, dtype=np.float32)
        self.terminated = np.zeros(self.capacity, dtype=np.float32)
        self.ptr = 0  # next slot to write
        self.size = 0  # number of valid transitions

    def __len__(self) -> int:
        return self.size

    def add(
        self,
        obs: np.ndarray,
        action: np.ndarray,
        reward: float,
        next_obs: np.ndarray,
        terminated: bool,
    ) -> None:
        """Store one transition, overwriting the oldest when full."""
        i = self.ptr
        self.obs[i] = obs
        self.actions[i] = action
        self.rewards[i] = reward
        self.next_obs[i] = next_obs
        self.terminated[i] = float(terminated)
        self.ptr = (self.ptr + 1) % self.capacity
        self.size = min(self.size + 1, self.capacity)

    def sample(self, batch_size: int, rng: np.random.Generator) -> Batch:
        """Uniformly sample ``batch_size`` transitions (with replacement) using ``rng``."""
        if self.size == 0:
            raise ValueError("cannot sample from an empty replay buffer")
        idx = rng.integers(0, self.size, size=batch_size)
        return Batch(
            self.obs[idx], self.actions[idx], self.rewards[idx], self.next_obs[idx],
            self.terminated[idx],
        )

    def _chronological(self) -> dict[str, np.ndarray]:
        """Valid contents, oldest first."""
        start = self.ptr if self.size == self.capacity else 0
        order = (start + np.arange(self.size)) % self.capacity
        return {k: getattr(self, k)[order] for k in ("obs", "actions", "rewards", "next_obs",
                                                     "terminated")}

    def state_dict(self) -> dict[str, Any]:
        """Contents as torch tensors (only the ``size`` valid rows) plus pointer and size."""
        keys = ("obs", "actions", "rewards", "next_obs", "terminated")
        return {
            "capacity": self.capacity,
            "obs_dim": self.obs_dim,
            "act_dim": self.act_dim,
            "ptr": self.ptr,
            "size": self.size,
            **{k: torch.from_numpy(getattr(self, k)[: self.size].copy()) for k in keys},
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Restore contents. With the same capacity the layout (and thus sampling) is exact; into a
        different capacity the transitions are copied oldest first (keeping the newest if smaller).
        """
        if state["obs_dim"] != self.obs_dim or state["act_dim"] != self.act_dim:
            raise ValueError("replay buffer dimensions do not match the checkpoint")
        keys = ("obs", "actions", "rewards", "next_obs", "terminated")
        data = {k: state[k].numpy() for k in keys}
        size = int(state["size"])
        if state["capacity"] == self.capacity:
            for k in keys:
                getattr(self, k)[:size] = data[k]
            self.ptr, self.size = int(state["ptr"]), size
            return
        # different capacity: unroll into chronological order first
        start = int(state["ptr"]) if size == state["capacity"] else 0
        order = (start + np.arange(size)) % max(size, 1)
        n = min(size, self.capacity)
        order = order[size - n:]
        for k in keys:
            getattr(self, k)[:n] = data[k][order]
        self.size = n
        self.ptr = n % self.capacity


# ----------------------------------------------------------------------------------------------
# Networks
# ----------------------------------------------------------------------------------------------
def mlp(in_dim: int, out_dim: int, hidden_sizes: tuple[int, ...]) -> nn.Sequential:
    """Linear-ReLU-...-Linear with PyTorch's default (Kaiming-uniform) initialisation."""
    layers: list[nn.Module] = []
    d = in_dim
    for h in hidden_sizes:
        layers += [nn.Linear(d, h), nn.ReLU()]
        d = h
    layers.append(nn.Linear(d, out_dim))
    return nn.Sequential(*layers)


class Actor(nn.Module):
    """Deterministic policy ``mu(s) = tanh(MLP(s))`` in normalised action units [-1, 1]."""

    def __init__(self, obs_dim: int, act_dim: int, hidden_sizes: tuple[int, ...]) -> None:
        super().__init__()
        self.net = mlp(obs_dim, act_dim, hidden_sizes)

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return torch.tanh(self.net(obs))


class TwinCritic(nn.Module):
    """Two independent Q networks ``Q_i(s, a) = MLP_i([s, a])`` (normalised actions)."""

    def __init__(self, obs_dim: int, act_dim: int, hidden_sizes: tuple[int, ...]) -> None:
        super().__init__()
        self.q1_net = mlp(obs_dim + act_dim, 1, hidden_sizes)
        self.q2_net = mlp(obs_dim + act_dim, 1, hidden_sizes)

    def forward(self, obs: torch.Tensor, act: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        x = torch.cat([obs, act], dim=-1)
        return self.q1_net(x), self.q2_net(x)

    def q1(self, obs: torch.Tensor, act: torch.Tensor) -> torch.Tensor:
        return self.q1_net(torch.cat([obs, act], dim=-1))


class ScaledPolicy(nn.Module):
    """Actor followed by the affine map onto the environment's action box (for export)."""

    def __init__(self, actor: Actor, low: np.ndarray, high: np.ndarray) -> None:
        super().__init__()
        self.actor = actor
        self.register_buffer("scale", torch.as_tensor((high - low) / 2.0, dtype=torch.float32))
        self.register_buffer("center", torch.as_tensor((high + low) / 2.0, dtype=torch.float32))

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return self.center + self.scale * self.actor(obs)


# ----------------------------------------------------------------------------------------------
# Agent
# ----------------------------------------------------------------------------------------------
class TD3Agent:
    """TD3 actor, twin critics, their targets, optimisers and the agent's own RNGs.

    Randomness used by the agent comes from ``self.rng`` (numpy: exploration noise, warm-up
    actions, minibatch indices) and ``self.torch_rng`` (torch CPU: target policy noise); the
    networks are initialised from ``config.seed`` without touching the global torch RNG.
    """

    def __init__(
        self,
        obs_dim: int,
        act_dim: int,
        action_low: np.ndarray,
        action_high: np.ndarray,
        config: TD3Config | None = None,
    ) -> None:
        self.config = cfg = config if config is not None else TD3Config()
        self.obs_dim, self.act_dim = int(obs_dim), int(act_dim)
        self.action_low = np.asarray(action_low, dtype=np.float64).reshape(self.act_dim)
        self.action_high = np.asarray(action_high, dtype=np.float64).reshape(self.act_dim)
        if not (np.all(np.isfinite(self.action_low)) and np.all(np.isfinite(self.action_high))):
            raise ValueError("TD3 needs a bounded action space")
        if np.any(self.action_high <= self.action_low):
            raise ValueError("action_high must exceed action_low in every dimension")
        self.device = torch.device(cfg.device)

        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(cfg.seed)
            self.actor = Actor(self.obs_dim, self.act_dim, cfg.hidden_sizes).to(self.device)
            self.critic = TwinCritic(self.obs_dim, self.act_dim, cfg.hidden_sizes).to(self.device)
        self.actor_target = copy.deepcopy(self.actor)
        self.critic_target = copy.deepcopy(self.critic)
        for p in (*self.actor_target.parameters(), *self.critic_target.parameters()):
            p.requires_grad_(False)
        self.actor_optimizer = torch.optim.Adam(self.actor.parameters(), lr=cfg.actor_lr)
        self.critic_optimizer = torch.optim.Adam(self.critic.parameters(), lr=cfg.critic_lr)

        self.rng = np.random.default_rng(cfg.seed)
        self.torch_rng = torch.Generator(device="cpu").manual_seed(cfg.seed)
        self.num_updates = 0  # critic updates so far (the policy-delay counter)

    @classmethod
    def for_env(cls, env: gym.Env, config: TD3Config | None = None) -> TD3Agent:
        """Build an agent for a Gymnasium env with a flat Box observation and Box action space."""
        obs_space, act_space = env.observation_space, env.action_space
        if not isinstance(act_space, gym.spaces.Box) or not isinstance(obs_space, gym.spaces.Box):
            raise TypeError("TD3 needs Box observation and action spaces")
        return cls(
            int(np.prod(obs_space.shape)), int(np.prod(act_space.shape)),
            act_space.low.reshape(-1), act_space.high.reshape(-1), config,
        )

    # -- acting ---------------------------------------------------------------------------------
    def scale_action(self, action: np.ndarray) -> np.ndarray:
        """Map a normalised action in [-1, 1]^d onto the environment's box ``[low, high]``."""
        center = (self.action_high + self.action_low) / 2.0
        scale = (self.action_high - self.action_low) / 2.0
        return (center + scale * np.asarray(action, dtype=np.float64)).astype(np.float32)

    def random_action(self) -> np.ndarray:
        """Warm-up action: uniform on [-1, 1]^d (normalised), from the agent's numpy RNG."""
        return self.rng.uniform(-1.0, 1.0, size=self.act_dim).astype(np.float32)

    @torch.no_grad()
    def select_action(self, obs: np.ndarray, explore: bool) -> np.ndarray:
        """Normalised action ``mu(s)``, plus per-dimension noise ``N(0, sigma^2 I)`` when exploring
        (then clipped to [-1, 1])."""
        obs_t = torch.as_tensor(np.asarray(obs, dtype=np.float32).reshape(1, -1))
        obs_t = obs_t.to(self.device)
        action = self.actor(obs_t)[0].cpu().numpy().astype(np.float64)
        if explore:
            noise = self.rng.normal(0.0, self.config.exploration_noise, size=self.act_dim)
            action = np.clip(action + noise, -1.0, 1.0)
        return action.astype(np.float32)

    @torch.no_grad()
    def select_actions(self, obs: np.ndarray, explore: bool) -> np.ndarray:
        """Batched :meth:`select_action`: ``obs`` ``(B, obs_dim)`` -> normalised actions
        ``(B, act_dim)`` float32; the noise is one ``(B, act_dim)`` draw from ``self.rng`` (for
        ``B = 1`` the same numbers as :meth:`select_action`)."""
        obs_t = torch.as_tensor(np.asarray(obs, dtype=np.float32).reshape(-1, self.obs_dim))
        action = self.actor(obs_t.to(self.device)).cpu().numpy().astype(np.float64)
        if explore:
            noise = self.rng.normal(0.0, self.config.exploration_noise, size=action.shape)
            action = np.clip(action + noise, -1.0, 1.0)
        return action.astype(np.float32)

    def act(self, obs: np.ndarray, explore: bool = False) -> np.ndarray:
        """Action in environment units for ``obs`` (deterministic unless ``explore``)."""
        return self.scale_action(self.select_action(obs, explore))

    def policy_module(self) -> ScaledPolicy:
        """A standalone copy of the actor mapping observations to environment actions."""
        policy = ScaledPolicy(copy.deepcopy(self.actor).cpu(), self.action_low, self.action_high)
        return policy.eval().requires_grad_(False)

    # -- learning -------------------------------------------------------------------------------
    def _to_tensors(self, batch: Batch) -> tuple[torch.Tensor, ...]:
        def t(x: np.ndarray) -> torch.Tensor:
            return torch.as_tensor(np.asarray(x, dtype=np.float32), device=self.device)

        return (
            t(batch.obs), t(batch.actions), t(batch.rewards).reshape(-1, 1), t(batch.next_obs),
            t(batch.terminated).reshape(-1, 1),
        )

    @torch.no_grad()
    def compute_target(
        self, rewards: torch.Tensor, next_obs: torch.Tensor, terminated: torch.Tensor
    ) -> torch.Tensor:
        """TD target with target policy smoothing and clipped double Q, shape ``(B, 1)``.

        The equations::

            eps ~ N(0, sigma^2), per dimension;  a' = clip(mu'(s') + clip(eps, -c, c), -1, 1)
            y   = r + gamma * (1 - terminated) * min(Q1'(s', a'), Q2'(s', a'))
        """
        cfg = self.config
        shape = (next_obs.shape[0], self.act_dim)
        eps = torch.randn(shape, generator=self.torch_rng).to(self.device) * cfg.policy_noise
        eps = eps.clamp(-cfg.target_noise_clip, cfg.target_noise_clip)
        next_action = (self.actor_target(next_obs) + eps).clamp(-1.0, 1.0)
        q1_next, q2_next = self.critic_target(next_obs, next_action)
        return rewards + cfg.gamma * (1.0 - terminated) * torch.min(q1_next, q2_next)

    def update(self, batch: Batch) -> dict[str, float]:
        """One TD3 gradient step on ``batch``: the critics always; every ``policy_delay``-th call
        also the actor and a Polyak update of both targets. Returns the losses as floats."""
        cfg = self.config
        obs, actions, rewards, next_obs, terminated = self._to_tensors(batch)

        # critics: regress both Q1 and Q2 onto the shared target y
        y = self.compute_target(rewards, next_obs, terminated)
        q1, q2 = self.critic(obs, actions)
        critic_loss = F.mse_loss(q1, y) + F.mse_loss(q2, y)
        self.critic_optimizer.zero_grad(set_to_none=True)
        critic_loss.backward()
        self.critic_optimizer.step()
        self.num_updates += 1
        info = {
            "critic_loss": critic_loss.item(),
            "q1": q1.mean().item(),
            "q2": q2.mean().item(),
            "target_q": y.mean().item(),
        }

        # delayed actor and target updates
        if self.num_updates % cfg.policy_delay == 0:
            # the critic is held fixed here: freezing its parameters skips their (unused) gradients,
            # about a third of the backward pass; the actor's gradient is unchanged bit for bit
            self.critic.requires_grad_(False)
            try:
                actor_loss = -self.critic.q1(obs, self.actor(obs)).mean()
                self.actor_optimizer.zero_grad(set_to_none=True)
                actor_loss.backward()
            finally:
                self.critic.requires_grad_(True)
            self.actor_optimizer.step()
            with torch.no_grad():  # theta' <- tau * theta + (1 - tau) * theta'
                for net, target in ((self.actor, self.actor_target),
                                    (self.critic, self.critic_target)):
                    for p, p_targ in zip(net.parameters(), target.parameters(), strict=True):
                        p_targ.copy_(cfg.tau * p + (1.0 - cfg.tau) * p_targ)
            info["actor_loss"] = actor_loss.item()
        return info

    # -- state ----------------------------------------------------------------------------------
    def state_dict(self) -> dict[str, Any]:
        """Networks, targets, optimisers, the agent's RNG states and the update counter."""
        return {
            "actor": self.actor.state_dict(),
            "critic": self.critic.state_dict(),
            "actor_target": self.actor_target.state_dict(),
            "critic_target": self.critic_target.state_dict(),
            "actor_optimizer": self.actor_optimizer.state_dict(),
            "critic_optimizer": self.critic_optimizer.state_dict(),
            "numpy_rng": self.rng.bit_generator.state,
            "torch_rng": self.torch_rng.get_state(),
            "num_updates": self.num_updates,
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.actor.load_state_dict(state["actor"])
        self.critic.load_state_dict(state["critic"])
        self.actor_target.load_state_dict(state["actor_target"])
        self.critic_target.load_state_dict(state["critic_target"])
        self.actor_optimizer.load_state_dict(state["actor_optimizer"])
        self.critic_optimizer.load_state_dict(state["critic_optimizer"])
        self.rng.bit_generator.state = state["numpy_rng"]
        self.torch_rng.set_state(state["torch_rng"])
        self.num_updates = int(state["num_updates"])

    @classmethod
    def from_checkpoint(cls, path: str | os.PathLike, device: str | None = None) -> TD3Agent:
        """Rebuild an agent (networks, optimisers, RNGs) from a :func:`train` checkpoint."""
        ckpt = load_checkpoint(path)
        _refuse_networks_only(ckpt, path)
        cfg = TD3Config.from_dict(ckpt["config"])
        if device is not None:
            cfg.device = device
        agent = cls(ckpt["obs_dim"], ckpt["act_dim"], ckpt["action_low"].numpy(),
                    ckpt["action_high"].numpy(), cfg)
        agent.load_state_dict(ckpt["agent"])
        return agent


# ----------------------------------------------------------------------------------------------
# Checkpoints
# ----------------------------------------------------------------------------------------------
def save_checkpoint(path: str | os.PathLike, checkpoint: dict[str, Any]) -> None:
    """Write ``checkpoint`` atomically: to a temporary file in the same directory, then rename."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as f:
        torch.save(checkpoint, f)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def load_checkpoint(path: str | os.PathLike) -> dict[str, Any]:
    """Load a checkpoint written by :func:`train` (a run directory or the file itself)."""
    path = Path(path)
    if path.is_dir():
        path = path / CHECKPOINT_NAME
    ckpt = torch.load(path, map_location="cpu", weights_only=True)
    if ckpt.get("format") != CHECKPOINT_FORMAT:
        raise ValueError(f"{path} is not a TD3 checkpoint ({CHECKPOINT_FORMAT})")
    return ckpt


def _refuse_networks_only(ckpt: dict[str, Any], path: str | os.PathLike) -> None:
    if ckpt.get("kind") == "best":
        raise ValueError(f"{path} holds only the networks of the best evaluation (no optimisers, "
                         f"buffer or RNG states): training can only continue from a run's "
                         f"{CHECKPOINT_NAME}")


# ----------------------------------------------------------------------------------------------
# Training loop
# ----------------------------------------------------------------------------------------------
def _flat_obs(obs: Any) -> np.ndarray:
    return np.asarray(obs, dtype=np.float32).reshape(-1)


def _truncate_csv(path: Path, fields: tuple[str, ...], keep: Callable[[dict[str, str]], bool]) -> None:
    """Keep only the rows of a log for which ``keep(row)`` (those written before the checkpoint
    a run resumes from)."""
    if not path.exists():
        return
    with open(path, newline="") as f:
        rows = [r for r in csv.DictReader(f) if keep(r)]
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)
    os.replace(tmp, path)


def _truncate_episode_log(path: Path, keep_episodes: int) -> None:
    """Drop rows of episodes ``>= keep_episodes`` (logged after the checkpoint we resume from)."""
    _truncate_csv(path, EPISODE_FIELDS, lambda row: int(row["episode"]) < keep_episodes)


class _PeriodicEvaluation:
    """Evaluation during training (``config.eval_every``, as Stable-Baselines3's
    ``EvalCallback``): :func:`evaluate` runs the deterministic policy in its own environment, a row
    goes to ``evaluations.csv`` and TensorBoard (``eval/``), and the actor and critic of the best
    evaluation so far go to ``best.pt`` (loadable wherever a checkpoint's policy is read, e.g.
    ``msr generate RUN/best.pt``).

    It draws from none of the training's RNGs (its environment is reset with the fixed seeds
    ``EVAL_SEED + i``), so a run's training is bit-identical with or without it. Its state (the
    best networks included) is part of the checkpoints, so a resumed run keeps the right best.
    """

    def __init__(self, env_fn: Callable[[], gym.Env] | None, cfg: TD3Config, run_dir: Path,
                 writer: Any, agent: TD3Agent, global_step: int, ckpt: dict[str, Any] | None,
                 resumed_here: bool, metadata: dict[str, Any] | None) -> None:
        self.env_fn, self.cfg, self.writer = env_fn, cfg, writer
        self.enabled = env_fn is not None and cfg.eval_every > 0
        self.csv_path = run_dir / EVALUATIONS_CSV
        self.best_path = run_dir / BEST_NAME
        state = ckpt.get("evaluation") if (resumed_here and ckpt is not None) else None
        self.best_return = float(state["best_mean_return"]) if state else -math.inf
        self.best_step = int(state["best_step"]) if state else -1
        self.best_networks = state["best_networks"] if state else None
        self.last_step = int(state["last_step"]) if state else -1
        self.next_step = self._next(global_step)
        if resumed_here:
            _truncate_csv(self.csv_path, EVALUATION_FIELDS,
                          lambda row: int(row["global_step"]) <= global_step)
        else:  # leftovers of an earlier run in this folder that left no checkpoint
            self.csv_path.unlink(missing_ok=True)
        if self.best_networks is not None:  # the best as of the checkpoint (not a later one)
            self.write_best(agent, metadata)
        else:
            self.best_path.unlink(missing_ok=True)

    def _next(self, global_step: int) -> int:
        every = max(self.cfg.eval_every, 1)
        return (global_step // every + 1) * every

    def due(self, global_step: int) -> bool:
        return self.enabled and global_step >= self.next_step

    def run(self, agent: TD3Agent, global_step: int, wall_time_s: float,
            metadata: dict[str, Any] | None) -> EvalResult:
        result = evaluate(agent, self.env_fn, self.cfg.eval_episodes, seed=EVAL_SEED)
        if result.mean_return > self.best_return:
            self.best_return, self.best_step = result.mean_return, global_step
            self.best_networks = {"actor": copy.deepcopy(agent.actor.state_dict()),
                                  "critic": copy.deepcopy(agent.critic.state_dict())}
            self.write_best(agent, metadata)
        row = {"global_step": global_step, "mean_return": result.mean_return,
               "std_return": result.std_return, "mean_length": float(np.mean(result.lengths)),
               "best_mean_return": self.best_return, "wall_time_s": round(wall_time_s, 3)}
        new_file = not self.csv_path.exists() or self.csv_path.stat().st_size == 0
        with open(self.csv_path, "a", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=EVALUATION_FIELDS)
            if new_file:
                writer.writeheader()
            writer.writerow(row)
        self.writer.add_scalar("eval/mean_return", result.mean_return, global_step)
        self.writer.add_scalar("eval/best_mean_return", self.best_return, global_step)
        self.last_step = global_step
        self.next_step = self._next(global_step)
        return result

    def write_best(self, agent: TD3Agent, metadata: dict[str, Any] | None) -> None:
        """``best.pt``: a checkpoint holding only the best networks (no optimisers, buffer or RNGs:
        it cannot be resumed or refined), with the step and return of their evaluation."""
        save_checkpoint(self.best_path, {
            "format": CHECKPOINT_FORMAT,
            "kind": "best",
            "config": self.cfg.to_dict(),
            "obs_dim": agent.obs_dim,
            "act_dim": agent.act_dim,
            "action_low": torch.from_numpy(agent.action_low.copy()),
            "action_high": torch.from_numpy(agent.action_high.copy()),
            "agent": self.best_networks,
            "global_step": self.best_step,
            "evaluation": {"mean_return": self.best_return, "episodes": self.cfg.eval_episodes,
                           "seed": EVAL_SEED},
            "metadata": metadata if metadata is not None else {},
        })

    def state_dict(self) -> dict[str, Any]:
        return {"best_mean_return": self.best_return, "best_step": self.best_step,
                "best_networks": self.best_networks, "last_step": self.last_step}


def _starting_point(
    ckpt_path: Path,
    resume: bool,
    init_from: str | os.PathLike | None,
    config: TD3Config | None,
    metadata: dict[str, Any] | None,
) -> tuple[dict[str, Any] | None, bool, TD3Config, dict[str, Any] | None]:
    """Where a run starts: ``(checkpoint or None, resumed from this run_dir, config, metadata)``.

    An existing checkpoint in the run directory is refused unless ``resume``; without one,
    ``init_from`` (another run's checkpoint) may seed the run. When resuming (or when no config is
    passed) the checkpoint's config is used, except for the :data:`RESUMABLE_SETTINGS` of a config
    passed; a resumed run keeps its metadata unless given new.
    """
    ckpt: dict[str, Any] | None = None
    if ckpt_path.exists():
        if not resume:
            raise FileExistsError(f"{ckpt_path} exists: pass resume=True or use a new run_dir")
        ckpt = load_checkpoint(ckpt_path)
    elif resume:
        warnings.warn(f"resume=True but no checkpoint in {ckpt_path.parent}: starting fresh",
                      stacklevel=3)
    resumed_here = ckpt is not None
    if ckpt is None and init_from is not None:
        ckpt = load_checkpoint(init_from)
        _refuse_networks_only(ckpt, init_from)
    if ckpt is not None:
        ckpt_cfg = TD3Config.from_dict(ckpt["config"])
        if resumed_here or config is None:
            if config is not None:
                # run settings that change no weight may change on resume; the rest is the run's
                passed = {k: getattr(config, k) for k in RESUMABLE_SETTINGS}
                if dataclasses.replace(config, **{k: getattr(ckpt_cfg, k)
                                                  for k in RESUMABLE_SETTINGS}) != ckpt_cfg:
                    warnings.warn("resuming: using the checkpoint's hyperparameters, not the ones "
                                  "passed", stacklevel=3)
                ckpt_cfg = dataclasses.replace(ckpt_cfg, **passed)
            config = ckpt_cfg
    cfg = config if config is not None else TD3Config()
    if metadata is None and resumed_here:
        metadata = ckpt.get("metadata")
    return ckpt, resumed_here, cfg, metadata


class _SeedRun:
    """The bookkeeping of one seed's training: its agent, replay buffer, episode log, TensorBoard
    writer, progress bar and checkpoints in ``run_dir``. :func:`train` drives one with a single
    environment; :func:`train_shared` drives several, one per crawler of a shared simulator.

    The caller resets the environment (``episode_seed(config.seed, self.episode)``), asks
    :meth:`act` for an action, steps, and hands the transition to :meth:`record`, which stores it,
    learns, and at an episode end logs it and maybe checkpoints. :meth:`finish` writes the final
    checkpoint; :meth:`close` closes the files.
    """

    def __init__(
        self,
        obs_dim: int,
        act_dim: int,
        action_low: np.ndarray,
        action_high: np.ndarray,
        config: TD3Config | None,
        steps: int,
        run_dir: str | os.PathLike,
        resume: bool,
        progress: bool,
        log_fn: Callable[[dict[str, Any]], None] | None,
        init_from: str | os.PathLike | None,
        progress_position: int | None,
        progress_desc: str | None,
        metadata: dict[str, Any] | None,
        seed_global_rngs: bool = True,
        eval_env_fn: Callable[[], gym.Env] | None = None,
    ) -> None:
        from torch.utils.tensorboard import SummaryWriter
        from tqdm.auto import tqdm

        self.run_dir = run_dir = Path(run_dir)
        run_dir.mkdir(parents=True, exist_ok=True)
        self.ckpt_path = run_dir / CHECKPOINT_NAME
        csv_path = run_dir / EPISODES_CSV

        ckpt, resumed_here, cfg, metadata = _starting_point(self.ckpt_path, resume, init_from,
                                                            config, metadata)
        self.resumed_here, self.cfg = resumed_here, cfg
        self.metadata = metadata
        self.steps = int(steps)
        self.log_fn = log_fn

        self.agent = agent = TD3Agent(obs_dim, act_dim, action_low, action_high, cfg)
        self.buffer = ReplayBuffer(min(cfg.buffer_size, self.steps), agent.obs_dim, agent.act_dim)
        self.global_step, self.episode, self.elapsed_before = 0, 0, 0.0
        if ckpt is not None:
            if (ckpt["obs_dim"], ckpt["act_dim"]) != (agent.obs_dim, agent.act_dim):
                raise ValueError("checkpoint does not match the environment's spaces")
            agent.load_state_dict(ckpt["agent"])
            self.buffer.load_state_dict(ckpt["buffer"])
            self.global_step = int(ckpt["global_step"])
            self.episode = int(ckpt["episode"]) + (0 if ckpt["at_episode_boundary"] else 1)
            if seed_global_rngs:
                random.setstate(ckpt["python_rng"])
                torch.set_rng_state(ckpt["torch_cpu_rng"])
            self.elapsed_before = float(ckpt["wall_time_s"]) if resumed_here else 0.0
        elif seed_global_rngs:
            random.seed(cfg.seed)
            torch.manual_seed(cfg.seed)
        self.start_step = self.global_step

        if resumed_here:
            _truncate_episode_log(csv_path, self.episode)
        elif csv_path.exists():
            csv_path.unlink()  # stale log of a run without checkpoint
        self.writer = SummaryWriter(str(run_dir), purge_step=self.global_step if resumed_here else None)
        if not resumed_here:
            self.writer.add_text("config", str(cfg.to_dict()))
        self.evaluation = _PeriodicEvaluation(eval_env_fn, cfg, run_dir, self.writer, agent,
                                              self.global_step, ckpt, resumed_here, metadata)
        self.t_start = time.time()
        self.next_checkpoint = (self.global_step // cfg.checkpoint_every + 1) * cfg.checkpoint_every
        self.bar = tqdm(total=self.steps, initial=min(self.global_step, self.steps),
                        disable=not progress, position=progress_position, desc=progress_desc,
                        dynamic_ncols=True, leave=True)
        self.csv_file = open(csv_path, "a", newline="")
        self.csv_writer = csv.DictWriter(self.csv_file, fieldnames=EPISODE_FIELDS)
        if csv_path.stat().st_size == 0:
            self.csv_writer.writeheader()
        self.sps_t, self.sps_step = time.time(), self.global_step
        self.ep_return, self.ep_len = 0.0, 0
        self.last_ended = False

    @property
    def done(self) -> bool:
        return self.global_step >= self.steps

    def reset_seed(self) -> int:
        """Seed of the environment reset that starts the current episode."""
        return episode_seed(self.cfg.seed, self.episode)

    def act(self, obs: np.ndarray) -> np.ndarray:
        """Normalised action: uniform random during warm-up, then mu(s) + N(0, sigma^2 I)."""
        if self.global_step < self.cfg.learning_starts:
            return self.agent.random_action()
        return self.agent.select_action(obs, explore=True)

    def record(self, obs: np.ndarray, action: np.ndarray, reward: float, next_obs: np.ndarray,
               terminated: bool, truncated: bool) -> bool:
        """Store one transition, learn, and handle an episode end; returns whether it ended."""
        cfg, agent = self.cfg, self.agent
        # store terminated (not done): truncated transitions bootstrap from the real s'
        self.buffer.add(obs, action, float(reward), next_obs, bool(terminated))
        self.ep_return += float(reward)
        self.ep_len += 1
        self.global_step += 1
        self.bar.update(1)

        # learn: one (or updates_per_step) TD3 update per env step after warm-up
        if self.global_step > cfg.learning_starts and len(self.buffer) >= cfg.batch_size:
            for _ in range(cfg.updates_per_step):
                info = agent.update(self.buffer.sample(cfg.batch_size, agent.rng))
                if agent.num_updates % cfg.log_every == 0:
                    for k, v in info.items():
                        self.writer.add_scalar(f"losses/{k}", v, self.global_step)

        self.last_ended = bool(terminated or truncated)
        if not self.last_ended:
            return False
        # episode end: log, maybe checkpoint; the caller resets with the next seed of the sequence
        row = {
            "episode": self.episode,
            "global_step": self.global_step,
            "return": self.ep_return,
            "length": self.ep_len,
            "terminated": int(bool(terminated)),
            "truncated": int(bool(truncated)),
            "wall_time_s": round(self.wall_time_s, 3),
        }
        self.csv_writer.writerow(row)
        self.csv_file.flush()
        self.writer.add_scalar("charts/episodic_return", self.ep_return, self.global_step)
        self.writer.add_scalar("charts/episodic_length", self.ep_len, self.global_step)
        now = time.time()
        self.writer.add_scalar("charts/sps", (self.global_step - self.sps_step)
                               / max(now - self.sps_t, 1e-9), self.global_step)
        self.sps_t, self.sps_step = now, self.global_step
        self.bar.set_postfix(ep=self.episode, ret=f"{self.ep_return:.3g}", refresh=False)
        if self.log_fn is not None:
            self.log_fn(row)
        self.episode += 1
        if self.evaluation.due(self.global_step):
            self.evaluation.run(agent, self.global_step, self.wall_time_s, self.metadata)
        if self.next_checkpoint <= self.global_step < self.steps:
            self.writer.flush()
            self.checkpoint(at_episode_boundary=True)
            self.next_checkpoint = (self.global_step // cfg.checkpoint_every + 1) * cfg.checkpoint_every
        if self.global_step < self.steps:
            self.ep_return, self.ep_len = 0.0, 0
        return True

    def checkpoint(self, at_episode_boundary: bool) -> None:
        agent = self.agent
        save_checkpoint(self.ckpt_path, {
            "format": CHECKPOINT_FORMAT,
            "config": self.cfg.to_dict(),
            "obs_dim": agent.obs_dim,
            "act_dim": agent.act_dim,
            "action_low": torch.from_numpy(agent.action_low.copy()),
            "action_high": torch.from_numpy(agent.action_high.copy()),
            "agent": agent.state_dict(),
            "buffer": self.buffer.state_dict(),
            "global_step": self.global_step,
            "episode": self.episode,  # index of the next episode (of the current one if mid-episode)
            "at_episode_boundary": at_episode_boundary,
            "python_rng": random.getstate(),
            "torch_cpu_rng": torch.get_rng_state(),
            "wall_time_s": self.wall_time_s,
            "metadata": self.metadata if self.metadata is not None else {},
            "evaluation": self.evaluation.state_dict(),
        })

    @property
    def wall_time_s(self) -> float:
        """Wall-clock time of the run so far, earlier sessions included, s."""
        return self.elapsed_before + time.time() - self.t_start

    def finish(self) -> None:
        """The last evaluation and the final checkpoint (unless a resumed run took no step)."""
        if not (self.resumed_here and self.global_step == self.start_step):
            if self.evaluation.enabled and self.evaluation.last_step != self.global_step:
                self.evaluation.run(self.agent, self.global_step, self.wall_time_s, self.metadata)
            self.checkpoint(at_episode_boundary=self.ep_len == 0 or self.last_ended)

    def close(self) -> None:
        self.csv_file.close()
        self.bar.close()
        self.writer.close()


def train(
    env_fn: Callable[[], gym.Env],
    config: TD3Config | None = None,
    steps: int = 100_000,
    run_dir: str | os.PathLike = "runs/td3",
    resume: bool = False,
    progress: bool = True,
    log_fn: Callable[[dict[str, Any]], None] | None = None,
    *,
    init_from: str | os.PathLike | None = None,
    progress_position: int | None = None,
    progress_desc: str | None = None,
    metadata: dict[str, Any] | None = None,
    eval_env_fn: Callable[[], gym.Env] | None = None,
) -> TD3Agent:
    """Train TD3 until ``steps`` environment steps in total and return the agent.

    Writes into ``run_dir``: ``episodes.csv`` (one row per finished episode: episode, global_step,
    return, length, terminated, truncated, wall_time_s), TensorBoard scalars, and
    ``checkpoint.pt`` (see the module docstring; every ``config.checkpoint_every`` steps at an
    episode boundary and at the end).

    Args:
        env_fn: makes the environment (flat Box observations, bounded Box actions).
        config: hyperparameters; on ``resume`` the checkpoint's config is used.
        steps: total environment steps of the run (counted from step 0, including steps done
            before a resume or inherited through ``init_from``).
        run_dir: output directory. Refuses to overwrite an existing checkpoint unless ``resume``.
        resume: continue from ``run_dir/checkpoint.pt`` (fresh start if there is none).
        progress: show a tqdm progress bar.
        log_fn: called with each episode's row (a dict) after it is written.
        init_from: start from another run's checkpoint (networks, optimisers, buffer, RNGs and
            counters; e.g. to refine a policy in another environment). Ignored when resuming from
            a checkpoint in ``run_dir``.
        progress_position, progress_desc: tqdm ``position`` and ``desc`` (one bar per worker).
        metadata: JSON-like dict (str, numbers, lists, dicts) stored in the checkpoint under
            ``"metadata"`` (e.g. the environment's case), so a checkpoint describes itself. When
            ``None`` the metadata of the checkpoint resumed from (if any) is kept.
        eval_env_fn: makes the evaluation environment; with ``config.eval_every > 0`` the
            deterministic policy is evaluated there periodically (``evaluations.csv``, ``eval/``
            scalars, the best actor in ``best.pt``; see :class:`TD3Config`). The training itself
            is bit-identical with or without it.
    """
    env = env_fn()
    obs_space, act_space = env.observation_space, env.action_space
    if not isinstance(act_space, gym.spaces.Box) or not isinstance(obs_space, gym.spaces.Box):
        env.close()
        raise TypeError("TD3 needs Box observation and action spaces")
    try:
        run = _SeedRun(int(np.prod(obs_space.shape)), int(np.prod(act_space.shape)),
                       act_space.low.reshape(-1), act_space.high.reshape(-1), config, steps, run_dir,
                       resume, progress, log_fn, init_from, progress_position, progress_desc,
                       metadata, eval_env_fn=eval_env_fn)
    except BaseException:
        env.close()
        raise
    prev_deterministic = torch.are_deterministic_algorithms_enabled()
    if run.cfg.torch_deterministic:
        torch.use_deterministic_algorithms(True)
    try:
        obs, _ = env.reset(seed=run.reset_seed())
        obs = _flat_obs(obs)
        while not run.done:
            action = run.act(obs)
            next_obs, reward, terminated, truncated, _ = env.step(run.agent.scale_action(action))
            next_obs = _flat_obs(next_obs)
            ended = run.record(obs, action, reward, next_obs, terminated, truncated)
            obs = next_obs
            if ended and not run.done:
                obs, _ = env.reset(seed=run.reset_seed())
                obs = _flat_obs(obs)
        run.finish()
    finally:
        run.close()
        env.close()
        torch.use_deterministic_algorithms(prev_deterministic)
    return run.agent


def train_shared(
    vec_env_fn: Callable[[int], gym.vector.VectorEnv],
    configs: list[TD3Config],
    steps: int,
    run_dirs: list[str | os.PathLike],
    resume: bool = False,
    progress: bool = True,
    *,
    progress_desc: str | None = None,
    metadata: list[dict[str, Any]] | None = None,
    eval_env_fn: Callable[[], gym.Env] | None = None,
) -> list[TD3Agent]:
    """Train independent seeds side by side, one crawler each in one shared simulator.

    ``vec_env_fn(K)`` makes a vector environment of ``K = len(configs)`` sub-environments with
    ``SAME_STEP`` autoreset whose sub-environment ``k`` reproduces the single environment exactly
    (:class:`~rl.vector_env.MagneticCrawlerVectorEnv`: all robots in one batched simulator). Agent
    ``k`` (``configs[k]``, its own networks, buffer, RNGs and ``run_dirs[k]``) drives sub-environment
    ``k`` only, and everything is done as :func:`train` does it for one seed: one transition and
    one update per step, episodes reset with ``episode_seed(configs[k].seed, episode)`` (the
    sub-environment is re-reset with that seed after its autoreset), checkpoints at episode
    boundaries in :func:`train`'s format. So each seed's run is bit-identical to
    ``train(single env, configs[k])`` (CPU, same thread count), its folder can be resumed by either
    function, and only the simulation is shared: the batched physics costs less per robot.

    A seed that reaches ``steps`` stops learning and acting (its crawler idles) while the others go
    on. ``metadata[k]`` goes into seed ``k``'s checkpoints. ``eval_env_fn``: as :func:`train`
    (each seed is evaluated in its own single environment). Returns the agents.
    """
    from gymnasium.vector import AutoresetMode

    if len(configs) < 1 or len(configs) != len(run_dirs):
        raise ValueError("train_shared needs one run_dir per config, and at least one config")
    if len({Path(d).resolve() for d in run_dirs}) != len(run_dirs):
        raise ValueError("every seed needs its own run_dir")
    k_runs = len(configs)
    env = vec_env_fn(k_runs)
    if env.metadata.get("autoreset_mode") != AutoresetMode.SAME_STEP or env.num_envs != k_runs:
        env.close()
        raise ValueError(f"train_shared needs a SAME_STEP vector env of {k_runs} sub-environments")
    obs_dim = int(np.prod(env.single_observation_space.shape))
    act_dim = int(np.prod(env.single_action_space.shape))
    low = env.single_action_space.low.reshape(-1)
    high = env.single_action_space.high.reshape(-1)
    runs: list[_SeedRun] = []
    try:
        for k, (config, run_dir) in enumerate(zip(configs, run_dirs, strict=True)):
            desc = f"{progress_desc or 'seed'} {config.seed}"
            # the global RNGs are one per process: seeded (unused by the agents) from the first seed
            runs.append(_SeedRun(obs_dim, act_dim, low, high, config, steps, run_dir, resume,
                                 progress, None, None, k, desc,
                                 metadata[k] if metadata is not None else None,
                                 seed_global_rngs=k == 0, eval_env_fn=eval_env_fn))
    except BaseException:
        for run in runs:
            run.close()
        env.close()
        raise
    prev_deterministic = torch.are_deterministic_algorithms_enabled()
    if any(run.cfg.torch_deterministic for run in runs):
        torch.use_deterministic_algorithms(True)
    try:
        obs, _ = env.reset(seed=[run.reset_seed() for run in runs])
        obs = np.asarray(obs, dtype=np.float32).reshape(k_runs, obs_dim)
        actions = np.zeros((k_runs, act_dim), dtype=np.float32)  # idle crawlers: no field change
        while not all(run.done for run in runs):
            active = [k for k, run in enumerate(runs) if not run.done]
            for k in active:
                actions[k] = runs[k].act(obs[k])
            for k in range(k_runs):
                if runs[k].done:
                    actions[k] = 0.0
            scaled = np.stack([runs[k].agent.scale_action(actions[k]) for k in range(k_runs)])
            next_obs, rewards, terminated, truncated, infos = env.step(scaled)
            next_obs = np.asarray(next_obs, dtype=np.float32).reshape(k_runs, obs_dim)
            reseed: list[int | None] = [None] * k_runs
            for k in active:
                ended = bool(terminated[k] or truncated[k])
                real_next = (np.asarray(infos["final_obs"][k], dtype=np.float32).reshape(-1)
                             if ended else next_obs[k])
                if runs[k].record(obs[k], actions[k], float(rewards[k]), real_next,
                                  bool(terminated[k]), bool(truncated[k])) and not runs[k].done:
                    reseed[k] = runs[k].reset_seed()
            mask = np.array([seed is not None for seed in reseed])
            if mask.any():  # the next episode starts from its seed, as train() resets it
                fresh, _ = env.reset(seed=reseed, options={"reset_mask": mask})
                fresh = np.asarray(fresh, dtype=np.float32).reshape(k_runs, obs_dim)
                next_obs[mask] = fresh[mask]
            obs = next_obs
        for run in runs:
            run.finish()
    finally:
        for run in runs:
            run.close()
        env.close()
        torch.use_deterministic_algorithms(prev_deterministic)
    return [run.agent for run in runs]


# ----------------------------------------------------------------------------------------------
# Training with a vector environment
# ----------------------------------------------------------------------------------------------
def _to_tensors(obj: Any) -> Any:
    """numpy arrays -> CPU tensors, recursively (checkpoints load with ``weights_only=True``)."""
    if isinstance(obj, np.ndarray):
        return torch.from_numpy(obj.copy())
    if isinstance(obj, dict):
        return {k: _to_tensors(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return type(obj)(_to_tensors(v) for v in obj)
    return obj


def _to_numpy(obj: Any) -> Any:
    """Inverse of :func:`_to_tensors`."""
    if isinstance(obj, torch.Tensor):
        return obj.numpy().copy()
    if isinstance(obj, dict):
        return {k: _to_numpy(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return type(obj)(_to_numpy(v) for v in obj)
    return obj


def train_vector(
    vec_env_fn: Callable[[], gym.vector.VectorEnv],
    config: TD3Config | None = None,
    steps: int = 100_000,
    run_dir: str | os.PathLike = "runs/td3",
    resume: bool = False,
    progress: bool = True,
    log_fn: Callable[[dict[str, Any]], None] | None = None,
    *,
    init_from: str | os.PathLike | None = None,
    progress_position: int | None = None,
    progress_desc: str | None = None,
    metadata: dict[str, Any] | None = None,
    eval_env_fn: Callable[[], gym.Env] | None = None,
) -> TD3Agent:
    """Train TD3 with a vector environment of ``N`` sub-environments (e.g.
    :class:`~rl.vector_env.MagneticCrawlerVectorEnv`): N transitions per vector step and, after
    the warm-up, ``N * updates_per_step`` gradient updates per vector step (one update per
    environment transition, as :func:`train`).

    Same outputs as :func:`train` (``episodes.csv`` with a global episode counter, numbered in the
    order episodes end, sub-environments in index order within a step; TensorBoard scalars;
    ``checkpoint.pt`` loadable by everything that reads :func:`train` checkpoints).

    Autoreset: the environment must declare ``metadata["autoreset_mode"] ==
    AutoresetMode.SAME_STEP``. For a sub-environment that ended on a step, the stored transition's
    ``next_obs`` is ``infos["final_obs"][i]`` (the real last observation) and ``terminated[i]`` is
    stored (a truncation bootstraps); the first observation of the new episode (the returned
    ``obs[i]``) only becomes the ``obs`` of the next transition. No transition spans a reset.

    Seeding: the environment is reset once, with ``seed=episode_seed(config.seed, 0)`` (so
    sub-environment ``i`` gets that seed ``+ i``); later episodes draw their initial fields from
    each sub-environment's own generator (autoreset).

    Checkpoints and exact resume: a checkpoint is written at the first vector step that reaches
    every multiple of ``config.checkpoint_every`` transitions, and at the end. It holds what
    :func:`train` saves plus, under ``"vector"``, the environment's full state
    (``env.get_state()``: the simulator memory block, fields, counters, generators), the current
    observations and each sub-environment's running return and length. Every vector step is a
    restorable point, so a killed run resumed from its checkpoint (or continued to more ``steps``)
    ends bit-identical to an uninterrupted one (CPU, same thread count). Environments without
    ``get_state``/``set_state`` train but cannot be resumed mid-episode.

    Args:
        vec_env_fn: makes the vector environment (flat Box single spaces, bounded actions).
        steps: total environment transitions (all sub-environments together) of the run; the run
            stops at the first vector step reaching it, so it takes ``ceil(steps / N)`` vector
            steps.
        eval_env_fn: as :func:`train` (a single environment); evaluations fall on the first
            vector step reaching each multiple of ``config.eval_every`` transitions.
        Others: as :func:`train`.
    """
    from gymnasium.vector import AutoresetMode
    from torch.utils.tensorboard import SummaryWriter
    from tqdm.auto import tqdm

    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    ckpt_path = run_dir / CHECKPOINT_NAME
    csv_path = run_dir / EPISODES_CSV

    ckpt, resumed_here, cfg, metadata = _starting_point(ckpt_path, resume, init_from, config,
                                                        metadata)

    env = vec_env_fn()
    if env.metadata.get("autoreset_mode") != AutoresetMode.SAME_STEP:
        env.close()
        raise ValueError("train_vector needs a vector env with autoreset_mode SAME_STEP")
    n_envs = int(env.num_envs)
    agent = TD3Agent(
        int(np.prod(env.single_observation_space.shape)), int(np.prod(env.single_action_space.shape)),
        env.single_action_space.low.reshape(-1), env.single_action_space.high.reshape(-1), cfg,
    )
    total = -(-int(steps) // n_envs) * n_envs
    buffer = ReplayBuffer(min(cfg.buffer_size, total), agent.obs_dim, agent.act_dim)
    global_step, episode, elapsed_before = 0, 0, 0.0
    vector_state: dict[str, Any] | None = None
    if ckpt is not None:
        if (ckpt["obs_dim"], ckpt["act_dim"]) != (agent.obs_dim, agent.act_dim):
            raise ValueError("checkpoint does not match the environment's spaces")
        agent.load_state_dict(ckpt["agent"])
        buffer.load_state_dict(ckpt["buffer"])
        global_step = int(ckpt["global_step"])
        random.setstate(ckpt["python_rng"])
        torch.set_rng_state(ckpt["torch_cpu_rng"])
        if resumed_here:
            elapsed_before = float(ckpt["wall_time_s"])
            vector_state = ckpt.get("vector")
            if vector_state is None or int(vector_state["num_envs"]) != n_envs:
                raise ValueError(f"{ckpt_path} holds no state of a {n_envs}-env vector run")
            episode = int(ckpt["episode"])
        else:
            episode = int(ckpt["episode"]) + (0 if ckpt["at_episode_boundary"] else 1)
    else:
        random.seed(cfg.seed)
        torch.manual_seed(cfg.seed)

    if resumed_here:
        _truncate_episode_log(csv_path, episode)
    elif csv_path.exists():
        csv_path.unlink()
    writer = SummaryWriter(str(run_dir), purge_step=global_step if resumed_here else None)
    if not resumed_here:
        writer.add_text("config", str(cfg.to_dict()))
    evaluation = _PeriodicEvaluation(eval_env_fn, cfg, run_dir, writer, agent, global_step, ckpt,
                                     resumed_here, metadata)

    if vector_state is not None:
        env.reset(seed=episode_seed(cfg.seed, episode))  # builds the simulator; then overwritten
        env.set_state(_to_numpy(vector_state["env_state"]))
        obs = _to_numpy(vector_state["obs"])
        ep_return = _to_numpy(vector_state["ep_return"])
        ep_len = _to_numpy(vector_state["ep_len"])
    else:
        obs, _ = env.reset(seed=episode_seed(cfg.seed, episode))
        obs = np.asarray(obs, dtype=np.float32).reshape(n_envs, agent.obs_dim)
        ep_return = np.zeros(n_envs, dtype=np.float64)
        ep_len = np.zeros(n_envs, dtype=np.int64)

    def checkpoint() -> None:
        env_state = env.get_state() if hasattr(env, "get_state") else None
        save_checkpoint(ckpt_path, {
            "format": CHECKPOINT_FORMAT,
            "config": cfg.to_dict(),
            "obs_dim": agent.obs_dim,
            "act_dim": agent.act_dim,
            "action_low": torch.from_numpy(agent.action_low.copy()),
            "action_high": torch.from_numpy(agent.action_high.copy()),
            "agent": agent.state_dict(),
            "buffer": buffer.state_dict(),
            "global_step": global_step,
            "episode": episode,  # index the next episode to end will get
            "at_episode_boundary": False,  # for train(): the sub-envs are mid-episode
            "python_rng": random.getstate(),
            "torch_cpu_rng": torch.get_rng_state(),
            "wall_time_s": elapsed_before + time.time() - t_start,
            "metadata": metadata if metadata is not None else {},
            "evaluation": evaluation.state_dict(),
            "vector": None if env_state is None else {
                "num_envs": n_envs,
                "env_state": _to_tensors(env_state),
                "obs": torch.from_numpy(obs.copy()),
                "ep_return": torch.from_numpy(ep_return.copy()),
                "ep_len": torch.from_numpy(ep_len.copy()),
            },
        })

    prev_deterministic = torch.are_deterministic_algorithms_enabled()
    if cfg.torch_deterministic:
        torch.use_deterministic_algorithms(True)
    t_start = time.time()
    start_step = global_step
    next_checkpoint = (global_step // cfg.checkpoint_every + 1) * cfg.checkpoint_every
    bar = tqdm(total=total, initial=min(global_step, total), disable=not progress,
               position=progress_position, desc=progress_desc, dynamic_ncols=True, leave=True)
    csv_file = open(csv_path, "a", newline="")
    try:
        csv_writer = csv.DictWriter(csv_file, fieldnames=EPISODE_FIELDS)
        if csv_path.stat().st_size == 0:
            csv_writer.writeheader()
        sps_t, sps_step = time.time(), global_step
        while global_step < steps:
            # 1. act: transition global_step + i is random during warm-up, then mu(s) + noise
            actions = np.empty((n_envs, agent.act_dim), dtype=np.float32)
            n_random = int(np.clip(cfg.learning_starts - global_step, 0, n_envs))
            for i in range(n_random):
                actions[i] = agent.random_action()
            if n_random < n_envs:
                actions[n_random:] = agent.select_actions(obs[n_random:], explore=True)
            next_obs, rewards, terminated, truncated, infos = env.step(agent.scale_action(actions))
            next_obs = np.asarray(next_obs, dtype=np.float32).reshape(n_envs, agent.obs_dim)
            terminated = np.asarray(terminated, dtype=bool)
            truncated = np.asarray(truncated, dtype=bool)
            # 2. store: the real s' of an ended sub-env is infos["final_obs"][i] (SAME_STEP)
            real_next = next_obs.copy()
            ended = np.flatnonzero(terminated | truncated)
            if ended.size:
                final_obs = infos["final_obs"]
                for i in ended:
                    real_next[i] = np.asarray(final_obs[i], dtype=np.float32).reshape(-1)
            for i in range(n_envs):
                buffer.add(obs[i], actions[i], float(rewards[i]), real_next[i], bool(terminated[i]))
            ep_return += np.asarray(rewards, dtype=np.float64)
            ep_len += 1
            before = global_step
            global_step += n_envs
            bar.update(n_envs)

            # 3. learn: updates_per_step updates per transition past the warm-up
            n_learn = max(0, global_step - max(before, cfg.learning_starts))
            if n_learn and len(buffer) >= cfg.batch_size:
                for _ in range(n_learn * cfg.updates_per_step):
                    info = agent.update(buffer.sample(cfg.batch_size, agent.rng))
                    if agent.num_updates % cfg.log_every == 0:
                        for k, v in info.items():
                            writer.add_scalar(f"losses/{k}", v, global_step)

            # 4. episode ends (the sub-envs are already reset): log in sub-env order
            for i in ended:
                row = {
                    "episode": episode,
                    "global_step": global_step,
                    "return": float(ep_return[i]),
                    "length": int(ep_len[i]),
                    "terminated": int(terminated[i]),
                    "truncated": int(truncated[i]),
                    "wall_time_s": round(elapsed_before + time.time() - t_start, 3),
                }
                csv_writer.writerow(row)
                writer.add_scalar("charts/episodic_return", row["return"], global_step)
                writer.add_scalar("charts/episodic_length", row["length"], global_step)
                bar.set_postfix(ep=episode, ret=f"{row['return']:.3g}", refresh=False)
                if log_fn is not None:
                    log_fn(row)
                episode += 1
                ep_return[i], ep_len[i] = 0.0, 0
            if ended.size:
                csv_file.flush()
                now = time.time()
                writer.add_scalar("charts/sps", (global_step - sps_step) / max(now - sps_t, 1e-9),
                                  global_step)
                sps_t, sps_step = now, global_step
            obs = next_obs
            if evaluation.due(global_step):
                evaluation.run(agent, global_step, elapsed_before + time.time() - t_start, metadata)
            if global_step >= next_checkpoint and global_step < steps:
                writer.flush()
                checkpoint()
                next_checkpoint = (global_step // cfg.checkpoint_every + 1) * cfg.checkpoint_every
        if global_step != start_step or not resumed_here:
            if evaluation.enabled and evaluation.last_step != global_step:
                evaluation.run(agent, global_step, elapsed_before + time.time() - t_start, metadata)
            checkpoint()
    finally:
        csv_file.close()
        bar.close()
        writer.close()
        env.close()
        torch.use_deterministic_algorithms(prev_deterministic)
    return agent


# ----------------------------------------------------------------------------------------------
# Evaluation
# ----------------------------------------------------------------------------------------------
@dataclass
class EvalResult:
    """Returns and lengths of evaluation episodes (``mean_return``, ``std_return`` as SB3's
    ``evaluate_policy``)."""

    returns: list[float]
    lengths: list[int]

    @property
    def mean_return(self) -> float:
        return float(np.mean(self.returns))

    @property
    def std_return(self) -> float:
        return float(np.std(self.returns))


def evaluate(
    agent: TD3Agent, env_fn: Callable[[], gym.Env], episodes: int = 10, seed: int = 0
) -> EvalResult:
    """Run ``episodes`` full episodes with deterministic actions ``mu(s)`` (no noise); episode ``i``
    is reset with ``seed + i``. Returns are undiscounted sums of rewards."""
    env = env_fn()
    returns, lengths = [], []
    try:
        for i in range(episodes):
            obs, _ = env.reset(seed=seed + i)
            done, ep_return, ep_len = False, 0.0, 0
            while not done:
                obs, reward, terminated, truncated, _ = env.step(agent.act(_flat_obs(obs)))
                ep_return += float(reward)
                ep_len += 1
                done = terminated or truncated
            returns.append(ep_return)
            lengths.append(ep_len)
    finally:
        env.close()
    return EvalResult(returns, lengths)
