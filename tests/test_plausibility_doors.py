"""Plausibility at every door (issue 48): unit mistakes in spec files, in the fields in space they
build and in field CSVs are refused (values that cannot be physical) or warned about (unusual
values), each message naming the file, the key, the value and the unit mistake it looks like;
``[checks] accept`` silences a warning on purpose. Also the dimensionless checks: a magnet or a
coil's wire on the rod, a field the rod cannot resolve, too few steps per period, a corrupt map."""

from __future__ import annotations

import re
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest
from spec_texts import CATHETER_ON_GROUND

from elastica_magnetic.field_csv import FieldCSVError, read_field_csv
from elastica_magnetic.field_maps import FieldMap
from elastica_magnetic.field_spec import describe_field
from elastica_magnetic.fields import TabulatedField
from elastica_magnetic.plausibility import QUANTITIES, ImplausibleValueWarning, judge
from elastica_magnetic.spatial_fields import CurrentLoopField, SpatialFieldError
from elastica_magnetic.spec_format import loads
from elastica_magnetic.specfile import SpecError, describe_robot, spec_field_limit

ROBOT = CATHETER_ON_GROUND


def _spec(old: str = "", new: str = "", extra: str = "") -> dict:
    text = ROBOT.replace(old, new) if old else ROBOT
    assert old == "" or text != ROBOT, old
    return loads(text + extra, "my.toml")


def _no_warning(call, *args):
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImplausibleValueWarning)
        return call(*args)


def test_every_quantity_has_a_unit_and_warn_inside_refuse():
    for q in QUANTITIES.values():
        assert q.unit and q.name
        for side in (0, 1):
            refuse, warn = q.refuse[side], q.warn[side]
            if refuse is not None and warn is not None:
                assert (warn.value >= refuse.value) if side == 0 else (warn.value <= refuse.value), q.name


# -- spec files: [robot], [physics], [actuation] ---------------------------------------------------


@pytest.mark.parametrize(("old", "new", "message"), [
    ("youngs_modulus = 3.0e6", "youngs_modulus = 84.5",
     r"my\.toml: \[robot\] youngs_modulus = 84\.5 Pa is below 100 Pa, the softest hydrogels .*; it "
     r"looks like kPa or MPa written where Pa is expected \(84\.5 kPa is 84500 Pa"),
    ("density = 1100.0", "density = 1.1",
     r"\[robot\] density = 1\.1 kg/m\^3 is below 50 kg/m\^3.*looks like g/cm\^3 written where "
     r"kg/m\^3 is expected \(1\.1 g/cm\^3 is 1100 kg/m\^3\)"),
    ("length = 0.05", "length = 50.0",
     r"\[robot\] length = 50 m is above 5 m.*looks like mm or cm written where m is expected "
     r"\(50 mm is 0\.05 m"),
    ("radius = 0.0005", "radius = 0.8",
     r"\[robot\] radius = 0\.8 m is above 0\.5 m.*looks like mm or cm written where m is expected"),
    ("static_mu = 0.8", "static_mu = 80.0",
     r"\[robot\.ground\] static_mu = 80 is above 10.*looks like % written where a plain number is "
     r"expected \(80 % is 0\.8\)"),
    ("[physics.accurate]\ndt = 1e-5", "[physics.accurate]\ndt = 8.0",
     r"\[physics\.accurate\] dt = 8 s is above 0\.01 s.*looks like us written where s is expected"),
    ("magnitude = 1.0e5", "magnitude = 5.0e6",
     r"\[robot\.magnetization\] magnitude = 5e\+06 A/m is above 2e\+06 A/m, above the saturation"),
    ("kinetic_mu = 0.6", "kinetic_mu = 0.6\nsurface_tolerance = 0.1",
     r"\[robot\.ground\] surface_tolerance: 0\.1 m is not below the rod's radius: the contact band is "
     r"200 radii of the rod \(r = 0\.0005 m\): an element 0\.1 m above the floor counts as touching"),
    ("kinetic_mu = 0.6", "kinetic_mu = 0.6\nslip_velocity_tolerance = 1.0",
     r"\[robot\.ground\] slip_velocity_tolerance: 1 m/s is 20 body lengths per second \(L = 0\.05 m\): "
     r"an element sliding slower counts as sticking"),
])
def test_a_unit_mistake_in_the_robot_is_refused(old, new, message):
    with pytest.raises(SpecError, match=message):
        describe_robot(_spec(old, new), "my.toml")


