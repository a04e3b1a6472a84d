"""``stream_field`` against a simulated board speaking the firmware's protocol."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pytest

from elastica_magnetic.hardware.calibration import (
    DacCodeModel,
    calibration_from_dict,
    expected_dac_codes,
    load_calibration,
)
from elastica_magnetic.hardware.protocol import (
    calibration_hash,
    crc16,
    wire_rows_mT,
    wire_values_mT,
)
from elastica_magnetic.hardware.stream import stream_field

QUEUE = 256


class FakeBoard:
    """Minimal model of the firmware: PONG, credits, one DAC line per row played, SAFE."""

    def __init__(self, calibration_path: Path) -> None:
        self.calibration = load_calibration(calibration_path)
        self.model = DacCodeModel(self.calibration)
        self.hash = calibration_hash(self.calibration)  # what STATUS reports
        self.upload = b""
        self.commands: list[str] = []
        self.rx = b""
        self.tx = b""
        self.queue: list[list[float]] = []
        self.received = 0
        self.applied = 0
        self.ended = False
        self.streaming = False
        self.max_outstanding = 0
        self.credit = 0

    # pyserial-like interface
    @property
    def in_waiting(self) -> int:
        return len(self.tx)

    def write(self, data: bytes) -> int:
        self.rx += data
        while b"\n" in self.rx:
            line, self.rx = self.rx.split(b"\n", 1)
            self._line(line.decode())
        return len(data)

    def read(self, n: int) -> bytes:
        self._tick()
        out, self.tx = self.tx[:n], self.tx[n:]
        return out

    def close(self) -> None:
        pass

    def _send(self, text: str) -> None:
        self.tx += (text + "\n").encode()

    def _safe(self, reason: str, row: int, detail: str = "") -> None:
        self.streaming = False
        self._send("DAC safe 32768 32768 32768")
        suffix = f" detail={detail}" if detail else ""
        self._send(f"SAFE {reason} row={row} applied={self.applied}{suffix}")

    def _line(self, line: str) -> None:
        if line and not line[0].isdigit():
            self.commands.append(line.split("*")[0][:12])
        if line == "PING":
            self._send("PONG")
        elif line == "STATUS":
            self._send(f"STATUS state=safe calibration={self.calibration.name} hash={self.hash} "
                       "source=compiled")
        elif line.startswith("CAL "):
            self._cal(line)
        elif line == "STREAM":
            self.streaming = True
            self.model.reset()
            self._send(f"OK STREAM queue={QUEUE} prefill=64")
            self.credit = QUEUE
            self._send(f"CREDIT {QUEUE}")
        elif line.startswith("END "):
            self.ended = True
        elif line and line[0].isdigit() and self.streaming:
            payload, crc = line.split("*")
            if crc16(payload.encode()) != int(crc, 16):
                self._safe("checksum", self.received, "crc-mismatch")
                return
            seq, *vals = payload.split(",")
            assert int(seq) == self.received
            self.received += 1
            assert self.received <= self.credit, "host exceeded its credit"
            self.queue.append([float(v) for v in vals])
            self.max_outstanding = max(self.max_outstanding, len(self.queue))

    def _cal(self, line: str) -> None:
        """The firmware's upload, modelled: record bytes, CRC-32, then the host's own checks."""
        words = line.split("*")[0].split()
        if words[1] == "BEGIN":
            self.upload = b""
            self._send("OK CAL-BEGIN bytes=216")
        elif words[1] == "DATA":
            assert int(words[2]) == len(self.upload)
            self.upload += bytes.fromhex(words[3])
            self._send(f"OK CAL-DATA next={len(self.upload)}")
        elif words[1] == "COMMIT":
            values = struct.unpack("<23d", self.upload[:184])
            m = [list(values[0:3]), list(values[3:6]), list(values[6:9])]
            data = {"name": self.upload[184:].rstrip(b"\0").decode(), "actuation_matrix_T_per_A": m,
                    "transconductance_A_per_V": list(values[9:12]),
                    "input_offset_V": list(values[12:15]), "dac_half_span_V": values[15],
                    "current_limit_A": list(values[16:19]),
                    "slew_limit_A_per_s": list(values[19:22]), "tick_hz": values[22]}
            try:
                cal = calibration_from_dict(data, "upload")
            except ValueError:
                self._send("ERR cal-refused reason=implausible")
                return
            self.calibration, self.model = cal, DacCodeModel(cal)
            self.hash = calibration_hash(cal)
            assert self.hash == words[2]
            self._send(f"OK CAL-COMMIT name={cal.name} hash={self.hash} slot=0")

    def _tick(self) -> None:
        if not self.streaming:
            return
        if self.queue:
            codes = self.model.codes(self.queue.pop(0))
            self._send(f"DAC {self.applied} {codes[0]} {codes[1]} {codes[2]}")
            self.applied += 1
            if self.received + QUEUE - len(self.queue) >= self.credit + 16:
                self.credit = self.received + QUEUE - len(self.queue)
                self._send(f"CREDIT {self.credit}")
        elif self.ended:
            self._safe("end", self.applied)


def field(n: int) -> np.ndarray:
    t = np.arange(n) / 100.0
    return np.stack([np.cos(t), np.sin(t), 0.2 * t], axis=1) * 1e-3


def test_stream_full_waveform_respects_credit(default_calibration_path: Path, tmp_path: Path) -> None:
    board = FakeBoard(default_calibration_path)
    f = field(600)
    result = stream_field("fake://", f, progress=False, timeout_s=30, log_path=tmp_path / "log",
                          open_port=lambda *a, **k: board)
    assert result.rows_sent == 600 and result.rows_applied == 600
    assert result.safe is not None and result.safe.reason == "end"
    assert result.ended_safe
    assert board.max_outstanding <= QUEUE
    expected = expected_dac_codes(load_calibration(default_calibration_path),
                                  wire_values_mT(wire_rows_mT(f)))
    np.testing.assert_array_equal(result.codes_array(), expected)
    assert "SAFE end" in (tmp_path / "log").read_text()
    assert result.summary()["rows_applied"] == 600


def test_stream_corrupt_row_stops_with_reason(default_calibration_path: Path) -> None:
    board = FakeBoard(default_calibration_path)
    result = stream_field("fake://", field(600), progress=False, timeout_s=30, corrupt_row=300,
                          open_port=lambda *a, **k: board)
    assert result.safe is not None
    assert (result.safe.reason, result.safe.row) == ("checksum", 300)
    assert result.ended_safe
    assert result.rows_applied < 300


class SilentPort:
    """A port whose board never answers (or breaks after ``fail_after`` reads); records writes."""

    def __init__(self, fail_after: int | None = None) -> None:
        self.written = b""
        self.reads = 0
        self.fail_after = fail_after
        self.closed = False

    in_waiting = 0

    def write(self, data: bytes) -> int:
        self.written += data
        return len(data)

    def read(self, n: int) -> bytes:
        self.reads += 1
        if self.fail_after is not None and self.reads > self.fail_after:
            raise OSError(5, "Input/output error")
        return b"PONG\nOK STREAM\nCREDIT 4\n" if self.reads == 1 and self.fail_after else b""

    def close(self) -> None:
        self.closed = True


def test_unreachable_ports_are_named() -> None:
    import pytest

    from elastica_magnetic.hardware.stream import StreamError

    for url in ("socket://127.0.0.1:1", "/dev/ttyMSR_no_such_device"):
        with pytest.raises(StreamError, match=rf"{url}: cannot open the port .*nothing was sent"):
            stream_field(url, np.zeros((3, 3)), progress=False, timeout_s=1.0)


def test_handshake_honours_the_timeout_and_stops_the_board() -> None:
    import time

    import pytest

    from elastica_magnetic.hardware.stream import StreamError

    port = SilentPort()
    begin = time.monotonic()
    with pytest.raises(StreamError, match="fake: no PONG within 0.2 s"):
        stream_field("fake", np.zeros((3, 3)), progress=False, timeout_s=0.2,
                     open_port=lambda *a, **k: port)
    assert time.monotonic() - begin < 2.0
    assert port.written.endswith(b"\nSTOP\n") and port.closed


def test_board_that_disconnects_is_named_and_stopped() -> None:
    import pytest

    from elastica_magnetic.hardware.stream import StreamError

    port = SilentPort(fail_after=3)
    with pytest.raises(StreamError, match=r"fake: link lost after \d+ of 10 rows \(\[Errno 5\] Input/output"):
        stream_field("fake", np.zeros((10, 3)), progress=False, timeout_s=5.0,
                     open_port=lambda *a, **k: port)
    assert port.written.endswith(b"\nSTOP\n") and port.closed


def test_stream_options_checked_at_parse_time(capsys, tmp_path: Path) -> None:
    import pytest

    from elastica_magnetic.cli import main

    for option, value in (("--timeout", "-1"), ("--timeout", "nan"), ("--baud", "0"),
                          ("--corrupt-row", "-2")):
        with pytest.raises(SystemExit):
            main(["real", "stream", "f.csv", "--port", "socket://127.0.0.1:1", option, value])
        assert f"argument {option}: expected" in capsys.readouterr().err
    csv_path = tmp_path / "f.csv"
    csv_path.write_text("1,2,3\n")
    assert main(["real", "stream", str(csv_path), "--port", "socket://127.0.0.1:1", "--timeout", "1",
                 "--no-progress"]) == 2
    assert "msr real stream: error: socket://127.0.0.1:1: cannot open the port" in capsys.readouterr().err


# ----------------------------------------------------------------- calibration and stream checks
YAO2023 = Path(__file__).resolve().parents[2] / "stm32" / "calibration" / "yao2023.json"


def csv_of(path: Path, field_mT: np.ndarray) -> Path:
    path.write_text("mag_x,mag_y,mag_z\n" + "".join(f"{x},{y},{z}\n" for x, y, z in field_mT))
    return path


def test_stream_refuses_a_waveform_the_calibration_cannot_make(tmp_path: Path, capsys,
                                                               default_calibration_path: Path) -> None:
    from elastica_magnetic.cli import main

    strong = csv_of(tmp_path / "strong.csv", np.tile([20.0, 0.0, 0.0], (50, 1)))
    argv = ["real", "stream", str(strong), "--port", "socket://127.0.0.1:1", "--no-progress",
            "--calibration", str(default_calibration_path)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "cannot follow this waveform" in err and "nothing was sent" in err
    # --allow-clipping lets it through to the port (here: none there)
    assert main([*argv, "--allow-clipping", "--timeout", "1"]) == 2
    assert "cannot open the port" in capsys.readouterr().err


def test_stream_uploads_a_differing_calibration(monkeypatch, tmp_path: Path, capsys,
                                                default_calibration_path: Path) -> None:
    import serial

    from elastica_magnetic.cli import main

    board = FakeBoard(default_calibration_path)
    monkeypatch.setattr(serial, "serial_for_url", lambda *a, **k: board)
    ten = csv_of(tmp_path / "ten.csv", np.tile([10.0, -9.0, 0.0], (150, 1)))
    argv = ["real", "stream", str(ten), "--port", "fake://", "--no-progress", "--json", "--calibration",
            str(YAO2023), "--timeout", "30"]
    assert main([*argv, "--no-upload"]) == 2
    assert "--no-upload" in capsys.readouterr().err and board.upload == b""
    board2 = FakeBoard(default_calibration_path)
    monkeypatch.setattr(serial, "serial_for_url", lambda *a, **k: board2)
    assert main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["calibration_uploaded"].startswith("OK CAL-COMMIT name=yao2023")
    assert summary["max_code_error_lsb"] == 0 and summary["rows_applied"] == 150
    assert board2.calibration.name == "yao2023"
    # the same again: the board already has it, nothing uploaded
    board2.applied = board2.received = 0
    board2.ended = False
    assert main(argv) == 0
    assert json.loads(capsys.readouterr().out)["calibration_uploaded"] is None


def test_stream_exits_nonzero_when_the_codes_differ(monkeypatch, tmp_path: Path, capsys,
                                                    default_calibration_path: Path) -> None:
    import serial

    from elastica_magnetic.cli import main

    board = FakeBoard(default_calibration_path)
    board.hash = calibration_hash(load_calibration(YAO2023))  # claims yao2023, plays default
    monkeypatch.setattr(serial, "serial_for_url", lambda *a, **k: board)
    weak = csv_of(tmp_path / "weak.csv", np.tile([3.0, 1.0, 0.0], (100, 1)))
    assert main(["real", "stream", str(weak), "--port", "fake://", "--no-progress", "--json",
                 "--calibration", str(YAO2023), "--timeout", "30"]) == 1
    captured = capsys.readouterr()
    assert json.loads(captured.out)["max_code_error_lsb"] > 1
    assert "differ from the host's by" in captured.err


def test_failed_connection_keeps_the_previous_log(tmp_path: Path, default_calibration_path: Path) -> None:
    import pytest

    from elastica_magnetic.hardware.stream import StreamError

    log = tmp_path / "board.log"
    old = b"MSR-FW 1.0 previous stream\r\nSAFE end row=3 applied=3\n\x00\xff"
    log.write_bytes(old)
    with pytest.raises(StreamError, match="cannot open the port"):
        stream_field("socket://127.0.0.1:1", np.zeros((3, 3)), progress=False, timeout_s=1.0,
                     log_path=log)
    assert log.read_bytes() == old
    with pytest.raises(StreamError, match="no PONG"):  # port opens, board silent
        stream_field("fake", np.zeros((3, 3)), progress=False, timeout_s=0.2, log_path=log,
                     open_port=lambda *a, **k: SilentPort())
    assert log.read_bytes() == old
    assert sorted(p.name for p in tmp_path.iterdir()) == ["board.log"]  # no temporary left
    board = FakeBoard(default_calibration_path)  # a stream that runs replaces it
    stream_field("fake://", field(20), progress=False, timeout_s=30, log_path=log,
                 open_port=lambda *a, **k: board)
    assert "SAFE end" in log.read_text()


def test_calibrate_upload_writes_and_uploads(monkeypatch, tmp_path: Path, capsys,
                                             default_calibration_path: Path) -> None:
    import serial

    from elastica_magnetic.cli import main

    board = FakeBoard(default_calibration_path)
    monkeypatch.setattr(serial, "serial_for_url", lambda *a, **k: board)
    currents = np.vstack([np.eye(3) * a for a in (-2.0, -1.0, 1.0, 2.0)])
    fields_mT = currents @ np.array([[2.1, 0.05, 0], [0.04, 1.9, 0], [0, 0.02, 2.0]]).T
    meas = tmp_path / "m.csv"
    np.savetxt(meas, np.hstack([currents, fields_mT]), delimiter=",", comments="",
               header="current_x_A,current_y_A,current_z_A,field_x_mT,field_y_mT,field_z_mT")
    out = tmp_path / "bench1.json"
    assert main(["real", "calibrate", str(meas), "--out", str(out), "--name", "bench1", "--upload",
                 "fake://", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["uploaded"]["after"].startswith("STATUS state=safe calibration=bench1 hash=")
    assert board.hash == calibration_hash(load_calibration(out))
    assert board.calibration.actuation_matrix_T_per_A[0][0] == pytest.approx(2.1e-3)


class GarbledCreditBoard(FakeBoard):
    """A board whose second credit line arrives garbled (``CREDIT abc``), mid-stream."""

    credits_sent = 0

    def _send(self, text: str) -> None:
        if text.startswith("CREDIT "):
            self.credits_sent += 1
            if self.credits_sent == 2:
                text = "CREDIT abc"
        super()._send(text)


def test_a_malformed_credit_line_is_named_and_the_board_stopped(default_calibration_path: Path,
                                                                 tmp_path: Path) -> None:
    from elastica_magnetic.hardware.protocol import parse_credit
    from elastica_magnetic.hardware.stream import StreamError

    assert [parse_credit(x) for x in ("CREDIT 256", "CREDIT abc", "CREDIT -1", "CREDIT", "CREDIT 1 2",
                                      "CREDIT ４")] == [256, None, None, None, None, None]
    board = GarbledCreditBoard(default_calibration_path)
    log = tmp_path / "board.log"
    with pytest.raises(StreamError) as caught:
        stream_field("fake://", field(600), progress=False, timeout_s=30, log_path=log,
                     open_port=lambda *a, **k: board)
    message = str(caught.value)
    assert message.startswith("fake://: the board sent a malformed credit line 'CREDIT abc' after "
                              f"{QUEUE} rows (expected 'CREDIT <n>'"), message
    assert board.received == QUEUE  # not a row beyond the last valid credit
    assert board.commands[-1] == "STOP"  # the fail-safe end: zero current
    assert "CREDIT abc" in log.read_text()  # the log keeps what the board said


def test_msr_stream_to_a_port_that_does_not_open_keeps_the_previous_log(tmp_path: Path, capsys) -> None:
    """Through the command (the log is a result file): ``--force`` replaces an earlier log only with
    one that says something; a port that does not open left an empty file over it (round 4, D1)."""
    from elastica_magnetic.cli import main
    from elastica_magnetic.result_file import result_file

    log = tmp_path / "board.log"
    old = b"MSR-FW 1.0 previous stream\r\nSAFE end row=3 applied=3\n"
    with result_file(log) as written:  # an earlier stream's log, as msr writes it
        written.path.write_bytes(old)
    assert main(["real", "stream", str(csv_of(tmp_path / "f.csv", np.zeros((3, 3)))), "--port",
                 "socket://127.0.0.1:1", "--log", str(log), "--force", "--timeout", "1",
                 "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "cannot open the port" in err and "board.log is left as it was (nothing was logged)" in err
    assert log.read_bytes() == old
    assert sorted(p.name for p in tmp_path.iterdir()) == [".msr-files.json", "board.log", "f.csv"]


def test_msr_stream_refuses_a_corrupt_row_past_the_waveform_before_connecting(tmp_path: Path, capsys,
                                                                               monkeypatch) -> None:
    """Round 10 S5: ``--corrupt-row 500`` on a 100-row waveform went on to the handshake (no row
    corrupted, and the stream of a good waveform then exited 1)."""
    from elastica_magnetic.cli import main

    waveform = csv_of(tmp_path / "f.csv", np.zeros((100, 3)))
    opened = []

    def no_port(*args, **kwargs):  # connecting at all is the failure
        opened.append(args)
        raise AssertionError("the port was opened")

    import serial

    with monkeypatch.context() as patched:
        patched.setattr(serial, "serial_for_url", no_port)
        status = main(["real", "stream", str(waveform), "--port", "loop://", "--timeout", "1",
                       "--corrupt-row", "500", "--no-progress"])
    assert status == 2 and not opened
    assert "--corrupt-row 500: the waveform has 100 rows (0-99) in " in capsys.readouterr().err
    # the last row is accepted (goes on to the port: loop:// echoes, no PONG)
    assert main(["real", "stream", str(waveform), "--port", "loop://", "--timeout", "0.3",
                 "--corrupt-row", "99", "--no-progress"]) == 2
    assert "no PONG within 0.3 s" in capsys.readouterr().err


def test_msr_stream_force_replaces_the_log_of_its_own_failed_stream(tmp_path: Path, capsys) -> None:
    """Round 10 V4: the log a failed stream kept (no firmware line in it: loop:// echoes PING) was
    refused by ``--force`` as 'not a board log (a file msr did not write?)'. A log msr recorded
    unchanged is replaced; a user's file, or msr's log changed since, stays refused."""
    from elastica_magnetic.cli import main

    waveform = str(csv_of(tmp_path / "f.csv", np.zeros((3, 3))))
    log = tmp_path / "new.log"
    command = ["real", "stream", waveform, "--port", "loop://", "--timeout", "0.3", "--no-progress",
               "--log", str(log)]
    assert main(command) == 2
    assert "no PONG" in capsys.readouterr().err and "PING" in log.read_text()
    manifest = json.loads((tmp_path / ".msr-files.json").read_text())["files"]
    assert set(manifest) == {"new.log"}
    assert main([*command, "--force"]) == 2
    err = capsys.readouterr().err
    assert "no PONG" in err and "not a board log" not in err, err
    log.write_text("PING\nmy notes\n")  # changed since msr wrote it
    assert main([*command, "--force"]) == 2
    err = capsys.readouterr().err
    assert "--log" in err and "new.log: is not a board log" in err and "no PONG" not in err, err
    assert log.read_text() == "PING\nmy notes\n"
    mine = tmp_path / "mine.log"
    mine.write_text("a file of the user's\n")
    assert main([*command[:-1], str(mine), "--force"]) == 2
    assert "mine.log: is not a board log" in capsys.readouterr().err
    assert mine.read_text() == "a file of the user's\n"
