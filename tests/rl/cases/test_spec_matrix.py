"""Variation keys mean the same on every spec a user can write (issue 49), over the spec matrix
(``spec_matrix.py``): the default set has every group; ``magnetization`` scales the magnetization
wherever the spec keeps it (pattern magnitude, each segment, a table), ``modulus`` scales Young's
and shear modulus together (or Young's with the Poisson ratio kept), by exactly the factor, in the
robot the parser builds; the keys a user's spec sets are accepted as written; and a spec with
``randomize = "default"`` (what ``msr refine --randomize default`` stores) reads back through its
own parser."""

from __future__ import annotations

import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import case_from_dict, with_randomize
from elastica_magnetic_rl.cases.variations import (
    DEFAULT_RANGES,
    Variant,
    VariationError,
    apply_variant,
    default_variations,
    parse_variation,
    resolve_variations,
)
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from spec_matrix import user_specs

from elastica_magnetic.specfile import describe_robot

MATRIX = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _robot(tables):
    return describe_robot(tables, "varied").robot("accurate")


def _varied(tables, variation, factor):
    variant = Variant("v", "one-at-a-time", {variation.name: factor})
    return _robot(apply_variant(tables, [variation], variant))


@MATRIX
@given(spec=user_specs(), factor=st.floats(0.5, 1.5))
def test_every_default_group_applies_and_scales_what_it_names(spec, factor):
    case = case_from_dict(spec, "drawn.toml")
    tables = case.robot.tables
    variations = {v.name: v for v in default_variations(tables)}
    assert set(variations) == set(DEFAULT_RANGES)  # no group silently dropped
    nominal = _robot(tables)

    varied = _varied(tables, variations["magnetization"], factor)
    np.testing.assert_allclose(varied.magnetization, factor * nominal.magnetization, rtol=1e-12)
    varied = _varied(tables, variations["modulus"], factor)
    assert varied.youngs_modulus == pytest.approx(factor * nominal.youngs_modulus, rel=1e-12)
    assert varied.shear_modulus == pytest.approx(factor * nominal.shear_modulus, rel=1e-12)
    varied = _varied(tables, variations["friction"], factor)
    assert varied.ground.kinetic_mu == pytest.approx(factor * nominal.ground.kinetic_mu)
    assert varied.ground.static_mu == pytest.approx(factor * nominal.ground.static_mu)
    varied = _varied(tables, variations["density"], factor)
    assert varied.density == pytest.approx(factor * nominal.density, rel=1e-12)


@MATRIX
@given(spec=user_specs())
def test_a_spec_randomized_by_default_reads_back_through_its_own_parser(spec):
    case = with_randomize(case_from_dict(spec, "drawn.toml"), tuple(
        default_variations(case_from_dict(spec, "drawn.toml").robot.tables)))
    stored = case.to_dict()  # what a run stores (run.json's case_spec)
    again = case_from_dict(stored, "run.json")
    assert again.to_dict() == stored
    assert [v.keys for v in again.training.randomize] == [v.keys for v in case.training.randomize]


@MATRIX
@given(spec=user_specs())
def test_the_keys_a_users_spec_sets_are_accepted_as_written(spec):
    """``robot.magnetization.magnitude`` written in the user's spec (a segments spec moves it into
    every segment when completed) and the named groups resolve on the complete spec."""
    tables = case_from_dict(spec, "drawn.toml").robot.tables
    written = spec["robot"]["magnetization"]
    if "magnitude" in written or written["kind"] not in ("segments", "table"):
        [variation] = resolve_variations([parse_variation("robot.magnetization.magnitude=0.9:1.1")],
                                         tables)
        nominal = _robot(tables)
        np.testing.assert_allclose(_varied(tables, variation, 1.1).magnetization,
                                   1.1 * nominal.magnetization, rtol=1e-12)
    for group in ("magnetization", "modulus"):
        resolve_variations([parse_variation(f"{group}=0.8:1.2")], tables)
    if "poisson_ratio" in spec["robot"]:
        with pytest.raises(VariationError, match="follows robot.youngs_modulus"):
            resolve_variations([parse_variation("robot.shear_modulus=0.8:1.2")], tables)


def test_a_table_is_varied_only_by_a_factor():
    spec = {"name": "t", "actuation": {"field_limit": 0.004}, "task": {"kind": "crawl"},
            "robot": {"name": "t", "length": 0.02, "n_elements": 4, "width": 0.008,
                      "thickness": 0.0008, "density": 1860.0, "youngs_modulus": 84500.0,
                      "poisson_ratio": 0.48, "ground": {}, "magnetization": {
                          "kind": "table", "values": [[5e4] * 4, [0.0] * 4, [0.0] * 4]}}}
    tables = case_from_dict(spec, "t.toml").robot.tables
    with pytest.raises(VariationError, match="is a table; it is varied by a factor"):
        resolve_variations([parse_variation("robot.magnetization.values=abs:1:2")], tables)
