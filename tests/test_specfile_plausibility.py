"""Plausibility before work (issue 35, mechanism 3): a spec whose name escapes its folder, whose
band is not thin, whose friction is reversed or whose time step cannot be stable is refused at
parse time, naming the file, table, key, the limit and what to change; a millimetre robot that
PyElastica's absolute rigidity threshold used to refuse is built and simulated."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from elastica_magnetic import RotatingField, run_open_loop
from elastica_magnetic.presets import ROBOTS, robot_by_name
from elastica_magnetic.section import equivalent_radius, rectangular_band_rod, rigidity_scale
from elastica_magnetic.spec_format import loads
from elastica_magnetic.specfile import SpecError, describe_robot, load_robot
from elastica_magnetic.stability import estimated_stable_time_step

BAND = """
name = "{case}"
[robot]
name = "{name}"
length = 0.02
n_elements = 8
width = {width}
thickness = 0.0008
density = 1860.0
youngs_modulus = 84500.0
poisson_ratio = 0.48
[robot.magnetization]
kind = "yao2023-pattern1"
[robot.ground]
static_mu = 0.8
kinetic_mu = {kinetic}
"""


def spec(case="c1", name="band", width=0.008, kinetic=0.6):
    return loads(BAND.format(case=case, name=name, width=width, kinetic=kinetic), "my.toml")


@pytest.mark.parametrize("name, why", [
    ("../x", "contains a path separator"), ("/abs", "contains a path separator"),
    ("a\\\\b", "contains a path separator"), ("..", "starts with a dot"),
    (".hidden", "starts with a dot"), ("", "is empty"), ("x\\ty", "contains a control character"),
    ("x" * 101, "is longer than 100 characters"),
])
@pytest.mark.parametrize("where", ["case", "robot"])
def test_a_name_that_is_a_path_is_refused(name, why, where):
    data = spec(**{"case" if where == "case" else "name": name})
    table = "" if where == "case" else "[robot] "
    with pytest.raises(SpecError, match=rf"^my\.toml: {re.escape(table)}name: .*{why}: a name "
                                        r"becomes a folder or file name.*not a path"):
        describe_robot(data, "my.toml")


def test_a_plain_name_is_kept():
    assert describe_robot(spec(case="m1-4mT.v2", name="my_robot 2"), "my.toml").name == "my_robot 2"


def test_a_band_narrower_than_thick_is_refused():
    with pytest.raises(SpecError, match=r"my\.toml: \[robot\] width: 0\.0005 m is smaller than "
                                        r"thickness = 0\.0008 m: the equivalent-rod model .* assumes "
                                        r"a thin band \(width >= thickness\)"):
        describe_robot(spec(width=0.0005), "my.toml")
    assert describe_robot(spec(width=0.0008), "my.toml")  # a square section is fine


def test_kinetic_friction_above_static_is_refused():
    with pytest.raises(SpecError, match=r"\[robot\.ground\] kinetic_mu: 0\.9 is above static_mu = "
                                        r"0\.8: Coulomb friction has kinetic <= static"):
        describe_robot(spec(kinetic=0.9), "my.toml")


@pytest.mark.parametrize("name", ROBOTS)
@pytest.mark.parametrize("physics", ["accurate", "training"])
def test_the_presets_time_steps_are_within_the_stable_limit(name, physics):
    robot = robot_by_name(name, physics)
    stable, limiting, limits = estimated_stable_time_step(robot)
    assert robot.dt < stable < limits[limiting]


MILLI = """
[robot]
name = "milli"
length = 0.002
n_elements = 10
width = 0.0008
thickness = 0.00008
density = 1860.0
youngs_modulus = 84500.0
poisson_ratio = 0.48
[robot.magnetization]
kind = "yao2023-pattern1"
[robot.ground]
"""


def test_a_millimetre_robot_with_the_default_time_step_is_refused_naming_the_limit(tmp_path):
    path = tmp_path / "milli.toml"
    path.write_text(MILLI)
    with pytest.raises(SpecError, match=r"milli\.toml: \[physics\.training\] dt: 0\.0001 s \(the "
                                        r"default\) is above this robot's stability limit 8\.7\de-06 s \(the "
                                        r"ground damping limit; .* Set dt = 2e-06 in "
                                        r"\[physics\.training\]"):
        load_robot(path, "accurate")
    path.write_text(MILLI + "[physics.training]\ndt = 4e-6\n[physics.accurate]\ndt = 1e-6\n")
    with pytest.raises(SpecError, match=r"\[physics\.accurate\] dt: 1e-06 s \(given\) is above this "
                                        r"robot's stability limit 8\.\d+e-07 s"):
        load_robot(path, "accurate")


def test_a_millimetre_band_is_built_with_its_own_rigidity_and_simulated(tmp_path):
    """A 2 mm x 0.8 mm x 80 um band: E I = 3.0e-13 N m^2 is below PyElastica 1.0's absolute
    threshold (Tolerance.atol(), 2.2e-12), which used to fail with "Bend matrix has to be greater
    than 0"; it is built stiffer by a power of two and softened back exactly."""
    radius = equivalent_radius(80e-6)
    second_moment = math.pi * radius**4 / 4
    shear = 84500.0 / (2 * 1.48)
    assert 84500.0 * second_moment < 2.3e-12 and rigidity_scale(radius, 84500.0, shear) >= 16
    rod = rectangular_band_rod(10, 0.002, 0.0008, 80e-6, 1860.0, 84500.0, shear)
    np.testing.assert_allclose(rod.bend_matrix[0, 0], 84500.0 * second_moment, rtol=1e-12)
    np.testing.assert_allclose(rod.bend_matrix[2, 2], shear * 2 * second_moment, rtol=1e-12)
    np.testing.assert_allclose(rod.shear_matrix[2, 2], 84500.0 * math.pi * radius**2, rtol=1e-12)
    path = tmp_path / "milli.toml"
    path.write_text(MILLI + "[physics.accurate]\ndt = 4e-7\n[physics.training]\ndt = 4e-6\n")
    result = run_open_loop(load_robot(path, "accurate"), RotatingField(4e-3, -1.0), 0.01)
    assert np.all(np.isfinite(result.trajectory.to_numpy()))
    assert 0.0 < result.max_height < 2e-3  # lifted by the field, not thrown by the ground

