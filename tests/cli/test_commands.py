"""``msr field simulate``: the field amplitude defaults to the spec's field limit; progress as plain lines
when the output is not a terminal."""

from __future__ import annotations

import json
from pathlib import Path

from elastica_magnetic.cli import main

SPECS = Path(__file__).resolve().parents[2] / "rl" / "specs"  # the repository root


def test_msr_simulate_defaults_to_the_specs_field_limit(tmp_path, capsys):
    spec = SPECS / "m1-10mT.toml"
    assert main(["field", "simulate", "--robot", str(spec), "--duration", "0.05", "--physics", "training",
                 "--out", str(tmp_path / "a"), "--json"]) == 0
    captured = capsys.readouterr()
    result = json.loads(captured.out)
    assert result["amplitude_T"] == 0.01 and result["amplitude_from"] == "[actuation] field_limit"
    # not a terminal: plain progress lines, not a redrawn bar
    assert "\r" not in captured.err and captured.err.count("simulate: 100% (5/5 x10ms)") == 1
    assert main(["field", "simulate", "--duration", "0.05", "--physics", "training", "--out",
                 str(tmp_path / "b"), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["amplitude_T"] == 0.004 and result["amplitude_from"].startswith("default")
    assert main(["field", "simulate", "--robot", str(spec), "--amplitude", "0.002", "--duration", "0.05",
                 "--physics", "training", "--out", str(tmp_path / "c"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["amplitude_T"] == 0.002


def test_msr_simulate_names_a_bad_field_limit(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text((SPECS / "m1-4mT.toml").read_text().replace("field_limit = 0.004", "field_limit = 2.0"))
    assert main(["field", "simulate", "--robot", str(bad), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert f"msr field simulate: error: {bad}: [actuation] field_limit: must be <= 1 (T), got 2.0" in err
    assert not (tmp_path / "out").exists()
