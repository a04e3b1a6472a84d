"""Issue 48, second round of tries: a calibration JSON with an unknown (misspelt) key is refused by
name, a fit that explains nothing is refused before anything is written, a doubtful fit is warned
about, and the fit's refusals name the measurements file and its columns."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from elastica_magnetic.cli import main
from elastica_magnetic.hardware.calibration import (
    CalibrationError,
    calibration_from_dict,
    load_calibration,
    save_calibration,
)
from elastica_magnetic.hardware.calibration_fit import fit_actuation_matrix

from .conftest import PUBLISHED_CSV, REPO

SHIPPED = sorted((REPO / "stm32" / "calibration").glob("*.json"))
YAO2023 = REPO / "stm32" / "calibration" / "yao2023.json"
HEADER = "current_x_A,current_y_A,current_z_A,field_x_mT,field_y_mT,field_z_mT"
COLUMNS = "current_x_A, current_y_A, current_z_A"
#: Coil constants (T/A), 2 mT/A with a little cross-coupling.
TRUE = np.array([[2e-3, 5e-5, 0.0], [4e-5, 2e-3, 0.0], [0.0, 2e-5, 1.8e-3]])


def write_measurements(path: Path, currents: np.ndarray, fields_mT: np.ndarray) -> Path:
    np.savetxt(path, np.hstack([currents, fields_mT]), delimiter=",", header=HEADER, comments="")
    return path


def random_currents(rows: int = 12, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-3.0, 3.0, size=(rows, 3))


# -- unknown keys in a calibration JSON (cj_unknown) ---------------------------------------------


def test_export_firmware_refuses_a_misspelt_calibration_key(tmp_path: Path, capsys) -> None:
    data = json.loads(YAO2023.read_text())
    data["transconductance_A_per_mV"] = [4000.0, 3000.0, 1500.0]  # the tester's file: extra key
    calibration = tmp_path / "cal.json"
    calibration.write_text(json.dumps(data))
    out = tmp_path / "fw"
    assert main(["real", "firmware", str(PUBLISHED_CSV), "--calibration", str(calibration),
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"msr real firmware: error: {calibration}: transconductance_A_per_mV: "
                          "unknown key; did you mean transconductance_A_per_V? (a calibration "
                          "takes: name, "), err
    assert "description" in err and "estimates" in err
    assert not out.exists()


def test_a_misspelt_key_is_named_before_the_key_it_leaves_missing() -> None:
    data = json.loads(YAO2023.read_text())
    data["slew_limit_A_per_S"] = data.pop("slew_limit_A_per_s")
    with pytest.raises(CalibrationError, match=r"^cal.json: slew_limit_A_per_S: unknown key; did "
                       r"you mean slew_limit_A_per_s\?"):
        calibration_from_dict(data, "cal.json")


def test_an_unknown_key_without_a_close_match_lists_the_keys() -> None:
    data = json.loads(YAO2023.read_text())
    data["operator"] = "me"
    with pytest.raises(CalibrationError, match=r"^cal.json: operator: unknown key \(a calibration "
                       r"takes: name, actuation_matrix_T_per_A, "):
        calibration_from_dict(data, "cal.json")


@pytest.mark.parametrize("path", SHIPPED, ids=[p.name for p in SHIPPED])
def test_every_shipped_calibration_loads_and_keeps_its_notes(path: Path, tmp_path: Path) -> None:
    data = json.loads(path.read_text())
    cal = load_calibration(path)
    again = load_calibration(save_calibration(tmp_path / path.name, cal))
    assert again.to_json_dict() == cal.to_json_dict()
    assert again.to_json_dict().keys() == data.keys() | {"tick_hz", "description"}


def test_a_calibration_fitted_on_a_base_with_notes_loads(tmp_path: Path) -> None:
    currents = np.vstack([np.eye(3) * a for a in (-2.0, -1.0, 1.0, 2.0)])
    meas = write_measurements(tmp_path / "m.csv", currents, currents @ TRUE.T * 1e3)
    out = tmp_path / "cal.json"
    assert main(["real", "calibrate", str(meas), "--base", str(YAO2023), "--out", str(out)]) == 0
    assert load_calibration(out).name == "measured"


# -- fits that explain nothing (mc_inconsistent) ---------------------------------------------------


def test_calibrate_refuses_fields_whose_signs_flip_every_other_row(tmp_path: Path, capsys) -> None:
    currents = random_currents()
    fields_mT = currents @ TRUE.T * 1e3
    fields_mT[1::2] *= -1.0  # the tester's file: every other row's field signs flipped
    meas = write_measurements(tmp_path / "m.csv", currents, fields_mT)
    out = tmp_path / "cal.json"
    assert main(["real", "calibrate", str(meas), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"msr real calibrate: error: {meas}: the fitted matrix explains nothing: the "
                          "residuals are more than 50% of the measured fields (field_x_mT: "
                          "residual RMS "), err
    assert "signs flipped" in err and "columns swapped" in err and "different setups" in err
    assert not out.exists()


def test_a_noisy_but_consistent_fit_is_not_refused() -> None:
    currents = random_currents(seed=1)
    noise = np.random.default_rng(2).normal(0.0, 0.5e-3, (12, 3))  # 0.5 mT on ~3.5 mT fields
    fit = fit_actuation_matrix(currents, currents @ TRUE.T + noise, "m.csv")
    assert np.all(fit.rms_residual_T < 0.5 * np.sqrt(np.mean((currents @ TRUE.T) ** 2, axis=0)))


def test_a_negative_diagonal_is_warned_about() -> None:
    backwards = TRUE.copy()
    backwards[1, 1] *= -1.0  # coil y wired backwards
    currents = random_currents()
    fit = fit_actuation_matrix(currents, currents @ backwards.T, "m.csv")
    assert fit.warnings == [
        "m.csv: actuation_matrix_T_per_A[1][1] = -2 mT/A is negative: coil y makes field_y_mT "
        "against current_y_A: a coil wired backwards, or a current or probe sign convention "
        "opposite to the other axes; check the wiring if this is not meant"]


def test_standard_errors_large_against_a_coil_constant_are_warned_about(tmp_path: Path,
                                                                        capsys) -> None:
    currents = np.vstack([np.eye(3) * a for a in (-2.0, -1.0, 1.0, 2.0)])
    noise_mT = np.random.default_rng(4).normal(0.0, 0.8, (12, 3))
    fields_mT = currents @ TRUE.T * 1e3 + noise_mT
    meas = write_measurements(tmp_path / "m.csv", currents, fields_mT)
    assert main(["real", "calibrate", str(meas), "--out", str(tmp_path / "cal.json"), "--json"]) == 0
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    se = np.array(summary["std_error_mT_per_A"])
    assert se.max() > 0.1 * 1.8  # the premise: above 10 % of the weakest coil's 1.8 mT/A
    assert len(summary["warnings"]) == 1
    assert summary["warnings"][0].startswith(f"{meas}: the standard error of actuation_matrix_T_per_A[")
    assert "the matrix is poorly determined" in summary["warnings"][0]
    assert f"msr real calibrate: warning: {meas}: the standard error" in captured.err


def test_a_good_fit_has_no_warning() -> None:
    currents = random_currents(seed=3)
    noise = np.random.default_rng(5).normal(0.0, 1e-6, (12, 3))
    assert fit_actuation_matrix(currents, currents @ TRUE.T + noise, "m.csv").warnings == []


# -- the fit's refusals name the file and its columns (mc_two, mc_collinear, mc_dup) -------------


def _refusal(tmp_path: Path, capsys, currents: np.ndarray) -> tuple[Path, str]:
    meas = write_measurements(tmp_path / "m.csv", currents, currents @ TRUE.T * 1e3)
    assert main(["real", "calibrate", str(meas), "--out", str(tmp_path / "cal.json")]) == 2
    assert not (tmp_path / "cal.json").exists()
    return meas, capsys.readouterr().err.strip()


def test_two_measurements_name_the_file(tmp_path: Path, capsys) -> None:
    meas, err = _refusal(tmp_path, capsys, random_currents(rows=2))
    assert err.startswith(f"msr real calibrate: error: {meas}: need at least 3 measurements (rows of "
                          f"{COLUMNS} and the fields they made), got 2"), err


def test_currents_along_one_direction_name_the_file_and_columns(tmp_path: Path, capsys) -> None:
    currents = np.zeros((12, 3))
    currents[:, 0] = random_currents()[:, 0]
    meas, err = _refusal(tmp_path, capsys, currents)
    assert err.startswith(f"msr real calibrate: error: {meas}: the currents ({COLUMNS}) of the 12 rows "
                          "(12 different settings) excite only 1 independent direction(s); drive "
                          "each coil on its own"), err


def test_identical_rows_are_said_to_be_identical(tmp_path: Path, capsys) -> None:
    currents = np.tile([[0.5, -1.25, 2.0]], (12, 1))
    meas, err = _refusal(tmp_path, capsys, currents)
    assert err == (f"msr real calibrate: error: {meas}: 12 rows, all the same currents ({COLUMNS} = "
                   "0.5, -1.25, 2 A): one setting cannot tell the three coils apart; drive each "
                   "coil on its own, at positive and negative currents")


def test_a_key_given_twice_is_refused(tmp_path):
    """A third round of tries: current_limit_A twice, the second silently won."""
    import json as _json

    from elastica_magnetic.hardware.calibration import (
        CalibrationError,
        default_calibration_path,
        load_calibration,
    )

    text = default_calibration_path().read_text()
    data = _json.loads(text)
    twice = text.rstrip().rstrip("}").rstrip() + ',\n  "current_limit_A": ' + \
        _json.dumps(data["current_limit_A"]) + "\n}\n"
    path = tmp_path / "twice.json"
    path.write_text(twice)
    with pytest.raises(CalibrationError, match="twice.json: current_limit_A: given twice"):
        load_calibration(path)


def test_a_bad_name_is_blamed_on_the_name_option_before_the_fit(tmp_path: Path, capsys) -> None:
    out = tmp_path / "cal.json"
    with pytest.raises(SystemExit) as info:  # an argparse refusal: before the measurements are read
        main(["real", "calibrate", str(tmp_path / "not-read.csv"), "--out", str(out), "--name", "my cal"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "argument --name: 'my cal': a calibration name must be 1-31 characters" in err, err
    assert not out.exists()


def test_an_upload_to_a_closed_port_says_the_calibration_was_written(tmp_path: Path, capsys) -> None:
    import socket

    with socket.socket() as probe:  # a port nothing listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    currents = random_currents()
    meas = write_measurements(tmp_path / "m.csv", currents, currents @ TRUE.T / 1e-3)
    out = tmp_path / "cal.json"
    assert main(["real", "calibrate", str(meas), "--out", str(out), "--upload",
                 f"socket://127.0.0.1:{port}"]) == 2
    err = capsys.readouterr().err
    assert "nothing was sent; the calibration was written to" in err and str(out.name) in err, err
    assert load_calibration(out).name == "measured"


def test_swapped_field_columns_are_refused(tmp_path: Path, capsys) -> None:
    """Each coil "making" the other axis' field fits perfectly and passed without a word (round 4,
    S3); then it was warned where the coils' cross-coupling left a diagonal in range and refused
    where it did not (round 12, V6): now refused whichever pair, nothing written."""
    currents = random_currents()
    fields_mT = currents @ TRUE.T / 1e-3
    meas = tmp_path / "m.csv"
    write_measurements(meas, currents, fields_mT[:, [1, 0, 2]])  # field_x and field_y swapped
    assert main(["real", "calibrate", str(meas), "--out", str(tmp_path / "cal.json")]) == 2
    err = capsys.readouterr().err
    assert "coil x (current_x_A) makes" in err and "along y" in err and "swapped" in err, err
    assert not (tmp_path / "cal.json").exists()


def test_a_column_named_twice_is_refused(tmp_path: Path, capsys) -> None:
    currents = random_currents()
    meas = write_measurements(tmp_path / "m.csv", currents, currents @ TRUE.T / 1e-3)
    lines = meas.read_text().splitlines()
    meas.write_text("\n".join([lines[0] + ",field_x_mT"] + [line + ",0" for line in lines[1:]]) + "\n")
    assert main(["real", "calibrate", str(meas), "--out", str(tmp_path / "cal.json")]) == 2
    assert "header on line 1 names field_x_mT twice (columns 4 and 7)" in capsys.readouterr().err
    assert not (tmp_path / "cal.json").exists()


def test_every_reader_of_a_calibration_warns_about_a_negative_diagonal(tmp_path: Path, capsys) -> None:
    """Only ``msr real calibrate`` warned; a hand-edited sign went through export-firmware (round 4, S4)."""
    data = json.loads((REPO / "stm32" / "calibration" / "default.json").read_text())
    data["actuation_matrix_T_per_A"][0][0] *= -1
    cal = tmp_path / "cal.json"
    cal.write_text(json.dumps(data))
    assert main(["real", "firmware", str(PUBLISHED_CSV), "--calibration", str(cal), "--out",
                 str(tmp_path / "fw")]) == 0
    assert "warning: " in (err := capsys.readouterr().err) and "[0][0]" in err and "is negative" in err
