"""The UART line protocol of the firmware (see ``stm32/src/app/link.h``).

Rows go out as ``<seq>,<mx>,<my>,<mz>*<CRC>`` with the field in mT written with 15 significant
digits (so the firmware's decimal parser reproduces exactly the double the host models) and a
CRC-16/CCITT-FALSE in 4 hex digits over everything before ``*``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic.field_csv import MILLITESLA

CRC16_POLY = 0x1021
CRC16_INIT = 0xFFFF
#: Significant digits of the mT values on the wire and in the flash table.
WIRE_DIGITS = 15

_DAC_RE = re.compile(r"^DAC (\d+|safe) (\d+) (\d+) (\d+)$")
_SAFE_RE = re.compile(r"^SAFE (\S+)(.*)$")
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


def wire_rows_mT(field_T: NDArray[np.float64]) -> list[tuple[str, str, str]]:
    """Text of every row (mT) for a field in tesla, ``(n, 3)``."""
    field_mT = np.asarray(field_T, dtype=np.float64) / MILLITESLA
    return [(wire_text(x), wire_text(y), wire_text(z)) for x, y, z in field_mT.tolist()]


def wire_values_mT(rows: list[tuple[str, str, str]]) -> NDArray[np.float64]:
    """The doubles the firmware parses from the wire text (``(n, 3)``, mT)."""
    return np.array([[float(v) for v in r] for r in rows], dtype=np.float64).reshape(-1, 3)


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


def parse_safe(line: str) -> SafeReport | None:
    """Parse a ``SAFE <reason> row=.. applied=.. [detail=..]`` line, or None."""
    m = _SAFE_RE.match(line.strip())
    if not m:
        return None
    kv = dict(_KV_RE.findall(m.group(2)))
    row = int(kv["row"]) if kv.get("row", "").isdigit() else None
    applied = int(kv["applied"]) if kv.get("applied", "").isdigit() else None
    return SafeReport(m.group(1), row, applied, kv.get("detail", ""), line.strip())
