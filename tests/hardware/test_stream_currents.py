"""Coil currents played by the board (``msr real stream coil_currents.csv``, ``STREAM CURRENTS``):
the host's twin of ``calib_currents_to_codes`` against the C code, ``stream_currents`` against a
simulated board, and the command's refusals before anything is sent."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from recorded_files import write_coil_currents

from elastica_magnetic.hardware.calibration import (
    DAC_MIDSCALE,
    DacCodeModel,
    calibration_header,
    expected_current_codes,
    load_calibration,
)
from elastica_magnetic.hardware.coil_currents import CoilCurrentsError, read_coil_currents
from elastica_magnetic.hardware.protocol import wire_rows, wire_values
from elastica_magnetic.hardware.stream import StreamError, stream_currents

from .conftest import REPO
from .test_calibration import simple_calibration
from .test_stream import FakeBoard, SilentPort

CURRENTS_DRIVER = r"""
#include <stdio.h>
#include "calibration.h"
#include "calibration_gen.h"
int main(void) {
    static const calib_params_t p = MSR_CALIBRATION_PARAMS;
    calib_t c;
    if (calib_init(&c, &p) != CALIB_OK) return 3;
    double amps[3];
    while (scanf("%lf %lf %lf", &amps[0], &amps[1], &amps[2]) == 3) {
        uint16_t codes[3];
        calib_currents_to_codes(&c, amps, codes, NULL);
        printf("%u %u %u\n", codes[0], codes[1], codes[2]);
    }
    return 0;
}
"""


def test_the_current_model_is_the_firmware_s_c_code(tmp_path: Path) -> None:
    """``DacCodeModel.currents_to_codes`` and ``calib_currents_to_codes`` give the same code on 4003
    rows: within and beyond the current limits, slewing, on the DAC's span and past it, non-finite."""
    gcc = shutil.which("gcc")
    assert gcc is not None, "gcc missing: bash stm32/ci.sh installs it"
    cal = simple_calibration(
        actuation_matrix_T_per_A=[[2e-3, 1e-4, -3e-5], [5e-5, 2.1e-3, 2e-5], [1e-5, -4e-5, 1.7e-3]],
        input_offset_V=[0.003, -0.002, 0.0],
        transconductance_A_per_V=[0.9, 1.1, 0.7],
        current_limit_A=[1.5, 2.0, 2.4],
        slew_limit_A_per_s=[30.0, 80.0, 50.0],
    )
    (tmp_path / "calibration_gen.h").write_text(calibration_header(cal))
    (tmp_path / "driver.c").write_text(CURRENTS_DRIVER)
    src = REPO / "stm32" / "src" / "app"
    exe = tmp_path / "driver"
    subprocess.run([gcc, "-std=c11", "-O2", "-ffp-contract=off", "-I", str(src), "-I", str(tmp_path),
                    str(tmp_path / "driver.c"), str(src / "calibration.c"), "-o", str(exe)],
                   check=True, timeout=60)
    rng = np.random.default_rng(5)
    rows = np.concatenate([rng.uniform(-3, 3, size=(2000, 3)),
                           np.cumsum(rng.normal(scale=0.2, size=(2000, 3)), axis=0),
                           [[np.nan, 0.1, 0.2], [0.1, np.inf, 0.2], [0.3, 0.2, -np.inf]]])
    text = "\n".join(" ".join(repr(v) for v in r) for r in rows.tolist()) + "\n"
    out = subprocess.run([str(exe)], input=text, capture_output=True, text=True, check=True,
                         timeout=60).stdout
    c_codes = np.array([[int(v) for v in line.split()] for line in out.splitlines()])
    py_codes = expected_current_codes(cal, rows)
    assert c_codes.shape == py_codes.shape == (4003, 3)
    np.testing.assert_array_equal(c_codes, py_codes)
    assert (py_codes[-3:] == DAC_MIDSCALE).all()


