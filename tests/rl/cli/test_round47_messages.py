"""Round 47 of held-out tries (issue 48): a clock in a language msr has no words for, its unit
named (``Zeit [ms]``, ``tiempo_ms``), is checked by that unit (S1); ``T_coil`` and ``T (°C)`` are no
clocks (V1); a misspelt key the table takes in place of a missing one is named (V2); a value
starting with a negative number (``--target -0.015,0``) is a value (V3); a calibration's current or
field column the fit does not read is refused, other columns named as not read (S2)."""

from __future__ import annotations

import math
import warnings

import pytest

from elastica_magnetic.cli import main
from elastica_magnetic.field_csv import FieldCSVError, read_field_csv


def run(argv: list[str]) -> int:
    """``msr argv``'s exit status (a parser's refusal exits through SystemExit)."""
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code)


def _field_csv(path, header: str, values: list[float]):
    rows = [f"{v:g},{4 * math.cos(0.1 * k):.4f},{4 * math.sin(0.1 * k):.4f},0" for k, v in enumerate(values)]
    path.write_text(f'"{header}",mag_x,mag_y,mag_z\n' + "\n".join(rows) + "\n")
    return path


def _read(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the unread-column warning of the columns that pass
        return read_field_csv(path)


@pytest.mark.parametrize("header, unit, seconds", [("Zeit [ms]", "ms", 0.001), ("tiempo_ms", "ms", 0.001),
                                                   ("Zeit_s", "s", 1.0), ("zeit (us)", "us", 1e-6)])
def test_a_clock_named_by_its_unit_alone_is_checked_by_it(tmp_path, header, unit, seconds):
    """S1: 0, 1, 2 under ``Zeit [ms]`` (a 1 kHz waveform) passed as a count of the rows."""
    refused = rf"rises by 1 {unit} every row \(from line 2\), evenly, as a clock does: {seconds:g} s per row"
    with pytest.raises(FieldCSVError, match=refused):
        _read(_field_csv(tmp_path / "f.csv", header, list(range(6))))
    clock = [0.01 / seconds * k for k in range(6)]  # the rows' own 0.01 s in that unit
    assert _read(_field_csv(tmp_path / "ok.csv", header, clock)).shape == (6, 3)


@pytest.mark.parametrize("header", ["T_coil", "T (°C)", "T [K]", "t_amb"])
def test_a_header_t_with_another_word_or_unit_is_no_clock(tmp_path, header):
    """V1: a coil temperature was refused as a clock "in unknown unit 'coil'"."""
    from elastica_magnetic.clock_columns import clock_scale

    assert clock_scale(header) is None
    assert _read(_field_csv(tmp_path / "f.csv", header, [25.0, 25.4, 25.3, 25.9, 26.0, 26.2])).shape == (6, 3)
    assert clock_scale("t [weeks]") == ("weeks", None) and clock_scale("t_ms") == ("ms", 1e-3)


def test_a_misspelt_key_the_table_takes_instead_is_named(tmp_path, capsys):
    """V2: ``poisson = 0.47`` was refused as "shear_modulus: missing (required)" alone."""
    spec = tmp_path / "s.toml"
    assert run(["case", "show", "m1-4mT", "--toml"]) == 0
    text = capsys.readouterr().out
    spec.write_text("\n".join("poisson = 0.47" if line.startswith("shear_modulus") else line
                              for line in text.splitlines()) + "\n")
    assert run(["case", "check", str(spec), "--no-sag"]) == 2
    err = capsys.readouterr().err
    assert "shear_modulus: missing (required); found poisson: a misspelling of poisson_ratio?" in err, err


def test_a_value_starting_with_a_negative_number_is_a_value():
    """V3: ``--target -0.015,0`` was "expected one argument": argparse took it for an option."""
    from elastica_magnetic.cli.app import build_parser

    parser = build_parser()
    args = parser.parse_args(["field", "baseline", "--case", "m1-4mT-goto", "--target", "-0.015,0",
                              "--duration", "0.5", "--out", "gt"])
    assert args.target == (-0.015, 0.0)
    args = parser.parse_args(["policy", "generate", "m1-4mT-goto", "--target", "-1e-2,-0.005"])
    assert args.target == (-0.01, -0.005)
    with pytest.raises(SystemExit):  # an unknown option is still one
        parser.parse_args(["policy", "generate", "m1-4mT-goto", "--tagret", "0.01,0"])


MEASURED = "1,0,0,{w}3,0,0\n0,1,0,{w}0,3,0\n0,0,1,{w}0,0,2\n1,1,0,{w}3,3,0\n"


@pytest.mark.parametrize("column, said", [
    ("current_w_A", "column 'current_w_A' is a current the fit does not read"),
    ("I_w (A)", "column 'I_w (A)' is a current the fit does not read"),
    ("field_z_uT", "column 'field_z_uT' is a field the fit does not read")])
def test_a_calibration_column_of_a_current_or_field_the_fit_does_not_read_is_refused(tmp_path, capsys, column,
                                                                                     said):
    """S2: a fourth coil's current was dropped without a word, its field absorbed by the others."""
    path = tmp_path / "m.csv"
    path.write_text(f'current_x_A,current_y_A,current_z_A,"{column}",field_x_mT,field_y_mT,field_z_mT\n'
                    + MEASURED.format(w="0.5,"))
    assert run(["real", "calibrate", str(path), "--out", str(tmp_path / "c.json")]) == 2
    assert said in capsys.readouterr().err and not (tmp_path / "c.json").exists()


def test_a_calibration_names_the_other_columns_it_does_not_read(tmp_path, capsys):
    path = tmp_path / "m.csv"
    path.write_text("current_x_A,current_y_A,current_z_A,note,field_x_mT,field_y_mT,field_z_mT\n"
                    + MEASURED.format(w="a,"))
    assert run(["real", "calibrate", str(path), "--out", str(tmp_path / "c.json"), "--json"]) == 0
    import json

    assert "column(s) 'note' not read" in json.loads(capsys.readouterr().out)["warnings"]


def test_times_of_day_stepping_otherwise_are_told_from_their_first_time(tmp_path):
    """V4: "stepping 0.02 s at line 3 (from 36000 to 36000 s)"."""
    rows = [f"{4 * math.cos(0.1 * k):.4f},{4 * math.sin(0.1 * k):.4f},0,10:00:00.{2 * k:02d}0"
            for k in range(6)]
    path = tmp_path / "f.csv"
    path.write_text("mag_x,mag_y,mag_z,Time\n" + "\n".join(rows) + "\n")
    told = r"stepping 0.02 s at line 3 \(from 0 to 0.02 s after its first time\)"
    with pytest.raises(FieldCSVError, match=told):
        _read(path)


def _stale_lock(folder) -> None:
    """The lock file a ``kill -9``-ed msr leaves beside ``folder``: its process is gone."""
    import json
    import subprocess
    import sys

    from elastica_magnetic.locks import host_name, lock_path

    gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                          text=True, check=True)
    owner = {"pid": int(gone.stdout), "host": host_name(), "command": "msr policy ship",
             "started_utc": "2026-12-05T10:00:00Z", "folder": str(folder)}
    lock_path(folder).write_text(json.dumps(owner))


