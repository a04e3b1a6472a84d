"""The training loop: K seeds, each on N sub-environments of one vector environment, one loop.

:func:`train_seeds` is the only training loop. Seed ``k`` drives sub-environments
``k N .. k N + N - 1`` of a vector environment with ``SAME_STEP`` autoreset (for the crawler:
:class:`~elastica_magnetic_rl.envs.vector_env.MagneticCrawlerVectorEnv`, every robot in one batched simulator;
any other Gymnasium environment is wrapped in a ``SyncVectorEnv``). The K seeds' networks live in one
:class:`~elastica_magnetic_rl.td3.algorithm.TD3` and are updated as one computation. Each seed keeps its own
bookkeeping (:class:`~elastica_magnetic_rl.runner.seed_run.SeedRun`): its run directory, replay buffer,
``episodes.csv``, TensorBoard scalars, evaluation with ``best.pt``, progress bar and checkpoints. The layouts
of the previous API are special cases: :func:`train` (one seed, one environment),
:func:`train_vector` (one seed, N environments) and :func:`train_shared` (K seeds, one
environment each).

Per vector step, for every seed: act (uniform random actions during the warm-up, then
``mu(s) + N(0, sigma^2)``), step, store each transition (the real final observation of an ended
episode, ``terminated`` not ``done``), then one update per new transition past the warm-up; ended
episodes are logged and their sub-environments reset with the seed's episode seeds
(:func:`~elastica_magnetic_rl.td3.algorithm.episode_seed`: episode ``e`` of seed ``s`` always starts from
``episode_seed(s, e)``; episodes are numbered as they start).

Equivalences (CPU, same thread count; tested): a seed trained beside others is bit-identical to the
same seed trained alone, and a run killed and resumed from its checkpoint ends bit-identical to an
uninterrupted one.

Evaluations fall on the first vector step at or after each multiple of ``eval_every`` where all of
the seed's sub-environments have just ended an episode (the same steps in every layout).
Checkpoints fall on the first vector step at or after each multiple of ``checkpoint_every`` where
every sub-environment of the group has just ended an episode; there the environments need not be
saved (they restart from episode seeds), so each seed's folder can be resumed in any layout.
Crawler episodes have a fixed length, so these steps come every episode. An environment that can
save its state (``get_state``/``set_state``) also allows checkpoints inside episodes, with that
state in every seed's checkpoint (``vector``): such a checkpoint resumes only in the same group of
seeds. Evaluation uses no RNG of the training, so the weights are bit-identical with or without
it.
"""

from __future__ import annotations

import os
import random
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch

from ..td3.agent import TD3Agent
from ..td3.algorithm import TD3, TD3Config, update_ratio
from .allocator import retain_freed_memory
from .evaluation import (
    EVAL_SEED,
    ActorPolicy,
    evaluate_many,
    flat_observation,
)
from .progress import GroupProgress
from .seed_run import SeedRun
from .stopping import StopRule

#: Where a group's training time goes (``timing`` in every checkpoint, s): choosing actions,
#: stepping and resetting the environments, storing transitions, TD3 updates, episode logs,
#: evaluations, checkpoints.
TIMING_KEYS = ("act", "env", "store", "update", "log", "evaluation", "checkpoint")


# ----------------------------------------------------------------------------------------------
# The loop
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


def _wrap(env_fn: Callable[[], gym.Env], n: int) -> gym.vector.VectorEnv:
    """``n`` copies of a single environment as a ``SAME_STEP`` vector environment."""
    from gymnasium.vector import AutoresetMode, SyncVectorEnv

    return SyncVectorEnv([env_fn] * n, autoreset_mode=AutoresetMode.SAME_STEP)