@pytest.mark.parametrize(("old", "new", "key", "message"), [
    ("magnitude = 1.0e5", "magnitude = 61.3", "robot.magnetization.magnitude",
     r"magnitude = 61\.3 A/m is below 1000 A/m.*looks like kA/m written where A/m is expected "
     r"\(61\.3 kA/m is 61300 A/m\)"),
    ("youngs_modulus = 3.0e6", "youngs_modulus = 500.0", "robot.youngs_modulus",
     r"youngs_modulus = 500 Pa is below 1000 Pa.*unusual"),
    ("density = 1100.0", "density = 9000.0", "robot.density", r"density = 9000 kg/m\^3 is above"),
    ("poisson_ratio = 0.45", "poisson_ratio = -0.2", "robot.poisson_ratio", r"auxetic"),
    ("[physics.accurate]\ndt = 1e-5", "[physics.accurate]\ndt = 2e-9", "physics.accurate.dt",
     r"dt = 2e-09 s is below 1e-08 s, finer than any soft robot needs"),
    ("kinetic_mu = 0.6", "kinetic_mu = 0.6\nsurface_tolerance = 1e-4", "robot.ground.surface_tolerance",
     r"the contact band is 0\.2 radii of the rod"),
    ("kinetic_mu = 0.6", "kinetic_mu = 0.6\nslip_velocity_tolerance = 1e-3",
     "robot.ground.slip_velocity_tolerance", r"0\.001 m/s is 0\.02 body lengths per second"),
])
def test_an_unusual_robot_value_warns_naming_the_key_and_accept_silences_it(old, new, key, message):
    with pytest.warns(ImplausibleValueWarning, match=r"^my\.toml: .*" + message) as record:
        describe_robot(_spec(old, new), "my.toml")
    assert record[0].message.key == key
    assert f'add "{key}" to [checks] accept' in str(record[0].message)
    accepted = _spec(old, new, f'[checks]\naccept = ["{key}"]\n')
    description = _no_warning(describe_robot, accepted, "my.toml")
    assert description.tables["checks"] == {"accept": [key]}  # kept with the robot


def test_accept_does_not_let_a_value_that_cannot_be_physical_through():
    spec = _spec("youngs_modulus = 3.0e6", "youngs_modulus = 84.5",
                 '[checks]\naccept = ["robot.youngs_modulus"]\n')
    with pytest.raises(SpecError, match="below 100 Pa"):
        describe_robot(spec, "my.toml")


@pytest.mark.parametrize(("checks", "message"), [
    ('[checks]\naccept = ["robot.youngs_modulos"]\n',
     r"my\.toml: \[checks\] accept: 'robot\.youngs_modulos' names no key of this spec"),
    ('[checks]\naccept = "robot.density"\n', r"\[checks\] accept: expected a list of dotted keys"),
    ('[checks]\nallow = []\n', r"\[checks\] allow: unknown key"),
])
def test_a_bad_checks_table_is_refused(checks, message):
    with pytest.raises(SpecError, match=message):
        describe_robot(_spec(extra=checks), "my.toml")


def test_a_field_limit_in_mt_is_refused_naming_the_mistake():
    with pytest.raises(SpecError, match=r"\[actuation\] field_limit: must be <= 1 \(T\), got 4\.0; "
                                        r"it looks like mT written where T is expected \(4 mT is "
                                        r"0\.004 T\)"):
        spec_field_limit(_spec(extra="[actuation]\nfield_limit = 4.0\n"), "my.toml")
    with pytest.raises(SpecError, match=r"field_limit = 2e-05 T is below 5e-05 T, the Earth's field"):
        spec_field_limit(_spec(extra="[actuation]\nfield_limit = 2e-5\n"), "my.toml")
    with pytest.warns(ImplausibleValueWarning, match=r"field_limit = 0\.5 T is above 0\.1 T"):
        spec_field_limit(_spec(extra="[actuation]\nfield_limit = 0.5\n"), "my.toml")


