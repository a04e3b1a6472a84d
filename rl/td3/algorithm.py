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
its targets set to the clone by :meth:`TD3.hold_actor_targets`).

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
import math
import warnings
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, TypeVar

import numpy as np
import torch

from elastica_magnetic.plausibility import SettingNotAppliedWarning

from .networks import Actor, ScaledPolicy, TwinCritic
from .replay_buffer import Batch
from .stacked import StackedMLP, load_member_adam_state, member_adam_state, prefixed, unprefixed

#: Arithmetic choices of :attr:`TD3Config.precision`.
PRECISIONS = ("fp32", "bf16")
#: ``|pre-tanh output|`` of the actor above which it counts as saturated (``tanh(3) = 0.995``):
#: there its gradient is below 1 % of the unsaturated one.
SATURATION_PREACTIVATION = 3.0


# ----------------------------------------------------------------------------------------------
# Hyperparameters
# ----------------------------------------------------------------------------------------------
_Part = TypeVar("_Part")


#: Most gradient updates per environment step: high update-to-data methods (REDQ, DroQ) use 20; far
#: beyond, a run spends its time updating on the same few transitions (1e9 stalled a run forever).
MAX_UPDATES_PER_STEP = 64
#: The largest learning rate a config takes (TD3's is 3e-4; Adam's steps above this only diverge).
MAX_LEARNING_RATE = 0.1


def _is_integer_setting(key: str, default: Any) -> bool:
    return isinstance(default, int) and not isinstance(default, bool) and key != "updates_per_step"


def _setting_form(key: str, default: Any) -> str:
    """What the text of setting ``key`` (default ``default``) must look like, for messages."""
    if key.endswith("hidden_sizes"):
        return "comma-separated layer widths, e.g. 256,256" + (", or none" if default is None else "")
    if isinstance(default, bool):
        return "true or false"
    if key == "noise_color":
        return "a number: the exponent of the noise's spectrum 1/f^beta (0 white, 1 pink, 2 red)"
    return "an integer" if _is_integer_setting(key, default) else "a number"


def setting_option(key: str, value: Any = None) -> str:
    """How the command line sets a run setting: ``--set batch_size=64``, or the setting's own
    option (``--device cuda``, ``--precision bf16``); without ``value``, ``--set batch_size``."""
    own = {"device": "--device", "precision": "--precision", "seed": "--seed-offset"}
    if key in own:
        return own[key] if value is None else f"{own[key]} {value}"
    if isinstance(value, (tuple, list)):
        value = ",".join(str(v) for v in value)
    return f"--set {key}" if value is None else f"--set {key}={value}"


