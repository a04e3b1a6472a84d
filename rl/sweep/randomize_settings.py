"""The run setting ``randomize`` (``msr train --randomize``, ``msr refine --randomize``, the
recipe ``robust``): which robots a run's training episodes draw from (domain randomization;
:mod:`~elastica_magnetic_rl.envs.randomization`).
"""

from __future__ import annotations

from ..cases.case import Case, with_randomize
from ..cases.recipes import RECIPE_RUN_SETTINGS
from ..cases.variations import default_variations

__all__ = ["RANDOMIZE_CHOICES", "randomized_cases"]

#: values of the ``randomize`` run setting (``None``: the spec's table, else the recipe's setting)
RANDOMIZE_CHOICES = ("default", "none")


def randomized_cases(loaded: dict[str, Case], randomize: str | None, recipe: str) -> dict[str, Case]:
    """The cases as they train: with ``randomize="default"`` the default variation set in their
    ``[training.randomize]``, with ``"none"`` none; with ``None`` the spec's own table, or, for a
    spec without one, the recipe's ``randomize`` run setting."""
    if randomize is not None and randomize not in RANDOMIZE_CHOICES:
        raise ValueError(f"--randomize must be default or none, got {randomize!r} (ranges of "
                         "your own go in the spec's [training.randomize] table)")
    setting = randomize or RECIPE_RUN_SETTINGS.get(recipe, {}).get("randomize")
    out = {}
    for name, case in loaded.items():
        if not case.field_actuated and (randomize == "default" or setting == "default"):
            given = "--randomize default" if randomize == "default" else f"--recipe {recipe}"
            raise ValueError(f"{given}: case {name!r} is steered by a source ([actuation] kind = "
                             f"\"{case.actuation.kind}\"); domain randomization varies a crawler's robot, "
                             "and the catheter cases train on their nominal robot: leave it out (or "
                             "choose the fast or pink-ln recipe)")
        if randomize == "none":
            case = with_randomize(case, ())
        elif setting == "default" and (randomize == "default" or not case.training.randomize):
            case = with_randomize(case, tuple(default_variations(case.robot.tables)))
        out[name] = case
    return out