def test_current_codes_by_hand() -> None:
    """I / g + offset in the DAC's 2.5 V half span, the current limit, the slew limit from 0 A, and
    a non-finite current at mid-scale leaving the slew where it was (the C tests' numbers)."""
    model = DacCodeModel(simple_calibration(input_offset_V=[0.01, 0.0, 0.0],
                                            transconductance_A_per_V=[1.0, 2.0, 1.0]))
    assert model.currents_to_codes([0.5, -0.5, 0.2]) == (32768 + 6684, 32768 - 3277, 32768 + 2621)
    limited = DacCodeModel(simple_calibration(current_limit_A=[1.0, 2.0, 2.0]))
    assert limited.currents_to_codes([5.0, 0.0, 0.0])[0] == 32768 + 13107
    slewed = DacCodeModel(simple_calibration(slew_limit_A_per_s=[1000.0, 1000.0, 10.0]))
    assert [slewed.currents_to_codes([0, 0, 0.5])[2] for _ in range(5)] == \
        [32768 + 1311, 32768 + 2621, 32768 + 3932, 32768 + 5243, 32768 + 6553]
    assert slewed.currents_to_codes([0, float("nan"), 0]) == (DAC_MIDSCALE,) * 3
    assert slewed.currents_to_codes([0, 0, 0])[2] == 32768 + 5243  # from 0.5 A, one step down


class CurrentsBoard(FakeBoard):
    """The simulated board, knowing ``STREAM CURRENTS`` (``answer`` replaces its answer)."""

    def __init__(self, calibration_path: Path, answer: str | None = None) -> None:
        super().__init__(calibration_path)
        self.currents = False
        self.answer = answer

    def _line(self, line: str) -> None:
        if line in ("STREAM", "STREAM CURRENTS"):
            self.commands.append(line)
            self.currents = line == "STREAM CURRENTS"
            self.streaming = True
            self.model.reset()
            self._send(self.answer or ("OK STREAM queue=256 prefill=64"
                                       + (" mode=currents" if self.currents else "")))
            self.credit = 256
            self._send("CREDIT 256")
        else:
            super()._line(line)

    def _tick(self) -> None:
        """The simulated board's tick, its rows converted as currents in a currents session."""
        if not self.currents:
            super()._tick()
            return
        model = self.model
        self.model = _AsCurrents(model)  # type: ignore[assignment]
        try:
            super()._tick()
        finally:
            self.model = model


class _AsCurrents:
    """A :class:`DacCodeModel` whose ``codes`` of a row are those of currents (A)."""

    def __init__(self, model: DacCodeModel) -> None:
        self.model = model

    def codes(self, row: list[float]) -> tuple[int, int, int]:
        return self.model.currents_to_codes(row)


def test_stream_currents_plays_amperes_bit_exactly(default_calibration_path: Path) -> None:
    board = CurrentsBoard(default_calibration_path)
    t = np.arange(300) / 100.0
    currents = np.stack([np.sin(t), 0.5 * np.cos(2 * t)], axis=1)  # two coils: output 2 at 0 A
    result = stream_currents("fake://", currents, progress=False, timeout_s=30,
                             open_port=lambda *a, **k: board)
    assert "STREAM CURRENTS" in board.commands
    assert result.safe is not None and result.safe.reason == "end" and result.ended_safe
    assert result.summary()["mode"] == "currents" and result.rows_applied == 300
    rows = np.column_stack([currents, np.zeros(300)])
    expected = expected_current_codes(load_calibration(default_calibration_path),
                                      wire_values(wire_rows(rows)))
    np.testing.assert_array_equal(result.codes_array(), expected)
    assert (expected[:, 2] == DAC_MIDSCALE).all()
    with pytest.raises(ValueError, match=r"k <= 3 \(the board's outputs\)"):
        stream_currents("fake://", np.zeros((3, 4)), progress=False)


