"""Files saved as "UTF-8 with BOM" (Excel, Notepad) at the hardware commands' doors (issue 48,
"Tracebacks and vague messages", item 3). A calibration is a JSON document (json refuses a
byte-order mark; the message was "not valid JSON: Unexpected UTF-8 BOM (decode using
utf-8-sig)"): it is named, with how to save the file. A measurements CSV, a table whose first
header the mark would only hide, is read as if it had none."""

from __future__ import annotations

import json

import pytest

from elastica_magnetic.cli import main
from elastica_magnetic.hardware.calibration import CalibrationError, load_calibration

from .conftest import DEFAULT_CALIBRATION, PUBLISHED_CSV

BOM = b"\xef\xbb\xbf"
MEASUREMENTS = ("current_x_A,current_y_A,current_z_A,field_x_mT,field_y_mT,field_z_mT\n"
                "1,0,0,2,0,0\n0,1,0,0,2,0\n0,0,1,0,0,2\n1,1,0,2,2,0\n")


def test_a_calibration_with_a_byte_order_mark_is_named(tmp_path, capsys):
    path = tmp_path / "cal.json"
    path.write_bytes(BOM + DEFAULT_CALIBRATION.read_bytes())
    message = (f"{path} starts with a UTF-8 byte-order mark (saved by Excel/Notepad as 'UTF-8 "
               "with BOM'); save it as plain UTF-8")
    with pytest.raises(CalibrationError) as info:
        load_calibration(path)
    assert str(info.value) == message
    assert main(["real", "firmware", str(PUBLISHED_CSV), "--calibration", str(path), "--out",
                 str(tmp_path / "fw")]) == 2
    assert capsys.readouterr().err.strip() == f"msr real firmware: error: {message}"
    assert not (tmp_path / "fw").exists()


def test_measurements_with_a_byte_order_mark_are_read_as_without(tmp_path):
    plain, marked = tmp_path / "plain.csv", tmp_path / "marked.csv"
    plain.write_text(MEASUREMENTS)
    marked.write_bytes(BOM + MEASUREMENTS.encode())
    for measurements in (plain, marked):
        out = tmp_path / f"{measurements.stem}.json"
        assert main(["real", "calibrate", str(measurements), "--out", str(out), "--name", "bench"]) == 0
    fitted = [json.loads((tmp_path / f"{n}.json").read_text()) for n in ("plain", "marked")]
    assert fitted[0]["actuation_matrix_T_per_A"] == fitted[1]["actuation_matrix_T_per_A"]
