"""Field sources, field CSV reading and writing, magnetization patterns."""

import numpy as np
import pytest

from elastica_magnetic import (
    ConstantField,
    ControlledField,
    FieldCSVError,
    RampedField,
    RotatingField,
    TabulatedField,
    magnetization_from_function,
    read_field_csv,
    sinusoidal_magnetization,
    two_segment_magnetization,
    uniform_magnetization,
    write_field_csv,
    yao2023_magnetization,
)


def test_constant_and_ramped():
    np.testing.assert_array_equal(ConstantField([1e-3, 0, 0])(5.0), [1e-3, 0, 0])
    ramp = RampedField([2e-3, -2e-3, 0], ramp_time=0.5)
    np.testing.assert_allclose(ramp(0.0), 0.0)
    np.testing.assert_allclose(ramp(0.25), [1e-3, -1e-3, 0])
    np.testing.assert_allclose(ramp(3.0), [2e-3, -2e-3, 0])
    with pytest.raises(ValueError, match="3-vector in tesla"):
        ConstantField([1.0, 2.0])
    with pytest.raises(ValueError, match="ramp_time"):
        RampedField([0, 0, 1e-3], ramp_time=0.0)


def test_rotating_field_turns_counter_clockwise():
    field = RotatingField(amplitude=4e-3, frequency=2.0)
    np.testing.assert_allclose(field(0.0), [4e-3, 0, 0], atol=1e-18)
    np.testing.assert_allclose(field(0.125), [0, 4e-3, 0], atol=1e-18)  # a quarter turn
    np.testing.assert_allclose(np.linalg.norm(field(0.377)), 4e-3)
    ramped = RotatingField(4e-3, -1.0, phase=np.pi / 2, ramp_time=1.0)
    np.testing.assert_allclose(ramped(0.5), 2e-3 * np.array([np.cos(np.pi / 2 - np.pi),
                                                             np.sin(np.pi / 2 - np.pi), 0]),
                               atol=1e-18)


def test_tabulated_zero_order_hold():
    samples = np.array([[1.0, 0, 0], [2.0, 0, 0], [3.0, 0, 0]]) * 1e-3
    field = TabulatedField(samples, rate=100.0)
    assert field(0.0)[0] == 1e-3
    assert field(0.0099999)[0] == 1e-3
    assert field(0.01)[0] == 2e-3  # row i holds on [i/100, (i+1)/100)
    # accumulated time steps land a hair below the boundary: still the next row
    assert field(1250 * 8e-6 - 1e-16)[0] == 2e-3
    assert field(0.0299)[0] == 3e-3
    assert field(5.0)[0] == 3e-3  # hold after the end
    assert TabulatedField(samples, after_end="zero")(0.03)[0] == 0.0
    assert field.duration == pytest.approx(0.03)
    with pytest.raises(ValueError, match=r"\(n_samples, 3\)"):
        TabulatedField(np.zeros((3, 2)))
    with pytest.raises(ValueError, match="row 1"):
        TabulatedField([[0, 0, 0], [np.nan, 0, 0]])


def test_controlled_field_paper_rule():
    field = ControlledField(limit=4e-3, max_increment=0.3e-3)
    # increments are clipped per component to +-0.3 mT
    np.testing.assert_allclose(field.apply_increment([1e-3, -0.1e-3]), [0.3e-3, -0.1e-3, 0])
    # components clipped to the limit, then the amplitude scaled down to the limit
    field.set([3.9e-3, 3.9e-3, 0.0])
    np.testing.assert_allclose(np.linalg.norm(field(0.0)), 4e-3)
    np.testing.assert_allclose(field(0.0)[0], field(0.0)[1])
    field.set([10e-3, 0.0, 0.0])
    np.testing.assert_allclose(field(0.0), [4e-3, 0, 0])
    field.apply_increment([0.3e-3, 0.0])
    np.testing.assert_allclose(field(0.0), [4e-3, 0, 0])
    with pytest.raises(ValueError, match="delta"):
        field.apply_increment([np.nan, 0.0])


