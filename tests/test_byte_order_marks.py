"""Documents saved as "UTF-8 with BOM" (Excel, Notepad) are named as such (issue 48, "Tracebacks
and vague messages", item 3): a spec file was "not valid TOML: Invalid statement (at line 1,
column 1)". TOML has no byte-order mark (tomllib and other readers refuse it), so a spec is refused
with the message that says how to save it; CSV tables skip it (``tests/test_field_csv_robustness.py``,
``tests/hardware/test_byte_order_marks.py``, ``tests/cli/test_malformed_files.py``)."""

from __future__ import annotations

import pytest
from spec_texts import SMALL_BAND

from elastica_magnetic.cli import main
from elastica_magnetic.field_spec import load_field
from elastica_magnetic.specfile import SpecError, load_robot

BOM = b"\xef\xbb\xbf"

ROBOT = SMALL_BAND + """
[robot.magnetization]
kind = "uniform"
magnitude = 1000.0
direction = [0.0, 1.0, 0.0]

[robot.ground]
"""


def expected(path) -> str:
    return (f"{path} starts with a UTF-8 byte-order mark (saved by Excel/Notepad as 'UTF-8 with "
            "BOM'); save it as plain UTF-8")


def test_a_spec_with_a_byte_order_mark_is_named(tmp_path):
    path = tmp_path / "my.toml"
    path.write_bytes(BOM + ROBOT.encode())
    with pytest.raises(SpecError) as info:
        load_robot(path)
    assert str(info.value) == expected(path)
    path.write_bytes(ROBOT.encode())  # the same text without it is a robot
    assert load_robot(path).n_elements == 8


def test_the_field_of_a_spec_with_a_byte_order_mark_is_named_too(tmp_path):
    path = tmp_path / "my.toml"
    path.write_bytes(BOM + ROBOT.encode())
    with pytest.raises(SpecError) as info:
        load_field(path)
    assert str(info.value) == expected(path)
    path.write_bytes(ROBOT.encode())
    assert load_field(path) is None  # no [field] table: the uniform field of the command line


def test_the_command_line_names_it_before_simulating(tmp_path, capsys):
    path = tmp_path / "my.toml"
    path.write_bytes(BOM + ROBOT.encode())
    with pytest.raises(SystemExit) as info:
        main(["field", "simulate", "--robot", str(path), "--out", str(tmp_path / "out")])
    assert info.value.code == 2
    assert f"msr field simulate: error: argument --robot: {expected(path)}" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
