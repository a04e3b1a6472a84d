"""Field maps (:mod:`elastica_magnetic.field_maps`): interpolation order, the .npz and .csv files,
grid exports (COMSOL's spreadsheet format: column names, units, uneven grids), and poses."""

from __future__ import annotations

import math

import numpy as np
import pytest
from spec_texts import CATHETER

from elastica_magnetic import FieldMap, FieldMapDomainError, PointDipoleField, SpatialFieldError

RNG = np.random.default_rng(7)
ROBOT = CATHETER


def _dipole_grid(n):
    source = PointDipoleField([0.0, 0.0, 0.2], [0.0, 0.0, -0.06])
    axes = [np.linspace(-0.02, 0.02, n)] * 3
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)  # (n, n, n, 3)
    samples = source.at(grid.reshape(-1, 3).T).T.reshape(n, n, n, 3)
    return source, axes, samples


def test_field_map_converges_at_second_order(tmp_path):
    inner = RNG.uniform(-0.015, 0.015, size=(3, 40))
    errors = []
    for n in (11, 21, 41):
        source, axes, samples = _dipole_grid(n)
        fmap = FieldMap(*axes, samples)
        b, g = fmap.evaluate(inner)
        b_ref, g_ref = source.evaluate(inner)
        errors.append((np.abs(b - b_ref).max() / np.abs(b_ref).max(),
                       np.abs(g - g_ref).max() / np.abs(g_ref).max()))
    errors = np.array(errors)
    orders = np.log2(errors[0] / errors[-1]) / 2.0  # over two halvings of the spacing
    assert np.all(orders > 1.8), (errors, orders)
    assert errors[-1, 0] < 2e-3 and errors[-1, 1] < 2e-3


def test_field_map_files_round_trip(tmp_path):
    _, axes, samples = _dipole_grid(5)
    np.savez(tmp_path / "map.npz", x=axes[0], y=axes[1], z=axes[2], B=samples)
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    rows = np.hstack([grid, 1e3 * samples.reshape(-1, 3)])[RNG.permutation(125)]
    csv = tmp_path / "map.csv"
    np.savetxt(csv, rows, delimiter=",", header="x_m,y_m,z_m,Bx_mT,By_mT,Bz_mT", comments="")
    direct = FieldMap(*axes, samples)
    for loaded in (FieldMap.from_npz(tmp_path / "map.npz"), FieldMap.from_csv(csv)):
        np.testing.assert_allclose(loaded.samples, direct.samples, rtol=1e-14, atol=0)
    with pytest.raises(FieldMapDomainError, match=r"outside the map's grid"):
        direct.at(np.array([[0.0], [0.0], [0.05]]))
    bad = tmp_path / "bad.csv"
    bad.write_text("x,y,z,Bx,By,Bz\n0,0,0,1,1,1\n")
    with pytest.raises(SpatialFieldError, match="header must be x_m,y_m,z_m,Bx_mT,By_mT,Bz_mT"):
        FieldMap.from_csv(bad)
    np.savetxt(csv, rows[:-1], delimiter=",", header="x_m,y_m,z_m,Bx_mT,By_mT,Bz_mT", comments="")
    with pytest.raises(SpatialFieldError, match="do not fill a regular"):
        FieldMap.from_csv(csv)


def _comsol_export(path, x_mm, y_mm, z_mm, field, *, header_units=True, separator="  "):
    """A grid export as COMSOL writes it (spreadsheet format): % header, mm, T."""
    lines = ["% Model:              magnet.mph", "% Version:            COMSOL 6.1",
             "% Dimension:          3", f"% Nodes:              {len(x_mm) * len(y_mm) * len(z_mm)}"]
    if header_units:
        lines += ["% Length unit:        mm",
                  "% x                       y                        z                        "
                  "mf.Bx (T)                mf.By (T)                mf.Bz (T)"]
    else:
        lines += ["% x y z Bx By Bz"]
    for z in z_mm:  # COMSOL lists x fastest
        for y in y_mm:
            for x in x_mm:
                b = field(np.array([[x], [y], [z]]) * 1e-3)[:, 0]
                lines.append(separator.join(f"{v:.12g}" for v in (x, y, z, *b)))
    path.write_text("\n".join(lines) + "\n")
    return path


