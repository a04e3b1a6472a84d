"""Streaming a field waveform, or the coil currents of up to three coils, to the firmware over any
pyserial URL.

``socket://127.0.0.1:PORT`` reaches the QEMU emulator, ``/dev/ttyACM0`` a real board. Flow control
is by credit: the board announces ``CREDIT n`` (rows with ``seq < n`` may be sent) and the host
never exceeds it, so a waveform longer than the board's memory plays without gaps.

:func:`stream_field` sends ``STREAM`` and rows of field (mT); :func:`stream_currents` sends ``STREAM
CURRENTS`` and rows of the three outputs' currents (A). Both share one session (handshake,
calibration, credit, the fail-safe ``STOP``).
"""

from __future__ import annotations

import contextlib
import math
import os
import time
import urllib.parse
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic.hardware.calibration import DAC_MIDSCALE, Calibration
from elastica_magnetic.hardware.protocol import (
    BoardStatus,
    DacReport,
    SafeReport,
    calibration_hash,
    calibration_upload_lines,
    format_row,
    parse_credit,
    parse_dac,
    parse_safe,
    parse_status,
    wire_rows,
    wire_rows_mT,
)
from elastica_magnetic.result_file import FileKind

DEFAULT_BAUD = 115200
#: Rows per second of the firmware's playback (100 Hz tick).
PLAYBACK_HZ = 100.0
#: Seconds to wait for the board to answer PING after the port opens.
SYNC_TIMEOUT_S = 10.0
PING_INTERVAL_S = 0.5
READ_TIMEOUT_S = 0.02
#: Seconds to wait for the answer to one command (STATUS, a CAL line: the flash write included).
COMMAND_TIMEOUT_S = 10.0
#: The command that starts a session of each mode: field rows (mT) or coil-current rows (A).
STREAM_COMMANDS = {"field": "STREAM", "currents": "STREAM CURRENTS"}
#: The board's outputs (DAC8563 #1 A, #1 B, #2 A): the most coil currents one row holds.
BOARD_OUTPUTS = 3


#: The pyserial URL schemes that reach a board over the network, ``SCHEME://HOST:PORT``.
NETWORK_SCHEMES = ("socket", "rfc2217")
#: The port the examples in messages give (the QEMU board's, ``stm32/tests/qemu_e2e.py``).
EXAMPLE_TCP_PORT = 4321


class StreamError(RuntimeError):
    """The board did not answer or the link broke; the message says at which step."""


class CalibrationRefused(StreamError):
    """The board refused an uploaded calibration; the message holds its reason code."""


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
    calibration_before: str = ""
    uploaded: str = ""
    mode: str = "field"

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
            "mode": self.mode,
            "rows_total": self.rows_total,
            "rows_sent": self.rows_sent,
            "rows_applied": self.rows_applied,
            "ended_safe": self.ended_safe,
            "safe_reason": self.safe.reason if self.safe else None,
            "safe_row": self.safe.row if self.safe else None,
            "safe_detail": self.safe.detail if self.safe else None,
            "safe_line": self.safe.text if self.safe else None,
            "board": self.banner,
            "calibration_before": self.calibration_before or None,
            "calibration_uploaded": self.uploaded or None,
            "duration_s": round(self.duration_s, 3),
            "rows_per_s": round(rate, 1),
        }


def _is_board_log(path: Path) -> bool:
    with open(path, encoding="ascii") as handle:
        return any(line.startswith(("MSR-FW", "PONG")) for line in handle)


#: What ``msr real stream --log FILE --force`` may replace: an earlier log of the board's lines.
BOARD_LOG_FILE = FileKind("a board log (the firmware's lines: MSR-FW, PONG, ...)", _is_board_log,
                          of_no_case=True)


class _BoardLog:
    """``--log FILE``: the board's lines go to a temporary sibling of FILE, moved over FILE only
    once the board has said something, so a failed connection (port that does not open, board
    that never answers) leaves the previous log byte for byte."""

    def __init__(self, path: str | Path | None) -> None:
        self.path = Path(path) if path is not None else None
        self.handle: Any = None
        self.lines = 0

    def write(self, line: str) -> None:
        if self.path is None:
            return
        if self.handle is None:
            tmp = self.path.with_name(f".{self.path.name}.partial{os.getpid()}")
            try:
                self.handle = open(tmp, "w")  # noqa: SIM115
            except OSError as exc:
                raise StreamError(f"--log {self.path}: cannot write: {exc.strerror or exc}") from None
        self.handle.write(line + "\n")
        self.lines += 1

    def close(self) -> None:
        """Move the log into place when the board said anything; drop it otherwise."""
        if self.handle is None:
            return
        tmp = Path(self.handle.name)
        self.handle.close()
        self.handle = None
        if self.lines and self.path is not None:
            os.replace(tmp, self.path)
        else:
            tmp.unlink(missing_ok=True)


