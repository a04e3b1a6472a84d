"""The crawler's training recipes: named TD3 configurations (one home for them; light to import,
so the command line can list them)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

#: TD3 settings of the crawler that differ from :class:`~elastica_magnetic_rl.td3.config.TD3Config`'s
#: defaults: the authors' target-noise clip 0.8 (Fujimoto's is 0.5); and an evaluation every 5000 steps (not
#: in the paper; it changes no weight) that keeps the best actor in ``best.pt``. Everything else is the
#: paper's setting.
CRAWLER_TD3_OVERRIDES: dict[str, Any] = {"target_noise_clip": 0.8, "eval_every": 5000}

#: Training recipes (:data:`RECIPE_LIST`): named changes of the TD3 configuration on top of
#: :data:`CRAWLER_TD3_OVERRIDES`, each change an explicit
#: :class:`~elastica_magnetic_rl.td3.config.TD3Config` field. The task, reward, observation, action limits,
#: physics, episode length and step budget are the same in every recipe. ``paper``: the authors' recipe.
#: ``pink``: the paper's with temporally correlated (pink, ``1/f``) exploration noise instead of independent
#: Gaussian steps (Eberhard et al., ICLR 2023), a sequence per 20 s episode, same standard deviation.
#: ``pink-ln``: ``pink`` with layer normalisation in the critics' hidden layers (Ball et al., ICML 2023),
#: against the critics' overestimation that saturates the actor's ``tanh`` in the failed seeds
#: (docs/training.md). ``pink-ln-unsat``: ``pink-ln`` with a penalty on the actor's pre-``tanh`` outputs
#: beyond 3, so that a saturated actor still receives the critic's gradient (``pink-ln``'s failed ``m2-10mT``
#: seeds stayed at a half roll with saturated actors and calibrated critics).
#:
#: ``fast``: the design loop measured in minutes: ``pink-ln`` (its 256-256 networks) with
#: minibatches of 128 (half the paper's), bfloat16 networks in the updates (``fp32`` on a CPU
#: without bfloat16 units) and the ``target`` stop rule, confirmed in the accurate physics, on by
#: default (its ``run`` settings; ``--stop-when none`` turns it off): a seed that has met
#: the case's yardstick stops and frees its share of the worker. Measured with 8 seeds of each of
#: the four paper cases on a 2-core AMD EPYC (Zen 5): 7, 6, 6 and 7 of 8 (m1-10mT, m2-10mT,
#: m1-4mT, m2-4mT) in 21-27 min; on a 2-core Intel Xeon with AMX 7, 7, 5 and 6 of 8 in 42-51 min
#: (docs/training.md). Not taken: minibatches of 64 with 0.8 of the steps (a second version: 6,
#: 6, 5, 7 of 8 on the Intel machine in 27-40 min, 2 of 8 on m1-10mT on the AMD one), one update
#: per two transitions (4 of 8 on m1-10mT), 128-128 networks (3 of 4, then 1 of 4 by 80k), 64-64
#: (1 of 4).
#:
#: ``robust``: ``pink-ln`` trained on robots drawn anew for every episode and crawler from the
#: default variation set (domain randomization, Tobin et al. 2017; the run setting ``randomize``
#: of its ``run`` settings), so that one waveform works on the robot a lab actually built;
#: the observation is unchanged and evaluations stay on the nominal robot.
@dataclass(frozen=True)
class Recipe:
    """One training recipe: its ``name``, a one-line ``summary`` (the command line's help), its
    ``td3`` changes on :data:`CRAWLER_TD3_OVERRIDES` (explicit
    :class:`~elastica_magnetic_rl.td3.config.TD3Config` fields) and its ``run`` settings
    (``stop_when``, the default of ``msr train --stop-when``; ``randomize``, the default of
    ``--randomize`` for a case whose spec has no ``[training.randomize]``: not hyperparameters,
    they change when a seed stops or which robots it trains on, each overridable)."""

    name: str
    summary: str
    td3: Mapping[str, Any] = field(default_factory=dict)
    run: Mapping[str, Any] = field(default_factory=dict)


# the shared bases the recipes are composed from
_PINK = {"noise_color": 1.0, "noise_horizon": 2000}  # a pink-noise sequence per 20 s episode
_PINK_LN = {**_PINK, "critic_layer_norm": True}

#: Every recipe, in the order the command line lists them: adding one is adding an entry here.
RECIPE_LIST: tuple[Recipe, ...] = (
    Recipe("paper", "the authors' TD3 settings"),
    Recipe("pink", "the paper's with temporally correlated (pink) exploration noise", _PINK),
    Recipe("pink-ln", "pink, and layer normalisation in the critics", _PINK_LN),
    Recipe("pink-ln-unsat", "pink-ln, and a penalty that keeps the actor out of tanh's saturation",
           {**_PINK_LN, "actor_saturation_penalty": 1.0}),
    Recipe("fast", "pink-ln with minibatches of 128 and bfloat16 updates, whose seeds stop once they "
           "meet the case's yardstick (--stop-when target by default): 8 seeds of a paper case "
           "in 21-27 min on 2 cores (AMD Zen 5)",
           {**_PINK_LN, "batch_size": 128, "precision": "bf16"}, {"stop_when": "target"}),
    Recipe("robust", "pink-ln on robots randomized per episode (the default variation set: "
           "magnetization +-15 %, modulus +-20 %, friction +-25 %, density +-10 %; --randomize)",
           _PINK_LN, {"randomize": "default"}),
)

#: Views of :data:`RECIPE_LIST` by name: the TD3 changes, the run settings (recipes that have
#: some) and the one-line summaries.
RECIPES: dict[str, dict[str, Any]] = {r.name: dict(r.td3) for r in RECIPE_LIST}
RECIPE_RUN_SETTINGS: dict[str, dict[str, Any]] = {r.name: dict(r.run) for r in RECIPE_LIST if r.run}
RECIPE_SUMMARIES: dict[str, str] = {r.name: r.summary for r in RECIPE_LIST}

#: The recipe of a spec file that names none, and of the paper's four cases: ``pink-ln`` made more
#: seeds succeed than the paper's recipe in each of the four, 8 seeds against 8 (docs/training.md).
DEFAULT_RECIPE = "pink-ln"


def crawler_config(seed: int = 0, recipe: str = DEFAULT_RECIPE, **overrides: Any):
    """The crawler's TD3 configuration: the paper's settings (:data:`CRAWLER_TD3_OVERRIDES` on
    :class:`~elastica_magnetic_rl.td3.config.TD3Config`), then the ``recipe``'s changes (:data:`RECIPES`),
    then ``overrides`` (e.g. ``learning_starts`` for smoke runs)."""
    from ..td3.config import TD3Config

    if recipe not in RECIPES:
        raise ValueError(f"unknown recipe {recipe!r}; choose one of {', '.join(RECIPES)}")
    return TD3Config(**{**CRAWLER_TD3_OVERRIDES, **RECIPES[recipe], **overrides, "seed": int(seed)})
