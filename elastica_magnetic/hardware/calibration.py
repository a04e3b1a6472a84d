"""The coil calibration shared by the firmware and the host.

The chain from field to DAC code (identical, operation for operation, to
``stm32/src/app/calibration.c``; both use IEEE doubles without fused multiply-add):

1. ``b = field_mT * 1e-3`` (T)
2. ``I = inv(A) @ b`` (A), with ``A`` the measured actuation matrix (T per A) inverted by the
   adjugate
3. ``I`` clamped to ``+-current_limit_A`` per axis, then to ``I_prev +- slew_limit_A_per_s / tick_hz``
4. ``V = I / transconductance_A_per_V + input_offset_V`` (V, relative to the 2.5 V mid-scale)
5. ``code = clamp(32768 + round_half_away(V / dac_half_span_V * 32767), 0, 65535)``

A coil-current row (``STREAM CURRENTS``, :meth:`DacCodeModel.currents_to_codes`) gives ``I`` in A
for the three outputs and starts at step 3.

Mid-scale (32768, 0 A) is the safe state.
"""

from __future__ import annotations

import difflib
import json
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic.hardware.plausibility import (
    check_drive,
    check_matrix,
    matrix_warnings,
)
from elastica_magnetic.io import atomic_write_text, byte_order_mark_problem
from elastica_magnetic.plausibility import warn_implausible
from elastica_magnetic.result_file import FileKind

from ..io import missing_folder_hint

AXES = 3
#: The coil pairs in the order of a field row and of the DAC channels.
AXIS_NAMES = ("x", "y", "z")
TESLA_PER_MILLITESLA = 1e-3
DAC_MIDSCALE = 32768
DAC_HALF_RANGE = 32767.0
DAC_CODE_MIN = 0
DAC_CODE_MAX = 65535
#: A determinant below this times the product of the row 1-norms counts as singular (as in C).
MIN_RELATIVE_DET = 1e-9
#: From 2**52 on every double is an integer.
EXACT_INTEGER_LIMIT = 4503599627370496.0
_NAME_RE = re.compile(r"^[A-Za-z0-9_.-]{1,31}$")  # the board keeps 31 characters
#: What a calibration's name may be, for messages.
CALIBRATION_NAME_RULE = "must be 1-31 characters of letters, digits, '_', '.', '-'"


def _is_calibration_json(path: Path) -> bool:
    data = json.loads(path.read_text(encoding="utf-8-sig"))
    return isinstance(data, dict) and "actuation_matrix_T_per_A" in data


#: What ``msr real calibrate --out FILE --force`` may replace: an earlier calibration.
CALIBRATION_FILE = FileKind("a calibration JSON (with actuation_matrix_T_per_A)", _is_calibration_json,
                            of_no_case=True)


def is_calibration_name(name: object) -> bool:
    """Whether ``name`` can be a calibration's name (compiled into the firmware, kept by the board:
    see :data:`CALIBRATION_NAME_RULE`)."""
    return isinstance(name, str) and bool(_NAME_RE.match(name))

Matrix3 = list[list[float]]


class CalibrationError(ValueError):
    """A calibration file or value that cannot be used; the message names the file and key."""


