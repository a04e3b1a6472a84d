"""Round 48 of held-out tries (issue 48): an option given twice with different values is said
(S1); a word starting with a minus and a digit reaches its option's reader (V1); a whole number
written as a float is read by every integer option (V2); a calibration header's spaces are not
part of its names (V3); a clock running backwards is named as such (V4). The D1 (a finished design
continued and killed) is tested in tests/rl/design/test_design_run.py."""

from __future__ import annotations

import math
import warnings

import pytest

from elastica_magnetic.cli import main
from elastica_magnetic.cli.app import build_parser
from elastica_magnetic.field_csv import FieldCSVError, read_field_csv


def run(argv: list[str]) -> int:
    """``msr argv``'s exit status (a parser's refusal exits through SystemExit)."""
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code)


@pytest.mark.parametrize("argv, dest, said, used", [
    (["field", "simulate", "--duration", "0.1", "--duration", "0.2"], "duration",
     "msr field simulate: note: --duration given twice (0.1, then 0.2): the last, 0.2, is used", 0.2),
    (["policy", "notes", "m1-4mT", "--file", "a.md", "--notes", "b.md"], "file",
     "msr policy notes: note: --file and --notes given twice ('a.md', then 'b.md'): the last, 'b.md', is "
     "used", "b.md")])
def test_an_option_given_twice_with_different_values_is_said(argv, dest, said, used, capsys):
    """S1: argparse kept the last value without a word (another robot simulated, other notes).
    The last is still used (a script's defaults overridden after them), and said."""
    assert str(getattr(build_parser().parse_args(argv), dest)) == str(used)
    assert said in capsys.readouterr().err


@pytest.mark.parametrize("argv, said", [
    (["field", "simulate", "--frequency", "-1Hz"], "argument --frequency: expected a finite number of Hz"),
    (["field", "simulate", "--amplitude", "-4mT"], "argument --amplitude: expected a finite number of T"),
    (["field", "baseline", "--case", "m1-4mT-goto", "--target", "-15mm,0"],
     "got '-15mm,0': numbers alone, in m (-15mm is -0.015)")])
def test_a_negative_value_with_a_unit_reaches_its_options_reader(argv, said, capsys):
    """V1: these were "expected one argument": argparse took them for options."""
    assert run([*argv, "--out", "x"]) == 2
    assert said in capsys.readouterr().err


@pytest.mark.parametrize("argv, dest, value", [
    (["design", "m1-4mT", "--out", "d", "--generations", "1e0"], "generations", 1),
    (["bench", "--train-seeds", "1e0"], "train_seeds", 1),
    (["field", "baseline", "--case", "m1-4mT-goto", "--ring", "12.0"], "ring", 12),
    (["field", "baseline", "--case", "m1-4mT-goto", "--ring", "1.2e1"], "ring", 12)])
def test_every_integer_option_reads_a_whole_number_written_as_a_float(argv, dest, value):
    """V2: round 47's reading reached only options of type int; ``--ring 12.0`` was refused as
    "expected a number of targets (1 to 72), got '12.0'"."""
    assert getattr(build_parser().parse_args(argv), dest) == value


def test_a_fraction_is_still_no_integer(capsys):
    assert run(["field", "baseline", "--case", "m1-4mT-goto", "--ring", "12.5", "--out", "x"]) == 2
    assert "expected a number of targets (1 to 72), got '12.5'" in capsys.readouterr().err


MEASURED = "1,0,0,3,0,0\n0,1,0,0,3,0\n0,0,1,0,0,2\n1,1,0,3,3,0\n"


def test_spaces_around_a_calibrations_column_names_are_not_part_of_them(tmp_path, capsys):
    """V3: "missing column(s) field_z_mT ... (found ..., field_z_mT)" for ``field_z_mT ``."""
    path = tmp_path / "m.csv"
    path.write_text("current_x_A,current_y_A ,current_z_A,field_x_mT,field_y_mT,field_z_mT \n" + MEASURED)
    assert run(["real", "calibrate", str(path), "--out", str(tmp_path / "c.json")]) == 0
    assert (tmp_path / "c.json").is_file()


def test_a_calibrations_bad_value_and_comment_line_are_named(tmp_path, capsys):
    """Borderline of round 48: a NaN named its line but not its column; a comment line was read as
    the header without a word."""
    path = tmp_path / "m.csv"
    path.write_text("current_x_A,current_y_A,current_z_A,field_x_mT,field_y_mT,field_z_mT\n"
                    + MEASURED.replace("0,3,0\n", "0,x,0\n", 1))
    assert run(["real", "calibrate", str(path), "--out", str(tmp_path / "c.json")]) == 2
    assert "line 3: column field_y_mT: missing or non-numeric value 'x' (the row: 0, 1, 0, 0, x, 0)" in \
        capsys.readouterr().err
    path.write_text("# probe run 3\ncurrent_x_A,current_y_A,current_z_A,field_x_mT,field_y_mT,field_z_mT\n"
                    + MEASURED)
    assert run(["real", "calibrate", str(path), "--out", str(tmp_path / "c.json")]) == 2
    assert "line 1 is a comment (it starts with #): msr reads no comment lines" in capsys.readouterr().err


def test_a_clock_running_backwards_is_named(tmp_path):
    """V4: a ``t_s`` falling by 0.01 s a row was advised to "resample to 0.01 s steps"; its rows
    run backwards in time."""
    rows = [f"{0.59 - 0.01 * k:.2f},{4 * math.cos(0.1 * k):.4f},{4 * math.sin(0.1 * k):.4f},0"
            for k in range(6)]
    path = tmp_path / "f.csv"
    path.write_text("t_s,mag_x,mag_y,mag_z\n" + "\n".join(rows) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        told = (r"column 't_s' reads as a clock whose times fall every row \(from 0.59 s at line 2 to "
                r"0.54 s at line 7\): the rows run backwards in time")
        with pytest.raises(FieldCSVError, match=told):
            read_field_csv(path)