def train_seeds(
    vec_env_fn: Callable[[int], gym.vector.VectorEnv],
    configs: Sequence[TD3Config | None],
    steps: int,
    run_dirs: Sequence[str | os.PathLike],
    *,
    envs_per_seed: int = 1,
    resume: bool = False,
    progress: bool = True,
    log_fn: Callable[[dict[str, Any]], None] | None = None,
    init_from: Sequence[str | os.PathLike | None] | None = None,
    metadata: Sequence[dict[str, Any] | None] | None = None,
    eval_env_fn: Callable[[], gym.Env] | None = None,
    progress_position: int | None = None,
    progress_desc: str | None = None,
    eval_vec_env_fn: Callable[[int], gym.vector.VectorEnv] | None = None,
    stop_rules: Sequence[StopRule | None] | None = None,
) -> TD3:
    """Train ``K = len(configs)`` seeds for ``steps`` environment transitions each and return the
    :class:`~elastica_magnetic_rl.td3.algorithm.TD3` holding them.

    Args:
        vec_env_fn: ``vec_env_fn(K * envs_per_seed)`` makes a vector environment with
            ``SAME_STEP`` autoreset and flat Box spaces; its sub-environments reset with a list of
            seeds and ``options={"reset_mask": mask}`` (Gymnasium's ``SyncVectorEnv`` and
            :class:`~elastica_magnetic_rl.envs.vector_env.MagneticCrawlerVectorEnv` do).
        configs: one :class:`~elastica_magnetic_rl.td3.algorithm.TD3Config` per seed (``None``: the
            checkpoint's or the defaults); they must agree on everything but ``seed`` and on
            ``torch_deterministic``.
        steps: total transitions of each seed, counted from step 0 (steps done before a resume or
            inherited through ``init_from`` included); a seed stops at the first vector step
            reaching it.
        run_dirs: one output folder per seed (``episodes.csv``, TensorBoard scalars,
            ``checkpoint.pt``, ``replay.bin``, ``evaluations.csv``, ``best.pt``). A folder that
            holds a checkpoint is refused unless ``resume``; ``resume`` needs one in every folder.
        envs_per_seed: sub-environments (and so transitions and updates per vector step) of each
            seed.
        init_from: per seed, another run's checkpoint to start from (networks, optimisers,
            buffer, RNGs and counters; e.g. to refine a policy in another physics).
        metadata: per seed, a JSON-like dict stored in its checkpoints (e.g. the case).
        eval_env_fn: makes a single evaluation environment; with ``config.eval_every > 0`` each
            seed's deterministic policy is evaluated there periodically.
        log_fn: called with each episode's row (a dict) after it is written.
        eval_vec_env_fn: ``eval_vec_env_fn(m)`` makes ``m`` evaluation environments in one
            vector environment (``SAME_STEP``), each behaving as ``eval_env_fn()``: seeds due for
            evaluation at the same step are then evaluated together (same returns, the
            simulation shared).
        stop_rules: per seed, when it stops before ``steps``
            (:class:`~elastica_magnetic_rl.runner.stopping.StopRule`, decided at each of its
            evaluations; ``None``: never). A stopped seed writes its final checkpoint marked
            ``stopped`` and leaves the group at the next step where every sub-environment of the
            group has just ended an episode (at once for crawlers): its sub-environments and its
            slot in the stacked update are gone, the others go on bit-identical to a run without
            it. Resuming keeps each run's rule (a different one is refused); not given: the
            checkpoints' (new runs: none). A stopped seed is never trained further.

    Returns the learner holding every seed in the order given, each at its end (a stopped seed
    at its stop; the update counter is then the last seed's).
    """
    k_seeds, n = len(configs), int(envs_per_seed)
    if k_seeds < 1 or len(run_dirs) != k_seeds:
        raise ValueError("train_seeds needs one run_dir per config, and at least one config")
    if len({Path(d).resolve() for d in run_dirs}) != k_seeds:
        raise ValueError("every seed needs its own run_dir")
    if n < 1:
        raise ValueError(f"envs_per_seed must be >= 1, got {n}")
    from gymnasium.vector import AutoresetMode

    retain_freed_memory()  # the updates' temporaries reused, not page-faulted in (rl/runner/allocator.py)
    env = vec_env_fn(k_seeds * n)
    try:
        if env.metadata.get("autoreset_mode") != AutoresetMode.SAME_STEP or env.num_envs != k_seeds * n:
            raise ValueError(f"training needs a SAME_STEP vector environment of {k_seeds * n} "
                             "sub-environments")
        obs_space, act_space = env.single_observation_space, env.single_action_space
        if not isinstance(act_space, gym.spaces.Box) or not isinstance(obs_space, gym.spaces.Box):
            raise TypeError("TD3 needs Box observation and action spaces")
        obs_dim, act_dim = int(np.prod(obs_space.shape)), int(np.prod(act_space.shape))
        runs = [SeedRun(k, configs[k], steps, run_dirs[k], resume,
                        init_from[k] if init_from is not None else None,
                        metadata[k] if metadata is not None else None, obs_dim, act_dim, n,
                        "checkpoint" if stop_rules is None else stop_rules[k])
                for k in range(k_seeds)]
        if stop_rules is not None and len(stop_rules) != k_seeds:
            raise ValueError("train_seeds needs one stop rule (or None) per config")
        if any(r.stopped for r in runs):  # seeds stopped earlier are not trained further
            return _without_stopped(vec_env_fn, env, runs, configs, steps, run_dirs, n, resume,
                                    progress, log_fn, metadata, eval_env_fn, progress_position,
                                    progress_desc, eval_vec_env_fn, obs_dim, act_dim, act_space)
        if len({r.global_step for r in runs}) != 1:
            raise ValueError("the seeds of a group resume from checkpoints at different steps ("
                             + ", ".join(f"{r.run_dir}: {r.global_step}" for r in runs) + "): resume "
                             "each with the group it was trained in")
        learner = TD3(obs_dim, act_dim, act_space.low.reshape(-1), act_space.high.reshape(-1),
                      [r.cfg for r in runs])
        for r in runs:
            if r.ckpt is not None:
                learner.load_seed_state(r.k, r.ckpt["agent"])
        loop = _GroupLoop(env, runs, learner, n, log_fn, eval_vec_env_fn, vec_env_fn)
        learner = _loop(loop, progress, eval_env_fn, progress_position, progress_desc)
        env = loop.env  # a smaller one once seeds have stopped
        if any(r.final_state is not None for r in runs):
            return _assemble(learner, runs, act_space)
        return learner
    finally:
        env.close()


