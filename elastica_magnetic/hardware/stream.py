"""Streaming a field waveform to the firmware over any pyserial URL.

``socket://127.0.0.1:PORT`` reaches the QEMU emulator, ``/dev/ttyACM0`` a real board. Flow control
is by credit: the board announces ``CREDIT n`` (rows with ``seq < n`` may be sent) and the host
never exceeds it, so a waveform longer than the board's memory plays without gaps.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic.hardware.calibration import DAC_MIDSCALE
from elastica_magnetic.hardware.protocol import (
    DacReport,
    SafeReport,
    format_row,
    parse_dac,
    parse_safe,
    wire_rows_mT,
)

DEFAULT_BAUD = 115200
#: Rows per second of the firmware's playback (100 Hz tick).
PLAYBACK_HZ = 100.0
#: Seconds to wait for the board to answer PING after the port opens.
SYNC_TIMEOUT_S = 10.0
PING_INTERVAL_S = 0.5
READ_TIMEOUT_S = 0.02


class StreamError(RuntimeError):
    """The board did not answer or the link broke; the message says at which step."""


@dataclass
class StreamResult:
    """What the board reported during one stream.

    ``dac`` holds every ``DAC`` report in order (the firmware's writes, safe-state writes
    included); ``safe`` is the ``SAFE`` report that ended the stream (None on time-out).
    """

    rows_total: int
    rows_sent: int = 0
    dac: list[DacReport] = field(default_factory=list)
    safe: SafeReport | None = None
    banner: str = ""
    lines: list[str] = field(default_factory=list)
    duration_s: float = 0.0

    @property
    def row_codes(self) -> list[DacReport]:
        """DAC reports of played rows (safe-state writes excluded)."""
        return [d for d in self.dac if d.row is not None]

    @property
    def rows_applied(self) -> int:
        return len(self.row_codes)

    @property
    def ended_safe(self) -> bool:
        """A SAFE report arrived and the last DAC write was mid-scale on every axis."""
        return (self.safe is not None and bool(self.dac) and self.dac[-1].row is None
                and self.dac[-1].codes == (DAC_MIDSCALE,) * 3)

    def codes_array(self) -> NDArray[np.int64]:
        """``(rows_applied, 3)`` codes of played rows, in row order."""
        return np.array([d.codes for d in self.row_codes], dtype=np.int64).reshape(-1, 3)

    def summary(self) -> dict[str, Any]:
        rate = self.rows_sent / self.duration_s if self.duration_s > 0 else 0.0
        return {
            "rows_total": self.rows_total,
            "rows_sent": self.rows_sent,
            "rows_applied": self.rows_applied,
            "ended_safe": self.ended_safe,
            "safe_reason": self.safe.reason if self.safe else None,
            "safe_row": self.safe.row if self.safe else None,
            "safe_detail": self.safe.detail if self.safe else None,
            "safe_line": self.safe.text if self.safe else None,
            "board": self.banner,
            "duration_s": round(self.duration_s, 3),
            "rows_per_s": round(rate, 1),
        }


class _LineReader:
    def __init__(self, port: Any, log: Any | None) -> None:
        self.port = port
        self.log = log
        self.pending = b""

    def poll(self) -> list[str]:
        waiting = getattr(self.port, "in_waiting", 0) or 1
        data = self.port.read(waiting)
        if not data:
            return []
        self.pending += data
        *lines, self.pending = self.pending.split(b"\n")
        out = [line.decode("ascii", "replace").rstrip("\r") for line in lines]
        if self.log is not None:
            for line in out:
                self.log.write(line + "\n")
        return out


def stream_field(
    port_url: str,
    field_T: NDArray[np.float64],
    *,
    baudrate: int = DEFAULT_BAUD,
    corrupt_row: int | None = None,
    timeout_s: float | None = None,
    log_path: str | Path | None = None,
    progress: bool = True,
    open_port: Callable[..., Any] | None = None,
) -> StreamResult:
    """Stream ``field_T`` (``(n, 3)`` tesla, 100 rows/s) to the board at ``port_url``.

    Parameters
    ----------
    port_url : str
        Any pyserial URL or device (``socket://127.0.0.1:4321``, ``/dev/ttyACM0``).
    field_T : ndarray
        Field in tesla, one row per 10 ms.
    corrupt_row : int, optional
        Fault injection: row ``corrupt_row`` is sent with a digit changed after its checksum, so
        the firmware must stop at it with reason ``checksum``.
    timeout_s : float, optional
        Overall limit (default: playback time + 30 s).
    log_path : path, optional
        Every line the board sent is written there.
    progress : bool
        Show a tqdm progress bar of rows played.

    Returns
    -------
    StreamResult
        The board's reports; ``result.safe`` says how the stream ended.

    Raises
    ------
    StreamError
        No answer to PING, STREAM refused, or the link failed (the port's error is kept).

    A stream the board accepted and that ends without a SAFE report (time-out, link error,
    interrupt) is followed by a best-effort STOP, so the board goes to mid-scale at once.
    """
    import serial  # pyserial; imported here so the module loads without it
    from tqdm import tqdm

    rows = wire_rows_mT(field_T)
    n = len(rows)
    deadline_s = timeout_s if timeout_s is not None else n / PLAYBACK_HZ + 30.0
    result = StreamResult(rows_total=n)
    opener = open_port or serial.serial_for_url
    port = opener(port_url, baudrate=baudrate, timeout=READ_TIMEOUT_S)
    log = open(log_path, "w") if log_path is not None else None  # noqa: SIM115
    bar = tqdm(total=n, unit="row", desc="stream", disable=not progress, leave=False)
    start = time.monotonic()
    stream_sent = False
    try:
        reader = _LineReader(port, log)
        # 1. sync: PING until PONG (bytes sent before the board's UART is enabled are lost).
        last_ping = -PING_INTERVAL_S
        synced = False
        while time.monotonic() - start < SYNC_TIMEOUT_S and not synced:
            now = time.monotonic() - start
            if now - last_ping >= PING_INTERVAL_S:
                port.write(b"\nPING\n")
                last_ping = now
            for line in reader.poll():
                result.lines.append(line)
                if line.startswith("MSR-FW"):
                    result.banner = line
                synced = synced or line == "PONG"
        if not synced:
            raise StreamError(f"{port_url}: no PONG within {SYNC_TIMEOUT_S:.0f} s (is the board running?)")
        # 2. start the session
        port.write(b"STREAM\n")
        stream_sent = True
        credit = 0
        started = False
        t_start = time.monotonic()
        while not started:
            if time.monotonic() - t_start > SYNC_TIMEOUT_S:
                raise StreamError(f"{port_url}: no answer to STREAM")
            for line in reader.poll():
                result.lines.append(line)
                if line.startswith("OK STREAM"):
                    started = True
                elif line.startswith("CREDIT "):
                    credit = int(line.split()[1])
                elif line.startswith("SAFE "):
                    result.safe = parse_safe(line)
                    raise StreamError(f"{port_url}: STREAM refused: {line}")
        # 3. rows within the credit, then END; read reports until SAFE
        next_row = 0
        end_sent = False
        t0 = time.monotonic()
        while result.safe is None and time.monotonic() - t0 < deadline_s:
            if next_row < n and next_row < credit:
                upto = min(n, credit)
                chunk = b"".join(format_row(i, rows[i], corrupt=(i == corrupt_row))
                                 for i in range(next_row, upto))
                port.write(chunk)
                next_row = upto
                result.rows_sent = next_row
            if next_row == n and not end_sent:
                port.write(f"END {n}\n".encode("ascii"))
                end_sent = True
            for line in reader.poll():
                result.lines.append(line)
                if line.startswith("CREDIT "):
                    credit = max(credit, int(line.split()[1]))
                elif line.startswith("DAC "):
                    report = parse_dac(line)
                    if report is not None:
                        result.dac.append(report)
                        if report.row is not None:
                            bar.update(1)
                elif line.startswith("SAFE "):
                    result.safe = parse_safe(line)
        # 4. the safe-state DAC line precedes SAFE; nothing else to wait for
    except serial.SerialException as exc:
        raise StreamError(f"{port_url}: link failed: {exc}") from exc
    finally:
        if stream_sent and result.safe is None:
            try:  # the board may still be playing queued rows: mid-scale now
                port.write(b"STOP\n")
            except (serial.SerialException, OSError):
                pass  # link gone: the firmware's underrun check ends at mid-scale
        result.duration_s = time.monotonic() - start
        bar.close()
        if log is not None:
            log.close()
        port.close()
    return result
