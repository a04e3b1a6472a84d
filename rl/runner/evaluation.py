"""Evaluation of policies during and after training: deterministic episodes, one environment or
many policies at once in one vector environment, and the periodic evaluation of a training run
(as Stable-Baselines3's ``EvalCallback``: ``evaluations.csv``, TensorBoard ``eval/``, ``best.pt``)."""

from __future__ import annotations

import csv
import math
import os
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch

from ..runfiles.checkpoint import save_checkpoint
from ..runfiles.logs import read_log, unfinished_line
from ..runfiles.rundir import RunDir
from ..td3.algorithm import TD3
from ..td3.config import TD3Config
from ..td3.networks import actor_from_state

__all__ = ["ActorPolicy", "EvalResult", "PeriodicEvaluation", "evaluate", "evaluate_many"]

EVALUATION_FIELDS = ("global_step", "mean_return", "std_return", "mean_length", "best_mean_return",
                     "wall_time_s")
#: Evaluation episode ``i`` is reset with seed ``EVAL_SEED + i``: the same episodes at every
#: evaluation and for every seed of a sweep, so their returns compare.
EVAL_SEED = 1_000_000


def flat_observation(obs: Any) -> np.ndarray:
    """An observation as a flat float32 array (what the networks take)."""
    return np.asarray(obs, dtype=np.float32).reshape(-1)


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


def evaluate(agent: Any, env_fn: Callable[[], gym.Env], episodes: int = 10, seed: int = 0) -> EvalResult:
    """Run ``episodes`` full episodes with deterministic actions ``agent.act(obs)`` (no noise);
    episode ``i`` is reset with ``seed + i``. Returns are undiscounted sums of rewards."""
    env = env_fn()
    returns, lengths = [], []
    try:
        for i in range(episodes):
            obs, _ = env.reset(seed=seed + i)
            done, ep_return, ep_len = False, 0.0, 0
            while not done:
                obs, reward, terminated, truncated, _ = env.step(agent.act(flat_observation(obs)))
                ep_return += float(reward)
                ep_len += 1
                done = terminated or truncated
            returns.append(ep_return)
            lengths.append(ep_len)
    finally:
        env.close()
    return EvalResult(returns, lengths)


def evaluate_many(policies: Sequence[Any], vec_env_fn: Callable[[int], gym.vector.VectorEnv],
                  episodes: int = 1, seed: int = 0) -> list[EvalResult]:
    """:func:`evaluate` of several policies at once, policy ``i`` on sub-environment ``i`` of
    ``vec_env_fn(len(policies))`` (``SAME_STEP`` autoreset): episode ``e`` of every policy starts
    from ``seed + e``, as :func:`evaluate` starts it, so each result equals that policy's
    :func:`evaluate` in a single environment whose sub-environment counterpart behaves alike
    (the crawler's vector environment does, bit for bit); the simulation is shared."""
    env = vec_env_fn(len(policies))
    returns = [[] for _ in policies]
    lengths = [[] for _ in policies]
    try:
        act_dim = int(np.prod(env.single_action_space.shape))
        for e in range(episodes):
            obs, _ = env.reset(seed=[seed + e] * len(policies))
            running = np.ones(len(policies), dtype=bool)
            ep_return = np.zeros(len(policies))
            ep_len = np.zeros(len(policies), dtype=np.int64)
            while running.any():
                actions = np.zeros((len(policies), act_dim), dtype=np.float32)
                for i in np.flatnonzero(running):
                    actions[i] = policies[i].act(flat_observation(obs[i]))
                obs, rewards, terminated, truncated, _ = env.step(actions)
                for i in np.flatnonzero(running):
                    ep_return[i] += float(rewards[i])
                    ep_len[i] += 1
                    if terminated[i] or truncated[i]:
                        running[i] = False
                        returns[i].append(float(ep_return[i]))
                        lengths[i].append(int(ep_len[i]))
    finally:
        env.close()
    return [EvalResult(r, n) for r, n in zip(returns, lengths, strict=True)]


class ActorPolicy:
    """A deterministic policy from an actor's state dict (plain
    :class:`~elastica_magnetic_rl.td3.networks.Actor`, float32): what evaluation runs, so a ``best.pt``
    replays its recorded evaluation exactly."""

    def __init__(self, actor_state: dict[str, torch.Tensor], obs_dim: int, act_dim: int,
                 hidden_sizes: tuple[int, ...], action_low: np.ndarray,
                 action_high: np.ndarray) -> None:
        self.actor = actor_from_state(obs_dim, act_dim, tuple(hidden_sizes), actor_state)
        self.actor.load_state_dict(actor_state)
        self.actor.eval().requires_grad_(False)
        low, high = np.asarray(action_low, np.float64), np.asarray(action_high, np.float64)
        self.center, self.half_range = (high + low) / 2.0, (high - low) / 2.0

    @classmethod
    def of_seed(cls, learner: TD3, k: int) -> ActorPolicy:
        return cls(learner.actor_state(k), learner.obs_dim, learner.act_dim,
                   learner.config.actor_widths, learner.action_low, learner.action_high)

    @torch.no_grad()
    def act(self, obs: np.ndarray) -> np.ndarray:
        """Action in environment units, ``(act_dim,)`` float32."""
        obs_t = torch.as_tensor(np.asarray(obs, dtype=np.float32).reshape(1, -1))
        action = self.actor(obs_t)[0].numpy().astype(np.float64)
        return (self.center + self.half_range * action).astype(np.float32)


