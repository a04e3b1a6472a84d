"""Plausibility of calibration values, checked on the host before anything is sent or written.

A calibration whose numbers are syntactically fine can still be physically impossible: a matrix
written in mT/A where T/A is expected makes the board play 1/1000 of the field, measurements fed
in T instead of mT fit a matrix 1000x off. These checks name the likely unit mistake.

The absolute hardware ratings below are also compiled into the firmware
(``stm32/src/app/hw_ratings.h``; ``tests/hardware/test_plausibility.py`` checks both agree): the
board refuses an uploaded calibration outside them whatever the host says.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..plausibility import QUANTITIES

#: The firmware's fixed row rate (Hz); a calibration's ``tick_hz`` must equal it.
FIRMWARE_TICK_HZ = 100.0
#: Absolute ratings of the coil driver the firmware accepts (hw_ratings.h).
HW_MAX_CURRENT_A = 20.0
HW_MAX_SLEW_A_PER_S = 2000.0
HW_MAX_DAC_HALF_SPAN_V = 2.5
HW_MAX_ABS_OFFSET_V = 0.5
HW_MIN_TRANSCONDUCTANCE_A_PER_V = 0.01
HW_MAX_TRANSCONDUCTANCE_A_PER_V = 100.0
#: Slowest current slew (A/s) a coil driver plausibly has (host check only, not a hardware rating): a
#: coil of 100 mH on 24 V slews 240 A/s; below 1 A/s the field would take seconds to follow a
#: waveform of 100 rows per second (A/ms written where A/s is expected: 0.05 A/ms is 50 A/s).
MIN_PLAUSIBLE_SLEW_A_PER_S = 1.0
#: Largest 1-norm condition number of the actuation matrix (firmware and host alike).
MAX_MATRIX_CONDITION = 100.0

def _refuse_range(name: str, scale: float = 1.0) -> tuple[float, float]:
    """The refuse range of a quantity of the physical ranges' table, in units of ``scale``."""
    low, high = QUANTITIES[name].refuse
    return (low.value / scale, high.value / scale)  # type: ignore[union-attr]


#: Coil constant (|actuation matrix entry|) of Helmholtz-type coils, T/A: from about 10 uT/A
#: (a metre-sized pair with a few turns) to 50 mT/A (a centimetre-sized pair with ~1000 turns);
#: the table of physical ranges (:mod:`elastica_magnetic.plausibility`) holds it.
COIL_CONSTANT_RANGE_T_PER_A = _refuse_range("coil constant")
#: Units a matrix entry is often written in by mistake, with their size in T/A.
_MATRIX_UNIT_MISTAKES = QUANTITIES["coil constant"].mistakes

#: Fields a calibration measurement of such coils produces, mT (largest |field| of the data): the
#: fields coils make around a robot, from the table of physical ranges.
MEASURED_FIELD_RANGE_MT = _refuse_range("coil field", 1e-3)
#: Currents of such a measurement, A (largest |current| of the data).
MEASURED_CURRENT_RANGE_A = (1e-3, HW_MAX_CURRENT_A)
#: Condition number of the measured currents: above WARN the fit is reported as weak, above
#: REFUSE it is refused (coils driven together: drive each coil on its own).
CURRENT_CONDITION_WARN = 10.0
CURRENT_CONDITION_REFUSE = 100.0
#: Columns of an ``msr real calibrate`` measurements CSV: coil currents (A) and measured fields (mT);
#: the CLI reads them, the fit's messages name them.
CURRENT_COLUMNS = ("current_x_A", "current_y_A", "current_z_A")
FIELD_COLUMNS = ("field_x_mT", "field_y_mT", "field_z_mT")
#: A fit whose residual RMS on a field column exceeds this fraction of that column's own RMS explains
#: nothing (signs flipped, columns swapped, rows of different setups): refused.
FIT_RESIDUAL_FRACTION_REFUSE = 0.5
#: A matrix entry whose standard error exceeds this fraction of its coil's constant (the diagonal
#: entry of its column) is poorly determined: warned.
FIT_STD_ERROR_FRACTION_WARN = 0.1
_MILLITESLA = 1e-3


class PlausibilityError(ValueError):
    """A value that cannot be physically right; the message names the key and the likely mistake."""