def _assemble(learner: TD3, runs: list[SeedRun], act_space: gym.spaces.Box,
              states: list[dict[str, Any]] | None = None) -> TD3:
    """One learner with every seed of ``runs`` in order, each at its end: a stopped seed's state
    when it stopped, the others' from ``learner`` (their member ``run.k``) or ``states``."""
    if states is None:
        states = [r.final_state if r.final_state is not None else learner.seed_state(r.k)
                  for r in runs]
    whole = TD3(learner.obs_dim, learner.act_dim, act_space.low.reshape(-1),
                act_space.high.reshape(-1), [r.cfg for r in runs])
    for k, state in enumerate(states):
        whole.load_seed_state(k, state, same_counters=False)
    return whole


def _without_stopped(vec_env_fn, env, runs, configs, steps, run_dirs, n, resume, progress, log_fn,
                     metadata, eval_env_fn, progress_position, progress_desc, eval_vec_env_fn,
                     obs_dim, act_dim, act_space) -> TD3:
    """``train_seeds`` of a group some of whose seeds stopped in an earlier call: those are left
    as they are, the others trained (resumed) on their own; the learner of them all."""
    env.close()
    active = [k for k, r in enumerate(runs) if not r.stopped]
    for r in runs:
        r.buffer = None  # the active seeds' are loaded again below
    states: dict[int, dict[str, Any]] = {k: r.ckpt["agent"] for k, r in enumerate(runs) if r.stopped}
    if active:
        sub = train_seeds(vec_env_fn, [configs[k] for k in active], steps, [run_dirs[k] for k in active],
                          envs_per_seed=n, resume=resume, progress=progress, log_fn=log_fn,
                          metadata=None if metadata is None else [metadata[k] for k in active],
                          eval_env_fn=eval_env_fn, progress_position=progress_position,
                          progress_desc=progress_desc, eval_vec_env_fn=eval_vec_env_fn,
                          stop_rules=[runs[k].stop_rule for k in active])
        states.update({k: sub.seed_state(i) for i, k in enumerate(active)})
    probe = TD3(obs_dim, act_dim, act_space.low.reshape(-1), act_space.high.reshape(-1),
                [r.cfg for r in runs[:1]])
    return _assemble(probe, runs, act_space, [states[k] for k in range(len(runs))])


def _loop(loop: _GroupLoop, progress: bool, eval_env_fn: Callable[[], gym.Env] | None,
          position: int | None, desc: str | None) -> TD3:
    """Train the group's seeds to their step budget: the global RNGs and the environments
    restored or started, then :meth:`_GroupLoop.run`."""
    runs, learner = loop.runs, loop.learner
    vector_state = loop.restore_global_rngs()
    for k, run in enumerate(runs):
        run.open(progress, None if position is None else position + k,
                 f"{desc or 'seed'} {run.cfg.seed}" if len(runs) > 1 else desc, eval_env_fn)
        if run.evaluation.restore_best:
            run.evaluation.write_best(run.header(learner))
    return loop.run(loop.first_observations(vector_state))