def test_a_comsol_grid_export_loads_in_its_units_and_an_uneven_grid_is_resampled(tmp_path):
    """Issue 53: COMSOL exports ('%' header, mm) were refused. Units from the header; an uneven
    (refined) rectilinear grid resampled onto an even one, exact at the nodes it keeps."""
    dipole = PointDipoleField((0.0, 0.0, 1.0), (0.0, 0.0, -0.03))
    even = np.linspace(-4.0, 4.0, 5)
    path = _comsol_export(tmp_path / "even.txt", even, even, even, dipole.at)
    loaded = FieldMap.from_export(path)
    assert not loaded.resampled
    nodes = np.array([[0.002, -0.002], [0.0, 0.004], [-0.004, 0.002]])
    np.testing.assert_allclose(loaded.at(nodes), dipole.at(nodes), rtol=1e-10)
    # refined near the middle: uneven, resampled at 1 mm, the kept nodes exact
    uneven = np.array([-4.0, -2.0, -1.0, 0.0, 1.0, 2.0, 4.0])
    path = _comsol_export(tmp_path / "uneven.csv", uneven, even, even, dipole.at, separator=",")
    resampled = FieldMap.from_export(path)
    assert resampled.resampled and resampled.shape.tolist() == [9, 5, 5]
    np.testing.assert_allclose(resampled.at(nodes), dipole.at(nodes), rtol=1e-10)


def test_a_grid_export_without_units_or_with_contradicting_ones_is_refused(tmp_path):
    axis = np.linspace(-1.0, 1.0, 3)
    path = _comsol_export(tmp_path / "bare.txt", axis, axis, axis, lambda p: np.ones_like(p) * 1e-3,
                          header_units=False)
    with pytest.raises(SpatialFieldError, match="states no length unit.*give length_unit"):
        FieldMap.from_export(path)
    loaded = FieldMap.from_export(path, length_unit="mm", field_unit="T")
    assert loaded.spacing.tolist() == pytest.approx([1e-3] * 3)
    labelled = _comsol_export(tmp_path / "mm.txt", axis, axis, axis, lambda p: np.ones_like(p) * 1e-3)
    with pytest.raises(SpatialFieldError, match="the header's 'Length unit' line says the length unit is mm, "
                       "length_unit says m: leave the option out"):
        FieldMap.from_export(labelled, length_unit="m")


def test_a_spec_takes_a_comsol_export_as_a_field_map(tmp_path):
    from elastica_magnetic.field_spec import describe_field
    from elastica_magnetic.specfile import SpecError

    axis = np.linspace(-30.0, 30.0, 7)
    _comsol_export(tmp_path / "map.txt", axis, axis, axis, lambda p: np.stack(
        [0 * p[0], 0 * p[0] + 4e-3, 0 * p[0]]))
    setup = describe_field({"field": {"kind": "field-map", "file": "map.txt"}}, str(tmp_path / "my.toml"))
    np.testing.assert_allclose(setup.source().at(np.zeros((3, 1)))[:, 0], [0.0, 4e-3, 0.0])
    with pytest.raises(SpecError, match=r"\[field\]: .*map.txt: column 4 'mf.Bx \(T\)' says the field "
                                        "unit is T, field_unit says mT"):
        describe_field({"field": {"kind": "field-map", "file": "map.txt", "field_unit": "mT"}},
                       str(tmp_path / "my.toml"))


def test_a_field_map_with_a_pose_moves_and_turns_with_it():
    """Issue 53: a field map could not move with its magnet. A linear field (which trilinear
    interpolation reproduces exactly) tabulated in the map's frame, posed at ``position(t)``
    with its z along ``axis(t)``: B = R (G R^T (x - c) + B0) and the gradient R G R^T."""
    from elastica_magnetic.spatial_fields import rotation_to

    gradient = np.array([[0.1, 0.02, 0.0], [0.02, -0.04, 0.03], [0.0, 0.03, -0.06]])  # T/m
    offset = np.array([1e-3, -2e-3, 0.5e-3])  # T
    axis = np.linspace(-0.05, 0.05, 6)
    grid = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1)  # (6, 6, 6, 3)
    samples = grid @ gradient.T + offset
    centre = lambda t: np.array([0.01 * t, 0.0, 0.02])  # noqa: E731
    direction = lambda t: np.array([math.sin(t), 0.0, math.cos(t)])  # noqa: E731
    posed = FieldMap(axis, axis, axis, samples, position=centre, axis=direction)
    points = np.array([[0.012, -0.01, 0.03], [0.005, 0.02, -0.01], [0.03, 0.0, 0.025]])
    for t in (0.0, 0.4, 1.3):
        r = rotation_to(direction(t))
        expected_b = r @ (gradient @ (r.T @ (points - centre(t)[:, None])) + offset[:, None])
        b, g = posed.evaluate(points, t)
        np.testing.assert_allclose(b, expected_b, rtol=1e-10, atol=1e-15)
        np.testing.assert_allclose(g, np.repeat((r @ gradient @ r.T)[:, :, None], 3, axis=2),
                                   rtol=1e-9, atol=1e-12)
    unposed = FieldMap(axis, axis, axis, samples)
    np.testing.assert_allclose(unposed.at(points), gradient @ points + offset[:, None], rtol=1e-10)


