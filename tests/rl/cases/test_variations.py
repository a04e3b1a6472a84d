"""Variations: parsing (named errors), the default set, the designs, and variants through the
normal spec parser."""

import pytest
from elastica_magnetic_rl.cases.case import case_from_dict, load_case
from elastica_magnetic_rl.cases.variations import (
    Variation,
    VariationError,
    apply_variant,
    default_variations,
    design,
    get_value,
    parse_variation,
    resolve_variations,
    variable_keys,
)

from elastica_magnetic.specfile import SpecError


@pytest.fixture(scope="module")
def spec():
    return load_case("m1-4mT").to_dict()


def test_parse_relative_absolute_and_groups():
    v = parse_variation("robot.magnetization.magnitude=0.85:1.15")
    assert v == Variation("robot.magnetization.magnitude", ("robot.magnetization.magnitude",), 0.85,
                          1.15, False)
    v = parse_variation("robot.ground.kinetic_mu=abs:0.3:0.5")
    assert v.absolute and (v.low, v.high) == (0.3, 0.5)
    v = parse_variation("modulus=0.8:1.2")
    assert v.keys == ("robot.youngs_modulus", "robot.shear_modulus")
    v = parse_variation("robot.density+robot.ground.kinetic_mu=0.9:1.1")
    assert v.keys == ("robot.density", "robot.ground.kinetic_mu")


@pytest.mark.parametrize("text, message", [
    ("robot.density", "expected KEY=LOW:HIGH"),
    ("robot.density=1.1:0.9", "LOW 1.1 is greater than HIGH 0.9"),
    ("robot.density=0:1.1", "relative factors must be > 0"),
    ("robot.density=-0.5:1.1", "relative factors must be > 0"),
    ("robot.density=0.9", "the range must be LOW:HIGH"),
    ("robot.density=0.9:x", "HIGH 'x' is not a number"),
    ("robot.density=nan:1", "LOW must be finite"),
    ("friction=abs:0.3:0.5", "an absolute range (abs:) sets one key"),
    ("=0.9:1.1", "expected KEY[+KEY...]"),
    ("robot.density+robot.density=0.9:1.1", "a key appears twice"),
])
def test_parse_errors_are_named(text, message):
    with pytest.raises(VariationError) as info:
        parse_variation(text)
    assert message in str(info.value)
    assert text in str(info.value)


def test_unknown_key_lists_the_valid_keys_and_a_close_one(spec):
    with pytest.raises(VariationError) as info:
        resolve_variations([parse_variation("robot.magnetisation.magnitude=0.9:1.1")], spec)
    text = str(info.value)
    assert "unknown key 'robot.magnetisation.magnitude'" in text
    assert "did you mean robot.magnetization.magnitude" in text
    assert "robot.ground.kinetic_mu" in text and "robot.youngs_modulus" in text
    # integers (n_elements) and strings (the magnetization kind) are not variable
    assert "robot.n_elements" not in variable_keys(spec)
    with pytest.raises(VariationError, match="unknown key 'robot.n_elements'"):
        resolve_variations([parse_variation("robot.n_elements=0.5:2")], spec)


def test_key_varied_twice_and_relative_on_zero(spec):
    with pytest.raises(VariationError, match="robot.ground.static_mu is already taken by --vary friction; "
                                             "name it in one of them"):
        resolve_variations([parse_variation("friction=0.8:1.2"),
                            parse_variation("robot.ground.static_mu=0.9:1.1")], spec)
    # round 42: one key twice was "already varied by" itself
    with pytest.raises(VariationError, match="robot.density is named twice; name it once"):
        resolve_variations([parse_variation("robot.density=0.9:1.1"),
                            parse_variation("robot.density=0.8:1.2")], spec)
    assert get_value(spec, "robot.damping.kelvin_voigt") == 0.0
    with pytest.raises(VariationError, match="is 0 in this spec.*abs:LOW:HIGH"):
        resolve_variations([parse_variation("robot.damping.kelvin_voigt=0.5:2")], spec)
    resolve_variations([parse_variation("robot.damping.kelvin_voigt=abs:0:0.1")], spec)


def test_default_set(spec):
    defaults = {v.name: v for v in default_variations(spec)}
    assert {n: (v.low, v.high) for n, v in defaults.items()} == {
        "magnetization": (0.85, 1.15), "modulus": (0.8, 1.2), "friction": (0.75, 1.25),
        "density": (0.9, 1.1)}
    assert defaults["modulus"].keys == ("robot.youngs_modulus", "robot.shear_modulus")
    assert defaults["friction"].keys == ("robot.ground.static_mu", "robot.ground.kinetic_mu")


def spec_copy(spec):
    import copy

    return copy.deepcopy(spec)


def test_default_set_without_shear_modulus(spec):
    # a spec with a Poisson ratio has no shear modulus: it follows Young's modulus by itself
    other = spec_copy(spec)
    del other["robot"]["shear_modulus"]
    other["robot"]["poisson_ratio"] = 0.48
    modulus = {v.name: v for v in default_variations(other)}["modulus"]
    assert modulus.keys == ("robot.youngs_modulus",)


def test_designs_count_and_content(spec):
    variations = default_variations(spec)
    variants = design(variations, spec, samples=5, seed=3)
    kinds = [v.kind for v in variants]
    assert kinds.count("nominal") == 1 and kinds[0] == "nominal"
    assert kinds.count("one-at-a-time") == 8
    assert kinds.count("corner") == 16
    assert kinds.count("sample") == 5
    samples = [v for v in variants if v.kind == "sample"]
    for variation in variations:  # Latin hypercube: one draw in each fifth of every range
        strata = sorted(int(5 * (s.settings[variation.name] - variation.low)
                            / (variation.high - variation.low)) for s in samples)
        assert strata == [0, 1, 2, 3, 4]
    again = design(variations, spec, samples=5, seed=3)
    assert [v.settings for v in again] == [v.settings for v in variants]
    other = design(variations, spec, samples=5, seed=4)
    assert [v.settings for v in other][-5:] != [v.settings for v in variants][-5:]
    # one variation: its corners are its one-at-a-time ends, listed once
    single = design([variations[0]], spec)
    assert [v.label for v in single] == ["nominal", "magnetization x0.85", "magnetization x1.15"]


def test_variants_go_through_the_spec_parser(spec):
    variation = parse_variation("friction=0.5:1.5")
    variant = design([variation], spec, corners=False)[1]
    varied = apply_variant(spec, [variation], variant)
    case = case_from_dict(varied, "variant")
    robot = case.robot_spec("training")
    assert robot.ground.static_mu == pytest.approx(0.4) and robot.ground.kinetic_mu == pytest.approx(0.3)
    assert spec["robot"]["ground"]["static_mu"] == 0.8  # the nominal spec is unchanged
    bad = parse_variation("robot.ground.kinetic_mu=abs:-0.2:0.5")
    variant = design([bad], spec, corners=False)[1]
    with pytest.raises(SpecError, match=r"\[robot.ground\] kinetic_mu: must be >= 0"):
        case_from_dict(apply_variant(spec, [bad], variant), "variant")
