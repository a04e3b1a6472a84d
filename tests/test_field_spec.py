"""The [field] and [boundary] tables of a spec, and msr field simulate / replay with them."""

from __future__ import annotations

import json
import math
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
from spec_texts import CATHETER

from elastica_magnetic import ConstantGradientField, HelmholtzCoils, PointDipoleField, Waypoints
from elastica_magnetic.cli import main
from elastica_magnetic.field_spec import describe_field, load_field
from elastica_magnetic.spec_format import loads
from elastica_magnetic.specfile import SpecError

ROBOT = CATHETER
POINTS = np.array([[0.01, 0.02, 0.03], [0.0, -0.01, 0.02], [0.02, 0.0, -0.01]])


def catheter_spec() -> Path:
    return Path(str(resources.files("elastica_magnetic") / "data" / "examples" / "catheter.toml"))


def test_the_shipped_catheter_spec_reads():
    setup = load_field(catheter_spec())
    assert setup.clamp and setup.table["kind"] == "point-dipole"
    source = setup.source()
    assert isinstance(source, PointDipoleField)
    np.testing.assert_allclose(source.position(2.0), [-0.02 + 0.11 * 1.5 / 3.0, 0.04, 0.0])
    np.testing.assert_allclose(source.moment(0.15), [1.0, 0.0, 0.0])  # half-way up the ramp
    assert load_field("yao2023-m1") is None


def test_field_tables_build_the_sources_they_describe():
    spec = loads(ROBOT + """
[field]
kind = "helmholtz"
radius = 0.1
current = 2.0
turns = 50
axis = [0.0, 1.0, 0.0]
centre = [0.01, 0.0, 0.0]
frequency = 2.0
""")
    source = describe_field(spec).source()
    reference = HelmholtzCoils(0.1, current=lambda t: 2.0 * math.cos(4 * math.pi * t), centre=[0.01, 0, 0],
                               axis=[0, 1.0, 0], turns=50)
    for t in (0.0, 0.1, 0.3):
        np.testing.assert_array_equal(source.at(POINTS, t), reference.at(POINTS, t))
    moving = describe_field(loads(ROBOT + """
[field]
kind = "point-dipole"
moment = [0.0, 0.0, 1.0]
[field.path]
times = [0.0, 1.0]
points = [[0.0, 0.0, -0.05], [0.02, 0.0, -0.05]]
""")).source()
    expected = PointDipoleField([0, 0, 1.0], Waypoints([0, 1.0], [[0, 0, -0.05], [0.02, 0, -0.05]]))
    np.testing.assert_array_equal(moving.at(POINTS, 0.4), expected.at(POINTS, 0.4))


def test_a_constant_gradient_table():
    source = describe_field(loads(ROBOT + """
[field]
kind = "constant-gradient"
gradient = [[-0.1, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, -0.1]]
origin = [0.0, 0.0, 0.01]
ramp = 0.5
""")).source()
    reference = ConstantGradientField(np.diag([-0.1, 0.2, -0.1]), origin=[0.0, 0.0, 0.01])
    np.testing.assert_allclose(source.at(POINTS, 0.25), 0.5 * reference.at(POINTS), rtol=1e-15)
    np.testing.assert_allclose(source.gradient(POINTS, 1.0), reference.gradient(POINTS))


def test_finite_magnet_tables():
    pytest.importorskip("magpylib")
    from elastica_magnetic.magnet_fields import CylinderMagnetField

    source = describe_field(loads(ROBOT + """
[field]
kind = "cylinder-magnet"
diameter = 0.01
height = 0.02
polarization = [0.0, 0.0, 1.3]
axis = [1.0, 0.0, 0.0]
position = [0.0, 0.05, 0.0]
ramp = 0.5
""")).source()
    reference = CylinderMagnetField(0.01, 0.02, [0, 0, 1.3], [0.0, 0.05, 0.0], axis=[1.0, 0, 0])
    np.testing.assert_allclose(source.at(POINTS, 0.25), 0.5 * reference.at(POINTS), rtol=1e-12)
    with pytest.raises(SpecError, match=r"\[field\] dimension: must be positive lengths"):
        describe_field(loads(ROBOT + '[field]\nkind = "cuboid-magnet"\ndimension = [0.01, 0, 0.01]\n'
                             'polarization = [0, 0, 1.3]\n'))


def test_a_field_map_file_is_found_next_to_the_spec(tmp_path):
    axes = [np.linspace(-0.05, 0.05, 5)] * 3
    np.savez(tmp_path / "map.npz", x=axes[0], y=axes[1], z=axes[2], B=np.ones((5, 5, 5, 3)) * 1e-3)
    (tmp_path / "spec.toml").write_text(
        ROBOT + '[field]\nkind = "field-map"\nfile = "map.npz"\nscale = 2.0\n')
    source = load_field(tmp_path / "spec.toml").source()
    np.testing.assert_allclose(source.at(POINTS), 2e-3)