class _LineReader:
    def __init__(self, port: Any, log: _BoardLog) -> None:
        self.port = port
        self.log = log
        self.pending = b""
        self.lines: list[str] = []

    def poll(self) -> list[str]:
        waiting = getattr(self.port, "in_waiting", 0) or 1
        data = self.port.read(waiting)
        if not data:
            return []
        self.pending += data
        *lines, self.pending = self.pending.split(b"\n")
        out = [line.decode("ascii", "replace").rstrip("\r") for line in lines]
        for line in out:
            self.log.write(line)
        self.lines.extend(out)
        return out

    def wait_for(self, accept: Callable[[str], bool], timeout_s: float, what: str,
                 port_url: str) -> str:
        """Poll until a line satisfies ``accept`` (returned) or raise StreamError after ``timeout_s``."""
        start = time.monotonic()
        while time.monotonic() - start < timeout_s:
            for line in self.poll():
                if accept(line):
                    return line
        raise StreamError(f"{port_url}: no answer to {what} within {timeout_s:g} s")


def _sync(port: Any, reader: _LineReader, port_url: str, sync_s: float) -> str:
    """PING until PONG (bytes sent before the board's UART is enabled are lost); returns the banner
    seen meanwhile ("" if none)."""
    start = time.monotonic()
    last_ping = -PING_INTERVAL_S
    banner = ""
    while time.monotonic() - start < sync_s:
        now = time.monotonic() - start
        if now - last_ping >= PING_INTERVAL_S:
            port.write(b"\nPING\n")
            last_ping = now
        for line in reader.poll():
            if line.startswith("MSR-FW"):
                banner = line
            if line == "PONG":
                return banner
    raise StreamError(f"{port_url}: no PONG within {sync_s:g} s (is the board running?)")


def query_status(port: Any, reader: _LineReader, port_url: str) -> BoardStatus:
    """Send ``STATUS`` and return the board's answer."""
    port.write(b"STATUS\n")
    line = reader.wait_for(lambda x: x.startswith("STATUS ") or x.startswith("ERR "),
                           COMMAND_TIMEOUT_S, "STATUS", port_url)
    status = parse_status(line)
    if status is None or not status.hash:
        raise StreamError(f"{port_url}: the board does not report its calibration ({line!r}); "
                          "flash a firmware with calibration upload")
    return status


def upload_calibration_lines(port: Any, reader: _LineReader, port_url: str,
                             calibration: Calibration) -> str:
    """Upload ``calibration`` (``CAL BEGIN`` / ``DATA`` / ``COMMIT``, each acknowledged); returns
    the board's ``OK CAL-COMMIT`` line.

    Raises
    ------
    CalibrationRefused
        The board refused it (``ERR cal-...``): the message holds its reason; the board keeps
        its previous calibration.
    """
    for line in calibration_upload_lines(calibration):
        port.write(line)
        answer = reader.wait_for(lambda x: x.startswith("OK CAL") or x.startswith("ERR "),
                                 COMMAND_TIMEOUT_S, line.decode().split("*")[0].strip()[:20],
                                 port_url)
        if answer.startswith("ERR "):
            raise CalibrationRefused(f"{port_url}: the board refused calibration "
                                     f"{calibration.name!r}: {answer}; it keeps its previous one")
    return answer


def _ensure_calibration(port: Any, reader: _LineReader, port_url: str, calibration: Calibration,
                        upload: bool, result: StreamResult) -> None:
    status = query_status(port, reader, port_url)
    wanted = calibration_hash(calibration)
    result.calibration_before = status.text
    if status.hash == wanted:
        return
    if not upload:
        raise StreamError(
            f"{port_url}: the board's active calibration is {status.calibration!r} (hash "
            f"{status.hash}, {status.source}), not {calibration.name!r} (hash {wanted}); "
            "nothing was sent (--no-upload)")
    result.uploaded = upload_calibration_lines(port, reader, port_url, calibration)
    after = query_status(port, reader, port_url)
    if after.hash != wanted:
        raise StreamError(f"{port_url}: after the upload the board reports {after.text!r}, "
                          f"expected hash {wanted}")