# -- fields in space built from [field] --------------------------------------------------------------


def _field(table: str, source: str = "spec.toml", base: Path | None = None):
    text = ROBOT + table
    spec = loads(text, source)
    return describe_field(spec, str(base / source) if base else source)


@pytest.mark.parametrize(("table", "message"), [
    ('[field]\nkind = "cuboid-magnet"\ndimension = [20.0, 20.0, 20.0]\npolarization = [0, 0, 1.3]\n'
     'position = [0.02, 0.05, 0.0]\n',
     r"spec\.toml: \[field\] dimension: an edge = 20 m is above 1 m.*looks like mm or cm written "
     r"where m is expected \(20 mm is 0\.02 m"),
    ('[field]\nkind = "cylinder-magnet"\ndiameter = 0.01\nheight = 0.01\npolarization = [0, 0, 1300.0]\n'
     'position = [0.02, 0.05, 0.0]\n',
     r"\[field\] polarization: \|polarization\| = 1300 T is above 2 T.*looks like mT written where T "
     r"is expected \(1300 mT is 1\.3 T\)"),
    ('[field]\nkind = "constant-gradient"\ngradient = [[-50.0, 0, 0], [0, -50.0, 0], [0, 0, 100.0]]\n',
     r"\[field\] gradient: its largest \|dB_i/dx_j\| = 100 T/m is above 20 T/m.*looks like mT/m or "
     r"G/cm written where T/m is expected \(100 mT/m is 0\.1 T/m"),
    ('[field]\nkind = "point-dipole"\nmoment = [0.0, 1.0, 0.0]\nposition = [10.0, 40.0, 0.0]\n',
     r"\[field\] position: \|position\| = 41\.2311 m is above 10 m.*looks like mm or cm written"),
    ('[field]\nkind = "point-dipole"\nmoment = [0.0, 1.0, 0.0]\n[field.path]\ntimes = [0.0, 1.0]\n'
     'points = [[0.0, 40.0, 0.0], [20.0, 40.0, 0.0]]\n',
     r"\[field\.path\] points: the farthest point's distance from the origin = 44\.72\d* m is above 10 m"),
    ('[field]\nkind = "helmholtz"\nradius = 100.0\ncurrent = 2.0\ncentre = [0.0, 0.05, 0.0]\n',
     r"\[field\] radius = 100 m is above 5 m.*looks like mm or cm written"),
    ('[field]\nkind = "point-dipole"\nmoment = [0.0, 2.0e4, 0.0]\nposition = [0.02, 0.5, 0.0]\n',
     r"\[field\] moment: \|moment\| = 20000 A m\^2 is above 10000 A m\^2"),
    ('[field]\nkind = "helmholtz"\nradius = 0.1\ncurrent = 20000.0\ncentre = [0.0, 0.05, 0.0]\n',
     r"\[field\] current = 20000 A is above 10000 A.*looks like mA written where A is expected"),
])
def test_a_unit_mistake_in_a_field_table_is_refused(table, message):
    pytest.importorskip("magpylib") if "magnet" in table else None
    with pytest.raises(SpecError, match=message):
        _field(table)


def test_an_unusual_coil_current_warns_and_accept_silences_it():
    table = '[field]\nkind = "helmholtz"\nradius = 0.1\ncurrent = 2000.0\ncentre = [0.0, 0.05, 0.0]\n'
    with pytest.warns(ImplausibleValueWarning, match=r"\[field\] current = 2000 A is above 200 A.*"
                                                     r"looks like mA written where A is expected"):
        _field(table)
    _no_warning(_field, table + '[checks]\naccept = ["field.current"]\n')