@pytest.mark.parametrize("table, message", [
    ('[field]\nkind = "magnet"\n', r"\[field\] kind: expected one of point-dipole"),
    ('[field]\nkind = "point-dipole"\nmoment = [1, 0]\n', r"\[field\] moment: expected a list of 3"),
    ('[field]\nkind = "point-dipole"\nmoment = [1, 0, 0]\nposition = [0, 0, 1]\n'
     '[field.path]\ntimes = [0]\npoints = [[0, 0, 0]]\n', "give either position"),
    ('[field]\nkind = "point-dipole"\nmoment = [1, 0, 0]\n[field.path]\ntimes = [0, 0]\n'
     'points = [[0, 0, 0], [1, 0, 0]]\n', r"\[field.path\] times: must increase strictly"),
    ('[field]\nkind = "helmholtz"\nradius = -1.0\ncurrent = 1.0\n', r"\[field\] radius: must be > 0"),
    ('[field]\nkind = "helmholtz"\nradius = 0.1\ncurrent = 1.0\nmoment = [1, 0, 0]\n',
     r"\[field\] moment: unknown key"),
    ('[field]\nkind = "field-map"\nfile = "nowhere.npz"\n', "no such field map"),
    ('[boundary]\nclamp = "last"\n', r"\[boundary\] clamp: expected one of none, first"),
    ('[field]\nkind = "constant-gradient"\ngradient = [[1, 0], [0, 1]]\n',
     r"\[field\] gradient: expected 3 rows of 3 finite numbers \(T/m\)"),
    ('[field]\nkind = "constant-gradient"\ngradient = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]\n',
     r"spec.toml: \[field\]: gradient must be traceless"),
    # round 13 S2: sources that make no field anywhere (the unloaded rod reported as their result)
    ('[field]\nkind = "point-dipole"\nmoment = [0, 0, 0]\n',
     r"\[field\] moment: \[0, 0, 0\] A m\^2: this source makes no field anywhere"),
    ('[field]\nkind = "current-loop"\nradius = 0.05\ncurrent = 0.0\n',
     r"\[field\] current: 0 A: this source"),
    ('[field]\nkind = "constant-gradient"\ngradient = [[0, 0, 0], [0, 0, 0], [0, 0, 0]]\n',
     r"\[field\] gradient: every entry 0 T/m: this source makes no field"),
    ('[field]\nkind = "field-map"\nfile = "nowhere.npz"\nscale = 0.0\n',
     r"\[field\] scale: 0 \(every sample"),
])
def test_bad_field_tables_name_the_key(table, message):
    with pytest.raises(SpecError, match=message):
        describe_field(loads(ROBOT + table), "spec.toml")


def test_msr_simulate_runs_a_spec_with_a_field(tmp_path, capsys):
    spec = tmp_path / "magnet.toml"
    spec.write_text(ROBOT + """
[boundary]
clamp = "first"
[field]
kind = "point-dipole"
moment = [0.0, 0.5, 0.0]
position = [0.05, 0.03, 0.0]
""")
    status = main(["field", "simulate", "--robot", str(spec), "--duration", "0.05", "--out",
                   str(tmp_path / "out"),
                   "--json"])
    result = json.loads(capsys.readouterr().out)
    assert status == 0 and result["field"] == "point-dipole" and result["clamp"]
    assert Path(result["tip_path_figure"]).exists()
    trajectory = np.genfromtxt(tmp_path / "out" / "trajectory.csv", delimiter=",", names=True)
    # the tip turned towards the magnet's field; the clamped base (node 0 and the first element's
    # directors fixed) moves only by the first element's stretch and shear
    assert trajectory["front_y_m"][-1] > 1e-4
    assert abs(trajectory["back_x_m"][-1] - trajectory["back_x_m"][0]) < 1e-5
    assert abs(trajectory["back_y_m"][-1]) < 0.05 * trajectory["front_y_m"][-1]
    assert main(["field", "simulate", "--robot", str(spec), "--amplitude", "0.004",
                 "--out", str(tmp_path / "o2")]) == 2
    assert "--amplitude set the rotating field" in capsys.readouterr().err


def test_msr_replay_adds_the_spec_field_to_the_waveform(tmp_path, capsys):
    spec = tmp_path / "magnet.toml"
    spec.write_text(ROBOT + """
[boundary]
clamp = "first"
[field]
kind = "point-dipole"
moment = [0.0, 0.5, 0.0]
position = [0.05, 0.03, 0.0]
""")
    csv = tmp_path / "zero.csv"
    csv.write_text("mag_x,mag_y,mag_z\n" + "0,0,0\n" * 5)
    status = main(["field", "replay", str(csv), "--robot", str(spec), "--out", str(tmp_path / "out"),
                   "--json"])
    assert status == 0, capsys.readouterr().err
    result = json.loads(capsys.readouterr().out)
    trajectory = np.genfromtxt(result["trajectory_csv"], delimiter=",", names=True)
    assert trajectory["front_y_m"][-1] > 1e-6
