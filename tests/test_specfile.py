"""Spec files, the physics half: the [robot] and [physics] tables build the robot they describe,
and every kind of bad input is an error naming the file, the table, the key and the unit."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from spec_texts import SMALL_BAND

from elastica_magnetic import hu2018_robot, yao2023_robot
from elastica_magnetic.cli import main
from elastica_magnetic.spec_format import loads
from elastica_magnetic.specfile import (
    SpecError,
    describe_robot,
    dumps,
    load_robot,
    magnetization_array,
)

ROBOT = SMALL_BAND + """
[robot.magnetization]
kind = "uniform"
magnitude = 1000.0
direction = [0.0, 2.0, 0.0]

[robot.ground]
"""


def _same(a, b) -> bool:
    return all(getattr(a, f.name) == getattr(b, f.name) for f in dataclasses.fields(a)
               if f.name != "magnetization") and np.array_equal(a.magnetization, b.magnetization)


def test_a_minimal_robot_gets_every_default_and_its_values():
    description = describe_robot(loads(ROBOT, "r.toml"), "r.toml")
    robot = description.robot("accurate")
    assert robot.n_elements == 8 and robot.length == 0.02 and robot.section == "band"
    assert robot.shear_modulus == pytest.approx(84500.0 / (2 * 1.48), rel=1e-15)
    assert robot.radius == pytest.approx(0.0008 / math.sqrt(3.0))
    assert np.allclose(robot.magnetization, [[0.0] * 8, [1000.0] * 8, [0.0] * 8])
    assert robot.ground is not None and robot.ground.k == 0.08 and robot.damping is None
    assert (robot.mass_scale, robot.dt) == (1.0, 8e-6)
    training = description.robot("training")
    assert training.mass_scale == pytest.approx(1000 / 95) and training.dt == 1e-4
    # complete tables: every default written out, and they read back to the same robot
    tables = description.tables
    assert tables["robot"]["ground"]["stiffness"] == 0.08 and tables["robot"]["gravity"] == 9.80665
    again = describe_robot(loads(dumps(tables), "again.toml"), "again.toml")
    assert again.tables == tables and _same(again.robot("training"), training)


def test_the_presets_as_spec_tables_are_the_presets():
    """Writing the paper's robot as a spec (as the shipped case files do) loses nothing."""
    for pattern in (1, 2):
        text = f"""
[robot]
name = "yao2023-m{pattern}"
length = 0.02
n_elements = 64
width = 0.008
thickness = 0.0008
density = 1860.0
youngs_modulus = 84500.0
shear_modulus = {84.5e3 / 1.48!r}
[robot.magnetization]
kind = "yao2023-pattern{pattern}"
magnitude = 61300.0
[robot.ground]
[robot.damping]
"""
        description = describe_robot(loads(text))
        for physics in ("accurate", "training"):
            assert _same(description.robot(physics), yao2023_robot(pattern, physics))


def test_sinusoid_and_table_magnetizations():
    sinusoid = {"kind": "sinusoid", "magnitude": 61.3e3, "phase": 0.0}
    assert np.array_equal(magnetization_array(sinusoid, 32), hu2018_robot(32).magnetization)
    values = np.arange(24, dtype=float).reshape(3, 8).tolist()
    text = ROBOT.replace('kind = "uniform"\nmagnitude = 1000.0\ndirection = [0.0, 2.0, 0.0]',
                         f'kind = "table"\nvalues = {values}')
    robot = describe_robot(loads(text)).robot()
    assert np.array_equal(robot.magnetization, np.array(values))


def test_a_round_rod():
    text = ROBOT.replace("width = 0.008\nthickness = 0.0008", "radius = 0.0005")
    robot = describe_robot(loads(text)).robot()
    assert robot.section == "round" and robot.radius == 0.0005
    from elastica_magnetic.simulation import robot_rod

    assert np.allclose(robot_rod(robot).radius, 0.0005)


