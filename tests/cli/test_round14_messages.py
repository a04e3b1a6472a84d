"""Messages of a fourteenth round of held-out tries (issue 48): a milli-unit slip in ``--ramp`` and
``--timeout`` is named; an interruption names the user's output, never msr's own temporary
folder; a coil swap is said in one unit. Each test fails without its fix."""

from __future__ import annotations

import pytest

from elastica_magnetic.cli import interrupted_message, main
from elastica_magnetic.interrupts import Interrupted


def run(argv: list[str]) -> int:
    """``msr argv``'s exit status (a parser's refusal exits through SystemExit)."""
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code)


# -- V8: milli-unit slips --------------------------------------------------------------------------


def test_a_ramp_in_milliseconds_names_the_slip(tmp_path, capsys):
    assert run(["field", "simulate", "--ramp", "200", "--duration", "1", "--out", str(tmp_path / "x1")]) == 2
    err = capsys.readouterr().err
    assert ("--ramp 200 s is longer than --duration 1 s: the field would never reach its amplitude "
            "(ms written where s is expected? 200 ms is 0.2 s: give --ramp 0.2)") in err
    assert "Traceback" not in err and not (tmp_path / "x1").exists()


def test_a_ramp_a_little_longer_than_the_run_gets_no_made_up_hint(tmp_path, capsys):
    assert run(["field", "simulate", "--ramp", "2", "--duration", "1", "--out", str(tmp_path / "x1")]) == 2
    err = capsys.readouterr().err
    assert "--ramp 2 s is longer than --duration 1 s" in err and "written where" not in err
    assert "give a --ramp of at most 1 s, or a longer --duration" in err


def test_a_stream_timeout_in_milliseconds_is_refused_naming_the_slip(tmp_path, capsys):
    """``msr real stream ... --timeout 5000`` waited up to 83 minutes for a board that does not
    answer; an hour is the most, and 5000 is named as 5000 ms."""
    field = tmp_path / "f.csv"
    field.write_text("mag_x,mag_y,mag_z\n0,1,0\n")
    assert run(["real", "stream", str(field), "--port", "socket://127.0.0.1:9", "--timeout", "5000"]) == 2
    err = capsys.readouterr().err
    assert "--timeout: expected a finite number of s in (0, 3600], got '5000'" in err
    assert "(ms written where s is expected? 5000 ms is 5 s)" in err


# -- V7: an interruption names the user's output, not msr's temporaries -----------------------------


def test_the_interrupted_line_never_names_msrs_own_temporary_folder():
    """Round 14 V7: SIGTERM during ``msr field baseline`` (whose best run is written into the
    sweep's own temporary result folder) said ``.bp4.msr-new-vm-7834-eea928 was left as it was``:
    false (it was removed) and not the user's folder."""
    line = interrupted_message("field baseline", Interrupted(15),
                               [".bp4.msr-new-vm-7834-eea928", "bp4", "out/.bp4.msr-new-vm-7834-eea928/x"])
    assert line == ("msr field baseline: interrupted (SIGTERM); bp4 was left as it was (a result folder "
                    "is replaced whole or not at all)")
    # a folder of the user's that only looks alike is still named
    assert ".bp4.msr-new-backup was left" in interrupted_message("x", KeyboardInterrupt(),
                                                                  [".bp4.msr-new-backup"])


def test_a_result_written_inside_another_is_not_listed_as_left_as_it_was(tmp_path, monkeypatch):
    """The sweep's case: a result folder (the best run's) written into the temporary folder of
    another (the sweep's); an interruption inside lists the outer folder only."""
    from elastica_magnetic.results import aborted_results, result_folder

    monkeypatch.chdir(tmp_path)
    before = len(aborted_results())
    with pytest.raises(KeyboardInterrupt):
        with result_folder("bp4", kind="baseline") as outer:
            with result_folder(outer.path, kind="baseline"):
                raise Interrupted(15)
    kept = aborted_results()[before:]
    assert [str(folder) for folder in kept] == ["bp4"], kept
    assert ".msr-new" not in interrupted_message("field baseline", Interrupted(15), kept)
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # nothing left behind


# -- V9: a coil swap said in one unit --------------------------------------------------------------


def test_a_calibration_with_swapped_current_columns_names_both_fields_in_mT_per_A(tmp_path, capsys):
    """Round 14 V9: ``coil y (current_y_A) makes 2 mT/A along z but 2e-05 T/A along y``: two
    units for one comparison."""
    measurements = tmp_path / "m_swapyz.csv"
    measurements.write_text("current_x_A,current_y_A,current_z_A,field_x_mT,field_y_mT,field_z_mT\n"
                            "1,0,0,2,0,0\n0,1,0,0,0.02,2\n0,0,1,0,2,0\n1,1,1,2,2.02,2\n")
    assert run(["real", "calibrate", str(measurements), "--out", str(tmp_path / "c_sw.json")]) == 2
    err = capsys.readouterr().err
    assert "coil y (current_y_A) makes 2 mT/A along z but 0.02 mT/A along y, its own axis" in err, err
    assert " T/A along" not in err and not (tmp_path / "c_sw.json").exists()