@dataclass
class Hyperparameters:
    """What TD3 learns with: networks, optimisation, replay, exploration and TD3's own settings
    (defaults: the paper's / Fujimoto's values). Noise scales are in normalised action units
    (fractions of the action half-range)."""

    # networks and optimisation
    hidden_sizes: tuple[int, ...] = (256, 256)
    """Hidden layer widths (ReLU) of each critic, and of the actor unless
    :attr:`actor_hidden_sizes` says otherwise."""
    actor_hidden_sizes: tuple[int, ...] | None = None
    """Hidden layer widths of the actor when they differ from the critics' (e.g. a narrower
    actor); ``None`` (and a checkpoint without the key): the same as :attr:`hidden_sizes`."""
    critic_layer_norm: bool = False
    """Layer normalisation (PyTorch's ``LayerNorm``, learned gain and bias) after every hidden
    linear layer of both critics, before the ReLU (Ball et al. 2023): bounds how far a critic
    extrapolates beyond the replay data. Off in the paper's recipe; the actor never has it."""
    actor_saturation_penalty: float = 0.0
    """Weight ``lambda`` of a penalty on the actor's pre-``tanh`` outputs ``u`` beyond
    :data:`SATURATION_PREACTIVATION`, added to its loss: ``lambda * mean(relu(|u| - 3)^2)``
    (per action dimension and state). It keeps the outputs where ``tanh`` still passes the
    critic's gradient, so a saturated actor can still learn; it leaves the reachable actions as
    they are (``tanh(3) = 0.995``) and the reward untouched. 0 (the paper's recipe): off."""
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
    """Std of the Gaussian exploration noise, per action dimension."""
    noise_color: float = 0.0
    """Exponent ``beta`` of the exploration noise's power spectrum ``1 / f^beta``: 0 is white noise, drawn
    independently at every step (the paper's); 1 pink (Eberhard et al. 2023), 2 red. Colored noise is drawn as
    whole sequences (:func:`elastica_magnetic_rl.td3.exploration.colored_noise`), one per episode and
    sub-environment."""
    noise_horizon: int = 2000
    """Length of a colored-noise sequence, steps (a new one at every episode start, and when one
    runs out); the crawler's 20 s episode is 2000 steps."""
    # TD3 specifics
    policy_noise: float = 0.2
    """Std of the target policy smoothing noise."""
    target_noise_clip: float = 0.5
    """Clip of the target policy noise: 0.5 as Fujimoto et al.; the crawler paper's authors
    used 0.8."""
    policy_delay: int = 2
    """Actor and target networks are updated once every ``policy_delay`` critic updates."""
    updates_per_step: float = 1
    """Gradient steps per environment transition (after warm-up): an integer, or a fraction (e.g.
    0.5: one update every second transition), the updates then due at the end of each vector step
    counted exactly (an accumulator of the unspent fraction, kept in the checkpoints); see
    :func:`update_ratio`."""
    yardstick_warmup: int = 0
    """Start from the case's yardstick (0, the paper's: a warm-up of uniform random actions). With
    ``U > 0`` the warm-up's ``learning_starts`` transitions are played by the case's hand-designed
    controller (its action plus the exploration noise), then, before TD3's first update, the actor
    learns to copy the warm-up's actions (``U`` behaviour-cloning steps, :meth:`TD3.clone_step`) and
    the critics learn that actor's value (``U`` critic updates with the actor held): TD3 then
    improves a policy that already does what the yardstick does, instead of one from scratch (as
    Hester et al. 2018 and Nair et al. 2018 start from demonstrations)."""


@dataclass
class RunSettings:
    """How a seed's run computes, not what it learns from: its seed, where and in which precision
    its networks compute, and determinism."""

    seed: int = 0
    device: str = "cpu"
    """``"cpu"`` or ``"cuda"`` (any ``torch.device`` string)."""
    precision: str = "fp32"
    """Arithmetic of the networks' matrix products in the updates: ``"fp32"`` (the paper's) or
    ``"bf16"`` (bfloat16 products on float32 master weights; see
    :class:`~elastica_magnetic_rl.td3.stacked.StackedMLP`). Acting always runs in float32."""
    torch_deterministic: bool = True
    """Switch on ``torch.use_deterministic_algorithms`` while training (restored afterwards)."""


@dataclass
class Schedule:
    """When a run checkpoints, logs and evaluates (what Stable-Baselines3 leaves to ``learn()``'s
    callbacks): these change no weight, so a resumed run may change them."""

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