def _write_map(folder: Path, name: str, axes: np.ndarray, b: float) -> None:
    if name.endswith(".npz"):
        n = axes.shape[0]
        np.savez(folder / name, x=axes, y=axes, z=axes, B=np.full((n, n, n, 3), b))
        return
    rows = [f"{x:g},{y:g},{z:g},0,0,{b!r}" for x in axes for y in axes for z in axes]
    (folder / name).write_text("x_m,y_m,z_m,Bx_mT,By_mT,Bz_mT\n" + "\n".join(rows) + "\n")


@pytest.mark.parametrize(("name", "axes", "b", "message"), [
    ("mm.npz", np.linspace(-50.0, 50.0, 5), 1e-3,
     r"\[field\] file: the grid of .*mm\.npz: largest \|coordinate\| = 50 m is above 10 m.*looks like "
     r"mm or cm written where m is expected"),
    ("mT.npz", np.linspace(-0.05, 0.05, 5), 4.0,
     r"\[field\] file: the largest \|B\| of .*mT\.npz \(x scale 1\) = 6\.9282 T is above 3 T.*looks "
     r"like mT"),
    ("tesla.csv", np.linspace(-0.05, 0.05, 5), 0.004,
     r"\[field\] file: the largest \|B\| of .*tesla\.csv \(x scale 1\) = 0\.004 mT is below 0\.05 mT.*"
     r"looks like T written where mT is expected \(0\.004 T is 4 mT\)"),
    ("small.npz", np.linspace(0.06, 0.08, 3), 1e-3,
     r"\[field\] file: the robot's element centres .* are not all inside the map's grid"),
])
def test_a_field_map_in_the_wrong_unit_is_refused(tmp_path, name, axes, b, message):
    _write_map(tmp_path, name, axes, b)
    with pytest.raises(SpecError, match=message):
        _field(f'[field]\nkind = "field-map"\nfile = "{name}"\n', base=tmp_path)