def _matrix_entry_problem(value: float, where: str, diagonal: bool) -> str | None:
    """Diagonal entries (coil constants) must lie in the range; cross-coupling entries only below
    its top (they may be tiny or zero)."""
    low, high = COIL_CONSTANT_RANGE_T_PER_A
    magnitude = abs(value)
    if magnitude <= high and (not diagonal or magnitude >= low):
        return None
    if magnitude > high:
        likely = [unit for unit, size in _MATRIX_UNIT_MISTAKES if low <= magnitude * size <= high]
        hint = (f"it looks like {' or '.join(likely)} written where T/A is expected "
                f"(e.g. 2 mT/A is 0.002 T/A)" if likely else "check the unit: T/A is expected")
    else:
        hint = "check the unit: T/A is expected (2 mT/A is 0.002 T/A)"
    return (f"{where} = {value:g} T/A is outside {low:g}..{high:g} T/A, the range of "
            f"Helmholtz-type coils: {hint}")


#: A coil making this many times more field across its axis than along it has its channel swapped.
SWAP_RATIO = 10.0


def check_coil_axes(matrix: Sequence[Sequence[float]], source: str) -> None:
    """Refuse a fitted matrix (T/A) where a coil makes almost no field along its own axis (or
    :data:`SWAP_RATIO` times less than across it) but a coil's field along another: the coils'
    channels or the measurement columns are swapped (a unit mistake would shrink or grow every
    entry alike)."""
    low, high = COIL_CONSTANT_RANGE_T_PER_A
    a = np.abs(np.asarray(matrix, dtype=np.float64))
    names = "xyz"
    for j in range(3):
        i = int(np.argmax(a[:, j]))
        # the same mistake whichever pair: the coils' own cross-coupling (a few % of the axis's
        # field) may leave the swapped diagonal near zero or at a few % of the coil constant
        if i != j and low <= a[i, j] <= high and (a[j, j] < low or a[i, j] >= SWAP_RATIO * a[j, j]):
            raise PlausibilityError(
                f"{source}: coil {names[j]} (current_{names[j]}_A) makes {1e3 * a[i, j]:.3g} mT/A "
                f"along {names[i]} but {1e3 * a[j, j]:.3g} mT/A along {names[j]}, its own axis: the coils' "
                "channels or the columns of the measurements are swapped; fix the wiring or the "
                "column names and fit again")


def matrix_condition(matrix: Sequence[Sequence[float]]) -> float:
    """1-norm condition number ``||A||_1 ||inv(A)||_1`` (as the firmware computes it)."""
    a = np.asarray(matrix, dtype=np.float64)
    try:
        inverse = np.linalg.inv(a)
    except np.linalg.LinAlgError:
        return math.inf
    return float(np.linalg.norm(a, 1) * np.linalg.norm(inverse, 1))


def check_matrix(matrix: Sequence[Sequence[float]], source: str) -> None:
    """Refuse an actuation matrix (T/A) outside the range of Helmholtz-type coils or ill conditioned.

    Raises
    ------
    PlausibilityError
        A diagonal entry outside :data:`COIL_CONSTANT_RANGE_T_PER_A` or an off-diagonal one above
        it (the likely unit mistake named), or a condition number above
        :data:`MAX_MATRIX_CONDITION`; swapped channels first (:func:`check_coil_axes`: a swap
        leaves a diagonal entry near 0, which is no unit mistake).
    """
    check_coil_axes(matrix, source)
    for i, row in enumerate(matrix):
        for j, value in enumerate(row):
            problem = _matrix_entry_problem(float(value), f"actuation_matrix_T_per_A[{i}][{j}]",
                                            i == j)
            if problem:
                raise PlausibilityError(f"{source}: {problem}")
    cond = matrix_condition(matrix)
    if not cond <= MAX_MATRIX_CONDITION:
        raise PlausibilityError(
            f"{source}: actuation_matrix_T_per_A is ill conditioned (condition number {cond:.3g} > "
            f"{MAX_MATRIX_CONDITION:g}): the coils' fields are nearly parallel; remeasure it")


