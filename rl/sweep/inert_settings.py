"""Training settings that cannot act, refused before any work (``docs/errors.md``, "Training
options that cannot act"): a run whose weights would never be updated (its warm-up at or beyond
its steps, a minibatch larger than the run, too few updates per transition to make one), a warm-up
longer than the replay buffer keeps, an episode longer than the run (no return is ever measured),
and a stop rule asked for that cannot decide within the run.

Each message names the setting as the user gave it (``--set learning_starts=3000``, ``[training.td3]
learning_starts = 3000 (my.toml)``, or the default and where to change it), both numbers, and the
change that makes it act. Settings that still act at the end of a run are not refused: an
evaluation or checkpoint interval longer than the run leaves the final evaluation (``best.pt``)
and the final checkpoint, which every run makes.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ..cases.recipes import RECIPES

if TYPE_CHECKING:  # torch is imported only when a run is planned
    from ..runner.stopping import StopRule
    from ..td3.config import TD3Config

__all__ = ["SettingSources", "check_episodes_end", "check_evaluations_made", "check_noise_colored",
           "check_run_learns",
           "check_stop_rule_decides"]


@dataclass(frozen=True)
class SettingSources:
    """Where a run's settings come from, to name them: the TD3 settings given as options
    (``given``), the spec's ``[training.td3]`` (``spec_td3``, of the spec ``source``), whether
    ``--steps`` was given (else the spec's ``[training] steps``), the ``recipe`` and ``resumed``:
    the run's hyperparameters are its checkpoint's (a resumed run keeps them)."""

    given: Mapping[str, Any] = field(default_factory=dict)
    spec_td3: Mapping[str, Any] = field(default_factory=dict)
    source: str = "the spec"
    steps_given: bool = True
    resumed: bool = False
    recipe: str = ""

    def setting(self, key: str, value: Any) -> str:
        """``key = value`` as the user set it, e.g. ``--set batch_size=64``."""
        from ..td3.config import setting_option

        if self.resumed:
            return f"the run's {key} {value} (a resumed run keeps it)"
        if key in self.given:
            return setting_option(key, value)
        if key in self.spec_td3:
            return f"[training.td3] {key} = {value} ({self.source})"
        whose = f"the {self.recipe} recipe's" if key in RECIPES.get(self.recipe, {}) else "the default"
        return f"{key} {value} ({whose}; {setting_option(key)}=... or [training.td3] {key} sets it)"

    def steps(self, steps: int) -> str:
        """The run's steps as the user set them."""
        return f"--steps {steps}" if self.steps_given else f"[training] steps = {steps} ({self.source})"


def check_evaluations_made(config: TD3Config, sources: SettingSources) -> None:
    """Refuse (``ValueError``) a setting of the periodic evaluations (``eval_duration``,
    ``eval_episodes``) given by the user for a run that makes none (``eval_every`` 0): it would be
    recorded and change nothing. A spec's setting is refused only where the spec makes no evaluations
    either: ``--set eval_every=0`` turns a case's evaluations off, its own settings of them with them
    (the shipped goto and catheter cases evaluate several episodes)."""
    if config.eval_every > 0:
        return
    off_by_option = "eval_every" in sources.given
    for key, unset in (("eval_duration", 0.0), ("eval_episodes", 1)):
        value = getattr(config, key)
        if value != unset and (key in sources.given or (key in sources.spec_td3 and not off_by_option)):
            raise ValueError(f"{sources.setting(key, f'{value:g}')} sets the periodic evaluations, and "
                             f"{sources.setting('eval_every', 0)} makes none: give --set eval_every=N "
                             f"(steps between evaluations), or leave {key} out")


def check_noise_colored(config: TD3Config, sources: SettingSources) -> None:
    """Warn (:class:`SettingNotAppliedWarning`) of a ``noise_horizon`` given by the user for white
    exploration noise (``noise_color`` 0): the horizon shapes colored noise only."""
    from elastica_magnetic.plausibility import SettingNotAppliedWarning

    given = "noise_horizon" in sources.given or "noise_horizon" in sources.spec_td3
    if config.noise_color == 0 and given:
        warnings.warn(SettingNotAppliedWarning(
            f"{sources.setting('noise_horizon', config.noise_horizon)} sets how long colored exploration "
            f"noise is drawn ahead, and {sources.setting('noise_color', 0)} makes it white (each step "
            "drawn anew), which has no horizon: give --set noise_color=1 (pink) or 2 (red) for colored "
            "noise, or leave noise_horizon out"), stacklevel=2)


def check_run_learns(config: TD3Config, steps: int, sources: SettingSources) -> None:
    """Refuse (``ValueError``) a run of ``config`` trained to ``steps`` per seed whose weights
    would never be updated, whose buffer cannot hold the warm-up its ``yardstick_regularization``
    holds to, or (a new run) whose warm-up outgrows its replay buffer. A resumed run
    (``sources.resumed``) keeps its hyperparameters: only other ``--steps`` is suggested."""
    from ..td3.algorithm import update_ratio

    warm_up, batch = config.learning_starts, config.batch_size
    name, resumed = sources.setting, sources.resumed
    if warm_up >= steps:
        raise ValueError(
            f"the warm-up is the whole run: {name('learning_starts', warm_up)} is at or beyond "
            f"{sources.steps(steps)}, so every action is "
            + ("the yardstick's plus noise" if config.yardstick_warmup else "random")
            + " and no weight is ever updated (the "
            "seeds would end untrained); give "
            + ("" if resumed else f"--set learning_starts below {steps} or ") + f"--steps above {warm_up}")
    if batch > steps:
        raise ValueError(
            f"no minibatch in the whole run: {name('batch_size', batch)} is larger than "
            f"{sources.steps(steps)}: the replay buffer never holds a minibatch, so no weight is "
            "ever updated; give " + ("" if resumed else f"--set batch_size of at most {steps} or ")
            + f"--steps of at least {batch}")
    learning = steps - max(warm_up, batch - 1)  # transitions followed by updates
    made = learning * update_ratio(config.updates_per_step)
    if made < 1:
        raise ValueError(
            f"not one update in the whole run: {name('updates_per_step', config.updates_per_step)}"
            f" over the {learning} transitions after the warm-up and the first minibatch makes "
            f"{float(made):.3g} updates; "
            "give " + ("" if resumed else f"--set updates_per_step of at least {1 / learning:.3g}, or ")
            + "more --steps")
    if config.yardstick_regularization and config.buffer_size < steps:
        # fewer --steps is advice only where such a run still learns (past the warm-up and a minibatch)
        fewer = config.buffer_size > warm_up and config.buffer_size >= batch
        raise ValueError(
            f"{name('yardstick_regularization', f'{config.yardstick_regularization:g}')} holds the actor "
            "near the warm-up's transitions for the whole run, and "
            f"{name('buffer_size', config.buffer_size)} holds fewer than {sources.steps(steps)}: the "
            "ring would overwrite them; give "
            + ((f"--steps of at most {config.buffer_size}, or " if fewer else "")
               + f"train a new run (another --out) with --set buffer_size of at least {steps}" if resumed
               else f"--set buffer_size of at least {steps}"
               + (f", or --steps of at most {config.buffer_size}" if fewer else "")))
    if config.yardstick_dagger and config.dagger_end >= steps:
        from elastica_magnetic.plausibility import SettingNotAppliedWarning

        inside = "inside" if config.dagger_end > steps else "at the end of"
        warnings.warn(SettingNotAppliedWarning(
            f"{name('yardstick_dagger', config.yardstick_dagger)} after "
            f"{name('learning_starts', warm_up)} ends at step {config.dagger_end}, and "
            f"{sources.steps(steps)} ends the run {inside} DAgger: no TD3 step follows it (the seeds end "
            f"as the clone DAgger made); give --steps above {config.dagger_end} for TD3 after DAgger"
            + ("" if resumed or steps - warm_up - 1 < 1 else
               f", or --set yardstick_dagger of at most {steps - warm_up - 1} to end DAgger within the run")),
            stacklevel=2)
    updates = int(made) + config.yardstick_warmup  # a clone's critic updates count as held ones
    if config.critic_warmup >= updates:
        from elastica_magnetic.plausibility import SettingNotAppliedWarning

        warnings.warn(SettingNotAppliedWarning(
            f"{name('critic_warmup', config.critic_warmup)} holds the actor for the run's first "
            f"{config.critic_warmup} updates, and {sources.steps(steps)} makes {updates}: the actor never "
            "learns" + (" (a residual learner plays its yardstick unchanged)" if config.residual else "")
            + f"; give --set critic_warmup below {updates}, or more --steps"), stacklevel=2)
    if config.buffer_size < warm_up and not resumed:
        raise ValueError(
            f"the warm-up outgrows the replay buffer: {name('learning_starts', warm_up)} is above "
            f"{name('buffer_size', config.buffer_size)}: the buffer keeps only the last "
            f"{config.buffer_size} random transitions, so the first {warm_up - config.buffer_size} "
            f"are overwritten before any update reads them; give --set learning_starts of at most "
            f"{config.buffer_size} or --set buffer_size of at least {warm_up}")


def check_stop_rule_decides(rule: StopRule | None, config: TD3Config, steps: int, envs: int,
                            sources: SettingSources, episode_duration: float | None = None) -> None:
    """Refuse (``ValueError``) a stop rule that a new run of ``steps`` steps per seed (``envs``
    crawlers each) cannot fire: its evaluations (at the first episode end after each multiple of
    ``eval_every`` steps, and at the end of the run) are fewer than the rule needs to decide. With
    episodes of ``episode_duration`` s longer than ``eval_every`` steps, the evaluations are fewer
    (one per episode end at most): warned (:class:`SettingNotAppliedWarning`) when those of
    full-length episodes are too few (episodes that end early could still give enough)."""
    from elastica_magnetic.robot_spec import ACTION_PERIOD

    if rule is None or config.eval_every <= 0:
        return
    every = config.eval_every
    last = -(-steps // envs) * envs  # the run ends at the first vector step at or past ``steps``
    most = -(-last // every)  # one per interval begun, the last one at the end of the run
    needed = rule.evaluations_needed
    if most >= needed:
        if episode_duration is not None:
            _warn_if_episodes_thin_out(rule, config, last, envs, episode_duration, sources)
        return
    head = (f"--stop-when {rule.kind} cannot decide within the run: it needs {needed} evaluations, and "
            f"{sources.steps(steps)} with {sources.setting('eval_every', every)} makes at most {most}")
    episode = (0 if episode_duration is None
               else int(round(episode_duration / ACTION_PERIOD)) * max(1, envs))
    if episode > (last - 1) // (needed - 1):  # a shorter eval_every cannot help: one per episode end
        raise ValueError(
            f"{head}; evaluations come at episode ends, at most one per episode of {episode_duration:g} s "
            f"({episode} steps), so a shorter eval_every cannot add enough: give --steps of at least "
            f"{needed * episode}, or --stop-when none")
    raise ValueError(
        f"{head}; give --set eval_every of at most {(last - 1) // (needed - 1)} or --steps of at least "
        f"{max((needed - 1) * every + 1, needed * episode)}, or --stop-when none")


def evaluations_with_episodes(last: int, every: int, episode: int) -> int:
    """The evaluations of a run of ``last`` steps whose episodes all last ``episode`` steps (all
    sub-environments together): one at the first episode end at or past each due step (multiples of
    ``every``; the next one due after the step evaluated), and one at the end of the run."""
    count, due, end = 0, every, episode
    while end < last:
        if end >= due:
            count += 1
            due = (end // every + 1) * every
        end += episode
    return count + 1


def _warn_if_episodes_thin_out(rule: StopRule, config: TD3Config, last: int, envs: int,
                               episode_duration: float, sources: SettingSources) -> None:
    """Warn when full-length episodes give the stop rule fewer evaluations than it needs."""
    from elastica_magnetic.plausibility import SettingNotAppliedWarning
    from elastica_magnetic.robot_spec import ACTION_PERIOD

    episode = int(round(episode_duration / ACTION_PERIOD)) * max(1, envs)
    made = evaluations_with_episodes(last, config.eval_every, episode)
    if episode <= config.eval_every or made >= rule.evaluations_needed:
        return
    warnings.warn(SettingNotAppliedWarning(
        f"--stop-when {rule.kind} may not decide within the run: evaluations come at episode ends (the "
        f"first after each {sources.setting('eval_every', config.eval_every)} steps), and episodes of "
        f"{episode_duration:g} s ({episode} steps) end {made - 1} time(s) in {sources.steps(last)}: with "
        f"the evaluation at the end, {made} of the {rule.evaluations_needed} the rule needs (more only if "
        f"episodes end early); give --steps of at least {rule.evaluations_needed * episode}, or --stop-when "
        "none"), stacklevel=2)


def check_episodes_end(episode_duration: float, steps: int, envs: int, sources: SettingSources,
                       duration_given: bool = True) -> None:
    """A run of ``steps`` steps per seed (``envs`` crawlers each) in which no training episode of
    ``episode_duration`` s ends measures no return (its summary says nothing of what it learned)
    and evaluates only at its end. Refused (``ValueError``) when ``--episode-duration`` was given
    (a unit mistake, most likely); with the spec's own episode (a short trial run of a shipped
    case) a warning says so."""
    from elastica_magnetic.plausibility import judge, warn_implausible
    from elastica_magnetic.robot_spec import ACTION_PERIOD

    episode_steps = int(round(episode_duration / ACTION_PERIOD))
    per_crawler = -(-steps // max(1, envs))
    if episode_steps <= per_crawler:
        return
    given = (f"--episode-duration {episode_duration:g} s" if duration_given
             else f"[task] episode_duration = {episode_duration:g} s ({sources.source})")
    finding = judge("episode duration", episode_duration)
    hint = f" ({finding.text})" if finding is not None else ""
    text = (f"no training episode ends within the run: {given}{hint} is {episode_steps} steps of "
            f"{ACTION_PERIOD:g} s, and {sources.steps(steps)} over {envs} robot(s) gives each "
            f"{per_crawler}; the run measures no return; give --episode-duration of at most "
            f"{per_crawler * ACTION_PERIOD:g} s or --steps of at least {episode_steps * max(1, envs)}")
    if duration_given:
        raise ValueError(text)
    warn_implausible(text, "task.episode_duration")
