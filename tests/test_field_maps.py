"""Field maps (:mod:`elastica_magnetic.field_maps`): interpolation order, the .npz and .csv files,
grid exports (COMSOL's spreadsheet format: column names, units, uneven grids), and poses."""

from __future__ import annotations

import math

import numpy as np
import pytest

from elastica_magnetic import FieldMap, FieldMapDomainError, PointDipoleField, SpatialFieldError

RNG = np.random.default_rng(7)


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
    with pytest.raises(SpatialFieldError, match="the header says the length unit is mm, length_unit says m"):
        FieldMap.from_export(labelled, length_unit="m")


def test_a_spec_takes_a_comsol_export_as_a_field_map(tmp_path):
    from elastica_magnetic.field_spec import describe_field
    from elastica_magnetic.specfile import SpecError

    axis = np.linspace(-30.0, 30.0, 7)
    _comsol_export(tmp_path / "map.txt", axis, axis, axis, lambda p: np.stack(
        [0 * p[0], 0 * p[0] + 4e-3, 0 * p[0]]))
    setup = describe_field({"field": {"kind": "field-map", "file": "map.txt"}}, str(tmp_path / "my.toml"))
    np.testing.assert_allclose(setup.source().at(np.zeros((3, 1)))[:, 0], [0.0, 4e-3, 0.0])
    with pytest.raises(SpecError, match=r"\[field\]: .*map.txt: the header says the field unit is T, "
                                        "field_unit says mT"):
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