def test_a_grid_of_too_few_coordinates_is_named():
    with pytest.raises(SpatialFieldError, match="x must list at least 3 grid"):
        FieldMap([0, 1], [0, 1, 2], [0, 1, 2], np.zeros((2, 3, 3, 3)))


def _export(path, header, rows_of, xs=(-10.0, 0.0, 10.0), ys=(-5.0, 0.0, 5.0), zs=(-5.0, 0.0, 5.0)):
    """A grid export of ``header`` lines (without '% ') and rows ``rows_of(x, y, z)`` (6 numbers)."""
    lines = [f"% {line}" for line in header]
    for z in zs:
        for y in ys:
            for x in xs:
                lines.append("  ".join(f"{v:.12g}" for v in rows_of(x, y, z)))
    path.write_text("\n".join(lines) + "\n")
    return path


ORIGIN = np.zeros((3, 1))


def test_a_grid_exports_columns_are_read_by_their_names_in_any_order(tmp_path):
    """Round 10 S1: the column names were ignored (a file saying 'By first' read as Bx first)."""
    def rows(x, y, z):
        return (x, y, z, 1.0, 2.0, 3.0)

    plain = _export(tmp_path / "plain.txt",
                    ["Length unit: mm", "x  y  z  mf.Bx (mT)  mf.By (mT)  mf.Bz (mT)"], rows)
    np.testing.assert_allclose(FieldMap.from_export(plain).at(ORIGIN)[:, 0], [1e-3, 2e-3, 3e-3])
    # the same numbers under names in another order: the file says Bz, By, Bx
    swapped = _export(tmp_path / "swapped.txt",
                      ["Length unit: mm", "x  y  z  mf.Bz (mT)  mf.By (mT)  mf.Bx (mT)"], rows)
    np.testing.assert_allclose(FieldMap.from_export(swapped).at(ORIGIN)[:, 0], [3e-3, 2e-3, 1e-3])
    # coordinates in another order too (z first), each read as the coordinate it names
    def zyx(x, y, z):
        return (z, 1.0, y, 2.0, x, 3.0)

    mixed = _export(tmp_path / "mixed.txt",
                    ["Length unit: mm", "z  mf.Bx (mT)  y  mf.By (mT)  x  mf.Bz (mT)"], zyx,
                    xs=(-5.0, 0.0, 5.0), zs=(-10.0, 0.0, 10.0))
    loaded = FieldMap.from_export(mixed)
    np.testing.assert_allclose(loaded.origin, [-0.005, -0.005, -0.01])  # x spans 10 mm, z 20 mm
    np.testing.assert_allclose(loaded.at(np.array([[0.004], [0.004], [-0.009]]))[:, 0], [1e-3, 2e-3, 3e-3])


def test_each_field_column_is_read_in_its_own_unit(tmp_path):
    """Round 10 S1: 'mf.Bx (T)  mf.By (mT)' took the 0.005 T column as 0.005 mT."""
    path = _export(tmp_path / "units.txt",
                   ["Length unit: mm", "x  y  z  mf.Bx (T)  mf.By (mT)  mf.Bz (µT)"],
                   lambda x, y, z: (x, y, z, 0.005, 5.0, 5000.0))
    np.testing.assert_allclose(FieldMap.from_export(path).at(ORIGIN)[:, 0], [5e-3] * 3)
    with pytest.raises(SpatialFieldError, match=r"units.txt: column 4 'mf.Bx \(T\)' says the field unit is "
                                                r"T, field_unit says mT: leave the option out"):
        FieldMap.from_export(path, field_unit="mT")
    half = _export(tmp_path / "half.txt", ["Length unit: mm", "x  y  z  mf.Bx (T)  mf.By  mf.Bz (T)"],
                   lambda x, y, z: (x, y, z, 0.0, 0.0, 0.0))
    with pytest.raises(SpatialFieldError, match=r"half.txt: column 5 'mf.By' states no field unit while "
                                                "other columns do"):
        FieldMap.from_export(half)
    bad = _export(tmp_path / "bad.txt", ["Length unit: mm", "x  y  z  mf.Bx (T)  mf.By (A/m)  mf.Bz (T)"],
                  lambda x, y, z: (x, y, z, 0.0, 0.0, 0.0))
    with pytest.raises(SpatialFieldError, match=r"bad.txt: column 5 'mf.By \(A/m\)' names the field unit "
                                                "'A/m'; known: T, mT"):
        FieldMap.from_export(bad)