def test_field_csv_roundtrip_and_published_file(tmp_path, reference_dir):
    published = read_field_csv(reference_dir / "magnetic_field.csv")
    assert published.shape == (1000, 3)
    np.testing.assert_allclose(published[0], [-0.3e-3, -0.3e-3, 0.0], rtol=1e-6)
    assert np.abs(published).max() <= 4e-3 + 1e-9
    path = write_field_csv(tmp_path / "f.csv", published)
    np.testing.assert_array_equal(read_field_csv(path), published)
    assert path.read_text().splitlines()[0] == ",mag_x,mag_y,mag_z"


@pytest.mark.parametrize(
    "text, message",
    [
        (",mag_x,mag_y\n0,1,2\n", r"lacks column\(s\) mag_z"),
        (",mag_x,mag_y,mag_z\n0,1,2,3\n1,1,abc,3\n", r"line 3, column mag_y: 'abc' is not a number"),
        (",mag_x,mag_y,mag_z\n0,1,2,3\n1,1,2\n", "line 3 has 3 columns, expected 4"),
        (",mag_x,mag_y,mag_z\n0,1,2,nan\n", "line 2, column mag_z: non-finite"),
        (",mag_x,mag_y,mag_z\n0,1,2,3\n5,1,2,3\n", "line 3: index '5' out of sequence"),
        ("", "empty file"),
        (",mag_x,mag_y,mag_z\n", "no data rows"),
        ("1,2\n", "line 1 has 2 columns"),
    ],
)
def test_field_csv_errors_name_the_problem(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(FieldCSVError, match=message) as info:
        read_field_csv(path)
    assert "bad.csv" in str(info.value)


def test_field_csv_without_header_or_index(tmp_path):
    path = tmp_path / "plain.csv"
    path.write_text("1,2,3\r\n4,5,6e0\r\n")
    np.testing.assert_allclose(read_field_csv(path), [[1e-3, 2e-3, 3e-3], [4e-3, 5e-3, 6e-3]])
    with pytest.raises(FieldCSVError, match="no such field CSV"):
        read_field_csv(tmp_path / "missing.csv")
    folder = tmp_path / "run.csv"  # a folder named like a CSV (a generate result)
    folder.mkdir()
    (folder / "fields.csv").write_text("1,2,3\n")
    with pytest.raises(FieldCSVError, match=r"run\.csv: is a folder, not a field CSV file; give a CSV "
                                            r"file \(this folder has: fields\.csv\)"):
        read_field_csv(folder)


def test_magnetization_patterns():
    m1 = yao2023_magnetization(1, 64)
    assert m1.shape == (3, 64)
    np.testing.assert_allclose(m1[:, 0], [-61.3e3, 0, 0])
    np.testing.assert_allclose(m1[:, 31], [-61.3e3, 0, 0])
    np.testing.assert_allclose(m1[:, 32], [61.3e3, 0, 0])
    m2 = yao2023_magnetization(2, 64)
    np.testing.assert_allclose(m2[:, 0], [0, -61.3e3, 0])
    np.testing.assert_allclose(m2[:, 63], [0, 61.3e3, 0])
    np.testing.assert_allclose(uniform_magnetization(4, 2.0, (0, 0, 5))[:, 2], [0, 0, 2.0])
    sine = sinusoidal_magnetization(40, 1.0, phase=0.3)
    np.testing.assert_allclose(np.linalg.norm(sine, axis=0), 1.0)
    angle = np.unwrap(np.arctan2(sine[1], sine[0]))
    np.testing.assert_allclose(np.diff(angle), 2 * np.pi / 40)  # one full turn along the rod
    np.testing.assert_allclose(angle[0], 0.3 + np.pi / 40)
    custom = magnetization_from_function(
        lambda s: np.stack([s, 0 * s, 0 * s]), n_elements=4, length=4.0
    )
    np.testing.assert_allclose(custom[0], [0.5, 1.5, 2.5, 3.5])
    assert two_segment_magnetization(6, 1.0, (1, 0, 0), (0, 1, 0), split=2)[1, 2] == 1.0
    with pytest.raises(ValueError, match="pattern must be 1 or 2"):
        yao2023_magnetization(3)
    with pytest.raises(ValueError, match=r"must return shape \(3, 4\)"):
        magnetization_from_function(lambda s: s, 4, 1.0)
    with pytest.raises(ValueError, match="magnitude"):
        uniform_magnetization(4, -1.0)