def check_drive(tick_hz: float, dac_half_span_V: float, transconductance_A_per_V: Sequence[float],
                input_offset_V: Sequence[float], current_limit_A: Sequence[float],
                slew_limit_A_per_s: Sequence[float], source: str) -> None:
    """Refuse amplifier, DAC, limit and tick values the firmware cannot use (units: Hz, V, A/V, V,
    A, A/s; three-element sequences per axis x, y, z)."""
    if tick_hz != FIRMWARE_TICK_HZ:
        raise PlausibilityError(
            f"{source}: tick_hz = {tick_hz:.12g}, but the firmware ticks at a fixed "
            f"{FIRMWARE_TICK_HZ:g} Hz (its slew limit would be applied {tick_hz / FIRMWARE_TICK_HZ:.12g}x "
            f"off); set tick_hz to {FIRMWARE_TICK_HZ:g} exactly")
    if not dac_half_span_V <= HW_MAX_DAC_HALF_SPAN_V:
        raise PlausibilityError(
            f"{source}: dac_half_span_V = {dac_half_span_V:g} V exceeds the DAC8563's "
            f"{HW_MAX_DAC_HALF_SPAN_V:g} V (internal reference, gain 2: 0..5 V around 2.5 V)")
    for i in range(3):
        g, off = transconductance_A_per_V[i], input_offset_V[i]
        limit, slew = current_limit_A[i], slew_limit_A_per_s[i]
        if not HW_MIN_TRANSCONDUCTANCE_A_PER_V <= abs(g) <= HW_MAX_TRANSCONDUCTANCE_A_PER_V:
            raise PlausibilityError(
                f"{source}: transconductance_A_per_V[{i}] = {g:g} A/V is outside "
                f"{HW_MIN_TRANSCONDUCTANCE_A_PER_V:g}..{HW_MAX_TRANSCONDUCTANCE_A_PER_V:g} A/V "
                "(mA/V written where A/V is expected?)")
        if not abs(off) <= HW_MAX_ABS_OFFSET_V:
            raise PlausibilityError(
                f"{source}: input_offset_V[{i}] = {off:g} V exceeds +-{HW_MAX_ABS_OFFSET_V:g} V "
                "(mV written where V is expected?)")
        if not limit <= HW_MAX_CURRENT_A:
            hint = " (mA written where A is expected?)" if limit / 1000.0 <= HW_MAX_CURRENT_A else ""
            raise PlausibilityError(
                f"{source}: current_limit_A[{i}] = {limit:g} A exceeds the hardware rating of "
                f"{HW_MAX_CURRENT_A:g} A{hint}")
        if slew < MIN_PLAUSIBLE_SLEW_A_PER_S:
            raise PlausibilityError(
                f"{source}: slew_limit_A_per_s[{i}] = {slew:g} A/s is below "
                f"{MIN_PLAUSIBLE_SLEW_A_PER_S:g} A/s: the coil would need {limit / slew:.3g} s to reach "
                f"its {limit:g} A limit, and no waveform of 100 rows per second would be played (A/ms "
                f"written where A/s is expected? {slew:g} A/ms is {1e3 * slew:g} A/s)")
        if not slew <= HW_MAX_SLEW_A_PER_S:
            raise PlausibilityError(
                f"{source}: slew_limit_A_per_s[{i}] = {slew:g} A/s exceeds the hardware rating of "
                f"{HW_MAX_SLEW_A_PER_S:g} A/s (mA/s written where A/s is expected?)")


def check_measurements(currents_A: NDArray[np.float64], fields_mT: NDArray[np.float64],
                       source: str) -> None:
    """Refuse calibration measurements whose magnitudes betray a unit mistake.

    ``currents_A`` and ``fields_mT`` are ``(n, 3)``: coil currents in A and fields in mT.
    """
    peak_field = float(np.max(np.abs(fields_mT))) if fields_mT.size else 0.0
    peak_current = float(np.max(np.abs(currents_A))) if currents_A.size else 0.0
    f_low, f_high = MEASURED_FIELD_RANGE_MT
    if peak_field < f_low:
        raise PlausibilityError(
            f"{source}: the largest field is {peak_field:g} mT, below {f_low:g} mT: the fields look "
            "like tesla written where the field_*_mT columns expect mT (multiply by 1000)")
    if peak_field > f_high:
        raise PlausibilityError(
            f"{source}: the largest field is {peak_field:g} mT, above {f_high:g} mT: the fields look "
            "like uT or gauss written where the field_*_mT columns expect mT")
    i_low, i_high = MEASURED_CURRENT_RANGE_A
    if peak_current > i_high:
        raise PlausibilityError(
            f"{source}: the largest current is {peak_current:g} A, above the hardware rating of "
            f"{i_high:g} A: the currents look like mA written where the current_*_A columns expect A "
            "(divide by 1000)")
    if peak_current < i_low:
        raise PlausibilityError(
            f"{source}: the largest current is {peak_current:g} A, below {i_low:g} A: too small to "
            "calibrate (or kA written where A is expected)")


def current_condition(currents_A: NDArray[np.float64]) -> float:
    """2-norm condition number of the ``(n, 3)`` measured currents (inf when rank < 3)."""
    s = np.linalg.svd(np.asarray(currents_A, dtype=np.float64), compute_uv=False)
    return float(s[0] / s[-1]) if s[-1] > 0 else math.inf


