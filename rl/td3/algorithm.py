"""TD3 (Twin Delayed DDPG), the algorithm in one file in the style of CleanRL, for K seeds at once.

Reference: S. Fujimoto, H. van Hoof, D. Meger, "Addressing Function Approximation Error in
Actor-Critic Methods", ICML 2018 (https://arxiv.org/abs/1802.09477).

The three ingredients of TD3, all in :meth:`TD3.update`:

1. **Clipped double-Q learning.** Two critics ``Q1, Q2`` and their targets; the TD target uses
   the smaller target value::

       y = r + gamma * (1 - terminated) * min(Q1'(s', a'), Q2'(s', a'))

2. **Target policy smoothing.** The target action is the target actor's action plus clipped
   Gaussian noise, drawn independently per action dimension::

       a' = clip(mu'(s') + clip(eps, -c, c), -1, 1),   eps ~ N(0, sigma_target^2 I)

3. **Delayed policy updates.** Every ``policy_delay`` critic updates the actor ascends
   ``Q1(s, mu(s))`` and the targets follow by Polyak averaging::

       theta' <- tau * theta + (1 - tau) * theta'

   With :attr:`TD3Config.actor_saturation_penalty` ``lambda > 0`` the actor's loss also holds
   its pre-``tanh`` outputs ``u = MLP(s)`` below 3 in size::

       L_actor = -mean Q1(s, tanh(u)) + lambda * mean(relu(|u| - 3)^2)

Optionally (:attr:`TD3Config.yardstick_warmup` ``U > 0``) a run starts from demonstrations: the
warm-up's transitions come from a hand-designed controller, and before the first TD3 update the
actor clones them (``U`` steps of :meth:`TD3.clone_step`)::

       L_clone = mean || tanh(MLP(s)) - a ||^2

then the critics learn the clone's value (``U`` calls of :meth:`TD3.update` with the actor held,
its targets set to the clone by :meth:`TD3.hold_actor_targets`). With
:attr:`TD3Config.yardstick_regularization` ``beta > 0`` the actor stays held near the warm-up for
the whole run, as in TD3+BC (Fujimoto & Gu, "A Minimalist Approach to Offline Reinforcement
Learning", NeurIPS 2021), on a minibatch ``(s_w, a_w)`` of the warm-up's transitions::

       L_actor = -mean Q1(s, mu(s)) / mean|Q1(s, mu(s))| + beta * mean || tanh(MLP(s_w)) - a_w ||^2

(the normaliser held constant in the gradient, as TD3+BC's ``lambda``). A residual learner
(:attr:`TD3Config.residual`: the actor's output ``mu(s)`` is a correction of the yardstick) may be held
near a zero correction the same way (:attr:`TD3Config.correction_penalty` ``beta > 0``)::

       L_actor = -mean Q1(s, mu(s)) / mean|Q1(s, mu(s))| + beta * mean || mu(s) ||^2

K seeds as one computation
--------------------------
:class:`TD3` holds the networks of ``K`` independent seeds *stacked*: every layer is a batch of K
weight matrices and a forward pass is one batched matrix product per layer
(:class:`~elastica_magnetic_rl.td3.stacked.StackedMLP`); one :meth:`TD3.update` performs the update of
every seed, each on its own minibatch, with its own noise generators and its own Adam moments. The
seeds never mix: each seed's loss depends only on its own parameters, and the batched products
compute every slice exactly as a product of that slice alone, so seed ``k`` of a K-seed
:class:`TD3` is bit-identical to the same seed in a stack of another size (CPU, one thread;
tested over 600 updates; the fused Adam step needs each member's block of a parameter padded to
whole vectors, :class:`~elastica_magnetic_rl.td3.stacked.StackedMLP`). Measured exception: in
bfloat16 a stack of one seed at 16-wide networks takes another product path (the crawler's
256-wide networks agreed with stacks of 4 through 300 updates, both precisions). The one-seed
case with the conveniences of a single agent (``act``, ``policy_module``, ``from_checkpoint``) is
:class:`~elastica_magnetic_rl.td3.agent.TD3Agent`.

Conventions of this implementation
----------------------------------
* Actions are handled in **normalised units** ``[-1, 1]^d`` everywhere inside the agent: the actor
  ends in ``tanh``, the critics see normalised actions, the replay buffer stores them, and all noise
  scales (exploration ``sigma``, target noise and its clip) are fractions of the half-range of the
  action box. Only the action sent to the environment is mapped affinely onto ``[low, high]``
  (:meth:`TD3.scale_action`). For symmetric bounds ``[-m, m]`` this is exactly Fujimoto's
  ``max_action * sigma`` convention.
* Exploration noise is drawn **per action dimension** (not one scalar sample added to every
  dimension).
* The buffer stores ``terminated``, not ``done``: a time-limit truncation still bootstraps, and the
  stored ``next_obs`` of a truncated step is the real final observation.
* ``target_noise_clip`` defaults to Fujimoto's 0.5; the authors of the magnetic-crawler paper used
  0.8 (``TD3Config(target_noise_clip=0.8)``).
* Adam is PyTorch's (defaults: betas 0.9/0.999, eps 1e-8), its fused kernel where the device has
  one; its moments are elementwise, so they too are sliced per seed for a checkpoint.

The training loop (environments, logs, evaluation, checkpoints) is :mod:`elastica_magnetic_rl.runner.loop`;
the checkpoint format is :mod:`elastica_magnetic_rl.runfiles.checkpoint`.
"""

