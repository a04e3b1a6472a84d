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

Per vector step, for every seed: act (uniform random actions during the warm-up, or the case's
yardstick plus noise with ``yardstick_warmup``, cloned by the actor at the warm-up's end, then
``mu(s) + N(0, sigma^2)``), step, store each transition (the real final observation of an ended
episode, ``terminated`` not ``done``), then one update per new transition past the warm-up; ended
episodes are logged and their sub-environments reset with the seed's episode seeds
(:func:`~elastica_magnetic_rl.td3.algorithm.episode_seed`: episode ``e`` of seed ``s`` always starts from
``episode_seed(s, e)``; episodes are numbered as they start).

Equivalences (CPU, same thread count; tested): a seed trained beside others is bit-identical to
the same seed trained alone (:mod:`elastica_magnetic_rl.td3.algorithm` says how far that is
tested), and a run killed and resumed from its checkpoint ends bit-identical to an uninterrupted
one.

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

import dataclasses
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from ..td3.agent import TD3Agent
from ..td3.algorithm import TD3
from ..td3.config import TD3Config
from .allocator import retain_freed_memory
from .group import GroupLoop
from .seed_run import SeedRun
from .stopping import StopRule


# ----------------------------------------------------------------------------------------------
# The loop
# ----------------------------------------------------------------------------------------------
def _wrap(env_fn: Callable[[], gym.Env], n: int) -> gym.vector.VectorEnv:
    """``n`` copies of a single environment as a ``SAME_STEP`` vector environment."""
    from gymnasium.vector import AutoresetMode, SyncVectorEnv

    return SyncVectorEnv([env_fn] * n, autoreset_mode=AutoresetMode.SAME_STEP)


@dataclasses.dataclass(frozen=True)
class GroupOptions:
    """The options of :func:`train_seeds` besides the environments' maker, the configs, the steps
    and the run folders.

    Attributes:
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
            slot in the stacked update are gone, the others go on bit-identical to a run
            without it. Resuming keeps each run's rule (a
            different one is refused); not given: the checkpoints' (new runs: none). A stopped
            seed is never trained further, nor one resumed at its ``steps`` (seeds of one group
            may then stand at different steps: trained in other groupings).
        confirm_env_fn: where a fired rule with ``confirm`` is confirmed (one deterministic
            episode whose return must reach the threshold too; the crawler's: 10 s, accurate).
        confirm_vec_env_fn: the same as a vector environment (``confirm_vec_env_fn(1)``; used
            instead of ``confirm_env_fn`` when given: the crawler's batched simulator returns the
            same, faster).
        hand_back: asked at each vector step where every episode of the group has just ended;
            when it returns true while at least two seeds still train, every seed's checkpoint is
            written there and the call returns before the budget (no final evaluation): the
            seeds go on from their folders with ``resume``, in any grouping, bit-identical to an
            uninterrupted run (the equivalences of this module's docstring). How a sweep keeps an
            idle core busy (:mod:`elastica_magnetic_rl.sweep.rebalance`).
        yardstick_fn: makes one hand-designed controller of the case (``act(obs)`` -> an action in
            ``[-1, 1]^act_dim``, ``reset()`` at each episode start, ``state()``/``set_state()`` for
            checkpoints inside episodes; e.g.
            :class:`~elastica_magnetic_rl.envs.yardsticks.SteeringFieldPolicy`); needed by
            configs with ``yardstick_warmup``, whose warm-up it plays (one per sub-environment).
    """

    envs_per_seed: int = 1
    resume: bool = False
    progress: bool = True
    log_fn: Callable[[dict[str, Any]], None] | None = None
    init_from: Sequence[str | os.PathLike | None] | None = None
    metadata: Sequence[dict[str, Any] | None] | None = None
    eval_env_fn: Callable[[], gym.Env] | None = None
    progress_position: int | None = None
    progress_desc: str | None = None
    eval_vec_env_fn: Callable[[int], gym.vector.VectorEnv] | None = None
    stop_rules: Sequence[StopRule | None] | None = None
    confirm_env_fn: Callable[[], gym.Env] | None = None
    hand_back: Callable[[], bool] | None = None
    confirm_vec_env_fn: Callable[[int], gym.vector.VectorEnv] | None = None
    yardstick_fn: Callable[[], Any] | None = None