def _corrupt(path: Path, how: str) -> None:
    axes = np.linspace(-0.05, 0.05, 5)
    if how == "object array":
        np.savez(path, x=np.array([None] * 5, dtype=object), y=axes, z=axes, B=np.zeros((5, 5, 5, 3)))
        return
    if how == "strings":
        np.savez(path, x=np.array(["a"] * 5), y=axes, z=axes, B=np.zeros((5, 5, 5, 3)))
        return
    if how == "npy":
        with open(path, "wb") as handle:
            np.save(handle, axes)
        return
    np.savez(path, x=axes, y=axes, z=axes, B=np.zeros((5, 5, 5, 3)))
    data = path.read_bytes()
    if how == "not a zip":
        path.write_bytes(b"this is not a field map\n")
    elif how == "truncated":
        path.write_bytes(data[: len(data) // 2])
    elif how == "damaged member":
        with zipfile.ZipFile(path) as archive:
            members = {n: archive.read(n) for n in archive.namelist()}
        with zipfile.ZipFile(path, "w") as archive:
            for n, content in members.items():
                archive.writestr(n, b"\x93NUMPY garbage" if n == "B.npy" else content)


@pytest.mark.parametrize(("how", "message"), [
    ("not a zip", r"is not an \.npz archive \(a zip file of \.npy arrays"),
    ("truncated", r"damaged or not an \.npz archive"),
    ("damaged member", r"damaged or not an \.npz archive \(ValueError"),
    ("object array", r"damaged or not an \.npz archive \(ValueError: Object arrays"),
    ("strings", r"array x holds <U1 values, expected numbers"),
    ("npy", r"is a single \.npy array, not an \.npz archive"),
])
def test_a_corrupt_npz_field_map_is_a_named_error(tmp_path, how, message):
    path = tmp_path / "map.npz"
    _corrupt(path, how)
    with pytest.raises(SpatialFieldError, match=rf"^{re.escape(str(path))}: .*{message}"):
        FieldMap.from_npz(path)
    with pytest.raises(SpecError, match=rf"spec\.toml: \[field\]: {re.escape(str(path))}: .*{message}"):
        _field('[field]\nkind = "field-map"\nfile = "map.npz"\n', base=tmp_path)


# -- the source against the rod ---------------------------------------------------------------------


@pytest.mark.parametrize(("table", "message"), [
    ('[field]\nkind = "point-dipole"\nmoment = [0.0, 1.0, 0.0]\nposition = [0.01, 0.0002, 0.0]\n',
     r"the point dipole at \[0\.01, 0\.0002, 0\.0\] m \(t = 0\) is 0\.0002 m from "
     r"the rod's centreline at x = 0\.01 m \(element 2\), within its radius 0\.0005 m: the magnet "
     r"overlaps the rod"),
    ('[field]\nkind = "cuboid-magnet"\ndimension = [0.01, 0.01, 0.01]\npolarization = [0, 0, 1.3]\n'
     'position = [0.02, 0.0052, 0.0]\n', r"the cuboid magnet's body .* within its radius"),
    ('[field]\nkind = "cylinder-magnet"\ndiameter = 0.01\nheight = 0.004\npolarization = [0, 0, 1.3]\n'
     'axis = [0.0, 1.0, 0.0]\nposition = [0.03, 0.0, 0.0]\n', r"the cylinder magnet's body .* is 0 m"),
    ('[field]\nkind = "current-loop"\nradius = 0.01\ncurrent = 1.0\ncentre = [0.0025, 0.0, 0.0]\n',
     r"the wire of the loop of radius 0\.01 m at \[0\.0025, 0\.0, 0\.0\] m passes "
     r"0 m from the rod's centreline at x = 0\.0125 m \(element 2\).*the field is infinite on the wire"),
    ('[field]\nkind = "maxwell"\nradius = 0.02\ncurrent = 1.0\naxis = [0.0, 1.0, 0.0]\n'
     'centre = [0.025, 0.0173205, 0.0]\n', r"the wire of the loop of radius 0\.02 m"),
])
def test_a_magnet_or_a_wire_on_the_rod_is_refused(table, message):
    if "magnet" in table:
        pytest.importorskip("magpylib")
    with pytest.raises(SpecError, match=r"^spec\.toml: \[field\] (position|centre): " + message):
        _field(table)


def test_a_point_on_a_loops_wire_is_a_named_error_not_a_zero_division():
    loop = CurrentLoopField(0.01, current=1.0)
    with pytest.raises(SpatialFieldError, match=r"point \[0\.01, 0\.0, 0\.0\] m \(column 1\) at t = 0 s "
                                                r"lies on the wire of current loop 0 \(radius 0\.01 m"):
        loop.evaluate(np.array([[0.0, 0.01], [0.0, 0.0], [0.0, 0.0]]))


def test_a_field_the_rod_cannot_resolve_warns_and_accept_silences_it():
    table = '[field]\nkind = "point-dipole"\nmoment = [0.0, 0.01, 0.0]\nposition = [0.02, 0.004, 0.0]\n'
    with pytest.warns(ImplausibleValueWarning, match=r"\[field\] resolution: the field along the rod "
                                                     r"changes by .* more than 0\.5 x") as record:
        _field(table)
    assert any(w.message.key == "field.resolution" for w in record)
    _no_warning(_field, table + '[checks]\naccept = ["field.resolution"]\n')


def test_a_strong_field_on_the_rod_warns():
    table = '[field]\nkind = "point-dipole"\nmoment = [0.0, 1.0, 0.0]\nposition = [0.01, 0.003, 0.0]\n'
    with pytest.warns(ImplausibleValueWarning, match=r"\[field\] strength: the largest \|B\| on the rod "
                                                     r"at t = 0 \(point-dipole\) = 2\.79\d* T is above 1 T"):
        _field(table + '[checks]\naccept = ["field.resolution"]\n')


def test_too_few_steps_per_period_warns():
    table = ('[field]\nkind = "helmholtz"\nradius = 0.1\ncurrent = 2.0\nturns = 50\n'
             'centre = [0.0, 0.05, 0.0]\nfrequency = 10000.0\n')
    with pytest.warns(ImplausibleValueWarning, match=r"\[field\] frequency: 10000 Hz with \[physics\."
                                                     r"(training|accurate)\] dt = 1e-05 s is 10 time "
                                                     r"steps per period, fewer than 20"):
        _field(table)
    _no_warning(_field, table.replace("10000.0", "2.0"))


def test_the_shipped_catheter_and_plausible_fields_do_not_warn():
    from importlib import resources

    from elastica_magnetic.field_spec import load_field

    _no_warning(load_field, Path(str(resources.files("elastica_magnetic") / "data" / "examples"
                                     / "catheter.toml")))
    _no_warning(_field, '[field]\nkind = "constant-gradient"\n'
                        'gradient = [[-0.1, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, -0.1]]\n'
                        'origin = [0.0, 0.0, 0.01]\n')


# -- field CSVs ---------------------------------------------------------------------------------------


@pytest.mark.parametrize(("value", "message"), [
    (0.004, r"line 3: the largest \|field\| = 0\.004 mT is below 0\.05 mT.*looks like T written where "
            r"mT is expected \(0\.004 T is 4 mT\)"),
    (4000.0, r"line 3: the largest \|field\| = 4000 mT is above 1000 mT.*looks like uT written where "
             r"mT is expected \(4000 uT is 4 mT\)"),
])
def test_a_field_csv_in_the_wrong_unit_is_refused_where_it_is_played(tmp_path, value, message):
    path = tmp_path / "field.csv"
    path.write_text(f",mag_x,mag_y,mag_z\n0,0,0,0\n1,0,{value!r},0\n")
    with pytest.raises(FieldCSVError, match=rf"^{re.escape(str(path))}: {message}"):
        TabulatedField.from_csv(path)
    with pytest.raises(FieldCSVError, match=message):
        read_field_csv(path, plausible=True)
    assert read_field_csv(path)[1, 1] == value * 1e-3  # the parser alone reads any number


def test_an_unusual_field_csv_warns_and_a_zero_one_is_fine(tmp_path):
    path = tmp_path / "field.csv"
    path.write_text(",mag_x,mag_y,mag_z\n0,0.2,0,0\n")
    with pytest.warns(ImplausibleValueWarning, match=r"line 2: the largest \|field\| = 0\.2 mT is "
                                                     r"below 0\.5 mT"):
        TabulatedField.from_csv(path)
    path.write_text(",mag_x,mag_y,mag_z\n0,0,0,0\n1,4,0,0\n")
    _no_warning(TabulatedField.from_csv, path)
    path.write_text(",mag_x,mag_y,mag_z\n0,0,0,0\n")
    _no_warning(TabulatedField.from_csv, path)


def test_judge_names_every_mistake_that_fits():
    finding = judge("youngs modulus", 84.5)
    assert finding.refuse and not finding.high
    assert finding.text.startswith("84.5 Pa is below 100 Pa, the softest hydrogels")
    assert judge("youngs modulus", 84500.0) is None and judge("magnetization", 0.0) is None


@pytest.mark.parametrize("nu", ["0.55", "0.6"])
def test_a_poisson_ratio_just_above_one_half_is_not_taken_for_percent(nu):
    """Round 30, V4: poisson_ratio 0.55 or 0.6 was refused with "it looks like percent written where a
    plain number is expected (0.55 percent is 0.0055)": a fraction written in percent is at least 1."""
    with pytest.raises(SpecError, match=r"poisson_ratio") as refused:
        describe_robot(_spec("poisson_ratio = 0.45", f"poisson_ratio = {nu}"), "my.toml")
    assert "percent" not in str(refused.value), refused.value
    with pytest.raises(SpecError, match=r"looks like percent"):
        describe_robot(_spec("poisson_ratio = 0.45", "poisson_ratio = 45"), "my.toml")