@dataclass
class Calibration:
    """Calibration constants, SI units (see ``stm32/calibration/default.json``).

    Attributes
    ----------
    name : str
        Identifier compiled into the firmware banner (letters, digits, ``_.-``).
    actuation_matrix_T_per_A : list of list of float
        3x3 matrix ``A`` with ``field [T] = A @ coil currents [A]``.
    transconductance_A_per_V : list of float
        Amplifier gain per axis, coil current per input volt (A/V), nonzero.
    input_offset_V : list of float
        Amplifier input voltage (relative to mid-scale) that gives 0 A, per axis (V).
    dac_half_span_V : float
        Output swing from mid-scale to full scale (2.5 V with the internal reference, gain 2).
    current_limit_A : list of float
        Largest coil current magnitude per axis (A), > 0.
    slew_limit_A_per_s : list of float
        Largest current rate of change per axis (A/s), > 0.
    tick_hz : float
        Row rate (100 Hz).
    description : str
        Free text (where and how it was measured).
    extra : dict
        The other notes of :data:`NOTE_KEYS` (``estimates``), kept as written.
    """

    name: str
    actuation_matrix_T_per_A: Matrix3
    transconductance_A_per_V: list[float]
    input_offset_V: list[float]
    dac_half_span_V: float
    current_limit_A: list[float]
    slew_limit_A_per_s: list[float]
    tick_hz: float = 100.0
    description: str = ""
    extra: dict[str, Any] = field(default_factory=dict)

    def to_json_dict(self) -> dict[str, Any]:
        """The JSON object written by :func:`save_calibration`."""
        out: dict[str, Any] = {
            "name": self.name,
            "description": self.description,
            "actuation_matrix_T_per_A": [list(map(float, r)) for r in self.actuation_matrix_T_per_A],
            "transconductance_A_per_V": list(map(float, self.transconductance_A_per_V)),
            "input_offset_V": list(map(float, self.input_offset_V)),
            "dac_half_span_V": float(self.dac_half_span_V),
            "current_limit_A": list(map(float, self.current_limit_A)),
            "slew_limit_A_per_s": list(map(float, self.slew_limit_A_per_s)),
            "tick_hz": float(self.tick_hz),
        }
        out.update(self.extra)
        return out


_VECTOR_KEYS = ("transconductance_A_per_V", "input_offset_V", "current_limit_A",
                "slew_limit_A_per_s")
