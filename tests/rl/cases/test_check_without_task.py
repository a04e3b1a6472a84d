"""``msr case check`` on a spec without a ``[task]`` table (issue 48, "Tracebacks and vague
messages", item 5): such a spec describes a robot that ``msr field simulate --robot`` simulates but
``msr train`` cannot train. ``msr case check`` refused it ("task: missing (required)"); it now
checks the robot and says what it checked and what it could not, and why."""

from __future__ import annotations

import json

import pytest
from elastica_magnetic_rl.cases.case import load_case
from spec_texts import SMALL_BAND

from elastica_magnetic.cli import main as msr
from elastica_magnetic.specfile import dumps

SMALL_ROBOT = SMALL_BAND + """
[robot.magnetization]
kind = "uniform"
magnitude = 1000.0
direction = [0.0, 1.0, 0.0]

[robot.ground]
"""


def without(tmp_path, *tables: str) -> str:
    """m1-4mT's spec without ``tables``, as a file."""
    spec = {k: v for k, v in load_case("m1-4mT").to_dict().items() if k not in tables}
    path = tmp_path / "robot.toml"
    path.write_text(dumps(spec))
    return str(path)


def test_a_spec_without_task_or_training_is_checked_and_says_what_not(tmp_path, capsys):
    spec = without(tmp_path, "task", "training")
    assert msr(["case", "check", spec, "--no-sag"]) == 0
    out = capsys.readouterr().out
    assert "magnetic bending number M B L^2 A / EI = 21.8" in out and "dt training" in out
    assert out.rstrip().splitlines()[-1] == (
        "  checked: robot, time steps, field limit; not checked: sag (--no-sag); training (the "
        f"spec has no [task] table; it can be simulated with msr field simulate --robot {spec}, not "
        "trained)")


def test_a_training_table_without_a_task_is_said_to_be_unread(tmp_path, capsys):
    spec = without(tmp_path, "task")
    assert msr(["case", "check", spec, "--no-sag", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["checked"] == ["robot", "time steps", "field limit"]
    assert data["not_checked"][-1].startswith(
        "training (the spec has no [task] table, so its [training] table is not read either;")
    assert data["field_limit_T"] == 0.004 and not data["has_errors"]


def test_a_bare_robot_gets_its_sag_simulated(tmp_path, capsys):
    path = tmp_path / "small.toml"
    path.write_text(SMALL_ROBOT)
    assert msr(["case", "check", str(path)]) == 0
    last = capsys.readouterr().out.rstrip().splitlines()[-1]
    assert last.startswith("  checked: robot, time steps, sag; not checked: field limit (no "
                           "[actuation] field_limit); training (the spec has no [task] table;")


def test_a_bad_key_of_a_robot_without_task_is_named_before_the_check(tmp_path, capsys):
    path = tmp_path / "small.toml"
    path.write_text(SMALL_ROBOT.replace("length = 0.02", "length = -0.02"))
    with pytest.raises(SystemExit) as info:
        msr(["case", "check", str(path)])
    assert info.value.code == 2
    assert f"argument case: {path}: [robot] length: must be > 0 (m), got -0.02" in (
        capsys.readouterr().err)


def test_a_spec_with_a_task_is_still_checked_as_a_case(tmp_path, capsys):
    spec = without(tmp_path, "actuation")  # a case missing a required table stays an error
    with pytest.raises(SystemExit):
        msr(["case", "check", spec, "--no-sag"])
    assert f"argument case: {spec}: [actuation] missing: a required table (field_limit (T)" in (
        capsys.readouterr().err)


def test_show_of_a_spec_without_task_says_what_the_table_is_for(tmp_path, capsys):
    spec = without(tmp_path, "task")
    with pytest.raises(SystemExit):
        msr(["case", "show", spec])
    err = capsys.readouterr().err
    assert f"argument case: {spec}: [task] missing: a required table (what the robot learns" in err, err
    assert "msr field simulate --robot FILE" in err