#: The board's answers to a ``STREAM`` it does not know (a firmware older than ``STREAM CURRENTS``).
_UNKNOWN_STREAM = ("ERR unknown-command", "ERR unknown-stream-mode")


def _start_stream(port: Any, reader: _LineReader, port_url: str, result: StreamResult,
                  deadline: float) -> int:
    """``STREAM`` (or ``STREAM CURRENTS`` for ``result.mode`` "currents"); returns the first credit."""
    command = STREAM_COMMANDS[result.mode]
    port.write(f"{command}\n".encode("ascii"))
    credit = 0
    started = False
    while not started:
        if time.monotonic() > deadline:
            raise StreamError(f"{port_url}: no answer to {command} in time")
        for line in reader.poll():
            if line.startswith("OK STREAM"):
                _check_stream_mode(line, port_url, result.mode)
                started = True
            elif result.mode != "field" and line.startswith(_UNKNOWN_STREAM):
                raise StreamError(f"{port_url}: the board does not know {command} ({line}): its firmware "
                                  "plays field rows only; nothing was played: flash a firmware with "
                                  "coil-current streaming (docs/firmware.md, \"Coil currents\")")
            elif line.startswith("CREDIT"):
                credit = _credit(line, port_url, result)
            elif line.startswith("SAFE "):
                result.safe = parse_safe(line)
                raise StreamError(f"{port_url}: STREAM refused: {line}")
    return credit


def _check_stream_mode(line: str, port_url: str, mode: str) -> None:
    """A currents session must be answered ``... mode=currents``: a board that answered otherwise
    would play the currents (A) as a field (mT). A field session's answer has no ``mode=`` (or
    ``mode=field``)."""
    answered = dict(kv.split("=", 1) for kv in line.split()[2:] if "=" in kv).get("mode", "field")
    if answered != mode:
        raise StreamError(f"{port_url}: the board answered {STREAM_COMMANDS[mode]} with {line!r}, a "
                          f"{answered} session, not {mode}; nothing was played and STOP was sent: check "
                          "the firmware version")


def _credit(line: str, port_url: str, result: StreamResult) -> int:
    """The rows a ``CREDIT n`` line allows; a malformed one (``CREDIT abc``) is a StreamError
    naming it (the stream is then stopped: the host cannot know how many rows it may send)."""
    credit = parse_credit(line)
    if credit is None:
        raise StreamError(f"{port_url}: the board sent a malformed credit line {line!r} after "
                          f"{result.rows_sent} rows (expected 'CREDIT <n>', n a whole number of "
                          "rows); the stream was stopped: check the firmware version and the link")
    return credit


