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
from ..td3.algorithm import TD3, TD3Config
from .allocator import retain_freed_memory
from .evaluation import (
    EVAL_SEED,
    ActorPolicy,
    evaluate_many,
    flat_observation,
)
from .seed_run import SeedRun

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
                        metadata[k] if metadata is not None else None, obs_dim, act_dim, n)
                for k in range(k_seeds)]
        if len({r.global_step for r in runs}) != 1:
            raise ValueError("the seeds of a group resume from checkpoints at different steps ("
                             + ", ".join(f"{r.run_dir}: {r.global_step}" for r in runs) + "): resume "
                             "each with the group it was trained in")
        learner = TD3(obs_dim, act_dim, act_space.low.reshape(-1), act_space.high.reshape(-1),
                      [r.cfg for r in runs])
        for r in runs:
            if r.ckpt is not None:
                learner.load_seed_state(r.k, r.ckpt["agent"])
        return _loop(env, runs, learner, n, progress, log_fn, eval_env_fn, progress_position,
                     progress_desc, eval_vec_env_fn)
    finally:
        env.close()


def _loop(env: gym.vector.VectorEnv, runs: list[SeedRun], learner: TD3, n: int, progress: bool,
          log_fn: Callable[[dict[str, Any]], None] | None, eval_env_fn: Callable[[], gym.Env] | None,
          position: int | None, desc: str | None,
          eval_vec_env_fn: Callable[[int], gym.vector.VectorEnv] | None = None) -> TD3:
    cfg, k_seeds = learner.config, len(runs)
    obs_dim, act_dim = learner.obs_dim, learner.act_dim
    lead = runs[0]
    # the global RNGs (unused by the agents) are one per process: seeded from the first seed
    if lead.ckpt is not None:
        random.setstate(lead.ckpt["python_rng"])
        torch.set_rng_state(lead.ckpt["torch_cpu_rng"])
    else:
        random.seed(cfg.seed)
        torch.manual_seed(cfg.seed)
    vector_state = lead.ckpt.get("vector") if lead.resumed_here else None
    if vector_state is not None and (int(vector_state["num_envs"]) != k_seeds * n
                                     or list(vector_state["seeds"]) != [r.cfg.seed for r in runs]):
        raise ValueError(f"{lead.ckpt_path} was written inside episodes by the group of seeds "
                         f"{list(vector_state['seeds'])} with {int(vector_state['num_envs'])} "
                         "environments: resume it in that same group")
    for k, run in enumerate(runs):
        run.open(progress, None if position is None else position + k,
                 f"{desc or 'seed'} {run.cfg.seed}" if k_seeds > 1 else desc, eval_env_fn)
        if run.evaluation.restore_best:
            run.evaluation.write_best(run.header(learner))
    can_save_env = hasattr(env, "get_state") and hasattr(env, "set_state")

    def sub(k: int) -> slice:
        return slice(k * n, (k + 1) * n)

    def evaluate_seeds(due: list[int]) -> None:
        """Evaluate the seeds ``due``: together in one vector environment when there is one (the
        same returns as one by one), else one after the other."""
        if len(due) > 1 and eval_vec_env_fn is not None:
            results = evaluate_many([ActorPolicy.of_seed(learner, k) for k in due], eval_vec_env_fn,
                                    cfg.eval_episodes, EVAL_SEED)
            for k, result in zip(due, results, strict=True):
                run = runs[k]
                run.evaluation.record(result, learner, k, run.global_step, run.wall_time_s,
                                      run.header(learner))
        else:
            for k in due:
                run = runs[k]
                run.evaluation.run(learner, k, run.global_step, run.wall_time_s, run.header(learner))

    if vector_state is not None:
        env.reset(seed=[0] * (k_seeds * n))  # builds the simulator; then overwritten
        env.set_state(_to_numpy(vector_state["env_state"]))
        obs = _to_numpy(vector_state["obs"]).reshape(k_seeds * n, obs_dim)
        for k, run in enumerate(runs):
            run.ep_return[:] = _to_numpy(vector_state["ep_return"])[sub(k)]
            run.ep_len[:] = _to_numpy(vector_state["ep_len"])[sub(k)]
            run.ep_id[:] = _to_numpy(vector_state["ep_id"])[sub(k)]
            run.noise[:] = _to_numpy(vector_state["noise"])[sub(k)]
            run.noise_pos[:] = _to_numpy(vector_state["noise_pos"])[sub(k)]
    else:
        seeds = []
        for run in runs:
            run.ep_id[:] = np.arange(run.episode, run.episode + n)
            seeds += run.next_episode_seeds(n)
        obs, _ = env.reset(seed=seeds)
        obs = np.asarray(obs, dtype=np.float32).reshape(k_seeds * n, obs_dim)
        for k, run in enumerate(runs):
            for j in range(n):
                run.draw_noise(j, learner.rngs[k])

    def vector(obs: np.ndarray) -> dict[str, Any] | None:
        if not can_save_env:
            return None
        return {"num_envs": k_seeds * n, "seeds": [r.cfg.seed for r in runs],
                "env_state": _to_tensors(env.get_state()),
                "obs": torch.from_numpy(obs.copy()),
                "ep_return": torch.from_numpy(np.concatenate([r.ep_return for r in runs])),
                "ep_len": torch.from_numpy(np.concatenate([r.ep_len for r in runs])),
                "ep_id": torch.from_numpy(np.concatenate([r.ep_id for r in runs])),
                "noise": torch.from_numpy(np.concatenate([r.noise for r in runs])),
                "noise_pos": torch.from_numpy(np.concatenate([r.noise_pos for r in runs]))}

    prev_deterministic = torch.are_deterministic_algorithms_enabled()
    if cfg.torch_deterministic:
        torch.use_deterministic_algorithms(True)
    start_step = lead.global_step
    actions = np.zeros((k_seeds, n, act_dim), dtype=np.float32)
    # where the group's wall time goes (s, cumulative over resumes): the profile of a run
    timing = {key: 0.0 for key in TIMING_KEYS}
    if lead.resumed_here and lead.ckpt.get("timing"):
        timing.update({k: float(v) for k, v in lead.ckpt["timing"].items() if k in timing})
    clock = time.perf_counter()

    def lap(key: str) -> None:
        nonlocal clock
        now = time.perf_counter()
        timing[key] += now - clock
        clock = now

    for run in runs:
        run.timing = timing
    try:
        while not lead.done:
            # 1. act: transition global_step + i of a seed is random during warm-up, then mu + noise
            n_random = int(np.clip(cfg.learning_starts - lead.global_step, 0, n))
            if n_random < n:
                mu = learner.select_actions(obs.reshape(k_seeds, n, obs_dim)[:, n_random:],
                                            explore=False).astype(np.float64)
            for k, run in enumerate(runs):
                if n_random:
                    actions[k, :n_random] = learner.random_actions(k, n_random)
                if n_random < n:
                    noise = run.exploration(n_random, learner.rngs[k])
                    actions[k, n_random:] = np.clip(mu[k] + noise, -1.0, 1.0)
                elif cfg.noise_color > 0:  # the sequences keep time during the warm-up too
                    run.exploration(n, learner.rngs[k])
            flat_actions = actions.reshape(k_seeds * n, act_dim)
            lap("act")
            next_obs, rewards, terminated, truncated, infos = env.step(
                learner.scale_action(flat_actions))
            lap("env")
            next_obs = np.asarray(next_obs, dtype=np.float32).reshape(k_seeds * n, obs_dim)
            terminated = np.asarray(terminated, dtype=bool)
            truncated = np.asarray(truncated, dtype=bool)
            rewards = np.asarray(rewards, dtype=np.float64)
            ended = terminated | truncated

            # 2. store: the real s' of an ended episode is infos["final_obs"][i] (SAME_STEP)
            real_next = next_obs.copy()
            for i in np.flatnonzero(ended):
                real_next[i] = flat_observation(infos["final_obs"][i])
            before = lead.global_step
            for k, run in enumerate(runs):
                for j in range(n):
                    i = k * n + j
                    run.buffer.add(obs[i], flat_actions[i], float(rewards[i]), real_next[i],
                                   bool(terminated[i]))
                run.ep_return += rewards[sub(k)]
                run.ep_len += 1
                run.global_step += n
                run.bar.update(n)

            lap("store")
            # 3. learn: updates_per_step updates per transition past the warm-up, all seeds at once
            n_learn = max(0, lead.global_step - max(before, cfg.learning_starts))
            if n_learn and len(lead.buffer) >= cfg.batch_size:
                for _ in range(n_learn * cfg.updates_per_step):
                    info = learner.update([r.buffer.sample(cfg.batch_size, learner.rngs[k])
                                           for k, r in enumerate(runs)])
                    if learner.num_updates % cfg.log_every == 0:
                        for name, values in info.items():
                            for k, run in enumerate(runs):
                                run.writer.add_scalar(f"losses/{name}", float(values[k]),
                                                      run.global_step)

            lap("update")
            # 4. episode ends: log in sub-env order
            for k, run in enumerate(runs):
                for j in np.flatnonzero(ended[sub(k)]):
                    run.log_episode(j, bool(terminated[k * n + j]), bool(truncated[k * n + j]), log_fn)
                if ended[sub(k)].any():
                    run.csv_file.flush()
            all_ended = bool(ended.all())
            if lead.done:
                break
            # 5. evaluation when all of a seed's episodes have just ended (so its timing does not
            # depend on the layout); checkpoints at restorable points
            restorable = all_ended or can_save_env
            lap("log")
            evaluate_seeds([k for k, run in enumerate(runs)
                            if ended[sub(k)].all() and run.evaluation.due(run.global_step)])
            lap("evaluation")
            # 6. the next episodes of the ended sub-envs start from their seeds
            if ended.any():
                reset_seeds: list[int | None] = [None] * (k_seeds * n)
                for k, run in enumerate(runs):
                    for j in np.flatnonzero(ended[sub(k)]):
                        run.ep_id[j] = run.episode
                        reset_seeds[k * n + j] = run.next_episode_seeds(1)[0]
                checkpoint_due = restorable and lead.global_step >= lead.next_checkpoint
                if checkpoint_due and all_ended:  # before the new episodes: nothing of them to save
                    for run in runs:
                        run.episode -= n
                        run.checkpoint(learner, at_episode_boundary=True, vector=None)
                        run.episode += n
                    checkpoint_due = False
                    lap("checkpoint")
                fresh, _ = env.reset(seed=reset_seeds, options={"reset_mask": ended})
                fresh = np.asarray(fresh, dtype=np.float32).reshape(k_seeds * n, obs_dim)
                next_obs[ended] = fresh[ended]
                for k, run in enumerate(runs):  # the new episodes' noise (after any checkpoint)
                    for j in np.flatnonzero(ended[sub(k)]):
                        run.draw_noise(int(j), learner.rngs[k])
            else:
                checkpoint_due = restorable and lead.global_step >= lead.next_checkpoint
            obs = next_obs
            lap("env")
            if checkpoint_due:  # inside episodes: the environments' state goes along
                state = vector(obs)
                for run in runs:
                    run.checkpoint(learner, at_episode_boundary=False, vector=state)
                lap("checkpoint")

        # the last evaluation and the final checkpoint (unless a resumed run took no step)
        if not (lead.resumed_here and lead.global_step == start_step):
            lap("log")
            evaluate_seeds([k for k, run in enumerate(runs)
                            if run.evaluation.enabled and run.evaluation.last_step != run.global_step])
            lap("evaluation")
            all_ended = bool(ended.all()) if lead.global_step > start_step else True
            state = None if all_ended else vector(obs)
            for run in runs:
                run.checkpoint(learner, at_episode_boundary=all_ended, vector=state)
    finally:
        for run in runs:
            run.close()
        torch.use_deterministic_algorithms(prev_deterministic)
    return learner


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