@pytest.mark.parametrize("names, message", [
    ("x  y  z  mf.Bx (T)  mf.Bx (T)  mf.Bz (T)",
     r"columns 4 and 5 of the header both name Bx \('mf.Bx \(T\)' and 'mf.Bx \(T\)'\)"),
    ("x  y  z  mf.Hx (T)  mf.By (T)  mf.Bz (T)",
     r"column 4 of the header, 'mf.Hx \(T\)', is none of x, y, z"),
    ("x  y  z  mf.Bx (T)  mf.By (T)", "name 5 columns, the rows hold 6"),
    ("x  y  z  mf.Bx (T)  mf.By (T)  mf.Bz (T)  mf.normB (T)", "name 7 columns, the rows hold 6"),
])
def test_column_names_that_cannot_be_mapped_are_refused_naming_the_file_and_column(tmp_path, names, message):
    path = _export(tmp_path / "named.txt", ["Length unit: mm", names], lambda x, y, z: (x, y, z, 0, 0, 0))
    with pytest.raises(SpatialFieldError, match=f"named.txt: .*{message}"):
        FieldMap.from_export(path)


def test_a_header_without_column_names_keeps_x_y_z_bx_by_bz(tmp_path):
    free_text = _export(tmp_path / "free.txt", ["Length unit: cm", "Model: a magnet, exported by hand"],
                        lambda x, y, z: (x, y, z, 1.0, 2.0, 3.0))
    loaded = FieldMap.from_export(free_text, field_unit="mT")
    np.testing.assert_allclose(loaded.spacing, [0.1, 0.05, 0.05])
    np.testing.assert_allclose(loaded.at(ORIGIN)[:, 0], [1e-3, 2e-3, 3e-3])
    differing = _export(tmp_path / "differing.txt", ["Length unit: cm", "(T) (mT) (mT)"],
                        lambda x, y, z: (x, y, z, 1.0, 2.0, 3.0))
    with pytest.raises(SpatialFieldError, match="differing.txt: the header's units T, mT, mT differ, and it "
                                                "has no column names"):
        FieldMap.from_export(differing)


def test_the_coordinates_units_are_read_from_their_column_names(tmp_path):
    """Round 10 V10: '% x (mm)  y (mm)  z (mm)  mf.Bx (mT) ...' was refused as stating no length unit."""
    def rows(x, y, z):
        return (x, y, z, 1.0, 2.0, 3.0)

    named = ["x (mm)  y (cm)  z (m)  mf.Bx (mT)  mf.By (mT)  mf.Bz (mT)"]
    loaded = FieldMap.from_export(_export(tmp_path / "own.txt", named, rows))
    np.testing.assert_allclose(loaded.spacing, [0.01, 0.05, 5.0])
    agree = _export(tmp_path / "agree.txt", ["Length unit: mm", "x (mm)  y  z (mm)  Bx (T)  By (T)  Bz (T)"],
                    rows)
    np.testing.assert_allclose(FieldMap.from_export(agree).spacing, [0.01, 0.005, 0.005])
    conflict = _export(tmp_path / "conflict.txt",
                       ["Length unit: m", "x (mm)  y (mm)  z (mm)  Bx (T)  By (T)  Bz (T)"], rows)
    with pytest.raises(SpatialFieldError, match=r"conflict.txt: column 1 'x \(mm\)' says the length unit "
                                                r"is mm, the header's 'Length unit' line says m: correct "
                                                "the file"):
        FieldMap.from_export(conflict)
    partial = _export(tmp_path / "partial.txt", ["x (mm)  y  z  Bx (T)  By (T)  Bz (T)"], rows)
    with pytest.raises(SpatialFieldError, match=r"partial.txt: column 2 'y' states no length unit while"):
        FieldMap.from_export(partial)
    bare = _export(tmp_path / "bare.txt", ["x  y  z  Bx (T)  By (T)  Bz (T)"], rows)
    with pytest.raises(SpatialFieldError, match=r"bare.txt: states no length unit \(COMSOL: '% Length unit: "
                                                r"mm', or units in the column names such as 'x \(mm\)'"):
        FieldMap.from_export(bare)


