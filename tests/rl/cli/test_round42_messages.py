"""Round 42 of held-out tries (issue 48): what they found, each fixed with the message it gives."""

from __future__ import annotations

import re
import warnings

import pytest


@pytest.mark.parametrize("header, times", [("t_ms", [0, 1, 2, 3]), ("time (s)", [0, 1, 2, 3])])
def test_a_clock_column_first_is_checked_as_a_clock_not_a_row_index(tmp_path, header, times):
    """S1: a first column headed as a clock whose values were 0, 1, 2... (a 1 kHz waveform in ms, a
    1 Hz one in s) was taken for a row index and played at 100 Hz without a word; placed last it was
    refused."""
    from elastica_magnetic.field_csv import FieldCSVError, read_field_csv

    rows = [f"{header},mag_x,mag_y,mag_z"] + [f"{t},1,0,0" for t in times]
    (tmp_path / "f.csv").write_text("\n".join(rows) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(FieldCSVError, match=rf"column '{re.escape(header)}' reads as a clock stepping"):
            read_field_csv(tmp_path / "f.csv")
    rows = [f"{header},mag_x,mag_y,mag_z"] + [f"{0.01 * k * (1000 if 'ms' in header else 1):.6g},1,0,0"
                                              for k in range(4)]
    (tmp_path / "g.csv").write_text("\n".join(rows) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert read_field_csv(tmp_path / "g.csv").shape == (4, 3)  # a clock of the rows' 0.01 s steps
    (tmp_path / "h.csv").write_text("index,mag_x,mag_y,mag_z\n0,1,0,0\n1,1,0,0\n")
    assert read_field_csv(tmp_path / "h.csv").shape == (2, 3)  # a row index stays one


def test_a_measurements_csv_given_as_a_calibration_is_told_what_a_calibration_is(tmp_path):
    """Borderline of round 42: ``--calibration meas.csv`` (the measurements, not the calibration fitted
    from them) was told only "not valid JSON"."""
    from elastica_magnetic.hardware.calibration import CalibrationError, load_calibration

    header = "current_x_A,current_y_A,current_z_A,field_x_mT,field_y_mT,field_z_mT"
    (tmp_path / "meas.csv").write_text(f"{header}\n1,0,0,3,0,0\n")
    with pytest.raises(CalibrationError, match=r"meas.csv: not valid JSON \(.*\): it reads as a CSV "
                                               r"\(measurements\?\); a calibration is the JSON file "
                                               r"'msr real calibrate meas.csv --out CAL.json' writes"):
        load_calibration(tmp_path / "meas.csv")


def test_a_reference_in_other_units_is_told_to_give_si_units(tmp_path):
    """Borderline of round 42: a ``--reference`` with ``_mm`` or ``t_ms`` columns was told only which
    columns it lacks, no word on units (field CSVs read a clock in any unit)."""
    from elastica_magnetic.cli.commands import CommandError, _read_reference

    (tmp_path / "r.csv").write_text("t_ms,mid_x_mm,mid_y_mm,span_mm\n0,0,0,16\n10,1,0,16\n")
    with pytest.raises(CommandError, match=r"lacks column\(s\) t_s, mid_x_m.* \(found 't_ms', "
                                           r"'mid_x_mm', 'mid_y_mm', 'span_mm': a reference is read in SI "
                                           r"units, s and m"):
        _read_reference(tmp_path / "r.csv", 1.0, 0.016)