BAD = [
    ("length = 0.02", "length = -0.02", "[robot] length: must be > 0 (m), got -0.02"),
    ("length = 0.02", "length = nan", "[robot] length: expected a finite number (m)"),
    ("length = 0.02", 'length = "20 mm"', "[robot] length: expected a number (m)"),
    ("length = 0.02\n", "", "[robot] length: missing (required)"),
    ("youngs_modulus = 84500.0", "youngs_modulus = 0.0", "[robot] youngs_modulus: must be > 0 (Pa)"),
    ("n_elements = 8", "n_elements = 1", "[robot] n_elements: must be >= 2 (elements)"),
    ("n_elements = 8", "n_elements = 8.5", "[robot] n_elements: expected an integer"),
    ("density = 1860.0", "density = 1860.0\ncolour = 1", "[robot] colour: unknown key"),
    ("[robot.ground]", "[robot.ground]\nstifness = 1.0", "[robot.ground] stifness: unknown key"),
    ('kind = "uniform"', 'kind = "helix"', "[robot.magnetization] kind: expected one of"),
    ("direction = [0.0, 2.0, 0.0]", "direction = [0.0, 0.0]", "[robot.magnetization] direction: "
     "expected a list of 3 finite numbers"),
    ("direction = [0.0, 2.0, 0.0]", "direction = [0.0, 0.0, 0.0]", "must be a non-zero direction"),
    ("poisson_ratio = 0.48", "poisson_ratio = 0.48\nshear_modulus = 1e4",
     "give either shear_modulus (Pa) or poisson_ratio"),
    ("[robot.ground]", "[robot.ground]\n[physics.training]\ndt = 3e-4",
     "[physics.training] dt: must divide the 0.01 s control period"),
    ("[robot]", "speed = 1\n[robot]", ": speed: unknown top-level key"),
]


@pytest.mark.parametrize(("old", "new", "message"), BAD, ids=[b[2][:40] for b in BAD])
def test_bad_specs_name_the_file_table_key_and_unit(old, new, message):
    assert old in ROBOT
    with pytest.raises(SpecError) as err:
        describe_robot(loads(ROBOT.replace(old, new, 1), "my.toml"), "my.toml")
    assert str(err.value).startswith("my.toml: ") and message in str(err.value), str(err.value)


def test_a_table_of_the_wrong_shape_and_bad_toml(tmp_path):
    text = ROBOT.replace('kind = "uniform"\nmagnitude = 1000.0\ndirection = [0.0, 2.0, 0.0]',
                         'kind = "table"\nvalues = [[1.0, 2.0], [0.0, 0.0], [0.0, 0.0]]')
    with pytest.raises(SpecError, match=r"my.toml: \[robot.magnetization\] values: expected shape "
                                        r"\(3, 8\).*A/m.*got \(3, 2\)"):
        describe_robot(loads(text, "my.toml"), "my.toml")
    broken = tmp_path / "broken.toml"
    broken.write_text("[robot\nlength = 1")
    with pytest.raises(SpecError, match=r"broken.toml: not valid TOML"):
        load_robot(broken)
    with pytest.raises(SpecError, match=r"nothere.toml: no such spec file"):
        load_robot(tmp_path / "nothere.toml")
    with pytest.raises(SpecError, match="unknown robot 'yao2024'"):
        load_robot("yao2024")


def test_simulate_takes_a_spec_file_and_refuses_a_bad_one(tmp_path, capsys):
    good = tmp_path / "my.toml"
    good.write_text(ROBOT.replace("[robot.ground]", "[robot.ground]\n[robot.damping]"))
    out = tmp_path / "sim"
    assert main(["field", "simulate", "--robot", str(good), "--duration", "0.05", "--physics", "training",
                 "--out", str(out), "--json"]) == 0
    assert (out / "trajectory.csv").is_file()
    bad = tmp_path / "bad.toml"
    bad.write_text(ROBOT.replace("length = 0.02", "length = 0.0"))
    with pytest.raises(SystemExit) as exit_:
        main(["field", "simulate", "--robot", str(bad), "--out", str(tmp_path / "never")])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert "argument --robot: " in err and "bad.toml: [robot] length: must be > 0 (m)" in err
    assert not (tmp_path / "never").exists()


def test_the_sideways_friction_of_the_ground_is_a_choice_kept_through_a_dump():
    """``[robot.ground] sideways``: ``"rolling"`` (the default, left out of the complete tables so
    that earlier run records read the same) or ``"sliding"`` (a band); anything else named."""
    assert describe_robot(loads(ROBOT, "r.toml"), "r.toml").robot("training").ground.sideways == \
        "rolling"
    assert "sideways" not in describe_robot(loads(ROBOT, "r.toml"), "r.toml").tables["robot"]["ground"]
    sliding = describe_robot(loads(ROBOT + 'sideways = "sliding"\n', "s.toml"), "s.toml")
    assert sliding.robot("training").ground.sideways == "sliding"
    again = describe_robot(loads(dumps(sliding.tables), "again.toml"), "again.toml")
    assert again.robot("accurate").ground.sideways == "sliding"
    with pytest.raises(SpecError, match=r"s\.toml: \[robot\.ground\] sideways: expected one of "
                                        r"rolling, sliding; got 'slide'"):
        describe_robot(loads(ROBOT + 'sideways = "slide"\n', "s.toml"), "s.toml")