def test_ship_and_notes_say_the_stale_lock_of_a_killed_ship_they_take_over(trained, tmp_path, capsys):
    """Borderline of round 47: the lock file of a killed ``policy ship`` was removed by the next
    ``ship --force`` or ``notes`` without the note every other command gives."""
    run_dir = str(trained / "m1-4mT" / "seed0")
    ship = ["policy", "ship", run_dir, "--name", "p1", "--out", str(tmp_path / "pols"), "--no-measure"]
    assert run(ship) == 0
    folder = tmp_path / "pols" / "p1"
    _stale_lock(folder)
    capsys.readouterr()
    assert run([*ship, "--force"]) == 0
    assert "took over the stale lock of pid" in capsys.readouterr().err
    _stale_lock(folder)
    (tmp_path / "n.md").write_text("Tried on the bench.\n")
    assert run(["policy", "notes", str(folder), "--file", str(tmp_path / "n.md")]) == 0
    assert "took over the stale lock of pid" in capsys.readouterr().err


def test_a_loggers_clock_jittering_about_the_rows_step_passes_and_a_drifting_one_does_not(tmp_path):
    """Borderline of round 47: a 100 Hz logger's ``time_s`` jittering by 10 us was refused as
    "stepping 0.010014 s", advised to resample what is already at 0.01 s."""
    jitter = [0.01 * k + (7e-6 if k % 2 else -7e-6) for k in range(8)]
    assert _read(_field_csv(tmp_path / "j.csv", "time_s", jitter)).shape == (8, 3)
    drift = [0.0102 * k for k in range(8)]  # 98 Hz: every step off the same way
    with pytest.raises(FieldCSVError, match="reads as a clock stepping 0.0102 s at line 3"):
        _read(_field_csv(tmp_path / "d.csv", "time_s", drift))
    gap = [0.01 * k for k in range(4)] + [0.01 * k + 0.005 for k in range(4, 8)]  # one step 0.015 s
    with pytest.raises(FieldCSVError, match="reads as a clock stepping 0.015 s at line 6"):
        _read(_field_csv(tmp_path / "g.csv", "time_s", gap))