def train_seeds(
    vec_env_fn: Callable[[int], gym.vector.VectorEnv],
    configs: Sequence[TD3Config | None],
    steps: int,
    run_dirs: Sequence[str | os.PathLike],
    options: GroupOptions | None = None,
    /,
    **changes: Any,
) -> TD3:
    """Train ``K = len(configs)`` seeds for ``steps`` environment transitions each and return the
    :class:`~elastica_magnetic_rl.td3.algorithm.TD3` holding them.

    ``options`` (:class:`GroupOptions`, each field described there) with ``changes`` (its fields
    by name) give the rest.

    Args:
        vec_env_fn: ``vec_env_fn(K * envs_per_seed)`` makes a vector environment with
            ``SAME_STEP`` autoreset and flat Box spaces; its sub-environments reset with a list of
            seeds and ``options={"reset_mask": mask}`` (Gymnasium's ``SyncVectorEnv`` and
            :class:`~elastica_magnetic_rl.envs.vector_env.MagneticCrawlerVectorEnv` do).
        configs: one :class:`~elastica_magnetic_rl.td3.config.TD3Config` per seed (``None``: the
            checkpoint's or the defaults); they must agree on everything but ``seed`` and on
            ``torch_deterministic``.
        steps: total transitions of each seed, counted from step 0 (steps done before a resume or
            inherited through ``init_from`` included); a seed stops at the first vector step
            reaching it.
        run_dirs: one output folder per seed (``episodes.csv``, TensorBoard scalars,
            ``checkpoint.pt``, ``replay.bin``, ``evaluations.csv``, ``best.pt``). A folder that
            holds a checkpoint is refused unless ``resume``; ``resume`` needs one in every folder.

    Returns the learner holding every seed in the order given, each at its end (a stopped seed
    at its stop; the update counter is then the last seed's; after a hand-back, where it was).
    """
    o = dataclasses.replace(options or GroupOptions(), **changes)
    k_seeds, n = len(configs), int(o.envs_per_seed)
    _check_group(run_dirs, k_seeds, n, o.stop_rules, o.confirm_env_fn or o.confirm_vec_env_fn)
    retain_freed_memory()  # the updates' temporaries reused, not page-faulted in (rl/runner/allocator.py)
    env = vec_env_fn(k_seeds * n)
    try:
        obs_dim, act_dim, act_space = _flat_spaces(env, k_seeds * n)
        runs = _seed_runs(configs, steps, run_dirs, o.resume, o.init_from, o.metadata,
                          o.stop_rules, obs_dim, act_dim, n)
        done = [_done(r, steps) for r in runs]
        if any(r.stopped for r in runs) or (any(done) and not all(done)):  # not trained further
            env.close()
            # the same settings for the seeds left; their metadata and rules are passed per seed
            rest = dataclasses.replace(o, envs_per_seed=n, init_from=None, metadata=None,
                                       stop_rules=None)

            def same_settings(configs_left, steps_left, dirs_left, **per_seed):
                return train_seeds(vec_env_fn, configs_left, steps_left, dirs_left, rest, **per_seed)

            return _without_done(same_settings, runs, configs, run_dirs, o.metadata, steps,
                                 (obs_dim, act_dim, act_space))
        _check_yardstick(runs, o.yardstick_fn, obs_dim, act_dim)
        _check_residual(runs[0].cfg, env)
        learner = _group_learner(runs, obs_dim, act_dim, act_space)
        loop = GroupLoop(env, runs, learner, dataclasses.replace(o, envs_per_seed=n), vec_env_fn)
        learner = loop.train(o.progress, o.eval_env_fn, o.progress_position, o.progress_desc)
        env = loop.env  # a smaller one once seeds have stopped
        if any(r.final_state is not None for r in runs):
            return _assemble(learner, runs, act_space)
        return learner
    finally:
        env.close()


def _check_group(run_dirs: Sequence[str | os.PathLike], k_seeds: int, n: int,
                 stop_rules: Sequence[StopRule | None] | None,
                 confirm_env_fn: Callable[..., Any] | None = None) -> None:
    """Refuse a group without seeds, or whose seeds share a run folder, or whose per-seed
    arguments do not match its seeds, or a confirmed rule without its environment, before any
    environment is built."""
    if k_seeds < 1 or len(run_dirs) != k_seeds:
        raise ValueError("train_seeds needs one run_dir per config, and at least one config")
    if len({Path(d).resolve() for d in run_dirs}) != k_seeds:
        raise ValueError("every seed needs its own run_dir")
    if n < 1:
        raise ValueError(f"envs_per_seed must be >= 1, got {n}")
    if stop_rules is not None and len(stop_rules) != k_seeds:
        raise ValueError("train_seeds needs one stop rule (or None) per config")
    if confirm_env_fn is None and any(r is not None and r.confirm for r in stop_rules or ()):
        raise ValueError("a stop rule with a confirmation (StopRule.confirm) needs confirm_env_fn "
                         "or confirm_vec_env_fn")


