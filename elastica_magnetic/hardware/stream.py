"""Streaming a field waveform to the firmware over any pyserial URL.

``socket://127.0.0.1:PORT`` reaches the QEMU emulator, ``/dev/ttyACM0`` a real board. Flow control
is by credit: the board announces ``CREDIT n`` (rows with ``seq < n`` may be sent) and the host
never exceeds it, so a waveform longer than the board's memory plays without gaps.
"""

from __future__ import annotations

import contextlib
import math
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
        Overall limit in s, handshake included (default: playback time + 30 s; the handshake
        waits at most 10 s either way).
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
        The port cannot be opened, no answer to PING, STREAM refused, or the link broke; the
        message names the port. On any failure or time-out after the port opened, ``STOP`` is
        sent (best effort) so that the board sets zero current.
    """
    import serial  # pyserial; imported here so the module loads without it
    from tqdm import tqdm

    if timeout_s is not None and not (math.isfinite(timeout_s) and timeout_s > 0):
        raise ValueError(f"timeout_s must be a positive time in s, got {timeout_s}")
    rows = wire_rows_mT(field_T)
    n = len(rows)
    deadline_s = timeout_s if timeout_s is not None else n / PLAYBACK_HZ + 30.0
    sync_s = min(SYNC_TIMEOUT_S, deadline_s)
    result = StreamResult(rows_total=n)
    opener = open_port or serial.serial_for_url
    try:
        log = open(log_path, "w") if log_path is not None else None  # noqa: SIM115
    except OSError as exc:
        raise StreamError(f"--log {log_path}: cannot write: {exc.strerror or exc}") from None
    try:
        port = opener(port_url, baudrate=baudrate, timeout=READ_TIMEOUT_S)
    except (OSError, ValueError, serial.SerialException) as exc:
        if log is not None:
            log.close()
        raise StreamError(f"{port_url}: cannot open the port ({exc}); nothing was sent") from None
    bar = tqdm(total=n, unit="row", desc="stream", disable=not progress, leave=False)
    start = time.monotonic()
    finished = False
    try:
        reader = _LineReader(port, log)
        # 1. sync: PING until PONG (bytes sent before the board's UART is enabled are lost).
        last_ping = -PING_INTERVAL_S
        synced = False
        while time.monotonic() - start < sync_s and not synced:
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
            raise StreamError(f"{port_url}: no PONG within {sync_s:g} s (is the board running?)")
        # 2. start the session
        port.write(b"STREAM\n")
        credit = 0
        started = False
        while not started:
            if time.monotonic() - start > deadline_s:
                raise StreamError(f"{port_url}: no answer to STREAM within {deadline_s:g} s")
            for line in reader.poll():
                result.lines.append(line)
                if line.startswith("OK STREAM"):
                    started = True
                elif line.startswith("CREDIT "):
                    credit = int(line.split()[1])
                elif line.startswith("SAFE "):
                    result.safe = parse_safe(line)
                    raise StreamError(f"{port_url}: STREAM refused: {line}")
        # 3. rows within the credit, then END; read reports until SAFE or the overall time limit
        next_row = 0
        end_sent = False
        while result.safe is None and time.monotonic() - start < deadline_s:
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
        finished = True
    except (OSError, serial.SerialException) as exc:
        raise StreamError(
            f"{port_url}: link lost after {result.rows_sent} of {n} rows ({exc}); a STOP was sent "
            "if the port still accepted it, and the board zeroes the coils when its rows run out"
        ) from None
    finally:
        result.duration_s = time.monotonic() - start
        bar.close()
        if log is not None:
            log.close()
        if not finished or result.safe is None:
            _stop(port)  # fail safe: the board goes to zero current on STOP
        with contextlib.suppress(Exception):
            port.close()
    return result


def _stop(port: Any) -> None:
    """Best effort: ask the board for its safe state (mid-scale DAC, zero current)."""
    with contextlib.suppress(Exception):
        port.write(b"\nSTOP\n")
        flush = getattr(port, "flush", None)
        if flush is not None:
            flush()
