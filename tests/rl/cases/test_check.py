"""``msr case check`` and ``msr case show``'s summary (rl/cases/check.py)."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
from elastica_magnetic_rl.cases import check as case_check
from elastica_magnetic_rl.cases.case import load_case

from elastica_magnetic.cli import main as msr
from elastica_magnetic.spec_check import Issue
from elastica_magnetic.specfile import dumps


def _spec_file(tmp_path, name: str, changes: dict) -> str:
    """A copy of m1-4mT's spec with some tables changed, as a file."""
    spec = load_case("m1-4mT").to_dict()
    for (table, key), value in changes.items():
        target = spec
        for part in table.split("."):
            target = target[part]
        target[key] = value
    path = tmp_path / f"{name}.toml"
    path.write_text(dumps(spec))
    return str(path)


def test_check_prints_derived_quantities_and_exits_0(capsys):
    assert msr(["case", "check", "m1-4mT", "--no-sag"]) == 0
    out = capsys.readouterr().out
    assert "magnetic bending number M B L^2 A / EI = 21.8" in out
    assert "dt training" in out and "dt accurate" in out and "equivalent radius 0.4619 mm" in out
    assert msr(["case", "check", "m1-4mT", "--no-sag", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert {s["physics"] for s in data["time_steps"]} == {"training", "accurate"}
    assert data["yardstick_m"] == 0.0205


def test_check_warns_on_a_zero_yardstick(tmp_path, capsys):
    spec = _spec_file(tmp_path, "nostick", {("yardstick", "distance_10s"): 0.0})
    assert msr(["case", "check", spec, "--no-sag"]) == 0
    out = capsys.readouterr().out
    assert "warning: [yardstick] distance_10s" in out and "msr field baseline" in out


def test_check_exits_1_on_an_error(monkeypatch, capsys):
    real = case_check.check_case

    def with_error(case, sag=True):
        check = real(case, sag=sag)
        return dataclasses.replace(check, issues=[*check.issues,
                                                  Issue("error", "[physics.accurate] dt", "boom")])

    monkeypatch.setattr(case_check, "check_case", with_error)
    assert msr(["case", "check", "m1-4mT", "--no-sag"]) == 1
    assert "error: [physics.accurate] dt: boom" in capsys.readouterr().out


def test_show_is_a_readable_summary_of_long_tables(tmp_path, capsys):
    values = np.vstack([np.linspace(-61300.0, 61300.0, 64), np.zeros(64), np.zeros(64)])
    spec = _spec_file(tmp_path, "ramp", {("robot", "magnetization"):
                                        {"kind": "table", "values": values.tolist()}})
    assert msr(["case", "show", spec]) == 0
    out = capsys.readouterr().out
    assert "64 runs over 64 elements" in out and "{'" not in out and "61300.0," not in out
    assert len(out.splitlines()) < 30
    assert "field limit 4 mT" in out and "task         crawl" in out and "recipe pink-ln" in out
    assert msr(["case", "show", "m1-4mT", "--json"]) == 0  # the complete spec, as before
    assert json.loads(capsys.readouterr().out)["robot"]["magnetization"]["kind"] == "yao2023-pattern1"