class _GroupLoop:
    """The training loop of one group of K seeds on one vector environment, in its named steps:
    :meth:`act`, the environments' step, :meth:`store`, :meth:`learn`, :meth:`log_episode_ends`,
    :meth:`evaluate`, :meth:`start_next_episodes` and the checkpoints (at episode boundaries, or
    inside episodes with the environments' state). The order of these steps, and of the RNG draws
    in them, is what makes a seed bit-identical alone and in a group, and after a resume."""

    def __init__(self, env: gym.vector.VectorEnv, runs: list[SeedRun], learner: TD3, n: int,
                 log_fn: Callable[[dict[str, Any]], None] | None,
                 eval_vec_env_fn: Callable[[int], gym.vector.VectorEnv] | None,
                 vec_env_fn: Callable[[int], gym.vector.VectorEnv] | None = None) -> None:
        self.env, self.runs, self.learner, self.n = env, runs, learner, n
        self.log_fn, self.eval_vec_env_fn, self.vec_env_fn = log_fn, eval_vec_env_fn, vec_env_fn
        self.cfg, self.k_seeds = learner.config, len(runs)
        self.obs_dim, self.act_dim = learner.obs_dim, learner.act_dim
        # a Gymnasium vector environment that can save its state allows checkpoints inside episodes
        self.can_save_env = hasattr(env, "get_state") and hasattr(env, "set_state")
        self.actions = np.zeros((self.k_seeds, n, self.act_dim), dtype=np.float32)
        self.timing = {key: 0.0 for key in TIMING_KEYS}
        self.clock = time.perf_counter()
        # the unspent fraction of an update of a fractional updates_per_step (the group's seeds
        # are in lockstep: one value, kept in every seed's checkpoint)
        self.update_credit = self.lead.update_credit

    @property
    def lead(self) -> SeedRun:
        """The first seed still training (the group's step count; all such seeds are in
        lockstep), else the first seed."""
        return next((r for r in self.runs if not r.stopped), self.runs[0])

    @property
    def training(self) -> bool:
        """Whether a seed of the group still trains towards its budget."""
        return any(not r.stopped for r in self.runs) and not self.lead.done

    def sub(self, k: int) -> slice:
        """Seed ``k``'s sub-environments."""
        return slice(k * self.n, (k + 1) * self.n)

    # -- start -------------------------------------------------------------------------------
    def restore_global_rngs(self) -> dict[str, Any] | None:
        """Seed (or restore) the process's global RNGs, one per process, from the first seed;
        returns the environments' saved state of a checkpoint written inside episodes (checked to
        belong to this group), else ``None``."""
        lead, cfg = self.lead, self.cfg
        if lead.ckpt is not None:
            random.setstate(lead.ckpt["python_rng"])
            torch.set_rng_state(lead.ckpt["torch_cpu_rng"])
        else:
            random.seed(cfg.seed)
            torch.manual_seed(cfg.seed)
        vector_state = lead.ckpt.get("vector") if lead.resumed_here else None
        if vector_state is not None and (int(vector_state["num_envs"]) != self.k_seeds * self.n
                                         or list(vector_state["seeds"]) != [r.cfg.seed for r in self.runs]):
            raise ValueError(f"{lead.ckpt_path} was written inside episodes by the group of seeds "
                             f"{list(vector_state['seeds'])} with {int(vector_state['num_envs'])} "
                             "environments: resume it in that same group")
        return vector_state

    def first_observations(self, vector_state: dict[str, Any] | None) -> np.ndarray:
        """The environments restored from ``vector_state``, or reset with each seed's episode
        seeds (and the first episodes' exploration noise drawn); their observations ``(K n,
        obs_dim)``."""
        runs, n, total = self.runs, self.n, self.k_seeds * self.n
        if vector_state is not None:
            self.env.reset(seed=[0] * total)  # builds the simulator; then overwritten
            self.env.set_state(_to_numpy(vector_state["env_state"]))
            for k, run in enumerate(runs):
                for key, field in (("ep_return", run.ep_return), ("ep_len", run.ep_len),
                                   ("ep_id", run.ep_id), ("noise", run.noise),
                                   ("noise_pos", run.noise_pos)):
                    field[:] = _to_numpy(vector_state[key])[self.sub(k)]
            return _to_numpy(vector_state["obs"]).reshape(total, self.obs_dim)
        seeds = []
        for run in runs:
            run.ep_id[:] = np.arange(run.episode, run.episode + n)
            seeds += run.next_episode_seeds(n)
        obs, _ = self.env.reset(seed=seeds)
        obs = np.asarray(obs, dtype=np.float32).reshape(total, self.obs_dim)
        for k, run in enumerate(runs):
            for j in range(n):
                run.draw_noise(j, self.learner.rngs[k])
        return obs

    def lap(self, key: str) -> None:
        """Add the time since the last lap to ``timing[key]``."""
        now = time.perf_counter()
        self.timing[key] += now - self.clock
        self.clock = now

    # -- one vector step -----------------------------------------------------------------------
    def act(self, obs: np.ndarray) -> np.ndarray:
        """Actions ``(K n, act_dim)`` in [-1, 1]: transition ``global_step + i`` of a seed is
        random during the warm-up, then ``mu + noise``."""
        learner, cfg, n = self.learner, self.cfg, self.n
        n_random = int(np.clip(cfg.learning_starts - self.lead.global_step, 0, n))
        if n_random < n:
            mu = learner.select_actions(obs.reshape(self.k_seeds, n, self.obs_dim)[:, n_random:],
                                        explore=False).astype(np.float64)
        for k, run in enumerate(self.runs):
            if n_random:
                self.actions[k, :n_random] = learner.random_actions(k, n_random)
            if n_random < n:
                noise = run.exploration(n_random, learner.rngs[k])
                self.actions[k, n_random:] = np.clip(mu[k] + noise, -1.0, 1.0)
            elif cfg.noise_color > 0:  # the sequences keep time during the warm-up too
                run.exploration(n, learner.rngs[k])
        return self.actions.reshape(self.k_seeds * n, self.act_dim)

    def store(self, obs: np.ndarray, actions: np.ndarray, rewards: np.ndarray, next_obs: np.ndarray,
              terminated: np.ndarray, ended: np.ndarray, infos: dict[str, Any]) -> None:
        """Each seed's transitions into its buffer (the real s' of an ended episode is
        ``infos["final_obs"][i]``: ``SAME_STEP`` autoreset), its episode sums and counters."""
        real_next = next_obs.copy()
        for i in np.flatnonzero(ended):
            real_next[i] = flat_observation(infos["final_obs"][i])
        n = self.n
        for k, run in enumerate(self.runs):
            if run.stopped:  # waiting to leave the group: nothing of it is recorded
                continue
            for j in range(n):
                i = k * n + j
                run.buffer.add(obs[i], actions[i], float(rewards[i]), real_next[i], bool(terminated[i]))
            run.ep_return += rewards[self.sub(k)]
            run.ep_len += 1
            run.global_step += n
            run.bar.update(n)

    def learn(self, before: int) -> None:
        """``updates_per_step`` updates per transition past the warm-up (``before``: the step
        count before this vector step), all seeds at once; losses logged every ``log_every``. A
        fractional ratio owes ``n x ratio`` updates after ``n`` such transitions: the whole ones
        are made now, the rest (:attr:`update_credit`, exact) carried to the next steps."""
        cfg, learner, runs = self.cfg, self.learner, self.runs
        n_learn = max(0, self.lead.global_step - max(before, cfg.learning_starts))
        if not n_learn or len(self.lead.buffer) < cfg.batch_size:
            return
        owed = self.update_credit + n_learn * update_ratio(cfg.updates_per_step)
        n_updates = int(owed)  # floor: owed >= 0
        self.update_credit = owed - n_updates
        for run in self.runs:
            run.update_credit = self.update_credit
        for _ in range(n_updates):
            info = learner.update([r.buffer.sample(cfg.batch_size, learner.rngs[k])
                                   for k, r in enumerate(runs)])
            if learner.num_updates % cfg.log_every == 0:
                for name, values in info.items():
                    for k, run in enumerate(runs):
                        run.writer.add_scalar(f"losses/{name}", float(values[k]), run.global_step)

    def log_episode_ends(self, ended: np.ndarray, terminated: np.ndarray,
                         truncated: np.ndarray) -> None:
        """The ended episodes into each seed's ``episodes.csv``, in sub-environment order."""
        n = self.n
        for k, run in enumerate(self.runs):
            if run.stopped:
                continue
            for j in np.flatnonzero(ended[self.sub(k)]):
                run.log_episode(j, bool(terminated[k * n + j]), bool(truncated[k * n + j]), self.log_fn)
            if ended[self.sub(k)].any():
                run.csv_file.flush()

    def evaluate(self, due: list[int]) -> None:
        """Evaluate the seeds ``due``: together in one vector environment when there is one (the
        same returns as one by one), else one after the other."""
        learner, runs = self.learner, self.runs
        if len(due) > 1 and self.eval_vec_env_fn is not None:
            results = evaluate_many([ActorPolicy.of_seed(learner, k) for k in due],
                                    self.eval_vec_env_fn, self.cfg.eval_episodes, EVAL_SEED)
            for k, result in zip(due, results, strict=True):
                run = runs[k]
                run.evaluation.record(result, learner, k, run.global_step, run.wall_time_s,
                                      run.header(learner))
        else:
            for k in due:
                run = runs[k]
                run.evaluation.run(learner, k, run.global_step, run.wall_time_s, run.header(learner))

    def next_episode_seeds(self, ended: np.ndarray) -> list[int | None]:
        """The reset seeds of the ended sub-environments (``None`` for the others); their new
        episodes are numbered now."""
        reset_seeds: list[int | None] = [None] * (self.k_seeds * self.n)
        for k, run in enumerate(self.runs):
            for j in np.flatnonzero(ended[self.sub(k)]):
                run.ep_id[j] = run.episode
                reset_seeds[k * self.n + j] = run.next_episode_seeds(1)[0]
        return reset_seeds

    def start_next_episodes(self, ended: np.ndarray, reset_seeds: list[int | None],
                            next_obs: np.ndarray) -> None:
        """Reset the ended sub-environments (their first observations into ``next_obs``) and draw
        their new episodes' exploration noise."""
        if getattr(self, "fresh_env", False):  # a new environment's first reset: all of it
            fresh, _ = self.env.reset(seed=reset_seeds)
            self.fresh_env = False
        else:
            fresh, _ = self.env.reset(seed=reset_seeds, options={"reset_mask": ended})
        fresh = np.asarray(fresh, dtype=np.float32).reshape(self.k_seeds * self.n, self.obs_dim)
        next_obs[ended] = fresh[ended]
        for k, run in enumerate(self.runs):
            for j in np.flatnonzero(ended[self.sub(k)]):
                run.draw_noise(int(j), self.learner.rngs[k])

    # -- checkpoints ---------------------------------------------------------------------------
    def vector_state(self, obs: np.ndarray) -> dict[str, Any] | None:
        """The environments' state and each seed's episode state, for a checkpoint inside
        episodes (``None`` when the environments cannot save theirs)."""
        if not self.can_save_env:
            return None
        runs = self.runs
        return {"num_envs": self.k_seeds * self.n, "seeds": [r.cfg.seed for r in runs],
                "env_state": _to_tensors(self.env.get_state()),
                "obs": torch.from_numpy(obs.copy()),
                **{key: torch.from_numpy(np.concatenate([getattr(r, key) for r in runs]))
                   for key in ("ep_return", "ep_len", "ep_id", "noise", "noise_pos")}}

    def checkpoint_between_episodes(self) -> None:
        """Every seed's checkpoint at an episode boundary (before the new episodes are counted)."""
        for run in self.runs:
            if run.stopped:  # its final checkpoint is written
                continue
            run.episode -= self.n
            run.checkpoint(self.learner, at_episode_boundary=True, vector=None)
            run.episode += self.n

    def checkpoint_inside_episodes(self, obs: np.ndarray) -> None:
        """Every seed's checkpoint with the environments' state."""
        state = self.vector_state(obs)
        for run in self.runs:
            if not run.stopped:
                run.checkpoint(self.learner, at_episode_boundary=False, vector=state)

    # -- the loop ------------------------------------------------------------------------------
    def step(self, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
        """One vector step of every seed from ``obs``: act, step, store, learn, log. Returns the
        next observations (before any reset), which sub-environments ended, and whether the
        group's step budget is reached."""
        flat_actions = self.act(obs)
        self.lap("act")
        next_obs, rewards, terminated, truncated, infos = self.env.step(
            self.learner.scale_action(flat_actions))
        self.lap("env")
        next_obs = np.asarray(next_obs, dtype=np.float32).reshape(self.k_seeds * self.n, self.obs_dim)
        terminated = np.asarray(terminated, dtype=bool)
        truncated = np.asarray(truncated, dtype=bool)
        rewards = np.asarray(rewards, dtype=np.float64)
        ended = terminated | truncated
        before = self.lead.global_step
        self.store(obs, flat_actions, rewards, next_obs, terminated, ended, infos)
        self.lap("store")
        self.learn(before)
        self.lap("update")
        self.log_episode_ends(ended, terminated, truncated)
        return next_obs, ended, self.lead.done

    def between_steps(self, next_obs: np.ndarray, ended: np.ndarray) -> np.ndarray:
        """After a vector step: evaluations when all of a seed's episodes have just ended (so
        their timing does not depend on the layout), and the stop rules there; the ended episodes
        restarted, and the checkpoints due at restorable points. Returns the observations the
        next step starts from (``next_obs``, the new episodes' starts filled in; fewer rows once
        stopped seeds have left the group)."""
        all_ended = bool(ended.all())
        restorable = all_ended or self.can_save_env
        self.lap("log")
        due = [k for k, run in enumerate(self.runs) if not run.stopped
               and ended[self.sub(k)].all() and run.evaluation.due(run.global_step)]
        self.evaluate(due)
        self.lap("evaluation")
        if due:
            self.progress.evaluated()
        if all_ended or due:
            self.show_progress()
        self.apply_stop_rules(due)
        self.lap("checkpoint")
        if not any(not r.stopped for r in self.runs):
            return next_obs  # every seed has stopped: the loop ends
        if all_ended and any(r.stopped for r in self.runs):
            next_obs, ended = self.drop_stopped(), np.ones(self.k_seeds * self.n, dtype=bool)
        lead = self.lead
        checkpoint_due = restorable and lead.global_step >= lead.next_checkpoint
        if ended.any():
            reset_seeds = self.next_episode_seeds(ended)
            if checkpoint_due and all_ended:  # before the new episodes: nothing of them to save
                self.checkpoint_between_episodes()
                checkpoint_due = False
                self.lap("checkpoint")
            self.start_next_episodes(ended, reset_seeds, next_obs)
        self.lap("env")
        if checkpoint_due:  # inside episodes: the environments' state goes along
            self.checkpoint_inside_episodes(next_obs)
            self.lap("checkpoint")
        return next_obs

    def show_progress(self) -> None:
        """The group's rate and ETA (evaluations included) on its first seed's progress bar."""
        lead = self.lead
        estimate = self.progress.estimate(self.timing, lead.global_step, lead.steps,
                                          sum(not r.stopped for r in self.runs), self.cfg.eval_every
                                          if lead.evaluation.enabled else 0, lead.evaluation.last_step)
        if lead.bar is not None and not getattr(lead.bar, "disable", True):
            base = self.bar_desc.get(id(lead), "")
            lead.bar.set_description_str(f"{base} | {GroupProgress.describe(estimate)}".lstrip(" |"),
                                         refresh=False)

    def apply_stop_rules(self, evaluated: list[int]) -> None:
        """The seeds just evaluated whose stop rule fires write their final checkpoint and stop
        (they leave the group at its next common episode boundary)."""
        for k in evaluated:
            run = self.runs[k]
            reason = None if run.stop_rule is None else run.stop_rule.decide(run.evaluation_returns())
            if reason is not None:
                run.stop(self.learner, reason)

    def drop_stopped(self) -> np.ndarray:
        """At a step where every episode of the group has just ended: the stopped seeds leave.
        The others' states go into a new learner of them alone and their sub-environments into a
        new, smaller vector environment (as a resume in a smaller group would: at an episode
        boundary the environments restart from episode seeds). Returns an observation array of
        the new size (filled by the resets that follow)."""
        if self.vec_env_fn is None:
            raise RuntimeError("a group whose seeds stop needs its vector-environment factory")
        keep = [r for r in self.runs if not r.stopped]
        old = self.learner
        learner = TD3(old.obs_dim, old.act_dim, old.action_low, old.action_high, [r.cfg for r in keep])
        for i, run in enumerate(keep):
            learner.load_seed_state(i, old.seed_state(run.k))
            run.k = i
        for run in self.runs:
            if run.stopped:
                run.close()
                run.buffer = None  # its memory freed
        self.env.close()
        self.learner, self.runs, self.k_seeds = learner, keep, len(keep)
        self.env = self.vec_env_fn(self.k_seeds * self.n)
        self.fresh_env = True
        self.actions = np.zeros((self.k_seeds, self.n, self.act_dim), dtype=np.float32)
        return np.zeros((self.k_seeds * self.n, self.obs_dim), dtype=np.float32)

    def finish(self, obs: np.ndarray, ended: np.ndarray | None, start_step: int) -> None:
        """The last evaluation and the final checkpoint."""
        self.lap("log")
        self.evaluate([k for k, run in enumerate(self.runs) if not run.stopped
                       and run.evaluation.enabled and run.evaluation.last_step != run.global_step])
        self.lap("evaluation")
        if not any(not r.stopped for r in self.runs):
            return
        all_ended = bool(ended.all()) if self.lead.global_step > start_step else True
        state = None if all_ended else self.vector_state(obs)
        for run in self.runs:
            if run.stopped:
                continue
            run.checkpoint(self.learner, at_episode_boundary=all_ended, vector=state)

    def run(self, obs: np.ndarray) -> TD3:
        """Vector steps until the seeds' budget, then the final evaluation and checkpoint (unless
        a resumed run took no step); returns the learner."""
        lead = self.lead
        every_run = list(self.runs)  # the group shrinks when seeds stop
        prev_deterministic = torch.are_deterministic_algorithms_enabled()
        if self.cfg.torch_deterministic:
            torch.use_deterministic_algorithms(True)
        start_step = lead.global_step
        # where the group's wall time goes (s, cumulative over resumes): the profile of a run
        if lead.resumed_here and lead.ckpt.get("timing"):
            self.timing.update({k: float(v) for k, v in lead.ckpt["timing"].items() if k in self.timing})
        self.clock = time.perf_counter()
        self.progress = GroupProgress(self.timing, start_step)
        self.bar_desc = {id(r): getattr(r.bar, "desc", "") or "" for r in self.runs}
        for run in self.runs:
            run.timing = self.timing
        ended = None
        try:
            while self.training:
                next_obs, ended, done = self.step(obs)
                if done:  # ``obs`` stays this step's start: what the final checkpoint has held
                    break
                obs = self.between_steps(next_obs, ended)
            if not (lead.resumed_here and lead.global_step == start_step):
                self.finish(obs, ended, start_step)
        finally:
            for run in every_run:
                run.close()
            torch.use_deterministic_algorithms(prev_deterministic)
        return self.learner


# ----------------------------------------------------------------------------------------------
# The layouts of the single-seed API
# ----------------------------------------------------------------------------------------------
def _single(learner: TD3, k: int = 0) -> TD3Agent:
    """Seed ``k`` of ``learner`` as a :class:`~elastica_magnetic_rl.td3.agent.TD3Agent`."""
    agent = TD3Agent(learner.obs_dim, learner.act_dim, learner.action_low, learner.action_high,
                     learner.configs[k])
    agent.load_seed_state(0, learner.seed_state(k))
    return agent


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
    """One seed on one environment (:func:`train_seeds` with K = N = 1); returns its agent.

    ``env_fn`` makes a single Gymnasium environment (flat Box observations, bounded Box actions).
    Other arguments as :func:`train_seeds` (one of each).
    """
    learner = train_seeds(lambda k: _wrap(env_fn, k), [config], steps, [run_dir], resume=resume,
                          progress=progress, log_fn=log_fn,
                          init_from=[init_from] if init_from is not None else None,
                          metadata=[metadata], eval_env_fn=eval_env_fn,
                          progress_position=progress_position, progress_desc=progress_desc)
    return _single(learner)


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
    """One seed on the N sub-environments of ``vec_env_fn()`` (:func:`train_seeds` with K = 1):
    N transitions and N updates per vector step."""
    probe: list[gym.vector.VectorEnv] = []

    def make(total: int) -> gym.vector.VectorEnv:
        return probe.pop() if probe else vec_env_fn()

    probe.append(vec_env_fn())
    n_envs = int(probe[0].num_envs)
    learner = train_seeds(make, [config], steps, [run_dir], envs_per_seed=n_envs, resume=resume,
                          progress=progress, log_fn=log_fn,
                          init_from=[init_from] if init_from is not None else None,
                          metadata=[metadata], eval_env_fn=eval_env_fn,
                          progress_position=progress_position, progress_desc=progress_desc)
    return _single(learner)


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
    """K seeds, one sub-environment each (:func:`train_seeds` with N = 1); returns one agent per
    seed, each bit-identical to training that seed alone."""
    learner = train_seeds(vec_env_fn, configs, steps, run_dirs, resume=resume, progress=progress,
                          metadata=metadata, eval_env_fn=eval_env_fn, progress_desc=progress_desc)
    return [_single(learner, k) for k in range(learner.n_seeds)]


__all__ = ["train", "train_seeds", "train_shared", "train_vector"]