def test_a_countdown_falling_evenly_is_checked_as_a_clock(tmp_path):
    with pytest.raises(FieldCSVError, match=r"column 'remaining' falls by 0.02 every row"):
        _read(_field_csv(tmp_path / "f.csv", "remaining", [4.0 - 0.02 * k for k in range(6)]))
    rows_own = [4.0 - 0.01 * k for k in range(6)]
    assert _read(_field_csv(tmp_path / "ok.csv", "remaining", rows_own)).shape == (6, 3)


def test_a_whole_number_written_as_a_float_is_an_integer_option():
    """Borderline of round 47: ``--steps 1e5`` was argparse's "invalid int value"."""
    from elastica_magnetic.cli.app import build_parser

    assert build_parser().parse_args(["train", "--case", "m1-4mT", "--steps", "1e5"]).steps == 100_000
    with pytest.raises(SystemExit):
        build_parser().parse_args(["train", "--case", "m1-4mT", "--steps", "1.5"])


def test_a_comment_line_over_a_field_csv_is_named(tmp_path):
    path = tmp_path / "c.csv"
    path.write_text("# logger v2, rate 50 Hz\nmag_x,mag_y,mag_z\n1,0,0\n")
    with pytest.raises(FieldCSVError, match=r"line 1 is a comment \(it starts with #\): msr reads no"):
        _read(path)


def test_a_key_and_a_table_of_one_name_are_named(tmp_path, capsys):
    """Borderline of round 45: ``randomize = "none"`` in ``[training]`` beside a
    ``[training.randomize]`` table gave TOML's "Cannot overwrite a value" alone."""
    assert run(["case", "show", "m1-4mT", "--toml"]) == 0
    text = capsys.readouterr().out.replace('recipe = "pink-ln"', 'recipe = "pink-ln"\nrandomize = "none"')
    spec = tmp_path / "r.toml"
    spec.write_text(text + "\n[training.randomize]\nmagnetization = 0.1\n")
    assert run(["case", "check", str(spec), "--no-sag"]) == 2
    assert ("opens the table [training.randomize], and [training] already gives randomize a value "
            "(randomize = ...): a key and a table of one name; keep one of them") in capsys.readouterr().err


def test_a_constant_background_field_in_the_measurements_is_said():
    """Borderline of round 45: fields with a constant background (0.3 mT) were fitted without a
    word, the matrix taking part of it for the coils'."""
    import numpy as np

    from elastica_magnetic.hardware.calibration_fit import fit_actuation_matrix

    rng = np.random.default_rng(0)
    currents = rng.uniform(-2.0, 2.0, (12, 3))
    fields = currents @ np.diag([2e-3, 2e-3, 1.5e-3]) + rng.normal(0.0, 1e-5, (12, 3))
    assert not any("constant part" in w for w in fit_actuation_matrix(currents, fields, "m.csv").warnings)
    background = fields + np.array([3e-4, -2e-4, 0.0])
    said = [w for w in fit_actuation_matrix(currents, background, "m.csv").warnings if "constant part" in w]
    assert said and "(0.3" in said[0] and "measure the fields with every current at zero" in said[0], said
