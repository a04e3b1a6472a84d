"""Calibration file, the DAC code model (bit-identical to the firmware), and the matrix fit."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from elastica_magnetic.hardware.calibration import (
    DAC_MIDSCALE,
    Calibration,
    CalibrationError,
    DacCodeModel,
    calibration_from_dict,
    calibration_header,
    expected_dac_codes,
    invert3,
    load_calibration,
    round_half_away,
    save_calibration,
    volts_to_code,
)
from elastica_magnetic.hardware.calibration_fit import fit_actuation_matrix

from .conftest import REPO


def simple_calibration(**changes: object) -> Calibration:
    data = {
        "name": "test",
        "actuation_matrix_T_per_A": [[2e-3, 0, 0], [0, 2e-3, 0], [0, 0, 2e-3]],
        "transconductance_A_per_V": [1.0, 1.0, 1.0],
        "input_offset_V": [0.0, 0.0, 0.0],
        "dac_half_span_V": 2.5,
        "current_limit_A": [2.0, 2.0, 2.0],
        "slew_limit_A_per_s": [1000.0, 1000.0, 1000.0],
        "tick_hz": 100.0,
    }
    data.update(changes)
    return calibration_from_dict(data, "test")


def test_default_file_loads(default_calibration_path: Path) -> None:
    cal = load_calibration(default_calibration_path)
    assert cal.name == "default"
    assert cal.dac_half_span_V == 2.5
    assert DacCodeModel(cal).codes([0.0, 0.0, 0.0]) == (DAC_MIDSCALE,) * 3


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"current_limit_A": [1.0, 0.0, 1.0]}, "current_limit_A[1] must be > 0"),
        ({"actuation_matrix_T_per_A": [[1, 0, 0], [0, 1, 0], [0, 0, 0]]}, "singular"),
        ({"input_offset_V": [0.0, 0.0]}, "input_offset_V: expected a list of 3"),
        ({"dac_half_span_V": "2.5"}, "dac_half_span_V: expected a number"),
        ({"transconductance_A_per_V": [1.0, 0.0, 1.0]}, "nonzero"),
        ({"name": "bad name!"}, "name must be"),
    ],
)
def test_invalid_calibrations_name_the_key(change: dict, message: str) -> None:
    with pytest.raises(CalibrationError, match=message.replace("[", r"\[").replace("]", r"\]")):
        simple_calibration(**change)


def test_missing_key_and_bad_json(tmp_path: Path) -> None:
    bad = tmp_path / "c.json"
    bad.write_text(json.dumps({"name": "x"}))
    with pytest.raises(CalibrationError, match="missing key"):
        load_calibration(bad)
    bad.write_text("{")
    with pytest.raises(CalibrationError, match="not valid JSON"):
        load_calibration(bad)


def test_save_roundtrip(tmp_path: Path) -> None:
    cal = simple_calibration()
    path = save_calibration(tmp_path / "out.json", cal)
    assert load_calibration(path).to_json_dict() == cal.to_json_dict()


def test_hand_computed_codes() -> None:
    model = DacCodeModel(simple_calibration())
    # 1 mT / (2 mT/A) = 0.5 A = 0.5 V; 0.5 / 2.5 * 32767 = 6553.4 -> 6553 (same as the C test)
    assert model.codes([1.0, -1.0, 0.4]) == (32768 + 6553, 32768 - 6553, 32768 + 2621)


def test_rounding_and_clamping() -> None:
    assert round_half_away(2.5) == 3.0
    assert round_half_away(-2.5) == -3.0
    assert round_half_away(-0.49) == 0.0
    assert volts_to_code(1e300, 2.5) == 65535
    assert volts_to_code(-1e300, 2.5) == 0
    assert volts_to_code(float("nan"), 2.5) == DAC_MIDSCALE


def test_current_and_slew_limits() -> None:
    model = DacCodeModel(simple_calibration(current_limit_A=[1.0, 2.0, 2.0],
                                            slew_limit_A_per_s=[1000.0, 1000.0, 10.0]))
    assert model.codes([10.0, 0.0, 0.0])[0] == 32768 + 13107  # limited to 1 A
    z = [model.codes([0.0, 0.0, 1.0])[2] for _ in range(5)]
    assert z == [32768 + 1311, 32768 + 2621, 32768 + 3932, 32768 + 5243, 32768 + 6553]
    model.reset()
    assert model.codes([0.0, 0.0, 1.0])[2] == 32768 + 1311


def test_invert3_matches_numpy() -> None:
    rng = np.random.default_rng(1)
    for _ in range(20):
        m = np.eye(3) * 2e-3 + rng.normal(scale=2e-4, size=(3, 3))
        inv = invert3(m.tolist())
        assert inv is not None
        np.testing.assert_allclose(np.array(inv), np.linalg.inv(m), rtol=1e-12)
    assert invert3([[1, 2, 3], [2, 4, 6], [0, 0, 1]]) is None


def test_fit_recovers_matrix_with_residuals() -> None:
    rng = np.random.default_rng(2)
    true = np.array([[2.0, 0.05, 0.0], [0.04, 2.1, 0.01], [0.0, 0.02, 1.8]]) * 1e-3
    currents = rng.uniform(-2, 2, size=(30, 3))
    noise = rng.normal(scale=1e-6, size=(30, 3))
    fit = fit_actuation_matrix(currents, currents @ true.T + noise)
    np.testing.assert_allclose(fit.matrix_T_per_A, true, atol=2e-6)
    assert fit.rms_residual_T.shape == (3,)
    assert 0 < fit.max_abs_residual_T < 5e-6


def test_fit_rejects_degenerate_measurements() -> None:
    currents = np.array([[1.0, 0, 0], [2.0, 0, 0], [3.0, 0, 0], [4.0, 0, 0]])
    with pytest.raises(CalibrationError, match="independent"):
        fit_actuation_matrix(currents, currents * 1e-3)
    with pytest.raises(CalibrationError, match="at least 3"):
        fit_actuation_matrix(np.eye(3)[:2], np.eye(3)[:2])


DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include "calibration.h"
#include "calibration_gen.h"
int main(void) {
    static const calib_params_t p = MSR_CALIBRATION_PARAMS;
    calib_t c;
    if (calib_init(&c, &p) != CALIB_OK) return 3;
    double m[3];
    while (scanf("%lf %lf %lf", &m[0], &m[1], &m[2]) == 3) {
        uint16_t codes[3];
        calib_field_to_codes(&c, m, codes, NULL);
        printf("%u %u %u\n", codes[0], codes[1], codes[2]);
    }
    return 0;
}
"""


