"""A rotating field whose plane is turned about the vertical (issue 51): ``RotatingField(...,
heading=h)`` rotates in the plane of the vertical and ``(cos h, 0, -sin h)``; at ``h = 0`` it is
the paper's x-y field bit for bit. Turned 90 degrees it rolls the paper's robot sideways, which
the trajectory's z markers and ``msr field simulate --heading`` report."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from elastica_magnetic import RotatingField, yao2023_robot
from elastica_magnetic.cli import main as msr
from elastica_magnetic.simulation import build_simulation


def test_heading_zero_is_the_paper_field_exactly():
    turned, paper = RotatingField(4e-3, -1.0, 0.3, 0.2, heading=0.0), RotatingField(4e-3, -1.0, 0.3, 0.2)
    for t in np.linspace(0.0, 3.0, 301):
        a = 2 * math.pi * -1.0 * t + 0.3
        amplitude = 4e-3 * min(t / 0.2, 1.0)
        expected = [amplitude * math.cos(a), amplitude * math.sin(a), 0.0]
        assert turned(t).tolist() == paper(t).tolist() == expected


@pytest.mark.parametrize("heading", [math.pi / 2, -math.pi / 3, 2.5])
def test_the_turned_plane_holds_the_vertical_and_its_horizontal_direction(heading):
    field = RotatingField(4e-3, 0.7, heading=heading)
    normal = np.cross([math.cos(heading), 0.0, -math.sin(heading)], [0.0, 1.0, 0.0])
    for t in np.linspace(0.0, 2.0, 41):
        b = field(t)
        assert np.linalg.norm(b) == pytest.approx(4e-3, rel=1e-12)
        assert abs(b @ normal) < 1e-15


def _sideways(heading: float) -> tuple[float, float]:
    spec = yao2023_robot(1, "training")
    sim = build_simulation(spec, RotatingField(4e-3, -1.0, phase=0.5 * math.pi, ramp_time=0.2,
                                               heading=heading))
    start = sim.markers()
    sim.step(int(round(1.5 / spec.dt)))
    end = sim.markers()
    return end["mid_x_m"] - start["mid_x_m"], end["mid_z_m"] - start["mid_z_m"]


def test_a_field_turned_ninety_degrees_rolls_the_robot_sideways():
    dx, dz = _sideways(math.pi / 2)
    assert dz < -5e-3 and abs(dx) < 0.1 * abs(dz)  # toward -z, as the docstring says
    planar_dx, planar_dz = _sideways(0.0)
    assert planar_dz == 0.0  # the paper's field never leaves the x-y plane


def test_msr_field_simulate_heading(tmp_path, capsys):
    status = msr(["field", "simulate", "--physics", "training", "--duration", "1.5", "--heading",
                  "1.5708", "--out", str(tmp_path / "side"), "--json", "--no-progress"])
    assert status == 0
    result = json.loads(capsys.readouterr().out)
    assert result["heading_rad"] == 1.5708 and result["mid_dz_m"] < -5e-3
    trajectory = (tmp_path / "side" / "trajectory.csv").read_text().splitlines()
    assert trajectory[0].endswith("mid_z_m,back_z_m,front_z_m")
    with pytest.raises(SystemExit) as stopped:  # refused while parsing
        msr(["field", "simulate", "--heading", "90", "--out", str(tmp_path / "deg")])
    assert stopped.value.code == 2
    assert "degrees? give rad (90 degrees = 1.5708 rad)" in capsys.readouterr().err
    assert not (tmp_path / "deg").exists()