def _check_yardstick(runs: list[SeedRun], yardstick_fn: Callable[[], Any] | None, obs_dim: int,
                     act_dim: int) -> None:
    """A warm-up the yardstick plays needs one whose observation and action are the
    environment's (``ValueError`` naming what is missing, before any step)."""
    cfg = runs[0].cfg
    short = [r for r in runs if r.buffer.capacity < r.steps]
    if cfg.yardstick_regularization and short:
        raise ValueError(f"yardstick_regularization {cfg.yardstick_regularization:g} holds the actor near "
                         f"the warm-up's transitions for the whole run: buffer_size ({cfg.buffer_size}) must "
                         f"hold the run's {short[0].steps} steps, or the ring overwrites them")
    if not cfg.yardstick_warmup or runs[0].global_step >= cfg.dagger_end:
        return
    if yardstick_fn is None:
        raise ValueError(f"yardstick_warmup {cfg.yardstick_warmup}: the warm-up is played by the "
                         "case's yardstick, and none was given (yardstick_fn)"
                         + (" (DAgger's labels too)" if cfg.yardstick_dagger else ""))
    probe = yardstick_fn()
    if (probe.obs_dim, probe.act_dim) != (obs_dim, act_dim):
        raise ValueError(f"the yardstick reads {probe.obs_dim} observation entries and writes "
                         f"{probe.act_dim} action components; the environment has {obs_dim} and "
                         f"{act_dim}")


def _check_residual(cfg: TD3Config, env: gym.vector.VectorEnv) -> None:
    """A residual learner (``residual``) needs environments that play its corrections of the
    yardstick, with its weight; such environments need a residual learner (its actor starts at a
    zero correction): ``ValueError`` before any step otherwise."""
    subs = getattr(env, "envs", None)  # a SyncVectorEnv of single ones (``train``)
    played = float(getattr(env, "residual", None) or (getattr(subs[0], "residual", 0.0) if subs else 0.0))
    if played == cfg.residual:
        return
    if not cfg.residual:
        raise ValueError(f"the environments play corrections of the yardstick (residual {played:g}) and the "
                         "config learns a policy: set residual to the same weight")
    raise ValueError(f"residual {cfg.residual:g}: the actor learns a correction of the case's yardstick, and "
                     + ("the environments play its actions as they are" if not played else
                        f"the environments weigh it {played:g}")
                     + ": make them with elastica_magnetic_rl.envs.residual.residual_vector_env (msr train "
                       "does)")


def _flat_spaces(env: gym.vector.VectorEnv, total: int) -> tuple[int, int, gym.spaces.Box]:
    """The flat observation and action sizes of ``env`` and its single action space; refuses an
    environment that is not a ``SAME_STEP`` vector environment of ``total`` Box sub-environments."""
    from gymnasium.vector import AutoresetMode

    if env.metadata.get("autoreset_mode") != AutoresetMode.SAME_STEP or env.num_envs != total:
        raise ValueError(f"training needs a SAME_STEP vector environment of {total} "
                         "sub-environments")
    obs_space, act_space = env.single_observation_space, env.single_action_space
    if not isinstance(act_space, gym.spaces.Box) or not isinstance(obs_space, gym.spaces.Box):
        raise TypeError("TD3 needs Box observation and action spaces")
    return int(np.prod(obs_space.shape)), int(np.prod(act_space.shape)), act_space


def _seed_runs(configs: Sequence[TD3Config | None], steps: int, run_dirs: Sequence[str | os.PathLike],
               resume: bool, init_from: Sequence[str | os.PathLike | None] | None,
               metadata: Sequence[dict[str, Any] | None] | None,
               stop_rules: Sequence[StopRule | None] | None, obs_dim: int, act_dim: int,
               n: int) -> list[SeedRun]:
    """Each seed's bookkeeping, its folder opened (new, resumed or started from ``init_from``);
    without ``stop_rules`` each seed keeps its checkpoint's rule."""
    return [SeedRun(k, configs[k], steps, run_dirs[k], resume,
                    init_from[k] if init_from is not None else None,
                    metadata[k] if metadata is not None else None, (obs_dim, act_dim), n,
                    "checkpoint" if stop_rules is None else stop_rules[k])
            for k in range(len(configs))]


def _done(run: SeedRun, steps: int) -> bool:
    """Whether a seed has nothing left to train: stopped by its rule, or resumed at (or past) the
    step budget."""
    return bool(run.stopped) or (run.resumed_here and run.global_step >= steps)