def test_the_friction_integration_of_the_ground_is_a_choice_kept_through_a_dump():
    """``[robot.ground] friction``: ``"explicit"`` (PyElastica's, the default, left out of the complete
    tables) or ``"implicit"`` (needs a sliding band, refused by name on a rolling rod)."""
    plain = describe_robot(loads(ROBOT, "r.toml"), "r.toml")
    assert plain.robot("training").ground.friction == "explicit"
    assert "friction" not in plain.tables["robot"]["ground"]
    text = ROBOT + 'sideways = "sliding"\nfriction = "implicit"\n'
    implicit = describe_robot(loads(text, "i.toml"), "i.toml")
    assert implicit.robot("training").ground.friction == "implicit"
    again = describe_robot(loads(dumps(implicit.tables), "again.toml"), "again.toml")
    assert again.robot("accurate").ground.friction == "implicit"
    with pytest.raises(SpecError, match=r'i\.toml: \[robot\.ground\] friction: needs sideways = "sliding"'):
        describe_robot(loads(ROBOT + 'friction = "implicit"\n', "i.toml"), "i.toml")
    with pytest.raises(SpecError, match=r"i\.toml: \[robot\.ground\] friction: expected one of "
                                        r"explicit, implicit; got 'stick'"):
        describe_robot(loads(ROBOT + 'friction = "stick"\n', "i.toml"), "i.toml")


def test_a_shear_modulus_below_a_third_of_youngs_is_warned_about():
    """Round 11, S1: shear_modulus = 1000 Pa beside E = 84.5 kPa (an implied Poisson ratio of 41)
    passed in silence; written as poisson_ratio it is refused."""
    import warnings

    from elastica_magnetic.plausibility import ImplausibleValueWarning

    spec = loads(ROBOT.replace("poisson_ratio = 0.48", "shear_modulus = 1000.0"))
    with pytest.warns(ImplausibleValueWarning, match=r"\[robot\] shear_modulus: 1000 Pa is below a "
                                                     r"third of youngs_modulus \(84500 Pa\).*41\.2"):
        describe_robot(spec, "my.toml")
    spec["robot"]["shear_modulus"] = 84500.0 / 3.0  # nu = 0.5 exactly: an incompressible solid
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImplausibleValueWarning)
        describe_robot(spec, "my.toml")
        spec["robot"]["shear_modulus"] = 1000.0
        spec["checks"] = {"accept": ["robot.shear_modulus"]}
        describe_robot(spec, "my.toml")


def test_a_shear_modulus_above_youngs_is_warned_and_a_factor_of_100_away_refused():
    """Round 12, S1: G > E (an implied Poisson ratio below -0.5, as poisson_ratio = -0.9 is warned)
    passed in silence, and G written 1000x (kPa as Pa, either way) was only warned or not at all."""
    import warnings

    from elastica_magnetic.plausibility import ImplausibleValueWarning

    spec = loads(ROBOT.replace("poisson_ratio = 0.48", "shear_modulus = 100000.0"))
    with pytest.warns(ImplausibleValueWarning, match=r"shear_modulus: 100000 Pa is above "
                                                     r"youngs_modulus \(84500 Pa\).*-0\.578"):
        describe_robot(spec, "my.toml")
    for shear, named in ((57094594.6, r"G 676 times E is no solid's.*unit mistake"),
                         (57.09, r"impossible for a solid: kPa written where Pa is expected\? "
                                 r"\(57\.09 kPa is 57090 Pa\)")):
        spec["robot"]["shear_modulus"] = shear
        with pytest.raises(SpecError, match=r"my\.toml: \[robot\] shear_modulus: .*" + named):
            describe_robot(spec, "my.toml")
    with warnings.catch_warnings():  # the authors' effective E / (1 + nu) and the isotropic range
        warnings.simplefilter("error", ImplausibleValueWarning)
        for shear in (84500.0 / 1.48, 84500.0 / 2.0, 84500.0):
            spec["robot"]["shear_modulus"] = shear
            describe_robot(spec, "my.toml")


def test_a_segment_fraction_in_percent_is_named():
    """Round 11, V5: fraction = 50 got "must be <= 1" without the percent hint the other fraction
    keys give."""
    text = ROBOT.replace('kind = "uniform"\nmagnitude = 1000.0\ndirection = [0.0, 2.0, 0.0]',
                         'kind = "segments"\nsegments = [{fraction = 50, direction = [1.0, 0.0, 0.0]},'
                         ' {fraction = 50, direction = [-1.0, 0.0, 0.0]}]\nmagnitude = 61300.0')
    with pytest.raises(SpecError, match=r"segments\[0\]\] fraction: must be <= 1 \(of the length\), got "
                                        r"50; it looks like percent written for a fraction \(50 % is 0.5\)"):
        describe_robot(loads(text))