@dataclass
class TD3Config(Schedule, RunSettings, Hyperparameters):
    """A seed's settings in one flat record, the ``config`` of its checkpoints and ``run.json``:
    its :class:`Hyperparameters`, :class:`RunSettings` and :class:`Schedule` (fields in that
    order), checked together."""

    def __post_init__(self) -> None:
        self.hidden_sizes = tuple(int(h) for h in self.hidden_sizes)
        if self.actor_hidden_sizes is not None:
            self.actor_hidden_sizes = tuple(int(h) for h in self.actor_hidden_sizes)
        for name in ("hidden_sizes", "actor_hidden_sizes"):
            widths = getattr(self, name)
            if widths is not None and (not widths or min(widths) < 1):
                raise ValueError(f"{name} must be one or more layers of >= 1 unit, got "
                                 f"{list(widths)}")
        for name in ("actor_lr", "critic_lr"):  # 0 changes no weight; Adam above 1 only diverges
            value = getattr(self, name)
            if not (math.isfinite(value) and 0.0 < value <= MAX_LEARNING_RATE):
                raise ValueError(f"{name} must be a finite number in (0, {MAX_LEARNING_RATE:g}] (Adam's "
                                 f"step size; TD3's is 3e-4), got {value}")
        if not 0.0 < self.tau <= 1.0:
            raise ValueError(f"tau must be in (0, 1], got {self.tau}")
        if not 0.0 <= self.gamma <= 1.0:
            raise ValueError(f"gamma must be in [0, 1], got {self.gamma}")
        for name in ("batch_size", "buffer_size", "policy_delay", "checkpoint_every", "log_every"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        if self.precision not in PRECISIONS:
            raise ValueError(f"precision must be one of {', '.join(PRECISIONS)}, got {self.precision!r}")
        if self.eval_episodes < 1:
            raise ValueError(f"eval_episodes must be >= 1, got {self.eval_episodes}")
        ratio = self.updates_per_step
        if not (isinstance(ratio, int | float) and math.isfinite(ratio)
                and 0 < ratio <= MAX_UPDATES_PER_STEP):
            raise ValueError(f"updates_per_step must be a finite number in (0, {MAX_UPDATES_PER_STEP}] "
                             f"(updates per transition), got {ratio}")
        if float(ratio).is_integer():
            self.updates_per_step = int(ratio)
        for name in ("learning_starts", "eval_every", "yardstick_warmup"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        for name in ("exploration_noise", "policy_noise", "target_noise_clip", "noise_color",
                     "actor_saturation_penalty"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value}")
        if self.noise_horizon < 2:
            raise ValueError(f"noise_horizon must be >= 2 steps, got {self.noise_horizon}")
        if self.yardstick_warmup and self.learning_starts < self.batch_size:
            raise ValueError(f"yardstick_warmup {self.yardstick_warmup} clones the warm-up's "
                             f"transitions: learning_starts ({self.learning_starts}) must be at least "
                             f"batch_size ({self.batch_size}) for a minibatch of them")
        if self.buffer_size < self.batch_size:
            raise ValueError(f"buffer_size ({self.buffer_size}) must be >= batch_size "
                             f"({self.batch_size}): a minibatch is drawn from the replay buffer, so "
                             "a smaller buffer never gives one and no weight is ever updated")

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    @property
    def actor_widths(self) -> tuple[int, ...]:
        """The actor's hidden layer widths (:attr:`actor_hidden_sizes`, else :attr:`hidden_sizes`)."""
        return self.actor_hidden_sizes if self.actor_hidden_sizes is not None else self.hidden_sizes

    def part(self, kind: type[_Part]) -> _Part:
        """Its :class:`Hyperparameters`, :class:`RunSettings` or :class:`Schedule`."""
        return kind(**{f.name: getattr(self, f.name) for f in dataclasses.fields(kind)})

    @classmethod
    def settable(cls) -> tuple[str, ...]:
        """The settings ``msr train --set KEY=VALUE`` and a spec's ``[training.td3]`` take: the
        :class:`Hyperparameters` and the :class:`Schedule` (a run's seed, device and precision
        have options of their own)."""
        return tuple(f.name for f in (*dataclasses.fields(Hyperparameters),
                                      *dataclasses.fields(Schedule)))

    @classmethod
    def parse_setting(cls, key: str, text: str) -> Any:
        """The value of setting ``key`` from its text (``"256,256"`` for layer widths, ``none``
        for an unset ``actor_hidden_sizes``, ``true``/``false``, ``1e6`` for an integer),
        checked as a config holding it would be. Raises ``ValueError`` naming the key, the
        settable keys and the expected form."""
        if key not in cls.settable():
            raise ValueError(f"unknown setting {key!r}; settable: {', '.join(cls.settable())}")
        default = getattr(cls(), key)
        text = text.strip()
        try:
            if key.endswith("hidden_sizes"):
                value: Any = None if (default is None and text.lower() == "none") else tuple(
                    int(w) for w in text.split(","))
            elif isinstance(default, bool):
                value = {"true": True, "1": True, "false": False, "0": False}[text.lower()]
            elif _is_integer_setting(key, default):
                value = float(text)
                if not value.is_integer():
                    raise ValueError
                value = int(value)
            else:
                value = float(text)
        except (ValueError, KeyError):
            raise ValueError(f"{key}={text}: expected {_setting_form(key, default)}") from None
        try:
            cls(**{key: value, **({"buffer_size": value} if key == "batch_size" else {})})
        except ValueError as exc:
            raise ValueError(f"{key}={text}: {exc}") from None
        return value

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> TD3Config:
        names = {f.name for f in dataclasses.fields(cls)}
        return cls(**{k: v for k, v in d.items() if k in names})


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
        self.actor_net = StackedMLP(k, (self.obs_dim, *cfg.actor_widths, self.act_dim))
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
        (actor first, then Q1, Q2)."""
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(seed)
            actor = Actor(self.obs_dim, self.act_dim, self.config.actor_widths)
            critic = TwinCritic(self.obs_dim, self.act_dim, self.config.hidden_sizes,
                                self.config.critic_layer_norm)
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
        action = torch.tanh(self.actor_net(obs_t.to(self.device))).cpu().numpy().astype(np.float64)
        if explore:
            sigma = self.config.exploration_noise
            noise = np.stack([rng.normal(0.0, sigma, size=action.shape[1:]) for rng in self.rngs])
            action = np.clip(action + noise, -1.0, 1.0)
        return action.astype(np.float32)

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
        next_action = (torch.tanh(self.actor_target_net(next_obs, self.compute_dtype)) + eps).clamp(-1, 1)
        q1_next, q2_next = self._q(self.critic_target_net, next_obs, next_action, self.compute_dtype)
        return rewards + cfg.gamma * (1.0 - terminated) * torch.min(q1_next, q2_next)

    def update(self, batches: list[Batch], train_actor: bool = True) -> dict[str, torch.Tensor]:
        """One TD3 gradient step of every seed, seed ``k`` on ``batches[k]``: the critics always;
        every ``policy_delay``-th call also the actors (unless ``train_actor`` is false: the critics
        then learn the value of the actors as they are) and a Polyak update of all targets. Returns
        each seed's losses as ``(K,)`` tensors (``critic_loss``, ``q1``, ``q2``, ``target_q`` and,
        on actor steps, ``actor_loss``)."""
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
            pre = self.actor_net(obs, dtype)
            mu = torch.tanh(pre)
            q1_mu = self.critic_net(torch.cat([obs, mu], dim=-1), dtype, members=slice(0, self.n_seeds))
            actor_loss = -q1_mu.mean(dim=(1, 2))
            if cfg.actor_saturation_penalty:  # lambda * mean(relu(|u| - 3)^2), each seed its own
                excess = torch.relu(pre.abs() - SATURATION_PREACTIVATION)
                actor_loss = actor_loss + cfg.actor_saturation_penalty * (excess ** 2).mean(dim=(1, 2))
            _step(self.actor_optimizer, torch.autograd.grad(actor_loss.sum(), self.actor_params))
            self._polyak()
            info["actor_loss"] = actor_loss.detach()
        return info

    def clone_step(self, batches: list[Batch]) -> torch.Tensor:
        """One behaviour-cloning step of every seed's actor, seed ``k`` on ``batches[k]``: the
        actor's Adam descends the mean squared distance of its action to the action taken::

            L_clone = mean || tanh(MLP(s)) - a ||^2

        Returns each seed's loss, ``(K,)``. The critics and the targets are not touched
        (:meth:`hold_actor_targets` sets the target actors to the clones)."""
        obs, actions, _, _, _ = self._stack(batches)
        mu = torch.tanh(self.actor_net(obs, self.compute_dtype))
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
        return prefixed((self.actor_target_net if target else self.actor_net).member_state(k), "net.")

    def critic_state(self, k: int, target: bool = False) -> dict[str, torch.Tensor]:
        """Seed ``k``'s twin critic (or its target) as a :class:`TwinCritic` state dict."""
        net = self.critic_target_net if target else self.critic_net
        return {**prefixed(net.member_state(k), "q1_net."),
                **prefixed(net.member_state(self.n_seeds + k), "q2_net.")}

    def actor_module(self, k: int = 0) -> Actor:
        """A standalone copy of seed ``k``'s actor (float32, CPU, eval mode)."""
        actor = Actor(self.obs_dim, self.act_dim, self.config.actor_widths)
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
