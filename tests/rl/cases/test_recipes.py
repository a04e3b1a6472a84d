"""The training recipes are one table (rl/cases/recipes.py, issue 50): each recipe an entry of
RECIPE_LIST composed from shared bases, and every view by name read from it."""

from __future__ import annotations

import dataclasses

import pytest
from elastica_magnetic_rl.cases.recipes import (
    CRAWLER_TD3_OVERRIDES,
    DEFAULT_RECIPE,
    RECIPE_LIST,
    RECIPE_RUN_SETTINGS,
    RECIPE_SUMMARIES,
    RECIPES,
    crawler_config,
)
from elastica_magnetic_rl.td3.config import TD3Config


def test_every_view_is_read_from_the_one_table():
    names = [recipe.name for recipe in RECIPE_LIST]
    assert len(set(names)) == len(names) and DEFAULT_RECIPE in names
    assert list(RECIPES) == names == list(RECIPE_SUMMARIES)
    assert RECIPE_RUN_SETTINGS == {r.name: dict(r.run) for r in RECIPE_LIST if r.run}
    assert all(RECIPE_SUMMARIES[name] for name in names)


@pytest.mark.parametrize("recipe", RECIPE_LIST, ids=lambda r: r.name)
def test_each_recipe_changes_only_td3_fields_and_builds_a_config(recipe):
    fields = {f.name for f in dataclasses.fields(TD3Config)}
    assert set(recipe.td3) <= fields and set(recipe.run) <= {"stop_when", "randomize"}
    config = crawler_config(3, recipe.name)
    for key, value in {**CRAWLER_TD3_OVERRIDES, **recipe.td3}.items():
        assert getattr(config, key) == value, key
    assert config.seed == 3