def _group_learner(runs: list[SeedRun], obs_dim: int, act_dim: int,
                   act_space: gym.spaces.Box) -> TD3:
    """The stacked learner of the group's seeds, each resumed from its checkpoint (if any); the
    seeds must stand at the same step."""
    if len({r.global_step for r in runs}) != 1:
        raise ValueError("the seeds of a group resume from checkpoints at different steps ("
                         + ", ".join(f"{r.run_dir}: {r.global_step}" for r in runs) + "): resume "
                         "each with the group it was trained in")
    learner = TD3(obs_dim, act_dim, act_space.low.reshape(-1), act_space.high.reshape(-1),
                  [r.cfg for r in runs])
    for r in runs:
        if r.ckpt is not None:
            learner.load_seed_state(r.k, r.ckpt["agent"])
    return learner


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


def _without_done(train_more: Callable[..., TD3], runs: list[SeedRun],
                  configs: Sequence[TD3Config | None], run_dirs: Sequence[str | os.PathLike],
                  metadata: Sequence[dict[str, Any] | None] | None, steps: int,
                  spaces: tuple[int, int, gym.spaces.Box]) -> TD3:
    """``train_seeds`` of a group some of whose seeds stopped or finished their ``steps`` in an
    earlier call (e.g. resumed in another grouping than they trained in): those are left as they
    are, the others trained (resumed) on their own by ``train_more(configs, steps, run_dirs,
    metadata=, stop_rules=)`` (``train_seeds`` with the call's other settings); the learner of
    them all."""
    active = [k for k, r in enumerate(runs) if not _done(r, steps)]
    for r in runs:
        r.buffer = None  # the active seeds' are loaded again below
    states: dict[int, dict[str, Any]] = {k: r.ckpt["agent"] for k, r in enumerate(runs) if _done(r, steps)}
    if active:
        sub = train_more([configs[k] for k in active], steps, [run_dirs[k] for k in active],
                         metadata=None if metadata is None else [metadata[k] for k in active],
                         stop_rules=[runs[k].stop_rule for k in active])
        states.update({k: sub.seed_state(i) for i, k in enumerate(active)})
    obs_dim, act_dim, act_space = spaces
    probe = TD3(obs_dim, act_dim, act_space.low.reshape(-1), act_space.high.reshape(-1),
                [r.cfg for r in runs[:1]])
    return _assemble(probe, runs, act_space, [states[k] for k in range(len(runs))])


# ----------------------------------------------------------------------------------------------
# The layouts of the single-seed API
# ----------------------------------------------------------------------------------------------
def _single(learner: TD3, k: int = 0) -> TD3Agent:
    """Seed ``k`` of ``learner`` as a :class:`~elastica_magnetic_rl.td3.agent.TD3Agent`."""
    agent = TD3Agent(learner.obs_dim, learner.act_dim, learner.action_low, learner.action_high,
                     learner.configs[k])
    agent.load_state_dict(learner.seed_state(k))
    return agent


def _one_seed(options: dict[str, Any]) -> dict[str, Any]:
    """:class:`GroupOptions` fields of one seed: its ``init_from`` and ``metadata`` as lists."""
    out = dict(options)
    for key in ("init_from", "metadata"):
        if out.get(key) is not None:
            out[key] = [out[key]]
    return out


def train(
    env_fn: Callable[[], gym.Env],
    config: TD3Config | None = None,
    steps: int = 100_000,
    run_dir: str | os.PathLike = "runs/td3",
    **options: Any,
) -> TD3Agent:
    """One seed on one environment (:func:`train_seeds` with K = N = 1); returns its agent.

    ``env_fn`` makes a single Gymnasium environment (flat Box observations, bounded Box actions).
    ``options``: the fields of :class:`GroupOptions` by name (``resume``, ``progress``,
    ``log_fn``, ``eval_env_fn``, ``progress_desc``...), ``init_from`` and ``metadata`` given for
    this one seed (a checkpoint path, a dict), as :func:`train_seeds` describes them.
    """
    learner = train_seeds(lambda k: _wrap(env_fn, k), [config], steps, [run_dir], **_one_seed(options))
    return _single(learner)


def train_vector(
    vec_env_fn: Callable[[], gym.vector.VectorEnv],
    config: TD3Config | None = None,
    steps: int = 100_000,
    run_dir: str | os.PathLike = "runs/td3",
    **options: Any,
) -> TD3Agent:
    """One seed on the N sub-environments of ``vec_env_fn()`` (:func:`train_seeds` with K = 1):
    N transitions and N updates per vector step. ``options`` as :func:`train`."""
    probe: list[gym.vector.VectorEnv] = []

    def make(total: int) -> gym.vector.VectorEnv:
        return probe.pop() if probe else vec_env_fn()

    probe.append(vec_env_fn())
    n_envs = int(probe[0].num_envs)
    learner = train_seeds(make, [config], steps, [run_dir], envs_per_seed=n_envs, **_one_seed(options))
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
