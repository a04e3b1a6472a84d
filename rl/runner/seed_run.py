"""One seed's bookkeeping in the training loop (:mod:`elastica_magnetic_rl.runner.loop`): where a run starts
(fresh, resumed, or from another run's checkpoint), its replay buffer and counters, exploration
noise, ``episodes.csv``, TensorBoard scalars, periodic evaluation with ``best.pt``, progress bar
and checkpoints in its run directory. Its networks live in the shared
:class:`~elastica_magnetic_rl.td3.algorithm.TD3` (member ``k``); the loop drives it.
"""

from __future__ import annotations

import csv
import dataclasses
import os
import random
import time
import warnings
from collections.abc import Callable
from fractions import Fraction
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch

from ..runfiles.checkpoint import (
    CHECKPOINT_FORMAT,
    ReplayFile,
    load_checkpoint,
    refuse_networks_only,
    save_checkpoint,
)
from ..runfiles.rundir import RunDir
from ..td3.algorithm import TD3, episode_seed
from ..td3.config import KEPT_ON_RESUME, Schedule, TD3Config
from ..td3.exploration import colored_noise
from ..td3.replay_buffer import ReplayBuffer
from .evaluation import PeriodicEvaluation, truncate_csv
from .stopping import StopRule

__all__ = ["EPISODE_FIELDS", "RESUMABLE_SETTINGS", "SeedRun", "starting_point"]

EPISODE_FIELDS = ("episode", "global_step", "return", "length", "terminated", "truncated",
                  "wall_time_s")
#: Fields of :class:`~elastica_magnetic_rl.td3.config.TD3Config` that a resumed run takes from the config
#: passed: its :class:`~elastica_magnetic_rl.td3.config.Schedule` (they change no weight: when to
#: checkpoint, log and evaluate; but its evaluations' length); every other field comes from the checkpoint.
RESUMABLE_SETTINGS = tuple(f.name for f in dataclasses.fields(Schedule) if f.name not in KEPT_ON_RESUME)


# ----------------------------------------------------------------------------------------------
# One seed's bookkeeping
# ----------------------------------------------------------------------------------------------
def starting_point(
    ckpt_path: Path,
    resume: bool,
    init_from: str | os.PathLike | None,
    config: TD3Config | None,
    metadata: dict[str, Any] | None,
) -> tuple[dict[str, Any] | None, bool, TD3Config, dict[str, Any] | None]:
    """Where a run starts: ``(checkpoint or None, resumed from this run_dir, config, metadata)``.

    An existing checkpoint in the run directory is refused unless ``resume``; ``resume`` without
    one is refused too (nothing of the folder is touched). Without a checkpoint, ``init_from``
    (another run's checkpoint) may seed the run. When resuming (or when no config is passed) the
    checkpoint's config is used, except for the :data:`RESUMABLE_SETTINGS` of a config passed; a
    resumed run keeps its metadata unless given new.
    """
    ckpt: dict[str, Any] | None = None
    if ckpt_path.exists():
        if not resume:
            raise FileExistsError(f"{ckpt_path} exists: pass resume=True or use a new run_dir")
        ckpt = load_checkpoint(ckpt_path)
        refuse_networks_only(ckpt, ckpt_path)
    elif resume:
        raise FileNotFoundError(f"cannot resume: {ckpt_path} does not exist (start a new run "
                                f"without resuming, or choose the folder that holds it)")
    resumed_here = ckpt is not None
    if ckpt is None and init_from is not None:
        ckpt = load_checkpoint(init_from)
        refuse_networks_only(ckpt, init_from)
    if ckpt is not None:
        ckpt_cfg = TD3Config.from_dict(ckpt["config"])
        if resumed_here or config is None:
            if config is not None:
                # run settings that change no weight may change on resume; the rest is the run's
                passed = {k: getattr(config, k) for k in RESUMABLE_SETTINGS}
                differing = [f"{f.name} (the run's {getattr(ckpt_cfg, f.name)!r}, passed "
                             f"{getattr(config, f.name)!r})" for f in dataclasses.fields(config)
                             if f.name not in RESUMABLE_SETTINGS
                             and getattr(config, f.name) != getattr(ckpt_cfg, f.name)]
                if differing:
                    warnings.warn("resuming: using the checkpoint's hyperparameters, not the ones "
                                  f"passed: {'; '.join(differing)}", stacklevel=3)
                ckpt_cfg = dataclasses.replace(ckpt_cfg, **passed)
            config = ckpt_cfg
    cfg = config if config is not None else TD3Config()
    if metadata is None and resumed_here:
        metadata = ckpt.get("metadata")
    return ckpt, resumed_here, cfg, metadata


