"""One group of seeds in one training loop, in its named steps (:class:`GroupLoop`).

:func:`~elastica_magnetic_rl.runner.loop.train_seeds` checks its arguments, opens each seed's
:class:`~elastica_magnetic_rl.runner.seed_run.SeedRun` and builds the stacked learner; a
:class:`GroupLoop` then runs the vector steps: act, step the environments, store, learn, log the
ended episodes, evaluate, apply the stop rules, restart the ended episodes and write the checkpoints
(between episodes, or inside them with the environments' state). The scheduling rules (which
vector steps evaluate and checkpoint) are in :mod:`elastica_magnetic_rl.runner.loop`'s docstring.
"""

from __future__ import annotations

import functools
import random
import time
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
import torch

from ..runfiles.checkpoint import state_to_numpy, state_to_tensors
from ..td3.algorithm import TD3, update_ratio
from .evaluation import EVAL_SEED, ActorPolicy, evaluate, evaluate_many, flat_observation
from .progress import GroupProgress
from .seed_run import SeedRun

#: Where a group's training time goes (``timing`` in every checkpoint, s): choosing actions,
#: stepping and resetting the environments, storing transitions, TD3 updates, episode logs,
#: evaluations, checkpoints.
TIMING_KEYS = ("act", "env", "store", "update", "log", "evaluation", "checkpoint")


