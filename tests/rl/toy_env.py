"""A tiny Gymnasium task and helpers for the tests of the algorithm and the training loop:
:class:`ToyEnv`, :func:`toy_config`, :class:`Killed` (a run killed from ``log_fn``) and
:func:`sync_vector_env`."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
from elastica_magnetic_rl.td3.config import TD3Config


class ToyEnv(gym.Env):
    """Tiny 1-D reaching task: obs (position, target, t/T); two action dims with asymmetric
    bounds; terminates at random (through ``self.np_random``) and is truncated after T steps."""

    metadata = {"render_modes": []}

    def __init__(self, max_steps: int = 20, p_terminate: float = 0.06) -> None:
        self.max_steps, self.p_terminate = max_steps, p_terminate
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (3,), np.float32)
        self.action_space = gym.spaces.Box(
            np.array([-1.0, 0.0], np.float32), np.array([1.0, 2.0], np.float32)
        )

    def _obs(self) -> np.ndarray:
        return np.array([self.pos, self.target, self.t / self.max_steps], np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.pos = float(self.np_random.uniform(-0.5, 0.5))
        self.target = float(self.np_random.uniform(-1.0, 1.0))
        self.t = 0
        return self._obs(), {}

    def step(self, action):
        action = np.asarray(action, dtype=np.float64)
        self.pos += 0.1 * action[0]
        self.t += 1
        reward = -((self.pos - self.target) ** 2) - 0.01 * (action[1] - 1.0) ** 2
        terminated = self.t < self.max_steps and bool(self.np_random.random() < self.p_terminate)
        truncated = self.t >= self.max_steps and not terminated
        return self._obs(), float(reward), terminated, truncated, {}


def toy_config(**kw) -> TD3Config:
    base = dict(hidden_sizes=(16, 16), batch_size=16, learning_starts=30, checkpoint_every=40,
                log_every=10)
    base.update(kw)
    return TD3Config(**base)


# ----------------------------------------------------------------------------------------------
# (3) resume determinism
# ----------------------------------------------------------------------------------------------
class Killed(Exception):
    pass


def sync_vector_env(env_fn, n):
    from gymnasium.vector import AutoresetMode, SyncVectorEnv

    return SyncVectorEnv([env_fn] * n, autoreset_mode=AutoresetMode.SAME_STEP)