def test_python_model_identical_to_firmware_c(tmp_path: Path) -> None:
    """Compile the firmware's calibration.c with the generated header and compare every code."""
    gcc = shutil.which("gcc")
    assert gcc is not None, "gcc missing: bash stm32/ci.sh installs it"
    cal = simple_calibration(
        actuation_matrix_T_per_A=[[2e-3, 1e-4, -3e-5], [5e-5, 2.1e-3, 2e-5], [1e-5, -4e-5, 1.7e-3]],
        input_offset_V=[0.003, -0.002, 0.0],
        transconductance_A_per_V=[0.9, 1.1, 1.0],
        current_limit_A=[1.5, 2.0, 2.4],
        slew_limit_A_per_s=[30.0, 80.0, 50.0],
    )
    (tmp_path / "calibration_gen.h").write_text(calibration_header(cal))
    (tmp_path / "driver.c").write_text(DRIVER)
    src = REPO / "stm32" / "src" / "app"
    exe = tmp_path / "driver"
    subprocess.run([gcc, "-std=c11", "-O2", "-ffp-contract=off", "-I", str(src), "-I",
                    str(tmp_path), str(tmp_path / "driver.c"), str(src / "calibration.c"),
                    "-o", str(exe)], check=True, timeout=60)
    rng = np.random.default_rng(3)
    rows = np.concatenate([rng.uniform(-5, 5, size=(2000, 3)),
                           np.cumsum(rng.normal(scale=0.3, size=(2000, 3)), axis=0)])
    text = "\n".join(" ".join(repr(v) for v in r) for r in rows.tolist()) + "\n"
    out = subprocess.run([str(exe)], input=text, capture_output=True, text=True, check=True,
                         timeout=60).stdout
    c_codes = np.array([[int(v) for v in line.split()] for line in out.splitlines()])
    py_codes = expected_dac_codes(cal, rows)
    assert c_codes.shape == py_codes.shape
    np.testing.assert_array_equal(c_codes, py_codes)
