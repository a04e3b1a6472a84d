"""Field CSV reader: encodings (issue 15, item 10) and a fuzz test of random mutations of a valid
file: every outcome is a correct parse or a FieldCSVError naming the file, never a traceback."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from elastica_magnetic import FieldCSVError, read_field_csv
from elastica_magnetic.field_csv import MILLITESLA

BOM = b"\xef\xbb\xbf"
VALID = b",mag_x,mag_y,mag_z\n0,1.5,-2.0,0.0\n1,1.25,-1.75,0.0\n2,1.0,-1.5,0.25\n3,0.5,-1.0,0.5\n"


@pytest.mark.parametrize(
    "data",
    [BOM + b"mag_x,mag_y,mag_z\n1,2,3\n4,5,6\n", BOM + b"1,2,3\n4,5,6\n",
     BOM + b",mag_x,mag_y,mag_z\r\n0,1,2,3\r\n1,4,5,6\r\n"],
)
def test_utf8_byte_order_mark_is_accepted(tmp_path, data):
    path = tmp_path / "excel.csv"
    path.write_bytes(data)
    np.testing.assert_allclose(read_field_csv(path), np.array([[1, 2, 3], [4, 5, 6]]) * MILLITESLA)


def test_non_utf8_file_names_the_file_and_line(tmp_path):
    path = tmp_path / "latin1.csv"
    path.write_bytes("mag_x,mag_y,mag_z\n1,2,3\n4,5,6 # \u00b5T\n".encode("latin-1"))
    with pytest.raises(FieldCSVError, match=r"latin1\.csv: line 3: byte 0xb5 is not UTF-8"):
        read_field_csv(path)


def test_csv_syntax_error_names_the_file(tmp_path):
    path = tmp_path / "nul.csv"
    path.write_bytes(b"1,2,3\n4,\x005,6\n")
    with pytest.raises(FieldCSVError, match=r"nul\.csv: line 2"):
        read_field_csv(path)


_PIECES = [b",", b"\n", b"\r", b"\r\n", b'"', b"-", b".", b"e", b"e999", b"nan", b"inf", b"0", b"7",
           b" ", b"\x00", b"\xff", b"\xc3", BOM, b"mag_x", b"mag_z", b";", b"\t", b"1_0", b"#"]


def _mutate(data: bytes, rng: np.random.Generator) -> bytes:
    data = bytearray(data)
    for _ in range(int(rng.integers(1, 4))):
        kind = int(rng.integers(0, 5))
        pos = int(rng.integers(0, len(data) + 1))
        if kind == 0 and data:  # delete a span
            del data[pos:pos + int(rng.integers(1, 6))]
        elif kind == 1:  # insert a piece
            data[pos:pos] = _PIECES[int(rng.integers(len(_PIECES)))]
        elif kind == 2 and data:  # replace one byte
            data[min(pos, len(data) - 1)] = int(rng.integers(0, 256))
        elif kind == 3:  # duplicate a span
            data[pos:pos] = data[pos:pos + int(rng.integers(1, 20))]
        else:  # truncate
            data = data[:pos]
    return bytes(data)


def test_fuzz_mutated_field_csv_parses_or_names_the_error(tmp_path):
    rng = np.random.default_rng(15)
    path = tmp_path / "fuzz.csv"
    outcomes = {"parsed": 0, "error": 0}
    for _ in range(600):
        path.write_bytes(_mutate(VALID, rng))
        try:
            field = read_field_csv(path)
        except FieldCSVError as exc:
            assert str(exc).startswith(str(path) + ":"), str(exc)
            outcomes["error"] += 1
            continue
        # A parse is a correct one: rows of 3 finite components, within what the text can hold.
        assert field.ndim == 2 and field.shape[1] == 3 and field.shape[0] >= 1
        assert field.dtype == np.float64 and np.all(np.isfinite(field))
        outcomes["parsed"] += 1
    assert outcomes["parsed"] > 20 and outcomes["error"] > 20, outcomes


def test_a_time_column_read_as_the_index_is_named(tmp_path):
    """Round 5, F11: a first column of times in s gave only "index '0.01' out of sequence, expected
    1". Without a header it is read as the index, and the message says so; headed as a clock (t_s)
    it is checked as one since round 42 (0.01 s steps: the rows' own, accepted)."""
    from elastica_magnetic.plausibility import ImplausibleValueWarning

    path = tmp_path / "tcol.csv"
    path.write_text("0,1,0,0\n0.01,1,0,0\n0.02,1,0,0\n")
    with pytest.raises(FieldCSVError, match=r"line 2: index '0.01' out of sequence, expected 1; "
                                            r"the first of four columns is read as a row index"):
        read_field_csv(path)
    path.write_text("t_s,mag_x,mag_y,mag_z\n0,1,0,0\n0.01,1,0,0\n0.02,1,0,0\n")
    with pytest.warns(ImplausibleValueWarning, match="'t_s' are not read"):
        assert read_field_csv(path).shape == (3, 3)


@pytest.mark.parametrize("first", ["0.01", "5.00", "1"])
def test_a_first_row_index_that_is_not_0_is_explained(tmp_path, first):
    """Round 35, V1: a first column of times starting at 0.01 s (or 5 s, or rows numbered from 1)
    was told only "index '0.01' out of sequence, expected 0" on the first row, the explanation given
    from the second row on; now on the first too (headed as a clock, the column is checked as one)."""
    path = tmp_path / "late.csv"
    path.write_text(f"{first},1,0,0\n0.02,1,0,0\n")
    with pytest.raises(FieldCSVError, match=rf"line 1: index '{first}' out of sequence, expected 0; the "
                                            r"first of four columns is read as a row index"):
        read_field_csv(path)


def test_round9_v6_trailing_comma_ms_index_and_non_regular_files(tmp_path):
    """Round 9, V6: a headerless file with a trailing comma was called a header lacking columns, a
    t_ms column (0, 10, 20...) got no time hint, a FIFO or /dev/null was "no such file"."""
    import os

    trailing = tmp_path / "trailing.csv"
    trailing.write_text("-0.29,-0.29,0.0,\n-0.28,-0.3,0.0,\n")
    with pytest.raises(FieldCSVError, match=r"line 1 has 4 columns, the last one empty \(a trailing"):
        read_field_csv(trailing)
    t_ms = tmp_path / "t_ms.csv"
    t_ms.write_text("0,1,0,0\n10,1,0,0\n20,1,0,0\n")  # headed t_ms, it is a clock (round 42)
    with pytest.raises(FieldCSVError, match=r"index '10' out of sequence, expected 1; the first of "
                                            r"four columns is read as a row index"):
        read_field_csv(t_ms)
    fifo = tmp_path / "fifo.csv"
    os.mkfifo(fifo)
    for path in (fifo, Path("/dev/null")):
        with pytest.raises(FieldCSVError, match="is not a regular file"):
            read_field_csv(path)
    with pytest.raises(FieldCSVError, match="no such field CSV file"):
        read_field_csv(tmp_path / "missing.csv")


def test_a_column_that_is_not_read_is_named(tmp_path):
    """Round 11: a field CSV with an extra named column (current_A) was played without a word
    that the column is not read."""
    from elastica_magnetic.plausibility import ImplausibleValueWarning

    path = tmp_path / "extra.csv"
    path.write_text("mag_x,mag_y,mag_z,current_A\n1,0,0,2\n1,0,0,2\n")
    with pytest.warns(ImplausibleValueWarning, match=r"column\(s\) 'current_A' are not read"):
        field = read_field_csv(path)
    np.testing.assert_allclose(field, [[1e-3, 0, 0], [1e-3, 0, 0]])


def test_round17_a_column_of_an_axis_the_spec_does_not_drive_is_refused():
    """Round 17 S: msr field replay played a 2 mT mag_z on a spec with axes = "xy" (no third coil
    pair) without a word, where x and y rows above their limit are refused."""
    import numpy as np

    from elastica_magnetic.field_csv import limit_problem

    field = np.zeros((5, 3))
    field[:, 0] = 1e-3
    assert limit_problem(field, {"x": 4e-3, "y": 4e-3}, "f.csv") is None
    field[3, 2] = 2e-3
    problem = limit_problem(field, {"x": 4e-3, "y": 4e-3}, "f.csv")
    assert problem.startswith("f.csv: data row 3 asks B_z = 2 mT, and the spec's [actuation] drives the "
                              "axes xy only"), problem
    assert limit_problem(field, {"x": 4e-3, "y": 4e-3, "z": 4e-3}, "f.csv") is None


def test_a_catheter_s_drive_given_as_a_field_csv_is_named(tmp_path):
    """The coils' currents or a magnet arm's path (``msr policy generate --target``'s drive) given where a
    field CSV goes (``msr real stream``, ``msr field replay``) are named for what they are, not as a
    field CSV that lacks mag_x, mag_y, mag_z."""
    coils = tmp_path / "coil_currents.csv"
    coils.write_text("t_s," + ",".join(f"current_{k}_A" for k in range(8)) + "\n0" + ",0.5" * 8 + "\n")
    with pytest.raises(FieldCSVError, match=r"coil_currents.csv: holds the currents of 8 coils "
                                            r"\(current_0_A, \.\.\., A\), a catheter.s drive"):
        read_field_csv(coils)
    arm = tmp_path / "magnet_path.csv"
    arm.write_text("t_s,magnet_x_m,magnet_y_m,magnet_z_m,direction_x,direction_y,direction_z\n0,0.09,0,0,1,0,0\n")
    with pytest.raises(FieldCSVError, match=r"holds a magnet arm's path \(magnet_x_m, \.\.\., m\)"):
        read_field_csv(arm)