class GroupLoop:
    """The training loop of one group of K seeds on one vector environment, in its named steps:
    :meth:`act`, the environments' step, :meth:`store`, :meth:`learn`, :meth:`log_episode_ends`,
    :meth:`evaluate`, :meth:`start_next_episodes` and the checkpoints (at episode boundaries, or
    inside episodes with the environments' state). The order of these steps, and of the RNG draws
    in them, is what makes a seed bit-identical alone and in a group, and after a resume."""

    def __init__(self, env: gym.vector.VectorEnv, runs: list[SeedRun], learner: TD3, options: Any,
                 vec_env_fn: Callable[[int], gym.vector.VectorEnv] | None = None) -> None:
        """``options``: the :class:`~elastica_magnetic_rl.runner.loop.GroupOptions` of the call
        (its sub-environments per seed, logs, evaluation, confirmation, hand-back and yardstick
        makers); ``vec_env_fn`` makes a smaller vector environment once seeds stop."""
        n = int(options.envs_per_seed)
        self.env, self.runs, self.learner, self.n = env, runs, learner, n
        # asked at each step where every episode has just ended: hand the seeds back (see
        # :meth:`hands_back`); ``handed_back`` once done
        self.hand_back, self.handed_back = options.hand_back, False
        self.vec_env_fn = vec_env_fn
        self.confirm_env_fn, self.confirm_vec_env_fn = options.confirm_env_fn, options.confirm_vec_env_fn
        self.cfg, self.k_seeds = learner.config, len(runs)
        self.log_fn, self.eval_vec_env_fn = options.log_fn, self.evaluation_maker(options.eval_vec_env_fn)
        self.obs_dim, self.act_dim = learner.obs_dim, learner.act_dim
        # a Gymnasium vector environment that can save its state allows checkpoints inside episodes
        self.can_save_env = hasattr(env, "get_state") and hasattr(env, "set_state")
        self.actions = np.zeros((self.k_seeds, n, self.act_dim), dtype=np.float32)
        self.timing = {key: 0.0 for key in TIMING_KEYS}
        self.clock = time.perf_counter()
        # the unspent fraction of an update of a fractional updates_per_step (the group's seeds
        # are in lockstep: one value, kept in every seed's checkpoint)
        self.update_credit = self.lead.update_credit
        # a warm-up played by the case's yardstick (``yardstick_warmup``): one controller per
        # sub-environment while the warm-up and DAgger after it (``yardstick_dagger``) last, else None
        self.yardstick_fn = options.yardstick_fn
        self.yardsticks: list[Any] | None = None
        if self.cfg.yardstick_warmup and self.lead.global_step < self.cfg.dagger_end:
            self.yardsticks = self._new_yardsticks()
        # each transition's label for DAgger or a clone of the commands: the yardstick's command
        self.labels = np.zeros_like(self.actions) if self.cfg.labelled else None

    def evaluation_maker(self, make: Callable[..., Any] | None) -> Callable[..., Any] | None:
        """``make`` (an evaluation environment's maker) with the run's ``eval_duration`` when it
        sets one (the maker then takes a ``duration`` keyword); the case's otherwise. The
        stop rule's confirmation keeps the case's: a ``target`` rule is refused with another."""
        if make is None or not self.cfg.eval_duration:
            return make
        return functools.partial(make, duration=self.cfg.eval_duration)

    def _new_yardsticks(self) -> list[Any]:
        if self.yardstick_fn is None:
            raise ValueError("yardstick_warmup needs the case's yardstick: train_seeds(..., "
                             "yardstick_fn=) makes one controller per sub-environment")
        return [self.yardstick_fn() for _ in range(self.k_seeds * self.n)]

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
            self.env.set_state(state_to_numpy(vector_state["env_state"]))
            for k, run in enumerate(runs):
                for key, field in (("ep_return", run.ep_return), ("ep_len", run.ep_len),
                                   ("ep_id", run.ep_id), ("noise", run.noise),
                                   ("noise_pos", run.noise_pos)):
                    field[:] = state_to_numpy(vector_state[key])[self.sub(k)]
            for controller, state in zip(self.yardsticks or (), vector_state.get("yardsticks") or (),
                                         strict=False):
                controller.set_state(state)
            return state_to_numpy(vector_state["obs"]).reshape(total, self.obs_dim)
        for controller in self.yardsticks or ():
            controller.reset()
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
        random during the warm-up (the yardstick's action plus noise with ``yardstick_warmup``),
        then ``mu + noise``; with ``yardstick_dagger`` each one's label too (:meth:`label`)."""
        learner, cfg, n = self.learner, self.cfg, self.n
        n_random = int(np.clip(cfg.learning_starts - self.lead.global_step, 0, n))
        if self.labels is not None:
            self.label(obs, n_random)
        if n_random < n:
            mu = learner.select_actions(obs.reshape(self.k_seeds, n, self.obs_dim)[:, n_random:],
                                        explore=False).astype(np.float64)
        for k, run in enumerate(self.runs):
            if n_random and self.yardsticks is not None:  # one noise draw for every sub-env
                noise = run.exploration(0, learner.rngs[k])
                shown = [self.yardsticks[k * n + j].act(obs[k * n + j]) for j in range(n_random)]
                if self.labels is not None:  # the warm-up's label: the yardstick's own command
                    self.labels[k, :n_random] = shown
                self.actions[k, :n_random] = np.clip(np.asarray(shown, dtype=np.float64)
                                                     + noise[:n_random], -1.0, 1.0)
                if n_random < n:
                    self.actions[k, n_random:] = np.clip(mu[k] + noise[n_random:], -1.0, 1.0)
                continue
            if n_random:
                self.actions[k, :n_random] = learner.random_actions(k, n_random)
            if n_random < n:
                noise = run.exploration(n_random, learner.rngs[k])
                self.actions[k, n_random:] = np.clip(mu[k] + noise, -1.0, 1.0)
            elif cfg.noise_color > 0:  # the sequences keep time during the warm-up too
                run.exploration(n, learner.rngs[k])
        return self.actions.reshape(self.k_seeds * n, self.act_dim)

    def label(self, obs: np.ndarray, n_random: int) -> None:
        """DAgger's labels of this vector step's transitions past the warm-up (``yardstick_dagger``):
        the yardstick's command at each observation the actor meets
        (:meth:`~elastica_magnetic_rl.envs.steering_yardstick.SteeringYardstick.label`) while DAgger
        lasts, zeros after it (never drawn: the labels are read only during DAgger); the
        yardsticks are let go once it ends."""
        self.labels[:, n_random:] = 0.0
        if self.yardsticks is None or n_random == self.n:
            return
        if self.lead.global_step >= self.cfg.dagger_end:
            self.yardsticks = None
            return
        for k in range(self.k_seeds):
            for j in range(n_random, self.n):
                i = k * self.n + j
                self.labels[k, j] = self.yardsticks[i].label(obs[i])

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
                label = None if self.labels is None else self.labels[k, j]
                run.buffer.add(obs[i], actions[i], float(rewards[i]), real_next[i], bool(terminated[i]),
                               label)
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
        if cfg.yardstick_warmup and before <= cfg.learning_starts:  # the first updates
            self.start_from_yardstick()
        owed = self.update_credit + n_learn * update_ratio(cfg.updates_per_step)
        n_updates = int(owed)  # floor: owed >= 0
        self.update_credit = owed - n_updates
        for run in self.runs:
            run.update_credit = self.update_credit
        held = self.warmup_batches if cfg.yardstick_regularization else None
        dagger = cfg.yardstick_dagger > 0 and before < cfg.dagger_end  # this step's updates are DAgger's
        for _ in range(n_updates):
            if dagger:
                info = self.dagger_update()
                continue
            info = learner.update([r.buffer.sample(cfg.batch_size, learner.rngs[k])
                                   for k, r in enumerate(runs)], warmup_batches=held,
                                  train_actor=learner.num_updates >= cfg.critic_warmup)
            if learner.num_updates % cfg.log_every == 0:
                for name, values in info.items():
                    for k, run in enumerate(runs):
                        run.writer.add_scalar(f"losses/{name}", float(values[k]), run.global_step)

    def dagger_update(self) -> dict[str, Any]:
        """One update of DAgger (``yardstick_dagger``), every seed at once: the critics learn the
        actor's value (a TD3 update with the actor held), then the actor takes a clone step on a
        minibatch of the whole buffer's labels (the yardstick's commands at the states met),
        and the target actor is set to it. Returns the losses (``clone_loss`` besides the critics')."""
        cfg, learner, runs = self.cfg, self.learner, self.runs
        info = learner.update([r.buffer.sample(cfg.batch_size, learner.rngs[k]) for k, r in enumerate(runs)],
                              train_actor=False)
        info["clone_loss"] = learner.clone_step([r.buffer.sample_labels(cfg.batch_size, learner.rngs[k])
                                                 for k, r in enumerate(runs)])
        learner.hold_actor_targets()
        if learner.num_updates % cfg.log_every == 0:
            for name, values in info.items():
                for k, run in enumerate(runs):
                    run.writer.add_scalar(f"losses/{name}", float(values[k]), run.global_step)
        return info

    def warmup_batches(self) -> list[Any]:
        """Each seed's minibatch of its warm-up's transitions (the first ``learning_starts`` of its
        buffer, the yardstick's), for ``yardstick_regularization``."""
        cfg, learner = self.cfg, self.learner
        return [r.buffer.sample_first(cfg.learning_starts, cfg.batch_size, learner.rngs[k])
                for k, r in enumerate(self.runs)]

    def start_from_yardstick(self) -> None:
        """The end of a warm-up the yardstick played (``yardstick_warmup`` U): every seed's actor
        clones the warm-up's actions (U steps; as played, or as commanded with ``clone_labels``), its
        target actor is set to the clone, and the
        critics learn the clone's value (U updates, the actor held); each seed is then evaluated
        (its own environment: the training's episodes go on), so ``best.pt`` starts from the
        clone."""
        cfg, learner, runs = self.cfg, self.learner, self.runs

        def batches(labels: bool = False) -> list[Any]:
            return [(r.buffer.sample_labels if labels else r.buffer.sample)(cfg.batch_size, learner.rngs[k])
                    for k, r in enumerate(runs)]

        for _ in range(cfg.yardstick_warmup):  # the critics below learn the actions as played
            clone_loss = learner.clone_step(batches(labels=cfg.clone_labels == "commanded"))
        learner.hold_actor_targets()
        for _ in range(cfg.yardstick_warmup):
            info = learner.update(batches(), train_actor=False)
        if not cfg.yardstick_dagger:  # DAgger's teacher stays
            self.yardsticks = None
        for k, run in enumerate(runs):
            run.writer.add_scalar("pretrain/clone_loss", float(clone_loss[k]), run.global_step)
            run.writer.add_scalar("pretrain/critic_loss", float(info["critic_loss"][k]), run.global_step)
        self.evaluate([k for k, run in enumerate(runs) if not run.stopped and run.evaluation.enabled])

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
        same returns as one by one; for the crawler also faster for one seed alone: the batched
        simulator), else one after the other."""
        learner, runs = self.learner, self.runs
        if due and self.eval_vec_env_fn is not None:
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
        for i in np.flatnonzero(ended) if self.yardsticks is not None else ():
            self.yardsticks[i].reset()

    # -- checkpoints ---------------------------------------------------------------------------
    def vector_state(self, obs: np.ndarray) -> dict[str, Any] | None:
        """The environments' state and each seed's episode state, for a checkpoint inside
        episodes (``None`` when the environments cannot save theirs)."""
        if not self.can_save_env:
            return None
        runs = self.runs
        return {"num_envs": self.k_seeds * self.n, "seeds": [r.cfg.seed for r in runs],
                "env_state": state_to_tensors(self.env.get_state()),
                "obs": torch.from_numpy(obs.copy()),
                "yardsticks": None if self.yardsticks is None else [c.state() for c in self.yardsticks],
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
            handing_back = all_ended and self.hands_back()
            if (checkpoint_due or handing_back) and all_ended:  # nothing of the new episodes to save
                self.checkpoint_between_episodes()
                checkpoint_due = False
                self.lap("checkpoint")
            if handing_back:  # the seeds go on elsewhere, from these checkpoints
                self.handed_back = True
                return next_obs
            self.start_next_episodes(ended, reset_seeds, next_obs)
        self.lap("env")
        if checkpoint_due:  # inside episodes: the environments' state goes along
            self.checkpoint_inside_episodes(next_obs)
            self.lap("checkpoint")
        return next_obs

    def hands_back(self) -> bool:
        """Whether the group stops here so that its seeds go on in other groups (the caller's
        ``hand_back`` says yes, and at least two seeds still train: one alone has nowhere better
        to go). Asked only where every episode has just ended: the checkpoints written there
        resume in any grouping (:mod:`elastica_magnetic_rl.runner.loop` says how exactly)."""
        return (self.hand_back is not None and sum(not r.stopped for r in self.runs) >= 2
                and bool(self.hand_back()))

    def show_progress(self) -> None:
        """The group's rate and ETA (evaluations included) on its first seed's progress bar."""
        lead = self.lead
        estimate = self.progress.estimate(self.timing, lead.global_step, lead.steps,
                                          sum(not r.stopped for r in self.runs), self.cfg.eval_every
                                          if lead.evaluation.enabled else 0, lead.evaluation.last_step,
                                          lead.evaluation.warmup_end)
        if lead.bar is not None and not getattr(lead.bar, "disable", True):
            base = self.bar_desc.get(id(lead), "")
            lead.bar.set_description_str(f"{base} | {GroupProgress.describe(estimate)}".lstrip(" |"),
                                         refresh=False)

    def apply_stop_rules(self, evaluated: list[int]) -> None:
        """The seeds just evaluated whose stop rule fires (and, for a rule with a confirmation,
        whose actor passes it) write their final checkpoint and stop (they leave the group at its
        next common episode boundary)."""
        for k in evaluated:
            run = self.runs[k]
            reason = None if run.stop_rule is None else run.stop_rule.decide(run.evaluation_returns())
            if reason is not None and run.stop_rule.confirm is not None:
                self.lap("checkpoint")
                reason = self.confirm_stop(k, reason)
                self.lap("evaluation")
            if reason is not None:
                run.stop(self.learner, reason)

    def confirm_stop(self, k: int, reason: str) -> str | None:
        """The fired rule of seed ``k`` confirmed: one episode of its deterministic actor in
        ``confirm_vec_env_fn`` (one sub-environment: the same return, the batched simulator's
        speed) or ``confirm_env_fn`` (for the crawler: 10 s from a zero field in the accurate
        physics);
        the reason with the confirmation if its return reaches the rule's threshold, else
        ``None`` (the seed trains on). Either way the return is logged (TensorBoard
        ``eval/confirmation_return``) and shown on the seed's progress output."""
        run = self.runs[k]
        rule = run.stop_rule
        policy = ActorPolicy.of_seed(self.learner, k)
        if self.confirm_vec_env_fn is not None:
            result = evaluate_many([policy], self.confirm_vec_env_fn, 1, EVAL_SEED)[0]
        else:
            result = evaluate(policy, self.confirm_env_fn, 1, EVAL_SEED)
        confirmed = float(result.mean_return)
        run.writer.add_scalar("eval/confirmation_return", confirmed, run.global_step)
        passed = confirmed >= rule.threshold
        message = (f"seed {run.cfg.seed} at step {run.global_step}: {reason}; "
                   f"{'confirmed' if passed else 'NOT confirmed'} in the {rule.confirm} physics "
                   f"(return {confirmed:.4g}, threshold {rule.threshold:.4g})"
                   f"{'' if passed else ': training goes on'}")
        if run.bar is not None and not getattr(run.bar, "disable", True):
            run.bar.write(message)
        if not passed:
            return None
        return f"{reason}; confirmed in the {rule.confirm} physics (return {confirmed:.4g})"

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
        if self.yardsticks is not None:  # every episode restarts: fresh controllers
            self.yardsticks = self._new_yardsticks()
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

    def train(self, progress: bool, eval_env_fn: Callable[[], gym.Env] | None,
              position: int | None, desc: str | None) -> TD3:
        """Train the group's seeds to their step budget: the global RNGs and the environments
        restored or started, each seed's logs and progress bar opened, then :meth:`run`."""
        runs, learner = self.runs, self.learner
        eval_env_fn = self.evaluation_maker(eval_env_fn)
        vector_state = self.restore_global_rngs()
        for k, run in enumerate(runs):
            run.open(progress, None if position is None else position + k,
                     f"{desc or 'seed'} {run.cfg.seed}" if len(runs) > 1 else desc, eval_env_fn)
            if run.evaluation.restore_best:
                run.evaluation.write_best(run.header(learner))
        return self.run(self.first_observations(vector_state))

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
                if self.handed_back:  # checkpointed: no final evaluation here
                    break
            if not self.handed_back and not (lead.resumed_here and lead.global_step == start_step):
                self.finish(obs, ended, start_step)
        finally:
            for run in every_run:
                run.close()
            torch.use_deterministic_algorithms(prev_deterministic)
        return self.learner


__all__ = ["TIMING_KEYS", "GroupLoop"]