from __future__ import annotations

import copy
import dataclasses
import warnings
from collections.abc import Callable
from fractions import Fraction
from typing import Any

import numpy as np
import torch

from elastica_magnetic.plausibility import SettingNotAppliedWarning

from .config import Q_SCALE_FLOOR, SATURATION_PREACTIVATION, TD3Config
from .networks import Actor, ScaledPolicy, TwinCritic
from .replay_buffer import Batch
from .stacked import StackedMLP, load_member_adam_state, member_adam_state, prefixed, unprefixed
from .steering_inputs import (
    STEERING_BLOCK,
    STEERING_FEATURES,
    mirror_symmetric,
    steering_features,
    steering_to_lab,
)


def update_ratio(updates_per_step: float) -> Fraction:
    """``updates_per_step`` as an exact fraction (its decimal value as written: 0.1 is 1/10), so
    that the updates due after ``n`` transitions, ``floor(n x ratio)`` over a run, never drift."""
    return Fraction(str(float(updates_per_step))).limit_denominator(1_000_000)


def episode_seed(base_seed: int, episode: int) -> int:
    """Seed of ``env.reset`` for episode ``episode`` of a run with seed ``base_seed``.

    Derived with ``numpy.random.SeedSequence`` so that runs with neighbouring seeds do not share
    episodes (``base_seed + episode`` would make episode 1 of seed 0 equal episode 0 of seed 1).
    """
    return int(np.random.SeedSequence([int(base_seed), int(episode)]).generate_state(1)[0])


def _adam(params: list[torch.Tensor], lr: float) -> torch.optim.Adam:
    """PyTorch's Adam (defaults), fused into one kernel per step where the device supports it."""
    return torch.optim.Adam(params, lr=lr, fused=True)


def _step(optimizer: torch.optim.Adam, grads: tuple[torch.Tensor, ...]) -> None:
    """One optimizer step with the given gradients (one per parameter, in order)."""
    for p, g in zip(optimizer.param_groups[0]["params"], grads, strict=True):
        p.grad = g  # kept until the next step (tests compare the last gradients)
    optimizer.step()


def _q_normalised(actor_loss: torch.Tensor, q1_mu: torch.Tensor) -> torch.Tensor:
    """Each seed's ``-mean Q1(s, mu(s))`` over ``mean |Q1(s, mu(s))|`` (at least :data:`Q_SCALE_FLOOR`), the
    normaliser held constant in the gradient, as TD3+BC's ``lambda``: the critic's term of a loss whose
    other term (a distance to the data, or to a zero correction) must not depend on the return's scale."""
    return actor_loss / q1_mu.detach().abs().mean(dim=(1, 2)).clamp_min(Q_SCALE_FLOOR)


def cpu_supports_bf16() -> bool:
    """Whether this CPU has native bfloat16 matrix units (AVX512-BF16 or AMX), so ``bf16`` is
    faster than ``fp32`` here."""
    try:
        return bool(torch.ops.mkldnn._is_mkldnn_bf16_supported())
    except (AttributeError, RuntimeError):
        return False


class PrecisionFallbackWarning(SettingNotAppliedWarning):
    """``bf16`` asked on a CPU without bfloat16 units: the run trains in ``fp32``."""


