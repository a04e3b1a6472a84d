"""Host-side plausibility: each implausible calibration, measurement or stream gets its named
error before anything is sent or written; the shipped yao2023 calibration makes every shipped
policy's waveform."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from elastica_magnetic.cli import main
from elastica_magnetic.hardware import plausibility
from elastica_magnetic.hardware.calibration import (
    CalibrationError,
    load_calibration,
)
from elastica_magnetic.hardware.calibration_fit import fit_actuation_matrix
from elastica_magnetic.hardware.export import export_firmware
from elastica_magnetic.hardware.plausibility import PlausibilityError

from .conftest import DEFAULT_CALIBRATION, REPO

YAO2023 = REPO / "stm32" / "calibration" / "yao2023.json"
HW_RATINGS_H = REPO / "stm32" / "src" / "app" / "hw_ratings.h"


def write_calibration(tmp_path: Path, **changes: object) -> Path:
    data = json.loads(DEFAULT_CALIBRATION.read_text())
    data.update(changes)
    path = tmp_path / "cal.json"
    path.write_text(json.dumps(data))
    return path


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"actuation_matrix_T_per_A": [[2.0, 0.05, 0], [0.04, 2.0, 0], [0, 0.02, 1.8]]},
         r"actuation_matrix_T_per_A\[0\]\[0\] = 2 T/A is outside .* looks like mT/A or G/A"),
        ({"actuation_matrix_T_per_A": [[2000.0, 0, 0], [0, 2000.0, 0], [0, 0, 2000.0]]},
         r"looks like uT/A written where T/A is expected"),
        ({"actuation_matrix_T_per_A": [[2e-6, 0, 0], [0, 2e-3, 0], [0, 0, 2e-3]]},
         r"\[0\]\[0\] = 2e-06 T/A is outside .*T/A is expected"),
        ({"actuation_matrix_T_per_A": [[2e-3, 1.98e-3, 0], [1.98e-3, 2e-3, 0], [0, 0, 2e-3]]},
         r"ill conditioned \(condition number 199 > 100\)"),
        # round 13 V2: rows y and z exchanged by hand, no cross-coupling: named as a swap, not units
        ({"actuation_matrix_T_per_A": [[2e-3, 0, 0], [0, 0, 1.8e-3], [0, 2e-3, 0]]},
         r"coil y \(current_y_A\) makes 2 mT/A along z but 0 mT/A along y, its own axis: .* swapped"),
        ({"tick_hz": 1000.0}, r"tick_hz = 1000, but the firmware ticks at a fixed 100 Hz"),
        # round 17 V: 100.0000001 was printed "tick_hz = 100" and refused (self-contradictory)
        ({"tick_hz": 100.0000001}, r"tick_hz = 100.0000001, but .* applied 1.000000001x off"),
        ({"current_limit_A": [2400.0, 2.4, 2.4]},
         r"current_limit_A\[0\] = 2400 A exceeds the hardware rating of 20 A \(mA written"),
        ({"slew_limit_A_per_s": [50.0, 50000.0, 50.0]}, r"slew_limit_A_per_s\[1\] = 50000 A/s"),
        # round 13 S1: A/ms written for A/s, a coil that would take 48 s to reach its limit
        ({"slew_limit_A_per_s": [0.05, 50.0, 50.0]},
         r"slew_limit_A_per_s\[0\] = 0.05 A/s is below 1 A/s: the coil would need 48 s "
         r".* 0.05 A/ms is 50 A/s"),
        ({"input_offset_V": [0.0, 0.0, 12.0]}, r"input_offset_V\[2\] = 12 V exceeds \+-0.5 V"),
        ({"transconductance_A_per_V": [1000.0, 1.0, 1.0]}, r"transconductance_A_per_V\[0\] = 1000"),
        ({"dac_half_span_V": 5.0}, r"dac_half_span_V = 5 V exceeds the DAC8563's 2.5 V"),
    ],
)
def test_implausible_calibration_files_are_refused(tmp_path: Path, change: dict, message: str) -> None:
    path = write_calibration(tmp_path, **change)
    with pytest.raises(PlausibilityError, match=message):
        load_calibration(path)


def test_export_refuses_implausible_calibration_before_writing(tmp_path: Path, capsys) -> None:
    cal = write_calibration(tmp_path, tick_hz=1000.0)
    csv_path = tmp_path / "f.csv"
    csv_path.write_text("1,2,0\n")
    out = tmp_path / "out"
    assert main(["real", "firmware", str(csv_path), "--calibration", str(cal), "--out", str(out)]) == 2
    assert "fixed 100 Hz" in capsys.readouterr().err
    assert not out.exists()


def measurements(currents: np.ndarray, matrix: np.ndarray, noise_mT: float = 0.0,
                 seed: int = 0) -> np.ndarray:
    fields_mT = currents @ matrix.T * 1e3
    fields_mT += np.random.default_rng(seed).normal(0.0, noise_mT, fields_mT.shape)
    return np.hstack([currents, fields_mT])


def write_measurements(path: Path, table: np.ndarray) -> Path:
    header = "current_x_A,current_y_A,current_z_A,field_x_mT,field_y_mT,field_z_mT"
    np.savetxt(path, table, delimiter=",", header=header, comments="")
    return path


TRUE = np.array([[2e-3, 5e-5, 0.0], [4e-5, 2e-3, 0.0], [0.0, 2e-5, 1.8e-3]])
ALONE = np.vstack([np.diag([a, a, a]) for a in (-2.0, -1.0, 1.0, 2.0)])


@pytest.mark.parametrize(
    ("scale_current", "scale_field", "message"),
    [
        (1.0, 1e-3, r"largest field is 0.00\d+ mT, below 0.05 mT: the fields look like tesla"),
        (1000.0, 1.0, r"largest current is 2000 A, above the hardware rating of 20 A: .* mA"),
        (1.0, 1e4, r"fields look like uT or gauss"),
    ],
)
def test_calibrate_names_unit_mistakes(tmp_path: Path, capsys, scale_current: float,
                                       scale_field: float, message: str) -> None:
    table = measurements(ALONE, TRUE)
    table[:, :3] *= scale_current
    table[:, 3:] *= scale_field
    meas = write_measurements(tmp_path / "m.csv", table)
    out = tmp_path / "c.json"
    assert main(["real", "calibrate", str(meas), "--out", str(out)]) == 2
    assert re.search(message, capsys.readouterr().err)
    assert not out.exists()


def test_calibrate_refuses_coils_driven_together(tmp_path: Path, capsys) -> None:
    # the case: two coils driven together (condition number ~900), 2 mA current noise
    rng = np.random.default_rng(1)
    base = np.array([[1.0, 1.0, 0.0], [1.0, 1.002, 0.0], [0.0, 0.0, 1.0]] * 4)
    currents = base * np.repeat([1.0, -1.0, 2.0, -2.0], 3)[:, None]
    fields_mT = currents @ TRUE.T * 1e3
    currents = currents + rng.normal(0.0, 0.002, currents.shape)
    meas = write_measurements(tmp_path / "m.csv", np.hstack([currents, fields_mT]))
    assert main(["real", "calibrate", str(meas), "--out", str(tmp_path / "c.json")]) == 2
    err = capsys.readouterr().err
    assert re.search(r"ill conditioned \(condition number \d{3,}", err), err
    assert not (tmp_path / "c.json").exists()


def test_calibrate_warns_and_reports_uncertainties(tmp_path: Path, capsys) -> None:
    # partly overlapping drive: condition number between the warning (10) and refusal (100)
    pair = np.array([[1.0, 0.9, 0.0], [0.9, 1.0, 0.0], [0.0, 0.0, 1.0]])
    currents = np.vstack([pair * a for a in (-2.0, -1.0, 1.0, 2.0)])
    fit = fit_actuation_matrix(currents, (currents @ TRUE.T))
    assert plausibility.CURRENT_CONDITION_WARN < fit.current_condition < 100, fit.current_condition
    meas = write_measurements(tmp_path / "m.csv", measurements(currents, TRUE, noise_mT=0.01))
    assert main(["real", "calibrate", str(meas), "--out", str(tmp_path / "c.json"), "--json"]) == 0
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    assert summary["current_condition_number"] > 10 and summary["warnings"]
    assert f"warning: {meas}: the measured currents' condition number" in captured.err
    se = np.array(summary["std_error_mT_per_A"])
    assert se.shape == (3, 3) and np.all(se > 0) and np.all(se < 0.05)


def test_well_conditioned_fit_recovers_the_matrix_within_its_uncertainty() -> None:
    table = measurements(ALONE, TRUE, noise_mT=0.01, seed=3)
    fit = fit_actuation_matrix(table[:, :3], table[:, 3:] * 1e-3)
    assert fit.current_condition == pytest.approx(1.0) and not fit.warnings
    error = np.abs(fit.matrix_T_per_A - TRUE)
    assert np.all(error < 5 * fit.std_error_T_per_A), (error, fit.std_error_T_per_A)


def test_fit_refuses_ill_conditioned_currents_directly() -> None:
    currents = np.array([[1.0, 1.0, 0], [1.0, 1.001, 0], [0, 0, 1.0], [-1.0, -1.0, 0]])
    with pytest.raises(CalibrationError, match="ill conditioned"):
        fit_actuation_matrix(currents, currents @ TRUE.T)


def test_firmware_ratings_match_the_host() -> None:
    text = HW_RATINGS_H.read_text()

    def define(name: str) -> float:
        m = re.search(rf"#define {name} \(?([0-9.eE+-]+)\)?", text)
        assert m, f"{name} not in {HW_RATINGS_H}"
        return float(m.group(1))

    assert define("HW_MAX_CURRENT_A") == plausibility.HW_MAX_CURRENT_A
    assert define("HW_MAX_SLEW_A_PER_S") == plausibility.HW_MAX_SLEW_A_PER_S
    assert define("HW_MAX_DAC_HALF_SPAN_V") == plausibility.HW_MAX_DAC_HALF_SPAN_V
    assert define("HW_MAX_ABS_OFFSET_V") == plausibility.HW_MAX_ABS_OFFSET_V
    assert define("HW_MIN_TRANSCONDUCTANCE_A_PER_V") == plausibility.HW_MIN_TRANSCONDUCTANCE_A_PER_V
    assert define("HW_MAX_TRANSCONDUCTANCE_A_PER_V") == plausibility.HW_MAX_TRANSCONDUCTANCE_A_PER_V
    assert define("HW_MAX_MATRIX_CONDITION") == plausibility.MAX_MATRIX_CONDITION
    assert define("HW_TICK_HZ") == plausibility.FIRMWARE_TICK_HZ


def test_shipped_calibrations_are_plausible() -> None:
    for path in (DEFAULT_CALIBRATION, YAO2023):
        load_calibration(path)


def test_yao2023_makes_every_shipped_policy_waveform(tmp_path: Path) -> None:
    policies = sorted((REPO / "rl" / "policies").glob("*/fields.csv"))
    assert policies, "no shipped policy waveforms found"
    peak = 0.0
    for csv_path in policies:
        summary = export_firmware(csv_path, YAO2023, tmp_path / csv_path.parent.name)
        assert summary["rows_clipped"] == 0, (csv_path, summary["clipping"])
        peak = max(peak, float(np.max(np.abs(np.loadtxt(csv_path, delimiter=",", skiprows=1)))))
    assert peak >= 9.9  # the 10 mT cases are among them
    # ... which the placeholder calibration cannot make (so the QEMU upload test means something)
    ten = REPO / "rl" / "policies" / "m1-10mT" / "fields.csv"
    with pytest.raises(ValueError, match="cannot follow this waveform"):
        export_firmware(ten, DEFAULT_CALIBRATION, tmp_path / "default")


def test_names_longer_than_the_board_keeps_are_refused(tmp_path: Path) -> None:
    with pytest.raises(CalibrationError, match="name must be 1-31 characters"):
        load_calibration(write_calibration(tmp_path, name="x" * 32))
    load_calibration(write_calibration(tmp_path, name="x" * 31))


def test_the_coil_ranges_are_read_from_the_one_table_of_physical_ranges() -> None:
    """Issue 48: the calibration checks read the coil constant and the coil field from
    elastica_magnetic.plausibility (one home per range), with unchanged values."""
    from elastica_magnetic.plausibility import QUANTITIES

    coil_constant, coil_field = QUANTITIES["coil constant"], QUANTITIES["coil field"]
    assert plausibility.COIL_CONSTANT_RANGE_T_PER_A == (1e-5, 5e-2) == tuple(
        b.value for b in coil_constant.refuse)
    assert plausibility._MATRIX_UNIT_MISTAKES is coil_constant.mistakes
    assert plausibility.MEASURED_FIELD_RANGE_MT == (0.05, 1000.0) == tuple(
        1e3 * b.value for b in coil_field.refuse)


def test_coils_fitted_with_their_channels_swapped_are_named_as_swapped():
    """Round 11, V1: coils measured with the x and y currents swapped (a permutation matrix) were
    refused as a unit mistake ("check the unit: T/A is expected"), naming the output file."""
    from elastica_magnetic.hardware.calibration_fit import fit_actuation_matrix

    matrix = np.array([[0.0, 2e-3, 0.0], [2e-3, 0.0, 0.0], [0.0, 0.0, 2e-3]])
    currents = np.vstack([np.eye(3), -np.eye(3), 0.5 * np.eye(3)])
    with pytest.raises(plausibility.PlausibilityError,
                       match=r"m.csv: coil x \(current_x_A\) makes 2 mT/A along y but 0 mT/A along x, "
                             r"its own axis: the coils' channels or the columns .* are swapped"):
        fit_actuation_matrix(currents, currents @ matrix.T, "m.csv")
    fit = fit_actuation_matrix(currents, currents @ np.diag([2e-3, 2e-3, 2e-3]).T, "m.csv")
    assert np.allclose(fit.matrix_T_per_A, np.diag([2e-3] * 3))


def test_a_swap_is_named_whichever_pair_and_whatever_the_coils_cross_coupling():
    """Round 12, V6: with the coils' own 2.5 % cross-coupling between x and y, swapped x and y
    currents left a diagonal of 0.05 mT/A: only warned, and the calibration written (x and z,
    whose coupling is ~0, were refused). A coupling of a few % with the channels right passes."""
    from elastica_magnetic.hardware.calibration_fit import fit_actuation_matrix

    coupled = np.array([[2e-3, 5e-5, 0.0], [5e-5, 2e-3, 0.0], [0.0, 0.0, 2e-3]])
    swap_xy = coupled[:, [1, 0, 2]]
    currents = np.vstack([np.eye(3), -np.eye(3), 0.5 * np.eye(3)])
    with pytest.raises(plausibility.PlausibilityError,
                       match=r"coil x \(current_x_A\) makes 2 mT/A along y but 0.05 mT/A along x"):
        fit_actuation_matrix(currents, currents @ swap_xy.T, "m.csv")
    fit = fit_actuation_matrix(currents, currents @ coupled.T, "m.csv")
    assert np.allclose(fit.matrix_T_per_A, coupled)
