"""``msr case check`` on a spec with a ``[field]`` in space (issue 48, a held-out round of tries,
sf_*): the check never built the field, so a magnet edge in mm, a polarization in mT, a gradient
in mT/m or not symmetric, a magnet inside the rod or a coil's wire through it passed with exit
status 0, while ``msr field simulate --robot`` refused each. ``case check`` now builds and checks the
field exactly as ``simulate`` does (the same message, exit status 2; warnings as warnings) and
lists ``field`` under "checked"."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from elastica_magnetic.cli import main as msr

CATHETER = (Path(__file__).resolve().parents[3] / "elastica_magnetic" / "data" / "examples"
            / "catheter.toml").read_text()

#: ``[field]`` tables with one mistake each (catheter: a 50 mm rod along +x, radius 0.5 mm).
MISTAKES = {
    "edge in mm": 'kind = "cuboid-magnet"\ndimension = [20, 20, 20]\npolarization = [1.3, 0, 0]\n'
                  "position = [0.03, 0.04, 0.0]\n",
    "polarization in mT": 'kind = "cuboid-magnet"\ndimension = [0.02, 0.02, 0.02]\n'
                          "polarization = [1300, 0, 0]\nposition = [0.03, 0.04, 0.0]\n",
    "gradient in mT/m": 'kind = "constant-gradient"\n'
                        "gradient = [[-50, 0, 0], [0, -50, 0], [0, 0, 100]]\n",
    "gradient not symmetric": 'kind = "constant-gradient"\n'
                              "gradient = [[0, 0.1, 0], [0, 0, 0], [0, 0, 0]]\n",
    "magnet in the rod": 'kind = "cuboid-magnet"\ndimension = [0.005, 0.005, 0.005]\n'
                         "polarization = [1.3, 0, 0]\nposition = [0.03, 0.0, 0.0]\n",
    "wire through the rod": 'kind = "current-loop"\nradius = 0.01\ncurrent = 1.0\nturns = 100\n'
                            "axis = [0, 0, 1]\ncentre = [0.025, 0.0, 0.0]\n",
}


def catheter_with(tmp_path: Path, field: str) -> Path:
    """The example catheter with its ``[field]`` (and ``[field.path]``) replaced by ``field``."""
    path = tmp_path / "catheter.toml"
    path.write_text(CATHETER[:CATHETER.index("[field]")] + "[field]\n" + field)
    return path


@pytest.mark.parametrize("mistake", list(MISTAKES))
def test_case_check_refuses_the_field_simulate_refuses(tmp_path, capsys, mistake):
    spec = catheter_with(tmp_path, MISTAKES[mistake])
    assert msr(["field", "simulate", "--robot", str(spec), "--physics", "training", "--duration", "0.02",
                "--out", str(tmp_path / "sim")]) == 2
    refused = capsys.readouterr().err.strip()
    assert refused.startswith(f"msr field simulate: error: {spec}: [field]")
    assert msr(["case", "check", "--no-sag", str(spec)]) == 2
    captured = capsys.readouterr()
    assert captured.err.strip() == refused.replace("msr field simulate:", "msr case check:", 1)
    assert captured.out == ""  # refused before the report


def test_case_check_lists_the_field_it_checked(tmp_path, capsys):
    spec = catheter_with(tmp_path, MISTAKES["edge in mm"].replace("[20, 20, 20]", "[0.02, 0.02, 0.02]"))
    assert msr(["case", "check", "--no-sag", "--json", str(spec)]) == 0
    assert json.loads(capsys.readouterr().out)["checked"] == ["robot", "time steps", "field", "boundary"]


def test_case_check_warns_where_simulate_warns(tmp_path, capsys):
    weak = MISTAKES["polarization in mT"].replace("[1300, 0, 0]", "[0.05, 0, 0]")
    spec = catheter_with(tmp_path, weak)
    assert msr(["case", "check", "--no-sag", str(spec)]) == 0
    captured = capsys.readouterr()
    assert (f"msr case check: warning: {spec}: [field] polarization: |polarization| = 0.05 T is below "
            "0.1 T, weaker than bonded ferrite magnets") in captured.err
    assert "  checked: robot, time steps, field, boundary;" in captured.out