class PeriodicEvaluation:
    """Evaluation during training (``config.eval_every``, as Stable-Baselines3's ``EvalCallback``):
    :func:`evaluate` runs the deterministic policy in its own environment, a row goes to
    ``evaluations.csv`` and TensorBoard (``eval/``), and the networks of the best evaluation so far
    go to ``best.pt``. Its state (the best networks included) is part of the checkpoints."""

    def __init__(self, env_fn: Callable[[], gym.Env] | None, cfg: TD3Config, run_dir: Path,
                 writer: Any, global_step: int, ckpt: dict[str, Any] | None,
                 resumed_here: bool) -> None:
        self.env_fn, self.cfg, self.writer = env_fn, cfg, writer
        self.enabled = env_fn is not None and cfg.eval_every > 0
        self.csv_path = RunDir(run_dir).evaluations_csv
        self.best_path = RunDir(run_dir).best
        state = ckpt.get("evaluation") if (resumed_here and ckpt is not None) else None
        self.best_return = float(state["best_mean_return"]) if state else -math.inf
        self.best_step = int(state["best_step"]) if state else -1
        self.best_networks = state["best_networks"] if state else None
        self.last_step = int(state["last_step"]) if state else -1
        self.last_return: float | None = None  # mean return of the latest evaluation in this process
        self.next_step = self._next(global_step)
        self.restore_best = self.best_networks is not None and resumed_here
        self.returns: list[float] = []  # every evaluation's mean return, in order
        if resumed_here:
            truncate_csv(self.csv_path, EVALUATION_FIELDS,
                          lambda row: int(row["global_step"]) <= global_step)
            if self.csv_path.exists():
                with open(self.csv_path, newline="") as f:
                    self.returns = [float(r["mean_return"]) for r in csv.DictReader(f)]
        else:  # leftovers of an earlier run in this folder that left no checkpoint
            self.csv_path.unlink(missing_ok=True)
        if not self.restore_best:
            self.best_path.unlink(missing_ok=True)

    @property
    def warmup_end(self) -> int:
        """The step before which no periodic evaluation falls: a warm-up the yardstick plays leaves
        the actor untrained until its clone, evaluated at the warm-up's end (an untrained actor must
        not be best.pt); 0 without such a warm-up."""
        return self.cfg.learning_starts if self.cfg.yardstick_warmup else 0

    def _next(self, global_step: int) -> int:
        every = max(self.cfg.eval_every, 1)
        return (max(global_step, self.warmup_end) // every + 1) * every

    def due(self, global_step: int) -> bool:
        return self.enabled and global_step >= self.next_step

    def run(self, learner: TD3, k: int, global_step: int, wall_time_s: float,
            header: dict[str, Any]) -> EvalResult:
        result = evaluate(ActorPolicy.of_seed(learner, k), self.env_fn, self.cfg.eval_episodes,
                          seed=EVAL_SEED)
        return self.record(result, learner, k, global_step, wall_time_s, header)

    def record(self, result: EvalResult, learner: TD3, k: int, global_step: int,
               wall_time_s: float, header: dict[str, Any]) -> EvalResult:
        """Log an evaluation of seed ``k``'s current policy; keep its networks if the best."""
        if result.mean_return > self.best_return:
            self.best_return, self.best_step = result.mean_return, global_step
            self.best_networks = {"actor": learner.actor_state(k), "critic": learner.critic_state(k)}
            self.write_best(header)
        self.returns.append(float(result.mean_return))
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
        self.last_return = result.mean_return
        self.next_step = self._next(global_step)
        return result

    def write_best(self, header: dict[str, Any]) -> None:
        """``best.pt``: only the best networks (it cannot be resumed or refined), with the step and
        return of their evaluation."""
        save_checkpoint(self.best_path, {
            **header, "kind": "best", "agent": self.best_networks, "global_step": self.best_step,
            "evaluation": {"mean_return": self.best_return, "episodes": self.cfg.eval_episodes,
                           "seed": EVAL_SEED},
        })

    def state_dict(self) -> dict[str, Any]:
        return {"best_mean_return": self.best_return, "best_step": self.best_step,
                "best_networks": self.best_networks, "last_step": self.last_step}


def truncate_csv(path: Path, fields: tuple[str, ...], keep: Callable[[dict[str, str]], bool]) -> None:
    """Keep only the rows of a log for which ``keep(row)`` (those written before the checkpoint
    a run resumes from), rewritten whole with its header. A row or header that a kill cut short
    (the text after the last line end; an empty log) is dropped with a note on stderr: the log
    then ends at its last whole row, which is at or before the checkpoint's step."""
    if not path.exists():
        return
    cut, empty = unfinished_line(path), path.stat().st_size == 0
    rows = [r for r in read_log(path, ("global_step",), whole_rows_only=True) if keep(r)]
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)
    os.replace(tmp, path)
    if cut or empty:  # what a kill while the log was written leaves
        what = f"dropped its unfinished last line {cut!r}" if cut else "it was empty"
        print(f"note: {path}: {what} (a kill while it was written); repaired: its header and "
              f"{len(rows)} whole row(s) up to the checkpoint", file=sys.stderr)