@pytest.mark.parametrize(("answer", "message"), [
    ("ERR unknown-command line=3", r"the board does not know STREAM CURRENTS \(ERR unknown-command "
                                   r"line=3\): its firmware plays field rows only"),
    ("OK STREAM queue=256 prefill=64", r"answered STREAM CURRENTS with 'OK STREAM queue=256 prefill=64', "
                                       r"a field session, not currents; nothing was played"),
])
def test_a_board_without_current_streaming_is_named_and_stopped(default_calibration_path: Path,
                                                                answer: str, message: str) -> None:
    """An older firmware (``ERR unknown-command``) or one that answers with a field session would
    play amperes as millitesla: refused before any row is sent, and STOP sent."""
    board = CurrentsBoard(default_calibration_path, answer=answer)
    sent: list[bytes] = []
    write = board.write
    board.write = lambda data: (sent.append(data), write(data))[1]  # type: ignore[method-assign]
    with pytest.raises(StreamError, match=message):
        stream_currents("fake://", np.full((5, 3), 0.1), progress=False, timeout_s=10,
                        open_port=lambda *a, **k: board)
    assert not any(chunk[:1].isdigit() for chunk in sent), "rows were sent"
    assert sent[-1] == b"\nSTOP\n"


def test_a_field_stream_accepts_the_old_answer_and_says_field(default_calibration_path: Path) -> None:
    from elastica_magnetic.hardware.stream import stream_field

    board = CurrentsBoard(default_calibration_path)
    result = stream_field("fake://", np.full((5, 3), 1e-3), progress=False, timeout_s=10,
                          open_port=lambda *a, **k: board)
    assert "STREAM" in board.commands and "STREAM CURRENTS" not in board.commands
    assert result.summary()["mode"] == "field"
    assert result.safe is not None and result.safe.reason == "end"


# ------------------------------------------------------------------------------- msr real stream
def _msr(argv: list[str]) -> int:
    from elastica_magnetic.cli import main

    return main(["real", "stream", *argv])


@pytest.fixture
def board(monkeypatch, default_calibration_path: Path) -> CurrentsBoard:
    import serial

    fake = CurrentsBoard(default_calibration_path)
    monkeypatch.setattr(serial, "serial_for_url", lambda *a, **k: fake)
    return fake


def test_msr_real_stream_plays_a_coil_current_file(tmp_path: Path, capsys, board: CurrentsBoard,
                                                   default_calibration_path: Path) -> None:
    """Three coils of ``msr field baseline``'s format (t_s, current_K_A, insertion_m at 0): played in
    a currents session, every code the host's to the bit, --json naming the mode; --codes-out keeps
    the codes."""
    three = write_coil_currents(tmp_path / "three.csv", n_coils=3, n_rows=120)
    codes = tmp_path / "codes.csv"
    status = _msr([str(three), "--port", "fake://", "--calibration", str(default_calibration_path),
                   "--json", "--no-progress", "--timeout", "30", "--codes-out", str(codes)])
    captured = capsys.readouterr()
    assert status == 0, captured.err
    summary = json.loads(captured.out)
    assert summary["mode"] == "currents" and summary["rows_applied"] == 120
    assert summary["max_code_error_lsb"] == 0 and summary["rows_in_order"]
    assert "STREAM CURRENTS" in board.commands
    drive = read_coil_currents(three)
    expected = expected_current_codes(load_calibration(default_calibration_path),
                                      wire_values(wire_rows(drive.board_rows())))
    from elastica_magnetic.hardware.export import read_expected_codes

    np.testing.assert_array_equal(read_expected_codes(codes), expected)


