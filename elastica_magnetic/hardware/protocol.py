"""The UART line protocol of the firmware (see ``stm32/src/app/link.h``).

Rows go out as ``<seq>,<mx>,<my>,<mz>*<CRC>`` with the field in mT (or, in a ``STREAM CURRENTS``
session, the three outputs' coil currents in A) written with 15 significant digits (so the
firmware's decimal parser reproduces exactly the double the host models) and a CRC-16/CCITT-FALSE
in 4 hex digits over everything before ``*``.
"""

from __future__ import annotations

import re
import struct
import zlib
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic.field_csv import MILLITESLA

CRC16_POLY = 0x1021
CRC16_INIT = 0xFFFF
#: Significant digits of the mT values on the wire and in the flash table.
WIRE_DIGITS = 15

_DAC_RE = re.compile(r"^DAC (\d+|safe) (\d+) (\d+) (\d+)$")
_SAFE_RE = re.compile(r"^SAFE (\S+)(.*)$")
_CREDIT_RE = re.compile(r"^CREDIT ([0-9]+)$")
_KV_RE = re.compile(r"(\w+)=(\S+)")


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE of ``data`` (check value: ``crc16(b"123456789") == 0x29B1``)."""
    crc = CRC16_INIT
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ CRC16_POLY) if crc & 0x8000 else (crc << 1)
            crc &= 0xFFFF
    return crc


def wire_text(value_mT: float) -> str:
    """One field component (mT) as written on the wire and in the flash table."""
    return format(float(value_mT), f".{WIRE_DIGITS}g")


def wire_rows(values: NDArray[np.float64]) -> list[tuple[str, str, str]]:
    """Text of every row of ``values`` ``(n, 3)``, already in the unit the board reads (mT for a
    field stream, A for a ``STREAM CURRENTS`` one)."""
    rows = np.asarray(values, dtype=np.float64).reshape(-1, 3)
    return [(wire_text(x), wire_text(y), wire_text(z)) for x, y, z in rows.tolist()]


def wire_rows_mT(field_T: NDArray[np.float64]) -> list[tuple[str, str, str]]:
    """Text of every row (mT) for a field in tesla, ``(n, 3)``."""
    return wire_rows(np.asarray(field_T, dtype=np.float64) / MILLITESLA)


def wire_values(rows: list[tuple[str, str, str]]) -> NDArray[np.float64]:
    """The doubles the firmware parses from the wire text (``(n, 3)``, in the rows' unit)."""
    return np.array([[float(v) for v in r] for r in rows], dtype=np.float64).reshape(-1, 3)


def wire_values_mT(rows: list[tuple[str, str, str]]) -> NDArray[np.float64]:
    """The doubles the firmware parses from the wire text of a field (``(n, 3)``, mT)."""
    return wire_values(rows)


def format_row(seq: int, row: tuple[str, str, str], corrupt: bool = False) -> bytes:
    """Encode one row line; ``corrupt=True`` changes a digit after the CRC (fault injection)."""
    payload = f"{seq},{row[0]},{row[1]},{row[2]}"
    crc = crc16(payload.encode("ascii"))
    if corrupt:
        # Flip the last digit of the x value: still a valid number, but the CRC no longer matches.
        head, x = f"{seq},", row[0]
        pos = max(i for i, c in enumerate(x) if c.isdigit())
        x = x[:pos] + ("1" if x[pos] != "1" else "2") + x[pos + 1:]
        payload = head + ",".join((x, row[1], row[2]))
    return f"{payload}*{crc:04X}\n".encode("ascii")


@dataclass
class DacReport:
    """One ``DAC`` line: ``row`` is None for the safe-state (mid-scale) write."""

    row: int | None
    codes: tuple[int, int, int]


@dataclass
class SafeReport:
    """One ``SAFE`` line: why the outputs went to mid-scale."""

    reason: str
    row: int | None
    applied: int | None
    detail: str
    text: str


def parse_dac(line: str) -> DacReport | None:
    """Parse a ``DAC <row|safe> <x> <y> <z>`` line, or None."""
    m = _DAC_RE.match(line.strip())
    if not m:
        return None
    row = None if m.group(1) == "safe" else int(m.group(1))
    return DacReport(row, (int(m.group(2)), int(m.group(3)), int(m.group(4))))


def parse_credit(line: str) -> int | None:
    """The row count of a ``CREDIT <n>`` line (``n`` a non-negative integer: rows with
    ``seq < n`` may be sent), or None when the line is not one (``CREDIT abc``, ``CREDIT -1``)."""
    m = _CREDIT_RE.match(line.strip())
    return int(m.group(1)) if m else None


def parse_safe(line: str) -> SafeReport | None:
    """Parse a ``SAFE <reason> row=.. applied=.. [detail=..]`` line, or None."""
    m = _SAFE_RE.match(line.strip())
    if not m:
        return None
    kv = dict(_KV_RE.findall(m.group(2)))
    row = int(kv["row"]) if kv.get("row", "").isdigit() else None
    applied = int(kv["applied"]) if kv.get("applied", "").isdigit() else None
    return SafeReport(m.group(1), row, applied, kv.get("detail", ""), line.strip())


# --------------------------------------------------------------------------- calibration upload
#: Order of the 23 doubles in a calibration record (firmware: calib_store.c).
CALIBRATION_NAME_BYTES = 32
CALIBRATION_RECORD_BYTES = 23 * 8 + CALIBRATION_NAME_BYTES
#: Record bytes per ``CAL DATA`` line (96 hex digits; the line stays below the board's 128).
CAL_DATA_CHUNK_BYTES = 48
_STATUS_RE = re.compile(r"^STATUS(.*)$")


def calibration_record(calibration: Any) -> bytes:
    """The 216-byte calibration record the board stores (little-endian doubles + name).

    Order: actuation matrix row-major (T/A), transconductance (A/V), input offset (V), DAC half
    span (V), current limit (A), slew limit (A/s), tick rate (Hz), then the name in 32 bytes
    padded with NUL. ``calibration`` is a :class:`~elastica_magnetic.hardware.calibration.Calibration`.
    """
    cal = calibration
    values = [v for row in cal.actuation_matrix_T_per_A for v in row]
    values += [*cal.transconductance_A_per_V, *cal.input_offset_V, cal.dac_half_span_V,
               *cal.current_limit_A, *cal.slew_limit_A_per_s, cal.tick_hz]
    name = cal.name.encode("ascii")
    if len(name) >= CALIBRATION_NAME_BYTES:
        raise ValueError(f"calibration name {cal.name!r} longer than {CALIBRATION_NAME_BYTES - 1}")
    return struct.pack("<23d", *map(float, values)) + name.ljust(CALIBRATION_NAME_BYTES, b"\0")


def calibration_hash(calibration: Any) -> str:
    """CRC-32 (IEEE, as zlib) of :func:`calibration_record`, 8 lower-case hex digits: what the
    board reports as ``hash=`` for its active calibration."""
    return f"{zlib.crc32(calibration_record(calibration)) & 0xFFFFFFFF:08x}"


def calibration_upload_lines(calibration: Any) -> list[bytes]:
    """``CAL BEGIN``, the ``CAL DATA <offset> <hex>*<CRC16>`` lines, ``CAL COMMIT <crc32>``."""
    record = calibration_record(calibration)
    lines = [b"CAL BEGIN\n"]
    for offset in range(0, len(record), CAL_DATA_CHUNK_BYTES):
        payload = f"CAL DATA {offset} {record[offset:offset + CAL_DATA_CHUNK_BYTES].hex()}"
        lines.append(f"{payload}*{crc16(payload.encode('ascii')):04X}\n".encode("ascii"))
    lines.append(f"CAL COMMIT {calibration_hash(calibration)}\n".encode("ascii"))
    return lines


@dataclass
class BoardStatus:
    """A ``STATUS`` line: the active calibration (name, CRC-32 hash, ``compiled`` or ``flash``)."""

    state: str
    calibration: str
    hash: str
    source: str
    text: str


def parse_status(line: str) -> BoardStatus | None:
    """Parse ``STATUS state=.. calibration=.. hash=.. source=..``, or None."""
    m = _STATUS_RE.match(line.strip())
    if not m:
        return None
    kv = dict(_KV_RE.findall(m.group(1)))
    return BoardStatus(kv.get("state", ""), kv.get("calibration", ""), kv.get("hash", ""),
                       kv.get("source", ""), line.strip())
