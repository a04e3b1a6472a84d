"""TD3's settings: the hyperparameters of the algorithm (:class:`Hyperparameters`), how a run
executes them (:class:`RunSettings`) and when it does what (:class:`Schedule`), together
:class:`TD3Config`, each checked where it is made. Free of PyTorch, so that the command line can
list and check the settings without importing it; the algorithm is :mod:`.algorithm`."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, TypeVar

from elastica_magnetic.field_csv import is_number
from elastica_magnetic.robot_spec import ACTION_PERIOD

#: What an actor reads (:attr:`Hyperparameters.actor_input`): the whole ``observation`` in the
#: lab's frame (the paper's), or a goto case's ``steering`` state in the robot's frame.
ACTOR_INPUTS = ("observation", "steering")
#: What a clone of the yardstick's warm-up copies (:attr:`Hyperparameters.clone_labels`): the
#: actions as ``played`` (the yardstick's plus the exploration noise) or as ``commanded`` (its own).
CLONE_LABELS = ("played", "commanded")

#: Arithmetic choices of :attr:`TD3Config.precision`.
PRECISIONS = ("fp32", "bf16")
#: ``|pre-tanh output|`` of the actor above which it counts as saturated (``tanh(3) = 0.995``):
#: there its gradient is below 1 % of the unsaturated one.
SATURATION_PREACTIVATION = 3.0
#: The smallest ``mean|Q1|`` the yardstick regularization divides by (a critic near zero at the
#: start would otherwise scale the Q term without bound).
Q_SCALE_FLOOR = 1e-6


# ----------------------------------------------------------------------------------------------
# Hyperparameters
# ----------------------------------------------------------------------------------------------
_Part = TypeVar("_Part")


#: Most gradient updates per environment step: high update-to-data methods (REDQ, DroQ) use 20; far
#: beyond, a run spends its time updating on the same few transitions (1e9 stalled a run forever).
MAX_UPDATES_PER_STEP = 64
#: The largest exploration or target-policy noise (standard deviation, a fraction of the action's
#: half-range): beyond it nearly every noisy action is clipped at a limit (TD3's noise is 0.1-0.2).
MAX_NOISE = 1.0
#: The widest clip of the target policy's noise: the action's full range (2 half-ranges), beyond which
#: the clip never acts (the noisy target action is clipped to the action's limits anyway).
MAX_NOISE_CLIP = 2.0
#: The reddest exploration noise, the exponent beta of its spectrum 1/f^beta: 0 white, 1 pink, 2 red
#: (a random walk); steeper is a drift over the whole horizon, no exploration step to step.
MAX_NOISE_COLOR = 2.0
#: Most cloning steps of a warm-up from the yardstick (each followed by a critic update): a clone
#: and its critics settle within thousands; a million is hours of updates before the run trains.
MAX_YARDSTICK_WARMUP = 1_000_000
#: The strongest hold on the yardstick's warm-up (``yardstick_regularization``), 25x TD3+BC's 0.4:
#: beyond it the actor's distance to the warm-up's actions outweighs any Q gradient.
MAX_YARDSTICK_REGULARIZATION = 10.0
#: The strongest hold on a residual learner's zero correction (``correction_penalty``): the same
#: TD3+BC weight, with the same reason.
MAX_CORRECTION_PENALTY = MAX_YARDSTICK_REGULARIZATION
#: Largest ``residual``: a correction of twice the largest command swings an action across its whole
#: range, beyond which the yardstick's command no longer matters.
MAX_RESIDUAL = 2.0
#: The longest evaluation episode a config takes, s (an hour: a goto episode is 30 s; more is a
#: step count or milliseconds written as seconds).
MAX_EVAL_DURATION = 3600.0
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
    if key == "actor_input":
        return " or ".join(ACTOR_INPUTS)
    if key == "clone_labels":
        return " or ".join(CLONE_LABELS)
    if key == "noise_color":
        return "a number: the exponent of the noise's spectrum 1/f^beta (0 white, 1 pink, 2 red)"
    if key == "eval_duration":
        return "a number of s (0: the case's evaluation), e.g. 0.5 for 500 ms"
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
    actor_input: str = "observation"
    """What the actor reads and answers in: ``"observation"``, the whole observation, answering
    the lab's field increments (the paper's); ``"steering"``, a goto case's steering state in the
    robot's own frame (the field and the target seen from the robot, the clock), answering
    increments along the robot's forward, up and left that the observed heading turns into the
    lab's (:mod:`~elastica_magnetic_rl.td3.steering_inputs`: why, and the formulas). The critics
    always read the whole observation and the lab's action."""
    actor_mirror: bool = False
    """With ``actor_input = "steering"``: a mirror-symmetric actor, whose command for a state's
    mirror image (z -> -z) is its command's mirror image, exactly
    (:func:`~elastica_magnetic_rl.td3.steering_inputs.mirror_symmetric`): one manoeuvre learned for
    both sides, and no left command where the robot, the field and the target are symmetric. Only
    for a robot that is its own mirror image (no z component of its magnetization; a case whose
    magnetization has one is refused)."""
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
    clone_labels: str = "played"
    """What the clone of :attr:`yardstick_warmup` copies: ``"played"`` (the warm-up's actions as
    played, the yardstick's command plus the exploration noise) or ``"commanded"`` (the yardstick's
    command before its noise, kept beside each warm-up transition). Why ``commanded``: the noise is
    there to show the clone the states around the yardstick's paths (DART: Laskey et al., CoRL
    2017, label those states with the supervisor's clean action); copying the noisy actions asks
    the clone to average the noise out, and what it does not average (a constant learning rate
    keeps it fitting the last minibatches' noise) is an error in every action. Measured on a
    catheter's clones it helped one seed of two (docs/steering_catheter.md)."""
    yardstick_dagger: int = 0
    """Environment steps of DAgger after the clone (0: none; needs :attr:`yardstick_warmup` and a
    yardstick that labels an observation by itself, a tip-reach case's steering law). For these
    steps the actor, plus the exploration noise, drives; the yardstick labels every observation
    the actor meets with the command it would give there; and each actor update is a clone step
    on labelled transitions of the whole buffer (the warm-up's labelled with the yardstick's
    command before its noise), the critics learning as in TD3 meanwhile. Why: a clone trained on
    the yardstick's states alone drifts where its own small errors take it, states the yardstick
    never showed it (compounding errors); labels on the clone's own states teach it the way back
    (DAgger: Ross, Gordon & Bagnell, AISTATS 2011). TD3 (with :attr:`yardstick_regularization`
    if set) follows for the run's remaining steps."""
    yardstick_regularization: float = 0.0
    """Hold the actor near the yardstick's warm-up for the whole run (0: plain TD3 after the
    clone). With ``beta > 0`` (needs :attr:`yardstick_warmup`) every actor update also descends
    the distance of its actions to the warm-up's on a minibatch of the warm-up's transitions, the
    critic's term normalised as in TD3+BC (Fujimoto & Gu 2021)::

        L_actor = -mean Q1(s, mu(s)) / mean|Q1(s, mu(s))| + beta * mean || mu(s_w) - a_w ||^2

    ``beta = 0.4`` is TD3+BC's ``alpha = 2.5``. Why: a critic that has only seen the yardstick's
    actions (plus noise) gives gradients off them that are extrapolation, and plain TD3 then walks
    the clone off the gait within a few thousand updates; the term keeps it where the critic's
    data is. It holds the actions, not the return: a gait that needs them finer than a clone makes
    them still fails (docs/training.md, "Starting from the yardstick")."""
    residual: float = 0.0
    """Learn a correction of the case's yardstick instead of a policy (0: off, the paper's). With
    ``rho > 0`` the environment plays ``clip(a_yardstick(s) + rho * mu(s), -1, 1)`` (normalised), the
    yardstick being the controller the case is judged against, run inside the environment with its
    memory (:mod:`~elastica_magnetic_rl.envs.residual`), and the actor's last layer starts at zero, so
    the first policy is the yardstick itself (residual policy learning: Silver et al. 2018, Johannink
    et al. 2019). Why: clones of a yardstick with memory (a goto case's manoeuvres, a coils law's
    field direction) end as other, worse controllers; a correction starts where the yardstick is and
    learns only what adds return. ``rho`` (at most :data:`MAX_RESIDUAL`) bounds the correction: 0.5
    moves an axis's command by at most half its largest increment either way. Not with
    :attr:`yardstick_warmup` (nothing to clone: the start is the yardstick already)."""
    correction_penalty: float = 0.0
    """Hold a residual learner's correction small for the whole run (0: plain TD3 on the
    correction; needs :attr:`residual`). With ``beta > 0`` every actor update also descends the
    correction's size, the critic's term normalised as in TD3+BC (Fujimoto & Gu 2021)::

        L_actor = -mean Q1(s, mu(s)) / mean|Q1(s, mu(s))| + beta * mean || mu(s) ||^2

    which is TD3+BC with the yardstick as the demonstrator: the yardstick's own action is a zero
    correction. ``beta = 0.4`` is TD3+BC's ``alpha = 2.5``. Why: the critic has seen only the
    yardstick's actions plus noise, and its gradient far from them is extrapolation; on
    ``m1-10mT-goto`` every correction plain TD3 made (four runs) lowered the yardstick's return.
    The term keeps the correction where a change pays more than it moves (measured: the catheters'
    first corrections that raise their laws' returns, docs/steering_catheter.md; at 10 mT it held
    the yardstick's return without raising it)."""
    critic_warmup: int = 0
    """The run's first ``N`` TD3 updates learn the critics only, the actor held (0: none; a clone's
    critic updates, :attr:`yardstick_warmup`, count among them). Why: TD3 moves the actor along the
    critic's gradient from the first update, and a critic that has not yet learned the value of the
    actions played gives gradients that are noise; a residual learner (:attr:`residual`) starts at a
    yardstick that works, and such early steps only take it away (measured on
    ``catheter-coils-reach``: evaluations fell from the law's return of 71 to -166 and -242 after
    5000 updates without it; docs/training.md)."""


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


