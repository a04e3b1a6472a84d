"""Property-based tests of the parsers of user files (issue 35): whatever a spec file or a field
CSV holds, the parser returns a valid result or raises its own named error (``SpecError``,
``FieldCSVError``), never another exception."""

from __future__ import annotations

import copy
import math
import os
import tempfile
from decimal import Decimal
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from spec_texts import SMALL_BAND

from elastica_magnetic.field_csv import FieldCSVError, read_field_csv
from elastica_magnetic.robot_spec import RobotSpec
from elastica_magnetic.spec_format import loads
from elastica_magnetic.specfile import SpecError, describe_robot

#: Examples per property; a longer soak outside the suite: MSR_HYPOTHESIS_EXAMPLES=5000.
EXAMPLES = int(os.environ.get("MSR_HYPOTHESIS_EXAMPLES", "150"))
SETTINGS = settings(max_examples=EXAMPLES, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])

BASE = loads('name = "c"\n' + SMALL_BAND + """name = "r"
[robot.magnetization]
kind = "two-segment"
magnitude = 1000.0
first = [1.0, 0.0, 0.0]
second = [0.0, 1.0, 0.0]
[robot.ground]
static_mu = 0.8
[robot.damping]
[robot.interaction]
cutoff = 0.01  # four elements: four radii is shorter than one of these
[physics.training]
dt = 1e-4
[physics.accurate]
dt = 8e-6
""")

KEYS = sorted({"name", "length", "n_elements", "width", "thickness", "radius", "density",
               "youngs_modulus", "shear_modulus", "poisson_ratio", "shear_coefficient", "gravity",
               "kind", "magnitude", "direction", "first", "second", "split", "phase", "values",
               "static_mu", "kinetic_mu", "stiffness", "damping", "surface_tolerance",
               "slip_velocity_tolerance", "relative", "node_offset", "legacy_force",
               "legacy_torque", "kelvin_voigt", "cutoff", "band_source", "self_contact_stiffness",
               "dt", "mass_scale", "robot", "physics", "magnetization", "ground", "interaction",
               "training", "accurate", "bogus"})

scalars = st.one_of(
    st.none(), st.booleans(), st.integers(-10**6, 10**6),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, 1e-300, 1e300, 5e-324, 0.5, 2.0, 64.0, 1e-7]),
    st.text(max_size=12), st.sampled_from(["uniform", "table", "sinusoid", "two-segment",
                                           "yao2023-pattern1", "../x", ".", ""]),
)
values = st.recursive(scalars, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.dictionaries(st.sampled_from(KEYS), inner, max_size=4)),
    max_leaves=12)
paths = st.lists(st.sampled_from(KEYS), min_size=1, max_size=3)


def _mutate(data: dict, path: list[str], value, delete: bool) -> dict:
    data = copy.deepcopy(data)
    node = data
    for key in path[:-1]:
        if not isinstance(node.get(key), dict):
            node[key] = {}
        node = node[key]
    if delete:
        node.pop(path[-1], None)
    else:
        node[path[-1]] = value
    return data


def _check_spec(data) -> None:
    try:
        description = describe_robot(data, "prop.toml")
    except SpecError as exc:
        assert str(exc).startswith("prop.toml: "), str(exc)
        return
    for physics in ("accurate", "training"):
        robot = description.robot(physics)
        assert isinstance(robot, RobotSpec)
        assert robot.magnetization.shape == (3, robot.n_elements)
        assert np.all(np.isfinite(robot.magnetization))
        assert robot.dt > 0 and math.isfinite(robot.length) and robot.length > 0


@SETTINGS
@given(st.lists(st.tuples(paths, values, st.booleans()), min_size=1, max_size=4))
def test_a_mutated_spec_is_a_robot_or_a_spec_error(mutations):
    data = BASE
    for path, value, delete in mutations:
        data = _mutate(data, path, value, delete)
    _check_spec(data)


@SETTINGS
@given(values)
def test_any_value_as_a_spec_is_a_robot_or_a_spec_error(value):
    _check_spec(value if isinstance(value, dict) else {"robot": value})


@SETTINGS
@given(st.text(max_size=300))
def test_any_text_as_toml_is_data_or_a_spec_error(text):
    try:
        data = loads(text, "prop.toml")
    except SpecError as exc:
        assert str(exc).startswith("prop.toml: not valid TOML")
        return
    _check_spec(data)


cells = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-5, 5).map(str),
    st.sampled_from(["", " ", "mag_x", "mag_y", "mag_z", "index", "1e3", "nan", "-inf", "0x10",
                     "1,5", '"2"', "\ufeff", "µ", "\x00", "1_0"]),
    st.text(max_size=5),
)
rows = st.lists(st.lists(cells, min_size=0, max_size=5).map(",".join), max_size=8)
line_ends = st.sampled_from(["\n", "\r\n", "\r"])


def _read(data: bytes):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "field.csv"
        path.write_bytes(data)
        try:
            field = read_field_csv(path)
        except FieldCSVError as exc:
            assert str(exc).startswith(str(path)), str(exc)
            return None
    assert field.ndim == 2 and field.shape[1] == 3 and field.shape[0] >= 1
    assert field.dtype == np.float64 and np.all(np.isfinite(field))
    return field


@settings(max_examples=EXAMPLES, deadline=None)
@given(st.booleans(), rows, line_ends)
def test_any_rows_as_a_field_csv_are_a_field_or_a_field_csv_error(header, body, end):
    lines = ([",mag_x,mag_y,mag_z"] if header else []) + body
    _read(end.join(lines).encode("utf-8", "surrogatepass"))


@settings(max_examples=EXAMPLES, deadline=None)
@given(st.binary(max_size=200))
def test_any_bytes_as_a_field_csv_are_a_field_or_a_field_csv_error(data):
    _read(data)


@settings(max_examples=EXAMPLES, deadline=None)
@given(st.lists(st.tuples(*[st.floats(-1e3, 1e3, allow_nan=False)] * 3), min_size=1, max_size=20))
def test_a_valid_field_csv_reads_back_in_tesla(samples):
    text = ",mag_x,mag_y,mag_z\n" + "".join(
        f"{i},{x!r},{y!r},{z!r}\n" for i, (x, y, z) in enumerate(samples))
    field = _read(text.encode())
    # each value the double nearest its decimal / 1000 (exact in decimal: one rounding)
    expected = [[float(Decimal(repr(v)) / 1000) for v in row] for row in samples]
    np.testing.assert_array_equal(field, np.array(expected, dtype=np.float64))