def _send_rows(port: Any, reader: _LineReader, port_url: str, rows: list[tuple[str, str, str]],
               credit: int, corrupt_row: int | None, result: StreamResult, bar: Any,
               deadline: float) -> None:
    """Rows within the credit, then END; read reports until SAFE or the deadline."""
    n = len(rows)
    next_row = 0
    end_sent = False
    while result.safe is None and time.monotonic() < deadline:
        if next_row < n and next_row < credit:
            upto = min(n, credit)
            port.write(b"".join(format_row(i, rows[i], corrupt=(i == corrupt_row))
                                for i in range(next_row, upto)))
            next_row = upto
            result.rows_sent = next_row
        if next_row == n and not end_sent:
            port.write(f"END {n}\n".encode("ascii"))
            end_sent = True
        for line in reader.poll():
            if line.startswith("CREDIT"):
                credit = max(credit, _credit(line, port_url, result))
            elif line.startswith("DAC "):
                report = parse_dac(line)
                if report is not None:
                    result.dac.append(report)
                    if report.row is not None:
                        bar.update(1)
            elif line.startswith("SAFE "):
                result.safe = parse_safe(line)


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
    calibration: Calibration | None = None,
    upload: bool = True,
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
        Every line the board sent is written there (replaced only once the board answered).
    progress : bool
        Show a tqdm progress bar of rows played.
    calibration : Calibration, optional
        The calibration to play with: the board's active one is queried (``STATUS``) and, when its
        hash differs, ``calibration`` is uploaded first (or, with ``upload=False``, StreamError).
    upload : bool
        Allow that upload.

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
    CalibrationRefused
        The board refused the uploaded calibration (its reason in the message).
    """
    options = StreamOptions(baudrate, corrupt_row, timeout_s, log_path, progress, open_port, calibration,
                            upload)
    return _stream_rows(port_url, wire_rows_mT(field_T), "field", options)


def stream_currents(
    port_url: str,
    currents_A: NDArray[np.float64],
    *,
    baudrate: int = DEFAULT_BAUD,
    corrupt_row: int | None = None,
    timeout_s: float | None = None,
    log_path: str | Path | None = None,
    progress: bool = True,
    open_port: Callable[..., Any] | None = None,
    calibration: Calibration | None = None,
    upload: bool = True,
) -> StreamResult:
    """Stream coil currents ``currents_A`` (``(n, k)`` A, ``k`` at most :data:`BOARD_OUTPUTS`, one row
    per 10 ms; column K on output K, the outputs beyond ``k`` at 0 A) to the board at ``port_url``
    in a ``STREAM CURRENTS`` session: the board converts each current with the calibration's
    current limit, slew limit, transconductance and offset, without the actuation matrix
    (:meth:`~elastica_magnetic.hardware.calibration.DacCodeModel.currents_to_codes`).

    The options, the result and the errors are those of :func:`stream_field`; in addition a board
    whose firmware does not know ``STREAM CURRENTS`` (an older one) or that does not answer it
    with ``mode=currents`` is a :class:`StreamError` (``STOP`` sent, nothing played).

    Raises
    ------
    ValueError
        ``currents_A`` has more columns than the board has outputs.
    """
    currents = np.asarray(currents_A, dtype=np.float64)
    if currents.ndim != 2 or currents.shape[1] > BOARD_OUTPUTS:
        raise ValueError(f"currents_A must have shape (n, k) with k <= {BOARD_OUTPUTS} (the board's "
                         f"outputs), got {currents.shape}")
    rows = np.zeros((currents.shape[0], BOARD_OUTPUTS))
    rows[:, :currents.shape[1]] = currents
    options = StreamOptions(baudrate, corrupt_row, timeout_s, log_path, progress, open_port, calibration,
                            upload)
    return _stream_rows(port_url, wire_rows(rows), "currents", options)


@dataclass(frozen=True)
class StreamOptions:
    """The keyword options of :func:`stream_field` and :func:`stream_currents`, as they pass them on."""

    baudrate: int = DEFAULT_BAUD
    corrupt_row: int | None = None
    timeout_s: float | None = None
    log_path: str | Path | None = None
    progress: bool = True
    open_port: Callable[..., Any] | None = None
    calibration: Calibration | None = None
    upload: bool = True


def _stream_rows(port_url: str, rows: list[tuple[str, str, str]], mode: str,
                 options: StreamOptions) -> StreamResult:
    """One session of ``mode`` (a key of :data:`STREAM_COMMANDS`) sending the wire text ``rows``."""
    timeout_s = options.timeout_s
    if timeout_s is not None and not (math.isfinite(timeout_s) and timeout_s > 0):
        raise ValueError(f"timeout_s must be a positive time in s, got {timeout_s}")
    deadline_s = timeout_s if timeout_s is not None else len(rows) / PLAYBACK_HZ + 30.0
    result = StreamResult(rows_total=len(rows), mode=mode)
    log = _BoardLog(options.log_path)
    port = _open(port_url, options.baudrate, options.open_port)
    session = _Session(port, _LineReader(port, log), port_url, result)
    try:
        session.run(rows, deadline_s, options.calibration, options.upload, options.corrupt_row,
                    options.progress)
    finally:
        log.close()
    return result


@dataclass
class _Session:
    """One stream over an open ``port``: its steps, and the fail-safe end of every one."""

    port: Any
    reader: _LineReader
    port_url: str
    result: StreamResult

    def run(self, rows: list[tuple[str, str, str]], deadline_s: float,
            calibration: Calibration | None, upload: bool, corrupt_row: int | None,
            progress: bool) -> None:
        """Handshake, calibration, STREAM, the rows; STOP unless the board ended the stream with
        SAFE; the port is closed in every case."""
        import serial  # pyserial; imported here so the module loads without it

        from ..progress import progress_bar

        port, reader, port_url, result = self.port, self.reader, self.port_url, self.result
        bar = progress_bar(len(rows), "stream", "row", disable=not progress, leave=False)
        start = time.monotonic()
        finished = False
        try:
            result.banner = _sync(port, reader, port_url, min(SYNC_TIMEOUT_S, deadline_s))
            if calibration is not None:
                _ensure_calibration(port, reader, port_url, calibration, upload, result)
            deadline = start + deadline_s
            credit = _start_stream(port, reader, port_url, result, deadline)
            _send_rows(port, reader, port_url, rows, credit, corrupt_row, result, bar, deadline)
            finished = True
        except (OSError, serial.SerialException) as exc:
            raise StreamError(
                f"{port_url}: link lost after {result.rows_sent} of {len(rows)} rows ({exc}); a "
                "STOP was sent if the port still accepted it, and the board zeroes the coils when "
                "its rows run out") from None
        finally:
            result.duration_s = time.monotonic() - start
            result.lines = reader.lines
            bar.close()
            if not finished or result.safe is None:
                _stop(port)  # fail safe: the board goes to zero current on STOP
            with contextlib.suppress(Exception):
                port.close()


def port_url_problem(port_url: str) -> str | None:
    """What is wrong with the TCP port of a network URL (``socket://HOST:PORT``,
    ``rfc2217://HOST:PORT``): none given, not a number, outside 1 to 65535; ``None`` when it is
    fine or ``port_url`` is not such a URL (a device, ``loop://``). pyserial's own message for a
    missing port is "'<=' not supported between instances of 'int' and 'NoneType'"."""
    scheme, sep, _ = port_url.partition("://")
    if not sep or scheme.lower() not in NETWORK_SCHEMES:
        return None
    netloc = urllib.parse.urlsplit(port_url).netloc
    host, colon, port_text = netloc.rpartition(":")
    if not colon or netloc.endswith("]"):  # "HOST" or "[::1]": no port at all
        host, port_text = netloc, ""
    example = f"e.g. {scheme}://{host or '127.0.0.1'}:{EXAMPLE_TCP_PORT}"
    if not port_text:
        return f"{port_url}: the URL has no port; {example}"
    if not (port_text.isascii() and port_text.isdigit() and 1 <= int(port_text) <= 65535):
        return (f"{port_url}: the port {port_text!r} is not a TCP port (a whole number from 1 to "
                f"65535); {example}")
    return None


def _open(port_url: str, baudrate: int, open_port: Callable[..., Any] | None) -> Any:
    import serial

    problem = port_url_problem(port_url)
    if problem is not None:
        raise StreamError(f"{problem}; nothing was sent")
    opener = open_port or serial.serial_for_url
    try:
        return opener(port_url, baudrate=baudrate, timeout=READ_TIMEOUT_S)
    except (OSError, ValueError, serial.SerialException) as exc:
        raise StreamError(f"{port_url}: cannot open the port ({exc}); nothing was sent") from None


def upload_calibration(port_url: str, calibration: Calibration, *, baudrate: int = DEFAULT_BAUD,
                       open_port: Callable[..., Any] | None = None) -> dict[str, str]:
    """Upload ``calibration`` to the board at ``port_url`` (``msr real calibrate --upload``); returns
    the board's status before and after.

    Raises
    ------
    StreamError, CalibrationRefused
        No answer, or the board refused it (reason in the message; it keeps the previous one).
    """
    import serial

    port = _open(port_url, baudrate, open_port)
    reader = _LineReader(port, _BoardLog(None))
    try:
        _sync(port, reader, port_url, SYNC_TIMEOUT_S)
        before = query_status(port, reader, port_url)
        answer = upload_calibration_lines(port, reader, port_url, calibration)
        after = query_status(port, reader, port_url)
    except (OSError, serial.SerialException) as exc:
        raise StreamError(f"{port_url}: link lost during the upload ({exc})") from None
    finally:
        with contextlib.suppress(Exception):
            port.close()
    if after.hash != calibration_hash(calibration):
        raise StreamError(f"{port_url}: after the upload the board reports {after.text!r}")
    return {"before": before.text, "answer": answer, "after": after.text}


def _stop(port: Any) -> None:
    """Best effort: ask the board for its safe state (mid-scale DAC, zero current)."""
    with contextlib.suppress(Exception):
        port.write(b"\nSTOP\n")
        flush = getattr(port, "flush", None)
        if flush is not None:
            flush()