class SeedRun:
    """The bookkeeping of one seed: replay buffer, counters, ``episodes.csv``, TensorBoard writer,
    evaluation, progress bar and checkpoints in ``run_dir``. Its networks live in the shared
    :class:`~elastica_magnetic_rl.td3.algorithm.TD3` (member ``k``)."""

    def __init__(self, k: int, config: TD3Config | None, steps: int, run_dir: str | os.PathLike,
                 resume: bool, init_from: str | os.PathLike | None, metadata: dict[str, Any] | None,
                 dims: tuple[int, int], n_envs: int,
                 stop_rule: StopRule | None | str = "checkpoint") -> None:
        self.k, self.steps, self.n_envs = k, int(steps), n_envs
        obs_dim, act_dim = dims
        self.run_dir = Path(run_dir)
        self.ckpt_path = RunDir(self.run_dir).checkpoint
        self.ckpt, self.resumed_here, self.cfg, self.metadata = starting_point(
            self.ckpt_path, resume, init_from, config, metadata)
        ckpt = self.ckpt
        # the buffer holds every transition of the run (rounded up to whole vector steps)
        total = -(-self.steps // n_envs) * n_envs
        self.buffer = ReplayBuffer(min(self.cfg.buffer_size, total), obs_dim, act_dim,
                                   labelled=self.cfg.labelled)
        self.global_step, self.episode, self.elapsed_before = 0, 0, 0.0
        self.replay = ReplayFile(self.run_dir)
        if ckpt is not None:
            if (ckpt["obs_dim"], ckpt["act_dim"]) != (obs_dim, act_dim):
                raise ValueError(f"{self.ckpt_path}: the checkpoint's spaces (obs {ckpt['obs_dim']}, "
                                 f"action {ckpt['act_dim']}) do not match the environment's "
                                 f"({obs_dim}, {act_dim})")
            self.buffer.load_state_dict(ckpt["buffer"])
            self.global_step = int(ckpt["global_step"])
            # the number the next episode gets (episodes cut by a checkpoint without the
            # environments' state are abandoned: their transitions stay in the buffer)
            self.episode = int(ckpt["episode"])
            if self.resumed_here:
                self.elapsed_before = float(ckpt["wall_time_s"])
                if "rows" in ckpt["buffer"]:
                    self.replay.rows = int(ckpt["buffer"]["rows"])
        self.start_step = self.global_step
        # the unspent fraction of an update (fractional updates_per_step), exact
        self.update_credit = Fraction(str(ckpt.get("update_credit", "0"))) if ckpt is not None \
            else Fraction(0)
        self.stop_rule, self.stopped = _stop_setting(self.ckpt if self.resumed_here else None,
                                                     stop_rule, self.ckpt_path)
        self.final_state: dict[str, Any] | None = None  # its networks' state when it stopped
        self.ep_return = np.zeros(n_envs, dtype=np.float64)
        self.ep_len = np.zeros(n_envs, dtype=np.int64)
        self.ep_id = np.zeros(n_envs, dtype=np.int64)  # episode number of each sub-env's episode
        self.timing: dict[str, float] = {}  # the group's, shared (set by the loop)
        # colored exploration noise (noise_color > 0): one sequence per sub-env and its position
        self.noise = np.zeros((n_envs, self.cfg.noise_horizon, act_dim))
        self.noise_pos = np.zeros(n_envs, dtype=np.int64)
        # the logs, opened by :meth:`open` once every seed of the group has been checked
        self.writer: Any = None
        self.bar: Any = None
        self.csv_file: Any = None

    def draw_noise(self, j: int, rng: np.random.Generator) -> None:
        """A new colored-noise sequence for sub-environment ``j`` (from the seed's generator)."""
        if self.cfg.noise_color > 0:
            self.noise[j] = colored_noise(self.cfg.noise_color, self.cfg.noise_horizon,
                                          self.noise.shape[2], rng)
            self.noise_pos[j] = 0

    def exploration(self, first: int, rng: np.random.Generator) -> np.ndarray:
        """The exploration noise of sub-envs ``first..N-1`` this step, ``(N - first, act_dim)``:
        white (drawn now) or the next samples of their colored sequences; every sequence moves
        on one step (a used-up one is replaced)."""
        sigma, n = self.cfg.exploration_noise, self.n_envs
        if self.cfg.noise_color == 0:
            return rng.normal(0.0, sigma, size=(n - first, self.noise.shape[2]))
        noise = sigma * self.noise[np.arange(first, n), self.noise_pos[first:]]
        self.noise_pos += 1
        for j in np.flatnonzero(self.noise_pos >= self.cfg.noise_horizon):
            self.draw_noise(int(j), rng)
        return noise

    def open(self, progress: bool, position: int | None, desc: str | None,
             eval_env_fn: Callable[[], gym.Env] | None) -> None:
        """Open the logs (after every seed of the group has been checked): the episode log is cut
        back to the checkpoint, or started anew."""
        from torch.utils.tensorboard import SummaryWriter

        from elastica_magnetic.progress import progress_bar

        self.run_dir.mkdir(parents=True, exist_ok=True)
        csv_path = RunDir(self.run_dir).episodes_csv
        if self.resumed_here:
            truncate_csv(csv_path, EPISODE_FIELDS,
                          lambda row: int(row["global_step"]) <= self.global_step)
            self.replay.truncate(self.buffer.obs_dim, self.buffer.act_dim, self.buffer.labels is not None)
        else:  # the stale logs of a start stopped before its first checkpoint: TensorBoard would
            # plot its curves with this run's as one seed
            csv_path.unlink(missing_ok=True)
            for stale in self.run_dir.glob("events.out.tfevents.*"):
                stale.unlink()
        self.writer = SummaryWriter(str(self.run_dir),
                                    purge_step=self.global_step if self.resumed_here else None)
        if not self.resumed_here:
            self.writer.add_text("config", str(self.cfg.to_dict()))
        self.evaluation = PeriodicEvaluation(eval_env_fn, self.cfg, self.run_dir, self.writer,
                                              self.global_step, self.ckpt, self.resumed_here)
        self.next_checkpoint = self._next_checkpoint()
        # a refinement counts its own steps, not its parent run's (metadata's refine_start_step)
        base = int((self.metadata or {}).get("refine_start_step", 0))
        self.bar = progress_bar(self.steps - base, desc or "", "step",
                                initial=min(self.global_step, self.steps) - base,
                                disable=not progress,
                                position=position, dynamic_ncols=True, leave=True)
        self.csv_file = open(csv_path, "a", newline="")
        self.csv_writer = csv.DictWriter(self.csv_file, fieldnames=EPISODE_FIELDS)
        if csv_path.stat().st_size == 0:
            self.csv_writer.writeheader()
        self.t_start = time.time()

    def postfix(self, row: dict[str, Any]) -> dict[str, str]:
        """The progress line's fields: the last episode's training return, and, once evaluated,
        the latest evaluation's mean return (deterministic, field from zero, in the run's physics)
        and the best so far (``best.pt``'s)."""
        out = {"ep": str(row["episode"]), "train ret": f"{row['return']:.3g}"}
        ev = self.evaluation
        if ev is not None and ev.last_return is not None:
            physics = (self.metadata or {}).get("physics", "training")
            out[f"eval ({physics})"] = f"{ev.last_return:.3g}"
            out["best"] = f"{ev.best_return:.3g} @{ev.best_step}"
        return out

    def _next_checkpoint(self) -> int:
        every = self.cfg.checkpoint_every
        return (self.global_step // every + 1) * every

    @property
    def done(self) -> bool:
        return self.global_step >= self.steps

    @property
    def wall_time_s(self) -> float:
        """Wall-clock time of the run so far, earlier sessions included, s."""
        return self.elapsed_before + time.time() - self.t_start

    def next_episode_seeds(self, n: int) -> list[int]:
        """Number the next ``n`` episodes and return their reset seeds."""
        first = self.episode
        self.episode += n
        return [episode_seed(self.cfg.seed, e) for e in range(first, first + n)]

    def log_episode(self, i: int, terminated: bool, truncated: bool,
                    log_fn: Callable[[dict[str, Any]], None] | None) -> None:
        row = {"episode": int(self.ep_id[i]), "global_step": self.global_step,
               "return": float(self.ep_return[i]), "length": int(self.ep_len[i]),
               "terminated": int(terminated), "truncated": int(truncated),
               "wall_time_s": round(self.wall_time_s, 3)}
        self.csv_writer.writerow(row)
        self.writer.add_scalar("charts/episodic_return", row["return"], self.global_step)
        self.writer.add_scalar("charts/episodic_length", row["length"], self.global_step)
        self.bar.set_postfix(self.postfix(row), refresh=False)
        if log_fn is not None:
            log_fn(row)
        self.ep_return[i], self.ep_len[i] = 0.0, 0

    def header(self, learner: TD3) -> dict[str, Any]:
        """The keys every checkpoint of this seed starts with."""
        return {"format": CHECKPOINT_FORMAT, "config": self.cfg.to_dict(),
                "obs_dim": learner.obs_dim, "act_dim": learner.act_dim,
                "action_low": torch.from_numpy(learner.action_low.copy()),
                "action_high": torch.from_numpy(learner.action_high.copy()),
                "metadata": self.metadata if self.metadata is not None else {},
                "stop_rule": None if self.stop_rule is None else self.stop_rule.to_dict()}

    def stop(self, learner: TD3, reason: str) -> None:
        """The seed's rule has fired at its evaluation now (all its episodes just ended): its
        final checkpoint, marked ``stopped`` (step, reason, rule), so that no resume trains it
        further; its networks' state is kept for the learner :func:`train_seeds` returns."""
        assert self.stop_rule is not None
        self.stopped = {"step": self.global_step, "reason": reason, "rule": self.stop_rule.to_dict()}
        self.checkpoint(learner, at_episode_boundary=True, vector=None)
        self.final_state = learner.seed_state(self.k)
        self.bar.set_postfix_str(f"stopped: {reason}", refresh=True)

    def checkpoint(self, learner: TD3, at_episode_boundary: bool,
                   vector: dict[str, Any] | None) -> None:
        """Write ``checkpoint.pt`` (atomically; the buffer's new rows appended to ``replay.bin``)."""
        self.writer.flush()
        save_checkpoint(self.ckpt_path, {
            **self.header(learner),
            "agent": learner.seed_state(self.k),
            "buffer": self.replay.state(self.buffer),
            "global_step": self.global_step,
            "episode": self.episode,  # the number the next episode to start will get
            "at_episode_boundary": at_episode_boundary,
            "python_rng": random.getstate(),
            "torch_cpu_rng": torch.get_rng_state(),
            "wall_time_s": self.wall_time_s,
            "evaluation": self.evaluation.state_dict(),
            "vector": vector,
            "timing": dict(self.timing),
            "stopped": self.stopped,
            "update_credit": str(self.update_credit),
        })
        self.next_checkpoint = self._next_checkpoint()

    def evaluation_returns(self) -> list[float]:
        """The returns of the seed's periodic evaluations so far, in order (what its stop rule
        decides from)."""
        return self.evaluation.returns

    def close(self) -> None:
        for log in (self.csv_file, self.bar, self.writer):  # those opened
            if log is not None:
                log.close()


def _stop_setting(ckpt: dict[str, Any] | None, passed: StopRule | None | str,
                  ckpt_path: Path) -> tuple[StopRule | None, dict[str, Any] | None]:
    """The stop rule of a run and whether it has stopped: a new run takes the rule passed
    (``"checkpoint"``: none); a resumed one keeps its checkpoint's, and a different rule passed is
    refused naming both (a checkpoint without the key had none)."""
    if ckpt is None:
        return (None if isinstance(passed, str) else passed), None
    saved = ckpt.get("stop_rule")
    rule = None if saved is None else StopRule.from_dict(saved)
    if not isinstance(passed, str) and passed != rule:
        def name(r: StopRule | None) -> str:
            return "none" if r is None else str(r.to_dict())
        raise ValueError(f"{ckpt_path}: the run's stop rule is {name(rule)}, not {name(passed)}: a "
                         "resumed run keeps its stop rule")
    return rule, ckpt.get("stopped")
