"""Property-based tests of the hardware parsers (issue 35): whatever a calibration file holds, it
is read as a calibration or refused with :class:`CalibrationError` / :class:`PlausibilityError`
naming the file, never another exception; whatever line a board sends, the line parsers return
a report or None, never raise."""

from __future__ import annotations

import copy
import json
import os
import tempfile
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from elastica_magnetic.hardware.calibration import (
    Calibration,
    CalibrationError,
    calibration_from_dict,
    load_calibration,
)
from elastica_magnetic.hardware.plausibility import PlausibilityError
from elastica_magnetic.hardware.protocol import parse_credit, parse_dac, parse_safe, parse_status

from .conftest import DEFAULT_CALIBRATION

#: Examples per property (few: the suite's time budget); a longer soak outside the suite:
#: MSR_HYPOTHESIS_EXAMPLES=5000.
EXAMPLES = int(os.environ.get("MSR_HYPOTHESIS_EXAMPLES", "50"))
SETTINGS = settings(max_examples=EXAMPLES, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])
BASE = json.loads(DEFAULT_CALIBRATION.read_text())
JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner,
                                                               max_size=3),
    max_leaves=8)
NAMED = (CalibrationError, PlausibilityError)


def read_or_refuse(data, source="cal.json") -> Calibration | None:
    try:
        return calibration_from_dict(data, source)
    except NAMED as exc:
        assert str(exc).startswith(source), str(exc)
        return None


@SETTINGS
@given(st.lists(st.tuples(st.sampled_from(sorted(BASE)), JSON_VALUES | st.just("delete")),
                min_size=1, max_size=3))
def test_a_mutated_calibration_is_read_or_refused_naming_it(mutations):
    data = copy.deepcopy(BASE)
    for key, value in mutations:
        if value == "delete":
            data.pop(key, None)
        else:
            data[key] = value
    read_or_refuse(data)


@SETTINGS
@given(st.sampled_from(["actuation_matrix_T_per_A", "transconductance_A_per_V",
                        "current_limit_A", "slew_limit_A_per_s", "input_offset_V"]),
       st.integers(0, 2), st.floats(allow_nan=True, allow_infinity=True))
def test_any_number_in_a_calibration_is_read_or_refused(key, index, value):
    data = copy.deepcopy(BASE)
    if key == "actuation_matrix_T_per_A":
        data[key][index][index] = value
    else:
        data[key][index] = value
    read_or_refuse(data)


@SETTINGS
@given(JSON_VALUES)
def test_any_json_value_as_a_calibration_is_refused_naming_it(value):
    assert read_or_refuse(value) is None


@SETTINGS
@given(st.binary(max_size=300))
def test_any_bytes_as_a_calibration_file_are_read_or_refused_naming_it(data):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "coils.json"
        path.write_bytes(data)
        try:
            load_calibration(path)
        except NAMED as exc:
            assert str(exc).startswith(str(path)), str(exc)


@SETTINGS
@given(st.sampled_from(["CREDIT ", "DAC ", "DAC safe ", "SAFE ", "STATUS ", ""]),
       st.text(max_size=40))
def test_any_board_line_is_parsed_or_none(prefix, rest):
    line = prefix + rest
    for parse in (parse_credit, parse_dac, parse_safe, parse_status):
        parse(line)  # a report or None: never raises
    credit = parse_credit(line)
    assert credit is None or (credit >= 0 and line.strip().startswith("CREDIT "))