def precision_used(precision: str, device: str) -> str:
    """The precision a run asking ``precision`` on ``device`` trains in: ``bf16`` is ``fp32`` on a
    CPU without bfloat16 units (:func:`resolve_precision` warns about it)."""
    if precision == "bf16" and torch.device(device).type == "cpu" and not cpu_supports_bf16():
        return "fp32"
    return precision


def resolve_precision(precision: str, device: str) -> str:
    """The precision a run will use: ``bf16`` falls back to ``fp32`` (with a
    :class:`PrecisionFallbackWarning`) on a CPU without bfloat16 units."""
    if precision_used(precision, device) != precision:
        warnings.warn(PrecisionFallbackWarning(
            "precision bf16: this CPU has no bfloat16 matrix units (AVX512-BF16/AMX); training in fp32 "
            "(as its run.json records)"), stacklevel=2)
        return "fp32"
    return precision


# ----------------------------------------------------------------------------------------------
# Agent: K seeds
# ----------------------------------------------------------------------------------------------
class TD3:
    """TD3 for ``K`` independent seeds: stacked actors, twin critics and their targets, each seed's
    Adam moments and RNGs. ``configs`` must agree on every hyperparameter except ``seed`` (the
    seeds train in lockstep: one update of every seed per call of :meth:`update`).

    Seed ``k``'s randomness comes from ``rngs[k]`` (numpy: exploration noise, warm-up actions,
    minibatch indices) and ``torch_rngs[k]`` (target policy noise); its networks are initialised
    from ``configs[k].seed`` exactly as a single ``nn.Linear`` agent would be, without touching the
    global torch RNG.
    """

    def __init__(self, obs_dim: int, act_dim: int, action_low: np.ndarray, action_high: np.ndarray,
                 configs: list[TD3Config]) -> None:
        if not configs:
            raise ValueError("TD3 needs at least one config")
        base = dataclasses.replace(configs[0], seed=0)
        for c in configs[1:]:
            if dataclasses.replace(c, seed=0) != base:
                raise ValueError("seeds trained together must share every hyperparameter but the seed")
        self.configs = list(configs)
        self.config = cfg = configs[0]
        self.n_seeds = k = len(configs)
        self.obs_dim, self.act_dim = int(obs_dim), int(act_dim)
        self.action_low = np.asarray(action_low, dtype=np.float64).reshape(self.act_dim)
        self.action_high = np.asarray(action_high, dtype=np.float64).reshape(self.act_dim)
        if not (np.all(np.isfinite(self.action_low)) and np.all(np.isfinite(self.action_high))):
            raise ValueError("TD3 needs a bounded action space")
        if np.any(self.action_high <= self.action_low):
            raise ValueError("action_high must exceed action_low in every dimension")
        self.device = torch.device(cfg.device)
        self.compute_dtype = {"fp32": torch.float32, "bf16": torch.bfloat16}[
            resolve_precision(cfg.precision, cfg.device)]

        hidden = cfg.hidden_sizes
        # a steering actor reads the observation's last blocks in the robot's frame (actor_input)
        self.steering_start = self.obs_dim - STEERING_BLOCK if cfg.actor_input == "steering" else None
        if self.steering_start is not None and (self.steering_start < 0 or self.act_dim != 3):
            raise ValueError(f"actor_input = 'steering' needs a goto case with three axes: observations of "
                             f"{self.obs_dim} entries, {self.act_dim} actions")
        actor_in = STEERING_FEATURES if self.steering_start is not None else self.obs_dim
        self.actor_net = StackedMLP(k, (actor_in, *cfg.actor_widths, self.act_dim))
        # the critics: members 0..K-1 are the seeds' Q1, members K..2K-1 their Q2
        self.critic_net = StackedMLP(2 * k, (self.obs_dim + self.act_dim, *hidden, 1),
                                     cfg.critic_layer_norm)
        for i, c in enumerate(configs):
            actor, critic = self._initial_networks(c.seed)
            self.actor_net.load_member_state(i, actor.net.state_dict())
            self.critic_net.load_member_state(i, critic.q1_net.state_dict())
            self.critic_net.load_member_state(k + i, critic.q2_net.state_dict())
        self.actor_net.to(self.device)
        self.critic_net.to(self.device)
        self.actor_target_net = copy.deepcopy(self.actor_net).requires_grad_(False)
        self.critic_target_net = copy.deepcopy(self.critic_net).requires_grad_(False)
        self.actor_params = list(self.actor_net.parameters())
        self.critic_params = list(self.critic_net.parameters())
        self.actor_optimizer = _adam(self.actor_params, cfg.actor_lr)
        self.critic_optimizer = _adam(self.critic_params, cfg.critic_lr)

        self.rngs = [np.random.default_rng(c.seed) for c in configs]
        self.torch_rngs = [torch.Generator(device="cpu").manual_seed(c.seed) for c in configs]
        self.num_updates = 0  # critic updates so far (the policy-delay counter)

    def _initial_networks(self, seed: int) -> tuple[Actor, TwinCritic]:
        """The initial networks of one seed: PyTorch's default initialisation drawn from ``seed``
        (actor first, then Q1, Q2); a residual learner's actor (``residual``) with its last layer
        zero, so that it starts at a zero correction (the same draws: the other layers are as
        without)."""
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(seed)
            actor = Actor(self.obs_dim, self.act_dim, self.config.actor_widths, self.steering_start,
                          self.config.actor_mirror)
            critic = TwinCritic(self.obs_dim, self.act_dim, self.config.hidden_sizes,
                                self.config.critic_layer_norm)
        if self.config.residual:
            with torch.no_grad():
                actor.net[-1].weight.zero_()
                actor.net[-1].bias.zero_()
        return actor, critic

    # -- acting ---------------------------------------------------------------------------------
    def scale_action(self, action: np.ndarray) -> np.ndarray:
        """Map normalised actions in [-1, 1]^d (any leading shape) onto ``[low, high]``."""
        center = (self.action_high + self.action_low) / 2.0
        scale = (self.action_high - self.action_low) / 2.0
        return (center + scale * np.asarray(action, dtype=np.float64)).astype(np.float32)

    def random_actions(self, k: int, n: int) -> np.ndarray:
        """Warm-up actions of seed ``k``: ``(n, act_dim)`` uniform on [-1, 1] from ``rngs[k]``."""
        return self.rngs[k].uniform(-1.0, 1.0, size=(n, self.act_dim)).astype(np.float32)

    @torch.no_grad()
    def select_actions(self, obs: np.ndarray, explore: bool) -> np.ndarray:
        """Normalised actions ``mu_k(s)`` of every seed: ``obs`` ``(K, n, obs_dim)`` -> ``(K, n,
        act_dim)`` float32, plus (when exploring) per-dimension noise ``N(0, sigma^2)``, one
        ``(n, act_dim)`` draw from each ``rngs[k]``, then clipped to [-1, 1]. Float32 always."""
        obs_t = torch.as_tensor(np.asarray(obs, dtype=np.float32).reshape(self.n_seeds, -1,
                                                                          self.obs_dim))
        action = self._mu(self.actor_net, obs_t.to(self.device))[1].cpu().numpy().astype(np.float64)
        if explore:
            sigma = self.config.exploration_noise
            noise = np.stack([rng.normal(0.0, sigma, size=action.shape[1:]) for rng in self.rngs])
            action = np.clip(action + noise, -1.0, 1.0)
        return action.astype(np.float32)

    def _mu(self, net: StackedMLP, obs: torch.Tensor,
            dtype: torch.dtype = torch.float32) -> tuple[torch.Tensor, torch.Tensor]:
        """The actors' pre-``tanh`` outputs and their actions in the lab's frame, ``(K, B, act_dim)``
        each, for observations ``(K, B, obs_dim)``: ``tanh(MLP(s))``, or for a steering actor
        ``lab(s, tanh(MLP(features(s))))`` (:mod:`.steering_inputs`; with ``actor_mirror`` the MLP's
        mirror-symmetric part)."""
        if self.steering_start is None:
            pre = net(obs, dtype)
            return pre, torch.tanh(pre)
        features = steering_features(obs, self.steering_start)
        if self.config.actor_mirror:
            pre = mirror_symmetric(lambda x: net(x, dtype), features)
        else:
            pre = net(features, dtype)
        return pre, steering_to_lab(obs, torch.tanh(pre), self.steering_start)

    # -- learning -------------------------------------------------------------------------------
    def _stack(self, batches: list[Batch]) -> tuple[torch.Tensor, ...]:
        def t(field: int, shape: tuple[int, ...]) -> torch.Tensor:
            x = np.stack([np.asarray(b[field], dtype=np.float32) for b in batches]).reshape(shape)
            return torch.as_tensor(x, device=self.device)

        k, n = len(batches), len(batches[0].obs)
        return (t(0, (k, n, self.obs_dim)), t(1, (k, n, self.act_dim)), t(2, (k, n, 1)),
                t(3, (k, n, self.obs_dim)), t(4, (k, n, 1)))

    def _q(self, net: StackedMLP, obs: torch.Tensor, act: torch.Tensor,
           dtype: torch.dtype) -> tuple[torch.Tensor, torch.Tensor]:
        """``Q1, Q2`` of every seed, each ``(K, B, 1)``: both critics in one stacked call."""
        x = torch.cat([obs, act], dim=-1)
        q = net(torch.cat([x, x]), dtype)
        return q[: self.n_seeds], q[self.n_seeds:]

    @torch.no_grad()
    def compute_target(self, rewards: torch.Tensor, next_obs: torch.Tensor,
                       terminated: torch.Tensor) -> torch.Tensor:
        """TD target with target policy smoothing and clipped double Q, ``(K, B, 1)`` from
        ``rewards`` and ``terminated`` ``(K, B, 1)`` and ``next_obs`` ``(K, B, obs_dim)``::

            eps ~ N(0, sigma^2), per dimension;  a' = clip(mu'(s') + clip(eps, -c, c), -1, 1)
            y   = r + gamma * (1 - terminated) * min(Q1'(s', a'), Q2'(s', a'))
        """
        cfg = self.config
        shape = (next_obs.shape[1], self.act_dim)
        eps = torch.stack([torch.randn(shape, generator=g) for g in self.torch_rngs])
        eps = (eps.to(self.device) * cfg.policy_noise).clamp(-cfg.target_noise_clip,
                                                             cfg.target_noise_clip)
        next_action = (self._mu(self.actor_target_net, next_obs, self.compute_dtype)[1] + eps).clamp(-1, 1)
        q1_next, q2_next = self._q(self.critic_target_net, next_obs, next_action, self.compute_dtype)
        return rewards + cfg.gamma * (1.0 - terminated) * torch.min(q1_next, q2_next)

    def update(self, batches: list[Batch], train_actor: bool = True,
               warmup_batches: Callable[[], list[Batch]] | None = None) -> dict[str, torch.Tensor]:
        """One TD3 gradient step of every seed, seed ``k`` on ``batches[k]``: the critics always;
        every ``policy_delay``-th call also the actors (unless ``train_actor`` is false: the critics
        then learn the value of the actors as they are) and a Polyak update of all targets. With
        :attr:`TD3Config.yardstick_regularization` the actors' step also needs ``warmup_batches``
        (called on actor steps only: seed ``k``'s minibatch of its yardstick warm-up's transitions,
        for each seed). Returns each seed's losses
        as ``(K,)`` tensors (``critic_loss``, ``q1``, ``q2``, ``target_q`` and, on actor steps,
        ``actor_loss``, with the regularization also ``warmup_distance``)."""
        cfg, dtype = self.config, self.compute_dtype
        obs, actions, rewards, next_obs, terminated = self._stack(batches)

        # critics: regress both Q1 and Q2 of each seed onto its target y (mean squared errors)
        y = self.compute_target(rewards, next_obs, terminated)
        q1, q2 = self._q(self.critic_net, obs, actions, dtype)
        critic_loss = ((q1 - y) ** 2).mean(dim=(1, 2)) + ((q2 - y) ** 2).mean(dim=(1, 2))
        # the seeds' losses are independent: the gradient of their sum is each seed's own gradient
        _step(self.critic_optimizer, torch.autograd.grad(critic_loss.sum(), self.critic_params))
        self.num_updates += 1
        info = {"critic_loss": critic_loss.detach(), "q1": q1.detach().mean(dim=(1, 2)),
                "q2": q2.detach().mean(dim=(1, 2)), "target_q": y.mean(dim=(1, 2))}

        # delayed actor and target updates: the actor ascends Q1(s, mu(s)), the critic held fixed
        # (only the actors' gradients are asked for, so none is computed for the critics' weights)
        if self.num_updates % cfg.policy_delay == 0 and not train_actor:
            self._polyak(actors=False)
        elif self.num_updates % cfg.policy_delay == 0:
            pre, mu = self._mu(self.actor_net, obs, dtype)
            q1_mu = self.critic_net(torch.cat([obs, mu], dim=-1), dtype, members=slice(0, self.n_seeds))
            actor_loss = -q1_mu.mean(dim=(1, 2))
            if cfg.yardstick_regularization:  # TD3+BC: -Q / mean|Q| + beta * mean ||mu(s_w) - a_w||^2
                distance = self._warmup_distance(warmup_batches)
                actor_loss = _q_normalised(actor_loss, q1_mu) + cfg.yardstick_regularization * distance
                info["warmup_distance"] = distance.detach()
            if cfg.correction_penalty:  # TD3+BC on a zero correction: -Q / mean|Q| + beta * mean ||mu(s)||^2
                size = (mu ** 2).sum(dim=-1).mean(dim=1)
                actor_loss = _q_normalised(actor_loss, q1_mu) + cfg.correction_penalty * size
                info["correction_size"] = size.detach()
            if cfg.actor_saturation_penalty:  # lambda * mean(relu(|u| - 3)^2), each seed its own
                excess = torch.relu(pre.abs() - SATURATION_PREACTIVATION)
                actor_loss = actor_loss + cfg.actor_saturation_penalty * (excess ** 2).mean(dim=(1, 2))
            _step(self.actor_optimizer, torch.autograd.grad(actor_loss.sum(), self.actor_params))
            self._polyak()
            info["actor_loss"] = actor_loss.detach()
        return info

    def _warmup_distance(self, warmup_batches: Callable[[], list[Batch]] | None) -> torch.Tensor:
        """Each seed's ``mean || tanh(MLP(s_w)) - a_w ||^2`` over its warm-up minibatch, ``(K,)``."""
        if warmup_batches is None:
            raise ValueError("yardstick_regularization: update() needs warmup_batches, a minibatch of "
                             "each seed's warm-up transitions")
        obs, actions, _, _, _ = self._stack(warmup_batches())
        mu = self._mu(self.actor_net, obs, self.compute_dtype)[1]
        return ((mu - actions) ** 2).mean(dim=(1, 2))

    def clone_step(self, batches: list[Batch]) -> torch.Tensor:
        """One behaviour-cloning step of every seed's actor, seed ``k`` on ``batches[k]``: the
        actor's Adam descends the mean squared distance of its action to the action taken::

            L_clone = mean || tanh(MLP(s)) - a ||^2

        Returns each seed's loss, ``(K,)``. The critics and the targets are not touched
        (:meth:`hold_actor_targets` sets the target actors to the clones)."""
        obs, actions, _, _, _ = self._stack(batches)
        mu = self._mu(self.actor_net, obs, self.compute_dtype)[1]
        loss = ((mu - actions) ** 2).mean(dim=(1, 2))
        _step(self.actor_optimizer, torch.autograd.grad(loss.sum(), self.actor_params))
        return loss.detach()

    @torch.no_grad()
    def hold_actor_targets(self) -> None:
        """The target actors set to the actors (after cloning: the critics then learn the clones'
        value, not that of the initial networks)."""
        self.actor_target_net.load_state_dict(self.actor_net.state_dict())

    @torch.no_grad()
    def _polyak(self, actors: bool = True) -> None:
        """theta' <- tau * theta + (1 - tau) * theta' for every target parameter (the critics'
        only when not ``actors``: a held actor's target stays its copy), as three multi-tensor
        operations (each product rounded, then the sum: the same floats as the per-parameter
        expression, in a tenth of the calls)."""
        tau = self.config.tau
        params = (self.actor_params if actors else []) + self.critic_params
        targets = [*(self.actor_target_net.parameters() if actors else ()),
                   *self.critic_target_net.parameters()]
        pulled = torch._foreach_mul(params, tau)
        torch._foreach_mul_(targets, 1.0 - tau)
        torch._foreach_add_(targets, pulled)

    # -- one seed's view ------------------------------------------------------------------------
    def actor_state(self, k: int, target: bool = False) -> dict[str, torch.Tensor]:
        """Seed ``k``'s actor (or target actor) as an :class:`Actor` state dict."""
        state = prefixed((self.actor_target_net if target else self.actor_net).member_state(k), "net.")
        if self.steering_start is not None:
            state["steering_start"] = torch.tensor(self.steering_start)
        if self.config.actor_mirror:
            state["steering_mirror"] = torch.tensor(1)
        return state

    def critic_state(self, k: int, target: bool = False) -> dict[str, torch.Tensor]:
        """Seed ``k``'s twin critic (or its target) as a :class:`TwinCritic` state dict."""
        net = self.critic_target_net if target else self.critic_net
        return {**prefixed(net.member_state(k), "q1_net."),
                **prefixed(net.member_state(self.n_seeds + k), "q2_net.")}

    def actor_module(self, k: int = 0) -> Actor:
        """A standalone copy of seed ``k``'s actor (float32, CPU, eval mode)."""
        actor = Actor(self.obs_dim, self.act_dim, self.config.actor_widths, self.steering_start,
                      self.config.actor_mirror)
        actor.load_state_dict(self.actor_state(k))
        return actor.eval().requires_grad_(False)

    def critic_module(self, k: int = 0, target: bool = False) -> TwinCritic:
        critic = TwinCritic(self.obs_dim, self.act_dim, self.config.hidden_sizes,
                            self.config.critic_layer_norm)
        critic.load_state_dict(self.critic_state(k, target))
        return critic.eval().requires_grad_(False)

    def policy_module(self, k: int = 0) -> ScaledPolicy:
        """A standalone copy of seed ``k``'s actor mapping observations to environment actions."""
        policy = ScaledPolicy(self.actor_module(k), self.action_low, self.action_high)
        return policy.eval().requires_grad_(False)

    def seed_state(self, k: int) -> dict[str, Any]:
        """Everything of seed ``k``: networks and targets (plain-module state dicts), Adam moments
        (same naming) and step counts, its RNG states and the update counter."""
        return {
            "actor": self.actor_state(k),
            "critic": self.critic_state(k),
            "actor_target": self.actor_state(k, target=True),
            "critic_target": self.critic_state(k, target=True),
            "actor_optimizer": member_adam_state(self.actor_optimizer, self.actor_net, [k],
                                                     ["net."]),
            "critic_optimizer": member_adam_state(
                self.critic_optimizer, self.critic_net, [k, self.n_seeds + k],
                ["q1_net.", "q2_net."]),
            "numpy_rng": self.rngs[k].bit_generator.state,
            "torch_rng": self.torch_rngs[k].get_state(),
            "num_updates": self.num_updates,
        }

    def load_seed_state(self, k: int, state: dict[str, Any], same_counters: bool = True) -> None:
        """Inverse of :meth:`seed_state` (the seeds of one :class:`TD3` must share their counters
        to train on together; ``same_counters=False`` lets a learner that only holds seeds at
        their ends, e.g. some stopped early, take them all)."""
        counters = (int(state["num_updates"]), int(state["actor_optimizer"]["step"]),
                    int(state["critic_optimizer"]["step"]))
        if same_counters and k > 0 and counters != self._counters():
            raise ValueError("seeds trained together must be at the same update count")
        self.actor_net.load_member_state(k, unprefixed(state["actor"], "net."))
        self.actor_target_net.load_member_state(k, unprefixed(state["actor_target"], "net."))
        for target, name in ((False, "critic"), (True, "critic_target")):
            net = self.critic_target_net if target else self.critic_net
            net.load_member_state(k, unprefixed(state[name], "q1_net."))
            net.load_member_state(self.n_seeds + k, unprefixed(state[name], "q2_net."))
        load_member_adam_state(self.actor_optimizer, self.actor_net, [k], ["net."],
                                   state["actor_optimizer"])
        load_member_adam_state(self.critic_optimizer, self.critic_net, [k, self.n_seeds + k],
                                   ["q1_net.", "q2_net."], state["critic_optimizer"])
        self.rngs[k].bit_generator.state = state["numpy_rng"]
        self.torch_rngs[k].set_state(state["torch_rng"])
        self.num_updates = counters[0]

    def _counters(self) -> tuple[int, int, int]:
        """Critic updates, Adam steps of the actors and of the critics."""
        return (self.num_updates,
                member_adam_state(self.actor_optimizer, self.actor_net, [], [])["step"],
                member_adam_state(self.critic_optimizer, self.critic_net, [], [])["step"])