def test_msr_real_stream_fails_when_the_board_plays_other_codes(tmp_path: Path, capsys,
                                                                board: CurrentsBoard) -> None:
    """The board's codes are compared with the host's model for the currents: a board that plays
    with another calibration than it claims ends with status 1."""
    yao = REPO / "stm32" / "calibration" / "yao2023.json"
    from elastica_magnetic.hardware.protocol import calibration_hash

    board.hash = calibration_hash(load_calibration(yao))  # claims yao2023, plays default
    two = write_coil_currents(tmp_path / "two.csv", n_coils=2, n_rows=60)
    assert _msr([str(two), "--port", "fake://", "--calibration", str(yao), "--json", "--no-progress",
                 "--timeout", "30"]) == 1
    captured = capsys.readouterr()
    assert json.loads(captured.out)["max_code_error_lsb"] > 1
    assert "differ from the host's by" in captured.err


def _refused(argv: list[str], capsys) -> str:
    assert _msr([*argv, "--port", "fake://", "--no-progress", "--timeout", "5"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


@pytest.fixture
def no_port(monkeypatch) -> None:
    """Opening the port fails the test: the refusals come before anything is sent."""
    import serial

    def never(*args, **kwargs):  # type: ignore[no-untyped-def]
        raise AssertionError("the port was opened")

    monkeypatch.setattr(serial, "serial_for_url", never)


def test_msr_real_stream_refuses_more_coils_than_outputs(tmp_path: Path, capsys, no_port) -> None:
    eight = write_coil_currents(tmp_path / "coil_currents.csv")  # catheter-coils-reach: 8 coils
    err = _refused([str(eight)], capsys)
    assert "msr real stream: error: " + str(eight) + ": needs 8 channels, the board drives 3 " in err


@pytest.mark.parametrize(("text", "message"), [
    ("t_s,current_0_A\n0,0.1\n0.02,0.2\n",
     r"line 3, column t_s: 0.02 s, expected 0.01 s: the board plays one row per 0.01 s from t_s = 0"),
    ("current_0_A\n0.1\n", r"no column t_s; a coil-current file has t_s \(s, 0, 0.01"),
    ("t_s,current_1_A,current_0_A\n0,0.1,0.2\n", r"current columns current_1_A, current_0_A: they are "
                                                 r"numbered from 0 in order"),
    ("t_s,current_0_A\n0,abc\n", r"line 2, column current_0_A: 'abc' is not a finite number \(A\)"),
    ("t_s,current_0_A\n0,nan\n", r"line 2, column current_0_A: 'nan' is not a finite number \(A\)"),
    ("t_s,current_0_A\n0,1500\n", r"line 2, column current_0_A: 1500 A; .* milliamperes written as "
                                  r"amperes\? \(give A\)"),
    ("t_s,current_0_A,insertion_m\n0,0.1,0\n0.01,0.1,0.002\n",
     r"line 3, column insertion_m: 0.002 m: the insertion stage moves, and the board drives the coils only"),
    ("t_s,current_0_A,mag_x\n0,0.1,1\n", r"column\(s\) 'mag_x' are not played"),
    ("t_s,current_0_A\n", r"header but no data rows"),
])
def test_a_coil_current_file_it_cannot_play_is_refused_by_line_and_column(tmp_path: Path, capsys, no_port,
                                                                          text: str, message: str) -> None:
    path = tmp_path / "coils.csv"
    path.write_text(text)
    with pytest.raises(CoilCurrentsError, match=message):
        read_coil_currents(path)
    assert str(path) in _refused([str(path)], capsys)


def test_currents_beyond_the_calibration_are_refused_unless_allowed(tmp_path: Path, capsys,
                                                                    default_calibration_path: Path,
                                                                    monkeypatch) -> None:
    """As for a field: beyond the current limit or the DAC span refused (--allow-clipping plays them
    clamped); faster than the slew limit warned about, and played."""
    import serial

    cal = ["--calibration", str(default_calibration_path)]
    strong = tmp_path / "strong.csv"
    strong.write_text("t_s,current_0_A,current_1_A\n0,0,0\n0.01,0.3,-3\n0.02,0.3,-3\n")
    with monkeypatch.context() as patch:
        patch.setattr(serial, "serial_for_url", lambda *a, **k: pytest.fail("the port was opened"))
        err = _refused([str(strong), *cal], capsys)
    assert ("strong.csv: line 3, column current_1_A: -3 A is beyond the current_limit_A[1] of calibration "
            "'default', 2.4 A on output 1 (DAC8563 #1 B; 2 row(s) over it): the board would clamp it. "
            "Lower the currents, or pass --allow-clipping to play them clamped; nothing was sent") in err
    board = CurrentsBoard(default_calibration_path)
    monkeypatch.setattr(serial, "serial_for_url", lambda *a, **k: board)
    assert _msr([str(strong), *cal, "--allow-clipping", "--port", "fake://", "--no-progress",
                 "--json", "--timeout", "30"]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["max_code_error_lsb"] == 0
    assert ("warning: " + str(strong) + ": line 3, column current_1_A: changes at 240 A/s, faster than the "
            "slew_limit_A_per_s of calibration 'default', 50 A/s") in captured.err


def test_a_magnet_path_is_refused_for_what_it_is(tmp_path: Path, capsys, no_port) -> None:
    arm = tmp_path / "magnet_path.csv"
    arm.write_text("t_s,magnet_x_m,magnet_y_m,magnet_z_m,direction_x,direction_y,direction_z\n0,0.09,0,0,1,0,0\n")
    err = _refused([str(arm)], capsys)
    assert "magnet_path.csv: holds a magnet arm's path (magnet_x_m, ..., m)" in err
    assert "the coil board cannot play it" in err and "arm's controller" in err


def test_msr_real_firmware_refuses_coil_currents(tmp_path: Path, capsys,
                                                 default_calibration_path: Path) -> None:
    from elastica_magnetic.cli import main

    three = write_coil_currents(tmp_path / "three.csv", n_coils=3)
    assert main(["real", "firmware", str(three), "--calibration", str(default_calibration_path),
                 "--out", str(tmp_path / "fw")]) == 2
    err = capsys.readouterr().err
    assert "three.csv: holds coil currents (current_0_A, ..., A), and the flash table (PLAY) is a field " \
           "waveform (mag_x, mag_y, mag_z in mT)" in err and "msr real stream" in err
    assert not (tmp_path / "fw").exists()


def test_silent_board_in_currents_mode_is_stopped() -> None:
    port = SilentPort()
    with pytest.raises(StreamError, match="fake: no PONG within 0.2 s"):
        stream_currents("fake", np.zeros((3, 3)), progress=False, timeout_s=0.2,
                        open_port=lambda *a, **k: port)
    assert port.written.endswith(b"\nSTOP\n") and port.closed


def test_current_columns_in_milliamperes_are_named_for_their_unit(tmp_path):
    """Round 30, V7: a coil-current file with ``current_0_mA`` columns was read as a field CSV ("lacks
    column(s) mag_x ..."); now each reader names the columns and the unit A, with the conversion."""
    from elastica_magnetic.field_csv import FieldCSVError, read_field_csv

    path = tmp_path / "ma.csv"
    path.write_text("t_s,current_0_mA,current_1_mA\n0,0,0\n0.01,100,50\n")
    with pytest.raises(CoilCurrentsError, match=r"current_0_mA, current_1_mA: a coil's current is in A.*"
                                                r"the currents in mA\? divide by 1000"):
        read_coil_currents(path)
    with pytest.raises(FieldCSVError, match=r"holds the currents of 2 coils \(current_0_mA"):
        read_field_csv(path)


@pytest.mark.parametrize("column", ["Current_0_A", "current_0_a", "current_0_amps", "CURRENT_0_AMPERE"])
def test_current_columns_spelled_otherwise_in_amperes_are_told_to_rename_only(tmp_path, column):
    """Round 31, V2, V3: ``Current_0_A`` was read as a field CSV ("lacks mag_x ..."), and
    ``current_0_a`` or ``current_0_amps`` told to "convert a to A": the values are amperes, only
    the name differs. Now the column is named with the exact spelling, the values left as they are."""
    path = tmp_path / "amps.csv"
    path.write_text(f"t_s,{column}\n0,0\n0.01,0.1\n")
    with pytest.raises(CoilCurrentsError, match=rf"{column}: a coil's current column is named current_<K>_A "
                                                r"exactly .* the values are amperes already") as refused:
        read_coil_currents(path)
    assert "convert" not in str(refused.value)


def test_currents_stamped_at_each_period_s_end_are_told_to_shift_not_resample(tmp_path):
    """Round 31, V4: a file at 100 rows per second whose t_s ran 0.01, 0.02, ... was told to "resample
    the currents to 100 rows per second", which it already was; now told to shift t_s by -0.01 s."""
    path = tmp_path / "late.csv"
    path.write_text("t_s,current_0_A\n0.01,0.1\n0.02,0.2\n0.03,0.3\n")
    with pytest.raises(CoilCurrentsError, match=r"the rows are 0.01 s apart but start at t_s = 0.01 s: "
                                                r"shift t_s by -0.01 s") as refused:
        read_coil_currents(path)
    assert "resample" not in str(refused.value)
    path.write_text("t_s,current_0_A\n0,0.1\n0.02,0.2\n0.04,0.3\n")
    with pytest.raises(CoilCurrentsError, match="resample the currents to 100 rows per second"):
        read_coil_currents(path)


@pytest.mark.parametrize("header", ["t_s,current_0", "t_s,current0_A"])
def test_current_columns_without_a_unit_or_underscore_are_named(tmp_path, header):
    """Round 32, V1: ``current_0`` (no unit) and ``current0_A`` (no underscore) were read as a field
    CSV ("lacks mag_x, mag_y, mag_z"); they are named as coil-current columns spelled otherwise."""
    path = tmp_path / "c.csv"
    path.write_text(f"{header}\n0,0.1\n0.01,0.1\n")
    with pytest.raises(CoilCurrentsError, match=r"a coil's current column is named current_<K>_A"):
        read_coil_currents(path)


def test_currents_logged_in_milliseconds_are_told_to_divide(tmp_path):
    """Round 32, V2: t_s in milliseconds (0, 10, 20, ...) was told to resample to 100 rows per second,
    a drive 1000 x slower; now told the times look like milliseconds."""
    path = tmp_path / "ms.csv"
    path.write_text("t_s,current_0_A\n0,0.1\n10,0.1\n20,0.1\n30,0.1\n")
    with pytest.raises(CoilCurrentsError, match=r"the times look like milliseconds; give seconds "
                                                r"\(divide t_s by 1000\)"):
        read_coil_currents(path)


@pytest.mark.parametrize("column", ["current_0 [A]", "current_0_(A)", "current 0 A", "current_0_A_", "I_0_A",
                                    "coil_0_A", "current_0 (mA)", "current_0_ma",
                                    "current_0_\u00b5A", "current_0_\u03bcA"])
def test_current_columns_with_brackets_spaces_or_another_prefix_are_named(tmp_path, column):
    """Round 33, V1: ``current_0 [A]``, ``current 0 A``, ``I_0_A``, ``coil_0_A`` ... were read as a
    field CSV ("lacks mag_x, mag_y, mag_z ... in mT"), even for a coil-currents spec; they are
    named as coil-current columns to rename (and a unit in brackets is read as the unit)."""
    path = tmp_path / "c.csv"
    path.write_text(f"t_s,{column}\n0,0.1\n0.01,0.1\n")
    with pytest.raises(CoilCurrentsError, match=r"a coil's current (column )?is") as refused:
        read_coil_currents(path)
    assert column in str(refused.value) and "current_0_A" in str(refused.value)
    assert ("divide by 1000" in str(refused.value)) == ("mA" in column or "ma" in column)
    from elastica_magnetic.field_csv import FieldCSVError, read_field_csv

    with pytest.raises(FieldCSVError, match=r"holds the currents of 1 coil"):
        read_field_csv(path)
