"""``stream_field`` against a simulated board speaking the firmware's protocol."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from elastica_magnetic.hardware.calibration import DacCodeModel, expected_dac_codes, load_calibration
from elastica_magnetic.hardware.protocol import crc16, wire_rows_mT, wire_values_mT
from elastica_magnetic.hardware.stream import stream_field

QUEUE = 256


class FakeBoard:
    """Minimal model of the firmware: PONG, credits, one DAC line per row played, SAFE."""

    def __init__(self, calibration_path: Path) -> None:
        self.model = DacCodeModel(load_calibration(calibration_path))
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
        if line == "PING":
            self._send("PONG")
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
