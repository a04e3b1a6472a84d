"""The replay buffer of TD3: a fixed-capacity ring of transitions (float32 numpy arrays), sampled
uniformly into a :class:`Batch` for each seed of :meth:`elastica_magnetic_rl.td3.algorithm.TD3.update`; its
state goes into a checkpoint (:mod:`elastica_magnetic_rl.runfiles.checkpoint`) so that a resumed run samples
exactly as the uninterrupted one would."""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
import torch


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

    A ``labelled`` buffer also stores, per transition, a teacher's action at ``obs`` (``labels``,
    normalised as the actions): what :meth:`sample_labels` draws for DAgger
    (:attr:`~elastica_magnetic_rl.td3.config.TD3Config.yardstick_dagger`).
    """

    def __init__(self, capacity: int, obs_dim: int, act_dim: int, labelled: bool = False) -> None:
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
        self.labels = np.zeros((self.capacity, self.act_dim), dtype=np.float32) if labelled else None
        self.ptr = 0  # next slot to write
        self.size = 0  # number of valid transitions
        self.total_added = 0  # transitions ever added (> size once the ring has wrapped)

    def __len__(self) -> int:
        return self.size

    def add(
        self,
        obs: np.ndarray,
        action: np.ndarray,
        reward: float,
        next_obs: np.ndarray,
        terminated: bool,
        label: np.ndarray | None = None,
    ) -> None:
        """Store one transition, overwriting the oldest when full (a labelled buffer needs its
        ``label``, ``(act_dim,)``)."""
        i = self.ptr
        if self.labels is not None:
            if label is None:
                raise ValueError("a labelled replay buffer needs each transition's label")
            self.labels[i] = label
        self.obs[i] = obs
        self.actions[i] = action
        self.rewards[i] = reward
        self.next_obs[i] = next_obs
        self.terminated[i] = float(terminated)
        self.ptr = (self.ptr + 1) % self.capacity
        self.size = min(self.size + 1, self.capacity)
        self.total_added += 1

    def sample(self, batch_size: int, rng: np.random.Generator) -> Batch:
        """Uniformly sample ``batch_size`` transitions (with replacement) using ``rng``."""
        if self.size == 0:
            raise ValueError("cannot sample from an empty replay buffer")
        idx = rng.integers(0, self.size, size=batch_size)
        return Batch(
            self.obs[idx], self.actions[idx], self.rewards[idx], self.next_obs[idx],
            self.terminated[idx],
        )

    def sample_first(self, n: int, batch_size: int, rng: np.random.Generator) -> Batch:
        """Uniformly sample ``batch_size`` of the first ``n`` transitions ever added (a warm-up's),
        with replacement; ``ValueError`` once the ring has overwritten them."""
        if self.total_added > self.capacity:
            raise ValueError(f"the first {n} transitions were overwritten: the buffer holds "
                             f"{self.capacity} and {self.total_added} were added")
        idx = rng.integers(0, min(n, self.size), size=batch_size)
        return Batch(
            self.obs[idx], self.actions[idx], self.rewards[idx], self.next_obs[idx],
            self.terminated[idx],
        )

    def sample_labels(self, batch_size: int, rng: np.random.Generator) -> Batch:
        """Uniformly sample ``batch_size`` transitions (with replacement) of a labelled buffer as a
        :class:`Batch` whose ``actions`` are the labels (the teacher's, for a clone step)."""
        if self.labels is None:
            raise ValueError("the replay buffer holds no labels (labelled=False)")
        if self.size == 0:
            raise ValueError("cannot sample from an empty replay buffer")
        idx = rng.integers(0, self.size, size=batch_size)
        return Batch(self.obs[idx], self.labels[idx], self.rewards[idx], self.next_obs[idx],
                     self.terminated[idx])

    def _keys(self) -> tuple[str, ...]:
        """The arrays a checkpoint holds."""
        keys = ("obs", "actions", "rewards", "next_obs", "terminated")
        return keys if self.labels is None else (*keys, "labels")

    def _chronological(self) -> dict[str, np.ndarray]:
        """Valid contents, oldest first."""
        start = self.ptr if self.size == self.capacity else 0
        order = (start + np.arange(self.size)) % self.capacity
        return {k: getattr(self, k)[order] for k in self._keys()}

    def state_dict(self) -> dict[str, Any]:
        """Contents as torch tensors (only the ``size`` valid rows) plus pointer and size."""
        keys = self._keys()
        return {
            "capacity": self.capacity,
            "obs_dim": self.obs_dim,
            "act_dim": self.act_dim,
            "ptr": self.ptr,
            "size": self.size,
            "total_added": self.total_added,
            **{k: torch.from_numpy(getattr(self, k)[: self.size].copy()) for k in keys},
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Restore contents. With the same capacity the layout (and thus sampling) is exact; into a
        different capacity the transitions are copied oldest first (keeping the newest if smaller).
        """
        if state["obs_dim"] != self.obs_dim or state["act_dim"] != self.act_dim:
            raise ValueError("replay buffer dimensions do not match the checkpoint")
        if self.labels is not None and "labels" not in state:
            raise ValueError("the checkpoint's replay buffer holds no labels: it was not written by a "
                             "run with yardstick_dagger or clone_labels 'commanded'")
        keys = self._keys()
        data = {k: state[k].numpy() for k in keys}
        size = int(state["size"])
        if state["capacity"] == self.capacity:
            for k in keys:
                getattr(self, k)[:size] = data[k]
            self.ptr, self.size = int(state["ptr"]), size
            self.total_added = int(state.get("total_added", size))
            return
        # different capacity: unroll into chronological order first
        start = int(state["ptr"]) if size == state["capacity"] else 0
        order = (start + np.arange(size)) % max(size, 1)
        n = min(size, self.capacity)
        order = order[size - n:]
        for k in keys:
            getattr(self, k)[:n] = data[k][order]
        self.size = self.total_added = n
        self.ptr = n % self.capacity