def test_an_uneven_grid_too_fine_to_resample_is_refused_before_it_is_made(tmp_path, monkeypatch):
    """Round 10 T1: one refined node made a 700 001-node axis (or a MemoryError traceback)."""
    import elastica_magnetic.field_maps as field_maps

    header = ["Length unit: mm", "x  y  z  Bx (T)  By (T)  Bz (T)"]
    ys = (-10.0, -5.0, 0.0, 5.0, 10.0)
    refined = _export(tmp_path / "refined.txt", header, lambda x, y, z: (x, y, z, 0.0, 0.0, 1.0),
                      xs=(-10.0, 0.0, 10.0, 10.0001), ys=ys)
    with pytest.raises(SpatialFieldError, match=r"refined.txt: the x axis is not evenly spaced, and its "
                                                r"finest spacing, 1e-07 m \(between 0.01 and 0.0100001 m\), "
                                                r"would need 200,002 x nodes on an even grid, "
                                                r"200,002 x 5 x 3 = 3,000,030 in all \(at most 2,000,000\): "
                                                "resample onto an even grid in the exporting tool"):
        FieldMap.from_export(refined)
    coarse = _export(tmp_path / "coarse.txt", header, lambda x, y, z: (x, y, z, 0.0, 0.0, 1.0),
                     xs=(-10.0, 0.0, 10.0, 10.1), ys=ys)
    loaded = FieldMap.from_export(coarse)  # 202 x 5 x 3 nodes: resampled
    assert loaded.resampled and loaded.shape.tolist() == [202, 5, 3]
    monkeypatch.setattr(field_maps, "MAX_RESAMPLED_NODES", 3000)
    with pytest.raises(SpatialFieldError, match=r"coarse.txt: the x axis .* 202 x 5 x 3 = 3,030 in all "
                                                r"\(at most 3,000\)"):
        FieldMap.from_export(coarse)


def test_msr_field_simulate_names_a_grid_too_fine_to_resample(tmp_path, capsys):
    from elastica_magnetic.cli import main

    _export(tmp_path / "refined.txt", ["Length unit: mm", "x  y  z  Bx (mT)  By (mT)  Bz (mT)"],
            lambda x, y, z: (x, y, z, 0.0, 4.0, 0.0), xs=(-10.0, 0.0, 10.0, 60.0, 60.0001),
            ys=(-10.0, 0.0, 10.0, 10.0001), zs=(-10.0, 0.0, 10.0))
    spec = tmp_path / "spec.toml"
    spec.write_text(ROBOT + '[boundary]\nclamp = "first"\n[field]\nkind = "field-map"\n'
                    'file = "refined.txt"\n')
    status = main(["field", "simulate", "--robot", str(spec), "--duration", "0.01",
                   "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert status == 2 and "Traceback" not in err, err
    assert "refined.txt: the x axis is not evenly spaced" in err and "nodes on an even grid" in err
    assert not (tmp_path / "o").exists()


def test_a_norm_column_beside_the_components_is_left_out(tmp_path):
    """Round 11, V2: COMSOL's common export with mf.normB after the components was refused as
    "expected rows of 6 numbers, got 7 columns"."""
    path = _export(tmp_path / "norm.txt", ["Length unit: mm",
                                           "x  y  z  mf.Bx (mT)  mf.By (mT)  mf.Bz (mT)  mf.normB (mT)"],
                   lambda x, y, z: (x, y, z, 3.0, 4.0, 0.0, 5.0))
    field_map = FieldMap.from_export(path)
    np.testing.assert_allclose(field_map.at(ORIGIN, 0.0).ravel(), [3e-3, 4e-3, 0.0])
    short = _export(tmp_path / "short.txt",
                    ["Length unit: mm", "x  y  z  mf.Bx (mT)  mf.By (mT)  mf.normB (mT)"],
                    lambda x, y, z: (x, y, z, 3.0, 4.0, 5.0))
    with pytest.raises(SpatialFieldError, match=r"short.txt: the header's column names .* name no Bz column"):
        FieldMap.from_export(short)