#: The :class:`Schedule` settings a resumed run keeps (the evaluations' length: ``best.pt`` compares
#: evaluations of one length).
KEPT_ON_RESUME = frozenset({"eval_duration"})


@dataclass
class Schedule:
    """When a run checkpoints, logs and evaluates (what Stable-Baselines3 leaves to ``learn()``'s
    callbacks): these change no weight, so a resumed run may change them (but
    :data:`KEPT_ON_RESUME`)."""

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
    eval_duration: float = 0.0
    """Seconds of each periodic evaluation's episode (:attr:`eval_every`); 0: the case's
    (the yardstick's 10 s, a goto or tip-reach task's whole episode). Shorter evaluations cost
    less (smoke runs), and ``best.pt`` is then the best of those: a seed's 10 s distance is still
    measured after training (``msr policy export-seeds``, ``msr loop``). Unlike the settings above, a
    resumed run keeps its own (:data:`KEPT_ON_RESUME`): ``best.pt`` compares evaluations of one
    length."""


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
        if self.actor_input not in ACTOR_INPUTS:
            raise ValueError(f"actor_input must be one of {', '.join(ACTOR_INPUTS)}, got "
                             f"{self.actor_input!r}")
        if self.actor_mirror and self.actor_input != "steering":
            raise ValueError("actor_mirror makes a steering actor mirror-symmetric: it needs actor_input = "
                             f"'steering', got {self.actor_input!r} (an actor reading the whole observation: "
                             "--set actor_mirror=false)")
        if self.clone_labels not in CLONE_LABELS:
            raise ValueError(f"clone_labels must be one of {', '.join(CLONE_LABELS)}, got "
                             f"{self.clone_labels!r}")
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
        if not (math.isfinite(self.eval_duration) and (self.eval_duration == 0.0 or ACTION_PERIOD
                                                        <= self.eval_duration <= MAX_EVAL_DURATION)):
            raise ValueError(f"eval_duration must be 0 (the case's evaluation, 10 s for a crawl) or a "
                             f"number of seconds in [{ACTION_PERIOD:g}, {MAX_EVAL_DURATION:g}] (at least "
                             f"one control step), got {self.eval_duration!r}")
        ratio = self.updates_per_step
        if not (isinstance(ratio, int | float) and math.isfinite(ratio)
                and 0 < ratio <= MAX_UPDATES_PER_STEP):
            raise ValueError(f"updates_per_step must be a finite number in (0, {MAX_UPDATES_PER_STEP}] "
                             f"(updates per transition), got {ratio}")
        if float(ratio).is_integer():
            self.updates_per_step = int(ratio)
        for name in ("learning_starts", "eval_every", "yardstick_warmup", "yardstick_dagger",
                     "critic_warmup"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        self._check_noise_and_yardstick()

    def _check_noise_and_yardstick(self) -> None:
        """The exploration and target noise, the warm-up from the yardstick and the buffer that
        holds it: each in its range (``ValueError`` naming the setting)."""
        for name in ("exploration_noise", "policy_noise", "target_noise_clip", "noise_color",
                     "actor_saturation_penalty", "yardstick_regularization"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value}")
        for name in ("exploration_noise", "policy_noise"):
            value = getattr(self, name)
            if value > MAX_NOISE:
                percent = f" (a percent? {value:g} % is {value / 100:g})" if value <= 100 else ""
                raise ValueError(f"{name} must be at most {MAX_NOISE:g} (a fraction of the action's "
                                 f"half-range; TD3's is 0.2), got {value:g}: every noisy action would sit "
                                 f"at a limit{percent}")
        if self.target_noise_clip > MAX_NOISE_CLIP:
            raise ValueError(f"target_noise_clip must be at most {MAX_NOISE_CLIP:g} (the action's full "
                             f"range, in half-ranges; TD3's is 0.5), got {self.target_noise_clip:g}: a wider "
                             "clip never acts")
        if self.noise_color > MAX_NOISE_COLOR:
            raise ValueError(f"noise_color must be at most {MAX_NOISE_COLOR:g} (the exponent beta of the "
                             f"noise's spectrum 1/f^beta: 0 white, 1 pink, 2 red), got {self.noise_color:g}")
        if self.noise_horizon < 2:
            raise ValueError(f"noise_horizon must be >= 2 steps, got {self.noise_horizon}")
        if self.yardstick_warmup > MAX_YARDSTICK_WARMUP:
            raise ValueError(f"yardstick_warmup must be at most {MAX_YARDSTICK_WARMUP} cloning steps (and "
                             f"as many critic updates), got {self.yardstick_warmup}: hours of updates before "
                             "the run trains (a clone settles within thousands; a run's step count written "
                             "here?)")
        if self.yardstick_regularization and not self.yardstick_warmup:
            raise ValueError(f"yardstick_regularization {self.yardstick_regularization:g} holds the actor "
                             "near the yardstick's warm-up: set yardstick_warmup too (e.g. 4000), or leave "
                             "it 0")
        if self.clone_labels == "commanded" and not self.yardstick_warmup:
            raise ValueError("clone_labels 'commanded' copies the yardstick's own commands in its "
                             "warm-up: set yardstick_warmup too (e.g. 4000), or leave clone_labels 'played'")
        if self.yardstick_dagger and not self.yardstick_warmup:
            raise ValueError(f"yardstick_dagger {self.yardstick_dagger} continues a clone of the yardstick's "
                             "warm-up on the clone's own states: set yardstick_warmup too (e.g. 4000), or "
                             "leave it 0")
        if not (math.isfinite(self.residual) and 0.0 <= self.residual <= MAX_RESIDUAL):
            raise ValueError(f"residual must be a number in [0, {MAX_RESIDUAL:g}] (the correction's weight "
                             f"on the yardstick's normalised command; 0 off), got {self.residual!r}")
        if not (math.isfinite(self.correction_penalty) and 0.0 <= self.correction_penalty
                <= MAX_CORRECTION_PENALTY):
            raise ValueError(f"correction_penalty must be a number in [0, {MAX_CORRECTION_PENALTY:g}] "
                             f"(TD3+BC's alpha = 2.5 is 0.4; 0 off), got {self.correction_penalty!r}")
        if self.correction_penalty and not self.residual:
            raise ValueError(f"correction_penalty {self.correction_penalty:g} holds a residual learner's "
                             "correction small: set residual too (e.g. 0.5), or leave it 0")
        if self.residual and self.yardstick_warmup:
            raise ValueError(f"residual {self.residual:g} starts the actor at the yardstick itself (a zero "
                             f"correction), nothing is to be cloned: yardstick_warmup must be 0, got "
                             f"{self.yardstick_warmup} (to learn the correction where a case's "
                             "[training.td3] sets a warm-up: --set yardstick_warmup=0 --set "
                             "yardstick_dagger=0; to clone the yardstick where it sets residual: --set "
                             "residual=0, and --set correction_penalty=0 where it sets that too)")
        if self.yardstick_regularization > MAX_YARDSTICK_REGULARIZATION:
            raise ValueError(f"yardstick_regularization must be at most {MAX_YARDSTICK_REGULARIZATION:g} "
                             f"(TD3+BC's alpha = 2.5 is 0.4), got {self.yardstick_regularization:g}: the "
                             "critic's term would no longer move the actor off the clone")
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
            elif key in ("actor_input", "clone_labels"):
                if text not in (ACTOR_INPUTS if key == "actor_input" else CLONE_LABELS):
                    raise ValueError
                value = text
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
            percent = text.strip().endswith("%") and is_number(text.strip()[:-1])
            hint = f" ({float(text.strip()[:-1]) / 100:g} for {text.strip()})" if percent else ""
            raise ValueError(f"{key}={text}: expected {_setting_form(key, default)}{hint}") from None
        # a setting whose rule involves another is checked beside a partner that satisfies it (the
        # rule itself is checked where the whole config is built)
        partner: dict[str, Any] = {"batch_size": {"buffer_size": value},
                                   "yardstick_regularization": {"yardstick_warmup": 1},
                                   "yardstick_dagger": {"yardstick_warmup": 1},
                                   "clone_labels": {"yardstick_warmup": 1},
                                   "correction_penalty": {"residual": 1.0},
                                   "actor_mirror": {"actor_input": "steering"}}.get(key, {})
        if key == "buffer_size":  # the run's minibatch (recipe, spec or --set) is judged with it later
            partner = {"batch_size": max(1, min(value, cls().batch_size))}
        try:
            cls(**{key: value, **partner})
        except ValueError as exc:
            raise ValueError(f"{key}={text}: {exc}") from None
        return value

    @property
    def labelled(self) -> bool:
        """Whether each transition keeps the yardstick's command beside the action played (DAgger's
        labels, or a clone of the commands)."""
        return self.yardstick_dagger > 0 or self.clone_labels == "commanded"

    @property
    def dagger_end(self) -> int:
        """The environment step at which :attr:`yardstick_dagger` ends (``learning_starts``
        without it): before it, past the warm-up, the actor learns by DAgger."""
        return self.learning_starts + self.yardstick_dagger

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> TD3Config:
        names = {f.name for f in dataclasses.fields(cls)}
        return cls(**{k: v for k, v in d.items() if k in names})

