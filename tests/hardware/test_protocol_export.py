"""Wire protocol, flash-table export and the msr sub-commands (without a board)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pytest

from elastica_magnetic.field_csv import write_field_csv
from elastica_magnetic.hardware import cli as hw_cli
from elastica_magnetic.hardware.calibration import expected_dac_codes, load_calibration
from elastica_magnetic.hardware.export import (
    MAX_TABLE_ROWS,
    export_firmware,
    read_expected_codes,
)
from elastica_magnetic.hardware.protocol import (
    crc16,
    format_row,
    parse_dac,
    parse_safe,
    wire_rows_mT,
    wire_values_mT,
)

from .conftest import PUBLISHED_CSV


def test_crc_check_value_matches_firmware() -> None:
    assert crc16(b"123456789") == 0x29B1  # same check value as stm32/tests/test_crc16.c
    assert crc16(b"") == 0xFFFF


def test_row_format_and_corruption() -> None:
    row = ("-0.300000011920929", "1e-05", "0")
    line = format_row(7, row)
    payload, crc = line.decode().rstrip("\n").split("*")
    assert payload == "7,-0.300000011920929,1e-05,0"
    assert int(crc, 16) == crc16(payload.encode())
    bad = format_row(7, row, corrupt=True).decode().rstrip("\n")
    bad_payload, bad_crc = bad.split("*")
    assert bad_crc == crc and bad_payload != payload
    assert crc16(bad_payload.encode()) != int(bad_crc, 16)


def test_wire_text_roundtrip_15_digits() -> None:
    field_T = np.array([[-0.30000001192092896e-3, 2.756907e-3, 0.0], [1e-9, -4e-3, 1.5e-3]])
    rows = wire_rows_mT(field_T)
    values = wire_values_mT(rows)
    np.testing.assert_allclose(values, field_T * 1e3, rtol=1e-14)
    digits = [v.lstrip("-").split("e")[0].replace(".", "").lstrip("0") for r in rows for v in r]
    assert max(len(d) for d in digits) <= 15


def test_parse_board_lines() -> None:
    d = parse_dac("DAC 12 1 2 65535")
    assert d is not None and d.row == 12 and d.codes == (1, 2, 65535)
    s = parse_dac("DAC safe 32768 32768 32768")
    assert s is not None and s.row is None
    safe = parse_safe("SAFE checksum row=500 applied=267 detail=crc-mismatch")
    assert safe is not None and (safe.reason, safe.row, safe.applied, safe.detail) == (
        "checksum", 500, 267, "crc-mismatch")
    assert parse_dac("CREDIT 5") is None


def test_export_writes_sources_and_codes(tmp_path: Path, default_calibration_path: Path) -> None:
    field = np.array([[1e-3, 0, 0], [0, -1e-3, 0.5e-3], [0, 0, 0]])
    csv = write_field_csv(tmp_path / "f.csv", field)
    summary = export_firmware(csv, default_calibration_path, tmp_path / "out")
    assert summary["rows"] == 3
    table = (tmp_path / "out" / "waveform_table.c").read_text()
    assert "msr_waveform_rows = 3u" in table and "{1.0, 0.0, 0.0}," in table
    header = (tmp_path / "out" / "calibration_gen.h").read_text()
    assert '#define MSR_CALIBRATION_NAME "default"' in header
    codes = read_expected_codes(tmp_path / "out" / "expected_dac_codes.csv")
    cal = load_calibration(default_calibration_path)
    np.testing.assert_array_equal(codes, expected_dac_codes(cal, field * 1e3))
    assert tuple(codes[2]) != (0, 0, 0)


def test_export_rejects_too_long_table(tmp_path: Path, default_calibration_path: Path) -> None:
    csv = write_field_csv(tmp_path / "long.csv", np.zeros((MAX_TABLE_ROWS + 1, 3)))
    with pytest.raises(ValueError, match="flash table limit"):
        export_firmware(csv, default_calibration_path, tmp_path / "out")


def test_published_waveform_codes_stay_in_range(default_calibration_path: Path, tmp_path: Path) -> None:
    assert PUBLISHED_CSV.is_file(), f"published waveform missing: {PUBLISHED_CSV}"
    summary = export_firmware(PUBLISHED_CSV, default_calibration_path, tmp_path)
    assert summary["rows"] == 1000
    assert 0 < summary["code_min"] and summary["code_max"] < 65535  # 4 mT well within full scale


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="msr")
    hw_cli.register(parser.add_subparsers(dest="command"))
    return parser


def test_cli_registers_three_commands() -> None:
    parser = _parser()
    for argv in (["stream", "f.csv", "--port", "loop://"],
                 ["export-firmware", "f.csv", "--calibration", "c.json", "--out", "d"],
                 ["calibrate", "m.csv", "--out", "c.json"]):
        args = parser.parse_args(argv)
        assert callable(args.func)


def test_cli_calibrate_writes_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rng = np.random.default_rng(5)
    true_mT = np.array([[2.0, 0.1, 0.0], [0.0, 1.9, 0.05], [0.02, 0.0, 1.7]])
    currents = rng.uniform(-1.5, 1.5, size=(12, 3))
    fields = currents @ true_mT.T + rng.normal(scale=1e-4, size=(12, 3))
    lines = ["current_x_A,current_y_A,current_z_A,field_x_mT,field_y_mT,field_z_mT"]
    lines += [",".join(repr(float(v)) for v in (*c, *f)) for c, f in zip(currents, fields, strict=True)]
    meas = tmp_path / "meas.csv"
    meas.write_text("\n".join(lines) + "\n")
    out = tmp_path / "cal.json"
    args = _parser().parse_args(["calibrate", str(meas), "--out", str(out), "--name", "bench1",
                                 "--json"])
    assert args.func(args) == 0
    cal = load_calibration(out)
    assert cal.name == "bench1"
    np.testing.assert_allclose(np.array(cal.actuation_matrix_T_per_A), true_mT * 1e-3, atol=1e-6)
    assert "rms_residual_mT" in capsys.readouterr().out


def test_cli_calibrate_bad_row_names_line(tmp_path: Path) -> None:
    from elastica_magnetic.cli import CommandError

    meas = tmp_path / "meas.csv"
    meas.write_text("current_x_A,current_y_A,current_z_A,field_x_mT,field_y_mT,field_z_mT\n"
                    "1,0,0,2,0,0\n0,1,0,0,2,0\n0,0,1,0,0,x\n")
    args = _parser().parse_args(["calibrate", str(meas), "--out", str(tmp_path / "c.json")])
    with pytest.raises(CommandError, match="line 4"):
        args.func(args)


def test_export_refuses_a_clipped_waveform_unless_allowed(tmp_path, capsys):
    """A 100 mT waveform is beyond the default coils' 2.4 A: say how many rows and by how much."""
    from elastica_magnetic.cli import main
    from elastica_magnetic.hardware.calibration import default_calibration_path

    csv_path = tmp_path / "strong.csv"
    csv_path.write_text("mag_x,mag_y,mag_z\n" + "0,0,0\n" * 3 + "100,0,0\n" * 4 + "1,0,0\n" * 100)
    argv = ["real", "firmware", str(csv_path), "--calibration", str(default_calibration_path()),
            "--out", str(tmp_path / "out"), "--json"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "strong.csv: the coils of calibration 'default' cannot follow this waveform" in err
    assert ("4 row(s) need more than the current limit of the x coils (up to 50.03 A for a limit "
            "of 2.4 A)") in err
    assert "4 row(s) clipped, first at data row 3" in err and "--allow-clipping" in err
    assert not (tmp_path / "out").exists()
    assert main([*argv, "--allow-clipping"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["rows_clipped"] == 4 and result["rows_slew_limited"] > 0