def check_fit_residuals(fields_T: NDArray[np.float64], residuals_T: NDArray[np.float64],
                        source: str) -> None:
    """Refuse a fit of ``field = A @ current`` that explains nothing.

    ``fields_T`` and ``residuals_T`` are ``(n, 3)`` in T. Residuals that are a large fraction of
    the fields mean the fields do not follow the currents linearly: no matrix is right then, and
    writing one would drive the coils with a wrong field.

    Raises
    ------
    PlausibilityError
        A field column whose residual RMS exceeds :data:`FIT_RESIDUAL_FRACTION_REFUSE` of its RMS.
    """
    field_rms = np.sqrt(np.mean(np.square(fields_T), axis=0))
    residual_rms = np.sqrt(np.mean(np.square(residuals_T), axis=0))
    bad = [i for i in range(3) if residual_rms[i] > FIT_RESIDUAL_FRACTION_REFUSE * field_rms[i]]
    if not bad:
        return
    numbers = "; ".join(f"{FIELD_COLUMNS[i]}: residual RMS {residual_rms[i] / _MILLITESLA:.3g} mT "
                        f"for a measured RMS of {field_rms[i] / _MILLITESLA:.3g} mT" for i in bad)
    raise PlausibilityError(
        f"{source}: the fitted matrix explains nothing: the residuals are more than "
        f"{FIT_RESIDUAL_FRACTION_REFUSE:.0%} of the measured fields ({numbers}), so the fields do not "
        f"follow the currents ({', '.join(CURRENT_COLUMNS)}) linearly. Likely causes: field signs "
        "flipped on some rows, columns swapped, rows from different setups in one file, or a "
        "constant background field (measure with every current at zero and subtract it); nothing was "
        "written")


def matrix_warnings(matrix_T_per_A: NDArray[np.float64], source: str) -> list[str]:
    """Why an actuation matrix (T/A, fitted or read from a file) may be wrong: a negative diagonal
    entry (a coil wired backwards, or a sign typo in a hand-edited file), or a coil that makes more
    field across its axis than along it (probe columns swapped, or coils cabled to the wrong
    amplifiers: a Helmholtz pair's field is along its axis)."""
    warnings = []
    diagonal = np.diag(matrix_T_per_A)
    for i in range(3):
        if diagonal[i] < 0:  # playable (the inverse copes), but rarely meant
            warnings.append(
                f"{source}: actuation_matrix_T_per_A[{i}][{i}] = {diagonal[i] / _MILLITESLA:.3g} "
                f"mT/A is negative: coil {'xyz'[i]} makes {FIELD_COLUMNS[i]} against "
                f"{CURRENT_COLUMNS[i]}: a coil wired backwards, or a current or probe sign "
                "convention opposite to the other axes; check the wiring if this is not meant")
    for j in range(3):  # column j: coil j
        i = int(np.argmax(np.abs(matrix_T_per_A[:, j])))
        if i != j:
            warnings.append(
                f"{source}: coil {'xyz'[j]} makes more field along {'xyz'[i]} "
                f"({matrix_T_per_A[i, j] / _MILLITESLA:.3g} mT/A, actuation_matrix_T_per_A[{i}][{j}]) "
                f"than along its own axis ({diagonal[j] / _MILLITESLA:.3g} mT/A): field columns "
                "swapped, or the coils cabled to the wrong amplifiers? A coil pair's field is along "
                "its axis")
    return warnings


def fit_warnings(matrix_T_per_A: NDArray[np.float64], std_error_T_per_A: NDArray[np.float64],
                 source: str) -> list[str]:
    """Why a fitted actuation matrix (T/A; standard errors T/A, NaN without spare rows) may be wrong:
    :func:`matrix_warnings`, or entries poorly determined compared with their coil's constant."""
    warnings = matrix_warnings(matrix_T_per_A, source)
    diagonal = np.diag(matrix_T_per_A)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.abs(std_error_T_per_A) / np.abs(diagonal)[None, :]  # column j: coil j
    ratio = np.where(np.isfinite(ratio), ratio, 0.0)
    i, j = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
    if ratio[i, j] > FIT_STD_ERROR_FRACTION_WARN:
        warnings.append(
            f"{source}: the standard error of actuation_matrix_T_per_A[{i}][{j}] is "
            f"{std_error_T_per_A[i, j] / _MILLITESLA:.3g} mT/A, {ratio[i, j]:.0%} of coil "
            f"{'xyz'[j]}'s constant {diagonal[j] / _MILLITESLA:.3g} mT/A (more than "
            f"{FIT_STD_ERROR_FRACTION_WARN:.0%}): the matrix is poorly determined; check for noisy "
            "or inconsistent rows, or measure more rows at larger currents")
    return warnings
