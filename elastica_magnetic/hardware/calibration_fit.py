"""Fitting a coil system's actuation matrix ``A`` (T per A, ``field = A @ current``) from measured
pairs of currents and fields at the workspace centre: the least-squares fit, its residuals and
standard errors, and the checks that refuse measurements which cannot determine it (``msr real
calibrate``). The calibration that carries the result is :mod:`.calibration`'s."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .calibration import AXES, CalibrationError
from .plausibility import (
    CURRENT_COLUMNS,
    CURRENT_CONDITION_REFUSE,
    CURRENT_CONDITION_WARN,
    check_coil_axes,
    check_fit_residuals,
    current_condition,
    fit_warnings,
)

__all__ = ["ActuationFit", "fit_actuation_matrix"]


@dataclass
class ActuationFit:
    """Result of :func:`fit_actuation_matrix`.

    Attributes
    ----------
    matrix_T_per_A : ndarray
        Fitted 3x3 actuation matrix (T/A).
    residuals_T : ndarray
        ``(m, 3)`` measured minus fitted field (T), for the m distinct measurements.
    rms_residual_T : ndarray
        Per-axis RMS of the residuals (T).
    max_abs_residual_T : float
        Largest absolute residual (T).
    std_error_T_per_A : ndarray
        3x3 standard errors of the matrix entries (T/A) from the residual scatter, NaN with only
        3 distinct measurements (no degree of freedom left).
    current_condition : float
        2-norm condition number of the measured currents (1 when each coil was driven alone at
        equal amplitude).
    warnings : list of str
        Why the fit may be weak (condition number above
        :data:`~elastica_magnetic.hardware.plausibility.CURRENT_CONDITION_WARN`, a negative
        diagonal entry, standard errors large against a coil constant; see
        :func:`~elastica_magnetic.hardware.plausibility.fit_warnings`), rows repeated exactly,
        standard errors that cannot be estimated.
    measurements : int
        The distinct measurements fitted (a row repeating another exactly is counted once: a
        copy adds no information, and would shrink the residual scatter to nothing).
    """

    matrix_T_per_A: NDArray[np.float64]
    residuals_T: NDArray[np.float64]
    rms_residual_T: NDArray[np.float64]
    max_abs_residual_T: float
    std_error_T_per_A: NDArray[np.float64]
    current_condition: float
    warnings: list[str]
    measurements: int


def fit_actuation_matrix(currents_A: NDArray[np.float64], fields_T: NDArray[np.float64],
                         source: str = "measurements") -> ActuationFit:
    """Least-squares fit of ``A`` in ``field = A @ current`` from measured pairs.

    Parameters
    ----------
    currents_A : array, shape (n, 3)
        Coil currents (A) applied in each measurement.
    fields_T : array, shape (n, 3)
        Field measured at the workspace centre (T).
    source : str
        The measurements file, named in every message.

    Raises
    ------
    CalibrationError
        Wrong shapes, fewer than 3 measurements, non-finite data, or currents that do not excite
        all three coils independently (rank < 3, or a condition number above
        :data:`~elastica_magnetic.hardware.plausibility.CURRENT_CONDITION_REFUSE`).
    PlausibilityError
        A fit that explains nothing (see
        :func:`~elastica_magnetic.hardware.plausibility.check_fit_residuals`).
    """
    currents = np.asarray(currents_A, dtype=np.float64)
    fields = np.asarray(fields_T, dtype=np.float64)
    _check_fit_input(currents, fields, source)
    notes = []
    distinct = np.unique(np.hstack([currents, fields]), axis=0)
    if len(distinct) < len(currents):  # a copied row: no new measurement, and no scatter
        notes.append(f"{source}: {len(currents) - len(distinct)} row(s) repeat another row exactly (the same "
                     f"currents and fields, as a copy would): each counted once, {len(distinct)} "
                     "measurements fitted")
        measured, currents, fields = currents, distinct[:, :AXES], distinct[:, AXES:]
    else:
        measured = currents
    solution, _, rank, _ = np.linalg.lstsq(currents, fields, rcond=None)
    if rank < AXES:
        raise _too_few_directions(measured, int(rank), source)
    cond = current_condition(currents)
    columns = ", ".join(CURRENT_COLUMNS)
    if cond > CURRENT_CONDITION_REFUSE:
        raise CalibrationError(
            f"{source}: the measured currents ({columns}) are ill conditioned (condition number "
            f"{cond:.3g} > {CURRENT_CONDITION_REFUSE:g}): the coils were driven together, so their "
            "fields cannot be told apart; drive each coil on its own, at positive and negative currents")
    warnings = notes
    if cond > CURRENT_CONDITION_WARN:
        warnings.append(
            f"{source}: the measured currents' condition number {cond:.3g} exceeds "
            f"{CURRENT_CONDITION_WARN:g}: the matrix is poorly determined (see std_error); drive "
            "each coil on its own")
    matrix = solution.T
    residuals = fields - currents @ solution
    check_fit_residuals(fields, residuals, source)
    check_coil_axes(matrix, source)
    rms = np.sqrt(np.mean(residuals**2, axis=0))
    dof = currents.shape[0] - AXES
    if dof > 0:
        variance = np.sum(residuals**2, axis=0) / dof  # per field axis
        diag = np.diag(np.linalg.inv(currents.T @ currents))  # per current axis
        std_error = np.sqrt(np.outer(variance, diag))
    else:
        std_error = np.full((AXES, AXES), np.nan)
        warnings.append(f"{source}: {len(currents)} distinct measurements determine the {AXES * AXES} "
                        "matrix entries exactly: their standard errors cannot be estimated (none given); "
                        "measure more settings (each coil at positive and negative currents)")
    warnings += fit_warnings(matrix, std_error, source) + _background_warning(currents, fields, source)
    return ActuationFit(matrix, residuals, rms, float(np.max(np.abs(residuals))), std_error, cond,
                        warnings, len(currents))


#: A constant part of the fields is a background where it exceeds this many standard errors...
BACKGROUND_STD_ERRORS = 5.0
#: ... and this fraction of the measured fields' RMS.
BACKGROUND_FRACTION = 0.02


def _background_warning(currents: NDArray[np.float64], fields: NDArray[np.float64], source: str) -> list[str]:
    """A constant field the currents do not make (the Earth's, a magnet or steel near the probe),
    found by fitting ``field = A @ current + b``: the matrix fitted without ``b`` takes part of it
    for the coils'. Judged where the rows leave ``b`` a standard error (more than 4 of them)."""
    n = len(currents)
    if n <= AXES + 1:
        return []
    design = np.hstack([currents, np.ones((n, 1))])
    solution, _, rank, _ = np.linalg.lstsq(design, fields, rcond=None)
    if rank < AXES + 1:
        return []  # a constant current on every row: a background cannot be told from the coils
    offset = solution[AXES]
    residuals = fields - design @ solution
    sigma = np.sqrt(np.sum(residuals**2, axis=0) / (n - AXES - 1))
    std_error = sigma * np.sqrt(np.linalg.inv(design.T @ design)[AXES, AXES])
    field_rms = np.sqrt(np.mean(fields**2, axis=0))
    found = ((np.abs(offset) > BACKGROUND_STD_ERRORS * std_error)
             & (np.abs(offset) > BACKGROUND_FRACTION * field_rms))
    if not np.any(found):
        return []
    values = ", ".join(f"{1e3 * b:.3g}" for b in offset)
    return [f"{source}: the fields have a constant part the currents do not make, ({values}) mT: a "
            "background field (the Earth's, a magnet or steel near the probe) that the matrix, fitted "
            "without it, takes in part for the coils'; measure the fields with every current at zero and "
            "subtract them"]


def _check_fit_input(currents: NDArray[np.float64], fields: NDArray[np.float64], source: str) -> None:
    """Shapes, enough rows, finite values."""
    if currents.ndim != 2 or currents.shape[1] != AXES or fields.shape != currents.shape:
        raise CalibrationError(f"{source}: currents and fields must both have shape (n, 3), got "
                               f"{currents.shape} and {fields.shape}")
    if currents.shape[0] < AXES:
        raise CalibrationError(
            f"{source}: need at least 3 measurements (rows of {', '.join(CURRENT_COLUMNS)} and the "
            f"fields they made), got {currents.shape[0]}; drive each coil on its own, at positive "
            "and negative currents")
    if not (np.all(np.isfinite(currents)) and np.all(np.isfinite(fields))):
        raise CalibrationError(f"{source}: measurements contain non-finite values")


def _too_few_directions(currents: NDArray[np.float64], rank: int, source: str) -> CalibrationError:
    """Currents that cannot tell the three coils apart; identical rows said as such."""
    columns = ", ".join(CURRENT_COLUMNS)
    settings = np.unique(currents, axis=0)
    if len(settings) == 1:
        values = ", ".join(f"{v:g}" for v in settings[0])
        return CalibrationError(
            f"{source}: {len(currents)} rows, all the same currents ({columns} = {values} A): one "
            "setting cannot tell the three coils apart; drive each coil on its own, at positive and "
            "negative currents")
    return CalibrationError(
        f"{source}: the currents ({columns}) of the {len(currents)} rows ({len(settings)} different "
        f"settings) excite only {rank} independent direction(s); drive each coil on its own, at "
        "positive and negative currents")