_REQUIRED_KEYS = ("name", "actuation_matrix_T_per_A", "dac_half_span_V", *_VECTOR_KEYS)
#: Free-text notes a calibration may carry: where it was measured, how each estimate was reached
#: (``stm32/calibration/yao2023.json``).
NOTE_KEYS = ("description", "estimates")
#: Every key a calibration JSON may hold; any other (a typo, a key in another unit) is refused.
CALIBRATION_KEYS = (*_REQUIRED_KEYS, "tick_hz", *NOTE_KEYS)


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise CalibrationError(f"{where}: expected a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise CalibrationError(f"{where}: non-finite value {value!r}")
    return v


def _vector(value: Any, where: str) -> list[float]:
    if not isinstance(value, list) or len(value) != AXES:
        raise CalibrationError(f"{where}: expected a list of {AXES} numbers (x, y, z), got {value!r}")
    return [_number(v, f"{where}[{i}]") for i, v in enumerate(value)]


def calibration_from_dict(data: dict[str, Any], source: str = "calibration") -> Calibration:
    """Validate a parsed JSON object and build a :class:`Calibration`.

    Raises
    ------
    CalibrationError
        Unknown key (with its close match), missing key, wrong shape, non-finite or non-positive
        value, or a singular matrix; the message names ``source`` and the key.
    PlausibilityError
        Values no Helmholtz coil set and coil driver can have (a matrix in mT/A, a current limit
        in mA, ``tick_hz`` other than the firmware's 100 Hz...), see
        :mod:`elastica_magnetic.hardware.plausibility`.
    """
    if not isinstance(data, dict):
        raise CalibrationError(f"{source}: expected a JSON object")
    _refuse_unknown_keys(data, source)  # first: a misspelt key also leaves its right one missing
    missing = [k for k in _REQUIRED_KEYS if k not in data]
    if missing:
        raise CalibrationError(f"{source}: missing key(s) {', '.join(missing)}")
    name = data["name"]
    if not is_calibration_name(name):
        raise CalibrationError(
            f"{source}: name {CALIBRATION_NAME_RULE}: {name!r}"
        )
    matrix_raw = data["actuation_matrix_T_per_A"]
    if not isinstance(matrix_raw, list) or len(matrix_raw) != AXES:
        raise CalibrationError(f"{source}: actuation_matrix_T_per_A must be 3 rows of 3 numbers")
    matrix = [_vector(r, f"{source}: actuation_matrix_T_per_A[{i}]") for i, r in enumerate(matrix_raw)]
    vectors = {k: _vector(data[k], f"{source}: {k}") for k in _VECTOR_KEYS}
    half_span = _number(data["dac_half_span_V"], f"{source}: dac_half_span_V")
    tick_hz = _number(data.get("tick_hz", 100.0), f"{source}: tick_hz")
    for key in ("current_limit_A", "slew_limit_A_per_s"):
        for i, v in enumerate(vectors[key]):
            if not v > 0:
                raise CalibrationError(f"{source}: {key}[{i}] must be > 0, got {v}")
    for i, v in enumerate(vectors["transconductance_A_per_V"]):
        if v == 0:
            raise CalibrationError(f"{source}: transconductance_A_per_V[{i}] must be nonzero")
    if not half_span > 0:
        raise CalibrationError(f"{source}: dac_half_span_V must be > 0, got {half_span}")
    if not tick_hz > 0:
        raise CalibrationError(f"{source}: tick_hz must be > 0, got {tick_hz}")
    if invert3(matrix) is None:
        raise CalibrationError(f"{source}: actuation_matrix_T_per_A is singular: {matrix}")
    check_matrix(matrix, source)
    check_drive(tick_hz, half_span, vectors["transconductance_A_per_V"], vectors["input_offset_V"],
                vectors["current_limit_A"], vectors["slew_limit_A_per_s"], source)
    return Calibration(
        name=name,
        actuation_matrix_T_per_A=matrix,
        transconductance_A_per_V=vectors["transconductance_A_per_V"],
        input_offset_V=vectors["input_offset_V"],
        dac_half_span_V=half_span,
        current_limit_A=vectors["current_limit_A"],
        slew_limit_A_per_s=vectors["slew_limit_A_per_s"],
        tick_hz=tick_hz,
        description=str(data.get("description", "")),
        extra={k: data[k] for k in NOTE_KEYS if k in data and k != "description"},
    )


def _refuse_unknown_keys(data: dict[Any, Any], source: str) -> None:
    """Refuse a key a calibration does not have (ignored, a misspelt ``transconductance_A_per_mV``
    would leave the value the user meant unused), naming the close match and the keys it takes."""
    unknown = [str(k) for k in data if k not in CALIBRATION_KEYS]
    if not unknown:
        return
    fmt = data.get("format")
    if isinstance(fmt, str) and "actuation_matrix_T_per_A" not in data:  # another msr file: say that
        raise CalibrationError(f"{source}: not a calibration JSON: its format is {fmt!r}, another file msr "
                               "writes (a shipped policy's policy.json is 'msr-policy-v1'), without an "
                               "actuation_matrix_T_per_A; give the file msr real calibrate writes (e.g. "
                               "stm32/calibration/default.json)")
    close = difflib.get_close_matches(unknown[0], CALIBRATION_KEYS, n=2, cutoff=0.8)
    hint = f"; did you mean {' or '.join(close)}?" if close else ""
    raise CalibrationError(f"{source}: {unknown[0]}: unknown key{hint} (a calibration takes: "
                           f"{', '.join(CALIBRATION_KEYS)})")


def _unique_keys(pairs: list[tuple[str, Any]], path: Path) -> dict[str, Any]:
    """A JSON object's pairs as a dict, a key given twice refused (json keeps the last silently:
    a limit written twice would be the second, unseen)."""
    keys = [key for key, _ in pairs]
    twice = sorted({key for key in keys if keys.count(key) > 1})
    if twice:
        raise CalibrationError(f"{path}: {', '.join(twice)}: given twice; give each key once")
    return dict(pairs)


def load_calibration(path: str | Path) -> Calibration:
    """Read and validate a calibration JSON file (see :func:`calibration_from_dict`); what
    :func:`~elastica_magnetic.hardware.plausibility.matrix_warnings` finds in its matrix is an
    :class:`~elastica_magnetic.plausibility.ImplausibleValueWarning` (``msr`` prints it)."""
    path = Path(path)
    if path.is_dir():
        raise CalibrationError(f"{path}: is a folder, not a calibration file (a JSON file written by "
                               "'msr real calibrate')")
    if not path.is_file():
        raise CalibrationError(f"{path}: no such calibration file{missing_folder_hint(path)}")
    try:
        text = path.read_text(encoding="utf-8")
        problem = byte_order_mark_problem(path, text)
        if problem is not None:  # else json's "Unexpected UTF-8 BOM (decode using utf-8-sig)"
            raise CalibrationError(problem)
        data = json.loads(text, object_pairs_hook=lambda pairs: _unique_keys(pairs, path))
    except UnicodeDecodeError as exc:
        raise CalibrationError(f"{path}: not UTF-8 text (byte {exc.start}): a calibration is a "
                               "JSON file written by 'msr real calibrate'") from None
    except json.JSONDecodeError as exc:
        spec_like = re.search(r"^\s*\[(robot|actuation|task)[\].]", text, re.MULTILINE) is not None
        csv_like = "," in text.partition("\n")[0] and not text.lstrip().startswith(("{", "["))
        hint = (": it is a spec file (TOML with a [robot] table), a robot's, not its coils' "
                "calibration: give the JSON 'msr real calibrate' writes from measured currents and "
                "fields (or stm32/calibration/yao2023.json)" if spec_like else
                ": it reads as a CSV (measurements?); a calibration is the JSON file 'msr real calibrate "
                f"{path.name} --out CAL.json' writes from measured currents and fields" if csv_like else
                ": a calibration is a JSON file written by 'msr real calibrate'")
        raise CalibrationError(f"{path}: not valid JSON ({exc}){hint}") from None
    calibration = calibration_from_dict(data, str(path))
    for warning in matrix_warnings(np.asarray(calibration.actuation_matrix_T_per_A), str(path)):
        warn_implausible(warning)
    return calibration


def save_calibration(path: str | Path, calibration: Calibration) -> Path:
    """Write ``calibration`` as JSON (validated first; atomically)."""
    data = calibration.to_json_dict()
    calibration_from_dict(data, str(path))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return atomic_write_text(path, json.dumps(data, indent=2) + "\n")


def default_calibration_path() -> Path:
    """``stm32/calibration/default.json`` of this checkout."""
    return Path(__file__).resolve().parents[2] / "stm32" / "calibration" / "default.json"


def invert3(m: Sequence[Sequence[float]]) -> Matrix3 | None:
    """Inverse of a 3x3 matrix by the adjugate, exactly as the firmware computes it.

    Returns None when the matrix is singular (same criterion as the firmware).
    """
    c00 = m[1][1] * m[2][2] - m[1][2] * m[2][1]
    c01 = m[1][2] * m[2][0] - m[1][0] * m[2][2]
    c02 = m[1][0] * m[2][1] - m[1][1] * m[2][0]
    det = m[0][0] * c00 + m[0][1] * c01 + m[0][2] * c02
    scale = 1.0
    for i in range(AXES):
        scale *= abs(m[i][0]) + abs(m[i][1]) + abs(m[i][2])
    if not math.isfinite(det) or not abs(det) > MIN_RELATIVE_DET * scale:
        return None
    return [
        [c00 / det, (m[0][2] * m[2][1] - m[0][1] * m[2][2]) / det,
         (m[0][1] * m[1][2] - m[0][2] * m[1][1]) / det],
        [c01 / det, (m[0][0] * m[2][2] - m[0][2] * m[2][0]) / det,
         (m[0][2] * m[1][0] - m[0][0] * m[1][2]) / det],
        [c02 / det, (m[0][1] * m[2][0] - m[0][0] * m[2][1]) / det,
         (m[0][0] * m[1][1] - m[0][1] * m[1][0]) / det],
    ]


def round_half_away(x: float) -> float:
    """Round half away from zero, as ``calib_round_half_away`` in C."""
    if not abs(x) < EXACT_INTEGER_LIMIT:
        return x
    if x >= 0.0:
        t = float(int(x))
        return t + 1.0 if x - t >= 0.5 else t
    t = float(int(-x))
    return -(t + 1.0) if -x - t >= 0.5 else -t


def volts_to_code(volts: float, half_span_V: float) -> int:
    """Amplifier input voltage (V from mid-scale) to DAC code, rounded and clamped."""
    scaled = volts / half_span_V * DAC_HALF_RANGE
    if not math.isfinite(scaled):
        return DAC_MIDSCALE
    scaled = min(max(scaled, -float(DAC_CODE_MAX)), float(DAC_CODE_MAX))
    code = float(DAC_MIDSCALE) + round_half_away(scaled)
    return int(min(max(code, float(DAC_CODE_MIN)), float(DAC_CODE_MAX)))


class DacCodeModel:
    """Stateful model of the firmware's field-to-code conversion (slew state included).

    Call :meth:`reset` where the firmware resets (start of a stream or table, safe state).
    """

    def __init__(self, calibration: Calibration) -> None:
        inverse = invert3(calibration.actuation_matrix_T_per_A)
        if inverse is None:
            raise CalibrationError("actuation matrix is singular")
        self.calibration = calibration
        self.inverse_A_per_T = inverse
        dt = 1.0 / calibration.tick_hz
        self.max_step_A = [s * dt for s in calibration.slew_limit_A_per_s]
        self.last_current_A = [0.0, 0.0, 0.0]

    def reset(self) -> None:
        """Forget the slew history (next row slews from 0 A)."""
        self.last_current_A = [0.0, 0.0, 0.0]

    def codes(self, mag_mT: Sequence[float]) -> tuple[int, int, int]:
        """DAC codes (x, y, z) for one row of field in **mT** (the firmware's input unit):
        ``calib_field_to_codes``."""
        b = [float(v) * TESLA_PER_MILLITESLA for v in mag_mT]
        if not all(math.isfinite(v) for v in b):
            return (DAC_MIDSCALE, DAC_MIDSCALE, DAC_MIDSCALE)
        currents = []
        for i in range(AXES):
            row = self.inverse_A_per_T[i]
            currents.append(row[0] * b[0] + row[1] * b[1] + row[2] * b[2])
        return self._limited_codes(currents)

    def currents_to_codes(self, current_A: Sequence[float]) -> tuple[int, int, int]:
        """DAC codes of outputs 0, 1, 2 for one row of coil currents in **A** (a ``STREAM
        CURRENTS`` row): ``calib_currents_to_codes``, the field path without the matrix. A
        non-finite current gives mid-scale on every output, the slew history unchanged."""
        currents = [float(v) for v in current_A]
        if not all(math.isfinite(v) for v in currents):
            return (DAC_MIDSCALE, DAC_MIDSCALE, DAC_MIDSCALE)
        return self._limited_codes(currents)

    def _limited_codes(self, currents: Sequence[float]) -> tuple[int, int, int]:
        """The tail both paths share (``currents_to_codes`` in C): current limit, slew limit,
        ``V = I / g + offset``, code; updates the slew history."""
        cal = self.calibration
        out = []
        for i in range(AXES):
            current = currents[i]
            limit = cal.current_limit_A[i]
            if current > limit:
                current = limit
            elif current < -limit:
                current = -limit
            last = self.last_current_A[i]
            step = self.max_step_A[i]
            if current - last > step:
                current = last + step
            elif current - last < -step:
                current = last - step
            self.last_current_A[i] = current
            volts = current / cal.transconductance_A_per_V[i] + cal.input_offset_V[i]
            out.append(volts_to_code(volts, cal.dac_half_span_V))
        return (out[0], out[1], out[2])


def expected_dac_codes(calibration: Calibration, rows_mT: NDArray[np.float64]) -> NDArray[np.int64]:
    """Codes the firmware writes for consecutive rows (field in mT), from a reset state.

    Returns an ``(n_rows, 3)`` integer array.
    """
    model = DacCodeModel(calibration)
    rows_mT = np.asarray(rows_mT, dtype=np.float64)
    return np.array([model.codes(r) for r in rows_mT.tolist()], dtype=np.int64).reshape(-1, AXES)


def expected_current_codes(calibration: Calibration, rows_A: NDArray[np.float64]) -> NDArray[np.int64]:
    """Codes the firmware writes for consecutive coil-current rows (A of outputs 0, 1, 2, a
    ``STREAM CURRENTS`` session), from a reset state. Returns an ``(n_rows, 3)`` integer array."""
    model = DacCodeModel(calibration)
    rows_A = np.asarray(rows_A, dtype=np.float64)
    return np.array([model.currents_to_codes(r) for r in rows_A.tolist()],
                    dtype=np.int64).reshape(-1, AXES)


@dataclass
class ClippingReport:
    """How far the coils fall short of a waveform (see :func:`clipping_report`).

    Attributes
    ----------
    rows : int
        Rows whose field the coils cannot reach (current limit or DAC span); slew-limited rows are
        reached late, not clipped, and counted apart.
    current_rows, max_current_A, current_limit_A : int, float, float
        Rows that need more than ``current_limit_A`` on some axis; the largest current needed (A)
        and the limit of that axis.
    slew_rows, max_slew_A_per_s : int, float
        Rows that need a faster current change than ``slew_limit_A_per_s`` (from 0 A at the
        first row); the fastest change needed after the current limit (A/s).
    dac_rows : int
        Rows whose amplifier input voltage exceeds the DAC's span.
    first_row : int or None
        First clipped row (0-based data row).
    first_slew_row : int or None
        First slew-limited row (0-based data row).
    max_rate_A_per_s, slew_limit_A_per_s : float
        The waveform's own fastest current change (A/s, from 0 A at the first row; the lag of
        earlier rows not added), on the axis most above its slew limit, and that limit (A/s).
    max_lag_mT : float
        The largest field the coils lag behind the (current-limited) waveform, mT: how far a
        slew-limited row falls short when it is played.
    """

    rows: int
    current_rows: int
    max_current_A: float
    current_limit_A: float
    slew_rows: int
    max_slew_A_per_s: float
    dac_rows: int
    first_row: int | None
    first_slew_row: int | None = None
    max_rate_A_per_s: float = 0.0
    slew_limit_A_per_s: float = 0.0
    max_lag_mT: float = 0.0
    current_axis: str = ""
    slew_axis: str = ""

    def describe(self) -> str:
        """One line: how many rows and by how much."""
        parts = []
        if self.current_rows:
            on = f" of the {self.current_axis} coils" if self.current_axis else ""
            parts.append(f"{self.current_rows} row(s) need more than the current limit{on} (up to "
                         f"{self.max_current_A:.4g} A for a limit of {self.current_limit_A:.4g} A)")
        if self.dac_rows:
            parts.append(f"{self.dac_rows} row(s) exceed the DAC's output span")
        return (f"{self.rows} row(s) clipped, first at data row {self.first_row}: " + "; ".join(parts)
                if self.rows else "no row clipped")

    def describe_slew(self) -> str:
        """One line: how many rows are slew-limited and by how much."""
        if not self.slew_rows:
            return "no row slew-limited"
        return (f"{self.slew_rows} row(s) slew-limited, first at data row {self.first_slew_row}: "
                f"the waveform changes a current{f' ({self.slew_axis} coils)' if self.slew_axis else ''} "
                f"at up to {self.max_rate_A_per_s:.4g} A/s for a slew "
                f"limit of {self.slew_limit_A_per_s:.4g} A/s, so the field lags it by up to "
                f"{self.max_lag_mT:.3g} mT")


def slew_warning(report: ClippingReport, field_csv: str | Path, calibration_name: str) -> str | None:
    """The warning for a waveform the coils follow late (slew-limited rows), ``None`` without.
    Such rows are played (reached late, not clipped: a step from 0 A is slew-limited by design),
    so they are not refused; but a user should know the coils will not follow the waveform."""
    if not report.slew_rows:
        return None
    return (f"{field_csv}: the coils of calibration {calibration_name!r} follow this waveform late: "
            f"{report.describe_slew()}; check the calibration's slew_limit_A_per_s (A/s), or slow "
            "the waveform")


def clipping_report(calibration: Calibration, rows_mT: NDArray[np.float64]) -> ClippingReport:
    """Rows of a waveform (field in mT) that the firmware clamps to the current limit or the DAC
    span, and rows it slew-limits, in the order :class:`DacCodeModel` applies them (from a reset
    state)."""
    cal = calibration
    inverse = np.array(invert3(cal.actuation_matrix_T_per_A))
    currents = np.asarray(rows_mT, dtype=np.float64).reshape(-1, AXES) * TESLA_PER_MILLITESLA @ inverse.T
    limit = np.array(cal.current_limit_A)
    over = np.abs(currents) > limit
    ratio = np.abs(currents) / limit
    clamped = np.clip(currents, -limit, limit)
    max_step = np.array(cal.slew_limit_A_per_s) / cal.tick_hz
    slew_rows = np.zeros(len(clamped), dtype=bool)
    dac_rows = np.zeros(len(clamped), dtype=bool)
    last = np.zeros(AXES)
    max_slew, max_lag_T = 0.0, 0.0
    matrix = np.array(cal.actuation_matrix_T_per_A)
    gain = np.array(cal.transconductance_A_per_V)
    offset = np.array(cal.input_offset_V)
    for k, target in enumerate(clamped):
        step = target - last
        slewed = np.abs(step) > max_step
        if slewed.any():
            slew_rows[k] = True
            max_slew = max(max_slew, float(np.max(np.abs(step))) * cal.tick_hz)
        last = last + np.clip(step, -max_step, max_step)
        max_lag_T = max(max_lag_T, float(np.linalg.norm(matrix @ (target - last))))
        dac_rows[k] = bool(np.any(np.abs(last / gain + offset) > cal.dac_half_span_V))
    clipped = over.any(axis=1) | dac_rows
    # the waveform's own fastest change (A/s, from 0 A), on the axis most above its slew limit
    rates = np.abs(np.diff(clamped, axis=0, prepend=np.zeros((1, AXES)))) * cal.tick_hz
    worst = (np.unravel_index(int(np.argmax(rates / (max_step * cal.tick_hz))), rates.shape)
             if rates.size else (0, 0))
    axis = np.unravel_index(int(np.argmax(ratio)), ratio.shape)[1] if ratio.size else 0
    return ClippingReport(
        rows=int(clipped.sum()),
        current_rows=int(over.any(axis=1).sum()),
        max_current_A=float(np.abs(currents).reshape(-1, AXES)[:, axis].max()) if ratio.size else 0.0,
        current_limit_A=float(limit[axis]),
        slew_rows=int(slew_rows.sum()),
        max_slew_A_per_s=max_slew,
        dac_rows=int(dac_rows.sum()),
        first_row=int(np.flatnonzero(clipped)[0]) if clipped.any() else None,
        first_slew_row=int(np.flatnonzero(slew_rows)[0]) if slew_rows.any() else None,
        max_rate_A_per_s=float(rates[worst]) if rates.size else 0.0,
        slew_limit_A_per_s=float(cal.slew_limit_A_per_s[worst[1]]),
        max_lag_mT=max_lag_T / TESLA_PER_MILLITESLA,
        current_axis=AXIS_NAMES[axis] if over.any() else "",
        slew_axis=AXIS_NAMES[worst[1]] if slew_rows.any() else "",
    )


def calibration_header(calibration: Calibration) -> str:
    """C header defining ``MSR_CALIBRATION_NAME`` and ``MSR_CALIBRATION_PARAMS`` (exact doubles)."""

    def num(v: float) -> str:
        return repr(float(v))

    def vec(v: Sequence[float]) -> str:
        return "{" + ", ".join(num(x) for x in v) + "}"

    cal = calibration
    matrix = "{" + ", ".join(vec(r) for r in cal.actuation_matrix_T_per_A) + "}"
    return "\n".join([
        "/* Generated by elastica_magnetic.hardware.calibration from the calibration JSON. */",
        "/* Do not edit: change the JSON and rebuild. */",
        "#ifndef MSR_CALIBRATION_GEN_H",
        "#define MSR_CALIBRATION_GEN_H",
        "",
        f'#define MSR_CALIBRATION_NAME "{cal.name}"',
        "#define MSR_CALIBRATION_PARAMS \\",
        "    { \\",
        f"        .actuation_T_per_A = {matrix}, \\",
        f"        .transconductance_A_per_V = {vec(cal.transconductance_A_per_V)}, \\",
        f"        .input_offset_V = {vec(cal.input_offset_V)}, \\",
        f"        .dac_half_span_V = {num(cal.dac_half_span_V)}, \\",
        f"        .current_limit_A = {vec(cal.current_limit_A)}, \\",
        f"        .slew_limit_A_per_s = {vec(cal.slew_limit_A_per_s)}, \\",
        f"        .tick_hz = {num(cal.tick_hz)}, \\",
        "    }",
        "",
        "#endif",
        "",
    ])
