"""How far ``msr real identify``'s fitted values can be trusted: the residual against the tracker's
noise, and per fitted value an interval and a verdict (identifiable or not, and why).

Two sources of the interval, the larger one stated:

- the Jacobian at the best fit: ``INTERVAL_SIGMAS`` standard errors of the log factor from
  ``s^2 (J^T J)^-1`` (a direction the residuals do not change along has an infinite one: a
  pseudo-inverse would give it 0, a tight interval on a value the motion does not determine);
- the starts: the farthest factor reached by a start whose cost is within ``NEAR_BEST_CHI2 s^2``
  of the best (statistically as good a fit, so inside the profile interval; a flat or rough
  cost lets the starts stop far apart where the local Jacobian sees a slope).

A value whose interval reaches beyond ``IDENTIFIABLE_WITHIN`` of the factor is reported as not
identifiable, with the reason: the motion hardly depends on it (flat cost), it trades off
against another fitted value (their correlation), or the starts end apart at the same cost.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["CORRELATED", "IDENTIFIABLE_WITHIN", "INTERVAL_SIGMAS", "NEAR_BEST_CHI2",
           "RESIDUAL_BODY_FLAG", "RESIDUAL_FLAG", "first_halfwidths", "judge_values", "near_best",
           "profile_halfwidths", "residual_against_body", "residual_against_noise", "residual_variance",
           "uncertainty"]

#: Standard errors in the stated interval (about 95 %).
INTERVAL_SIGMAS = 2.0
#: Cost above the best (in units of the residual variance) of a start still as good as the best:
#: the 95 % point of chi-square with one degree of freedom.
NEAR_BEST_CHI2 = 3.84
#: Half-width of the interval (fraction of the factor) past which a value is not identifiable.
IDENTIFIABLE_WITHIN = 0.10
#: Correlation of two fitted values past which one is said to trade off against the other.
CORRELATED = 0.9
#: Residual RMS / the tracker's noise past which the model does not explain the data.
RESIDUAL_FLAG = 2.0
#: A fitted robot that misses the tracked points by this fraction of its length (RMS) does not
#: explain the motion, whatever the tracker's noise: its values are not judged.
RESIDUAL_BODY_FLAG = 0.25
#: The quick profile: its least step (log factor), how the step grows while the cost stays
#: flat, least-squares steps of each re-fit of the other values, their Jacobian step.
PROFILE_MIN_STEP = 0.01
PROFILE_GROWTH = 1.5
PROFILE_REFIT_STEPS = 3
PROFILE_DIFF_STEP = 0.02
#: Eigenvalues of ``J^T J`` below this fraction of the largest count as zero (a flat direction).
_SINGULAR = 1e-10


def residual_variance(residual: NDArray[np.float64], unknowns: int,
                      noise_m: float | None = None) -> tuple[float, str]:
    """``(s^2, where from)``: the variance (m^2) the intervals are measured in: the residual
    variance (residuals minus ``unknowns`` degrees of freedom), or the square of the tracker's
    stated noise ``noise_m`` (m) where that is larger. A fit far inside the stated noise (synthetic
    data, or an overstated noise) would otherwise claim intervals the stated noise cannot give:
    a value 16 % away that fits 8 times below it was called "identifiable within 1 %"."""
    s2 = float(residual @ residual) / max(residual.size - unknowns, 1)
    if noise_m is not None and noise_m**2 > s2:
        return noise_m**2, "noise"
    return s2, "residual"


def uncertainty(residual: NDArray[np.float64], jac: NDArray[np.float64], s2: float | None = None
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Standard errors of the log factors (``inf`` along a direction the residuals do not change)
    and their correlation matrix (``nan`` where a standard error is infinite):
    ``s^2 (J^T J)^-1``, ``s^2`` given (m^2, :func:`residual_variance`), else the residual variance
    (residuals minus unknowns degrees of freedom)."""
    if s2 is None:
        s2 = residual_variance(residual, jac.shape[1])[0]
    eigenvalues, vectors = np.linalg.eigh(jac.T @ jac)
    flat = eigenvalues <= _SINGULAR * max(float(eigenvalues.max()), 1e-300)
    weights = vectors**2  # (value, direction)
    inverse = 1.0 / np.where(flat, 1.0, eigenvalues)
    # a flat direction makes every value it touches infinitely uncertain
    touched = ((weights > 1e-12) & flat).any(axis=1)
    variance = s2 * (weights * np.where(flat, 0.0, inverse)).sum(axis=1)
    sigma = np.where(touched, np.inf, np.sqrt(variance))
    cov = s2 * (vectors * np.where(flat, 0.0, inverse)) @ vectors.T
    scale = np.sqrt(np.maximum(np.diag(cov), 1e-300))
    corr = cov / np.outer(scale, scale)
    corr[touched, :] = np.nan
    corr[:, touched] = np.nan
    return sigma, corr


def profile_halfwidths(residual_of: Callable[[NDArray[np.float64]], NDArray[np.float64]],
                       x_best: NDArray[np.float64], s2: float, start_half: NDArray[np.float64],
                       corr: NDArray[np.float64], sigma: NDArray[np.float64],
                       bounds: tuple[float, float]) -> tuple[NDArray[np.float64], list[dict[str, Any]]]:
    """A quick profile of each fitted value: fixed ``start_half`` (log factor) on either side of
    ``x_best``, the others re-fitted (a few simulations, from where the correlation predicts), is
    the cost at least ``NEAR_BEST_CHI2 s2`` (m^2) above the best? If not, the half-width grows by
    ``PROFILE_GROWTH`` until it is, or until it passes the identifiable width. Returns the
    confirmed half-widths (log factor; ``inf`` where the cost stays flat past the identifiable
    width, or ``start_half`` already passes it: no interval is stated, and the cost is looked at
    once each way at that width, for :func:`lower_cost_found`) and one record per profile point.
    ``residual_of(x)``: the residuals (m) at log factors ``x``."""
    best = residual_of(x_best)
    cost_best, threshold = float(best @ best), NEAR_BEST_CHI2 * s2
    widest = np.log1p(IDENTIFIABLE_WITHIN)
    halves, records = np.array(start_half, dtype=np.float64), []
    for k in range(len(x_best)):
        if not halves[k] <= widest:  # not identifiable already; a linearised interval this wide
            halves[k] = np.inf     # is not to be trusted (the cost is far from quadratic)
            for side in (-1.0, 1.0):  # one look each way: a lower cost there is a fit stopped short
                rise = _profile_point(residual_of, x_best, k, side * widest, corr, sigma, bounds) - cost_best
                records.append({"value": k, "log_step": side * widest, "cost_rise_over_s2": rise / s2})
            continue
        for side in (-1.0, 1.0):
            half = max(halves[k], PROFILE_MIN_STEP)
            while True:
                rise = _profile_point(residual_of, x_best, k, side * half, corr, sigma, bounds) - cost_best
                records.append({"value": k, "log_step": side * half, "cost_rise_over_s2": rise / s2})
                if rise >= threshold or half > widest:
                    break
                half *= PROFILE_GROWTH
            halves[k] = np.inf if half > widest and rise < threshold else max(halves[k], half)
    return halves, records


def lower_cost_found(profile: Sequence[dict[str, Any]], n_values: int
                     ) -> list[dict[str, Any] | None]:
    """Per fitted value, the profile point whose cost lies below the fit's best by more than the
    noise allows (``NEAR_BEST_CHI2`` residual variances; the lowest such point), or ``None``: where
    one exists the fit stopped short of its minimum, and a flat or wide cost cannot be told from
    it."""
    found: list[dict[str, Any] | None] = [None] * n_values
    for point in profile:
        k = point["value"]
        if point["cost_rise_over_s2"] < -NEAR_BEST_CHI2 and (
                found[k] is None or point["cost_rise_over_s2"] < found[k]["cost_rise_over_s2"]):
            found[k] = point
    return found


def _profile_point(residual_of: Callable[[NDArray[np.float64]], NDArray[np.float64]],
                   x_best: NDArray[np.float64], k: int, step: float, corr: NDArray[np.float64],
                   sigma: NDArray[np.float64], bounds: tuple[float, float]) -> float:
    """The lowest cost (m^2) found with value ``k`` fixed at ``x_best[k] + step``: the others
    start where the correlation predicts and are re-fitted by a few least-squares steps."""
    from scipy.optimize import least_squares

    x = np.array(x_best, dtype=np.float64)
    x[k] = np.clip(x[k] + step, *bounds)
    others = [j for j in range(len(x)) if j != k]
    for j in others:  # the conditional mean of a Gaussian: x_j moves by corr * sigma_j / sigma_k
        if np.isfinite(corr[j, k]) and np.isfinite(sigma[j]) and sigma[k] > 0:
            x[j] = np.clip(x[j] + corr[j, k] * sigma[j] / sigma[k] * step, *bounds)
    r = residual_of(x)
    if not others:
        return float(r @ r)
    lowest = [float(r @ r)]

    def fun(sub: NDArray[np.float64]) -> NDArray[np.float64]:
        y = x.copy()
        y[others] = sub
        out = residual_of(y)
        lowest[0] = min(lowest[0], float(out @ out))
        return out

    least_squares(fun, x[others], bounds=bounds, method="trf", diff_step=PROFILE_DIFF_STEP,
                  max_nfev=PROFILE_REFIT_STEPS)
    return lowest[0]


def near_best(costs: Sequence[float], s2: float) -> list[bool]:
    """Which starts ended within ``NEAR_BEST_CHI2 s2`` (m^2) of the best cost (m^2)."""
    best = min(costs)
    return [c - best <= NEAR_BEST_CHI2 * s2 for c in costs]


def first_halfwidths(sigma: NDArray[np.float64], x_best: NDArray[np.float64],
                     start_x: Sequence[NDArray[np.float64]], near: Sequence[bool]
                     ) -> tuple[NDArray[np.float64], list[str]]:
    """Per fitted value, the half-width of its interval (log factor) before the profile: the
    larger of ``INTERVAL_SIGMAS`` standard errors and the farthest start as good as the best
    (``near``: the caller counts only starts that converged), and
    which one it is (``"jacobian"``, ``"starts"``)."""
    close = np.array([x for x, ok in zip(start_x, near, strict=True) if ok])
    halves, sources = [], []
    for k in range(len(x_best)):
        jacobian_half = INTERVAL_SIGMAS * float(sigma[k])
        starts_half = float(np.abs(close[:, k] - x_best[k]).max()) if close.size else 0.0
        halves.append(max(jacobian_half, starts_half))
        sources.append("jacobian" if jacobian_half >= starts_half else "starts")
    return np.array(halves), sources


def judge_values(names: Sequence[str], x_best: NDArray[np.float64], halves: NDArray[np.float64],
                 sources: Sequence[str], corr: NDArray[np.float64], jac: NDArray[np.float64],
                 s2: float, profile: Sequence[dict[str, Any]] | None = None) -> list[dict[str, Any]]:
    """Per fitted value: the interval of its factor (``halves``: half-widths, log factor), where
    it comes from (``sources``), and whether it is identifiable (else the reason); ``None``, not
    judged and no interval, where a value would be called not identifiable and a point of the
    ``profile`` lies lower than the fit's best (:func:`lower_cost_found`). An identifiable value
    with such a point keeps its interval (the profile rose past the threshold on both sides: it
    brackets the minimum) and gets ``stopped_short`` (where the lower cost lies, and a note): the
    fitted point is not the minimum, and its standard error is withdrawn."""
    out = []
    lower = lower_cost_found(profile, len(names)) if profile is not None else [None] * len(names)
    for k in range(len(names)):
        half = float(halves[k])
        identifiable = bool(np.isfinite(half) and np.expm1(half) <= IDENTIFIABLE_WITHIN)
        entry: dict[str, Any] = {  # no interval where the cost stays flat past the identifiable width
            "interval": ([float(np.exp(x_best[k] - half)), float(np.exp(x_best[k] + half))]
                         if np.isfinite(half) else None),
            "interval_from": sources[k],
            "identifiable": identifiable,
        }
        # not at its minimum: a value the cost seemed not to fix is not judged (one whose profile
        # rose on both sides within the identifiable width brackets the minimum: its interval stands)
        if (point := lower[k]) is not None and not identifiable:
            factor = float(np.exp(x_best[k] + point["log_step"]))
            entry.update(identifiable=None, interval=None, reason=(
                f"not judged: the fit stopped short of its minimum (the profile found a cost "
                f"{-point['cost_rise_over_s2']:.3g} residual variances lower at factor x{factor:.4g}, "
                "the others re-fitted); raise --max-evaluations or give more --starts"))
        elif point is not None:  # its interval brackets the minimum; the fit's point is not it
            factor = float(np.exp(x_best[k] + point["log_step"]))
            entry["stopped_short"] = {
                "factor": factor, "cost_below_best_over_s2": -point["cost_rise_over_s2"],
                "note": (f"the fit stopped short of its minimum: the profile found a cost "
                         f"{-point['cost_rise_over_s2']:.3g} residual variances lower at factor "
                         f"x{factor:.4g}, inside the interval (which holds the minimum); the fitted "
                         "value is not the minimum and has no standard error: raise --max-evaluations "
                         "or give more --starts")}
        elif not identifiable:
            entry["reason"] = _reason(k, names, corr, jac, s2, sources[k])
        out.append(entry)
    return out


def _reason(k: int, names: Sequence[str], corr: NDArray[np.float64], jac: NDArray[np.float64],
            s2: float, source: str) -> str:
    """Why value ``k`` is not identifiable: a flat cost (changing it alone by the identifiable
    width moves the residuals less than the noise), a correlation with another fitted value, or
    starts that end apart at the same cost."""
    alone = float(np.linalg.norm(jac[:, k])) * np.log1p(IDENTIFIABLE_WITHIN)
    if alone**2 < NEAR_BEST_CHI2 * s2:
        return (f"flat cost: changing it alone by {100 * IDENTIFIABLE_WITHIN:g} % changes the "
                "residuals by less than the noise (the motion hardly depends on it)")
    norms = np.maximum(np.linalg.norm(jac, axis=0), 1e-300)
    cosine = (jac.T @ jac) / np.outer(norms, norms)  # where the covariance says nothing (flat)
    others = [(abs(float(corr[k, j] if np.isfinite(corr[k, j]) else cosine[k, j])), names[j])
              for j in range(len(names)) if j != k]
    if others and max(others)[0] >= CORRELATED:
        r, other = max(others)
        return (f"correlated with {other} (|correlation| {r:.3f}): the motion fixes a combination "
                "of the two, not each")
    if source == "starts":
        return "the starts end apart at the same cost (flat or rough cost along this value)"
    if source == "profile":
        return (f"flat cost: fixed {100 * IDENTIFIABLE_WITHIN:g} % away and the others re-fitted, "
                "the cost rises less than the noise allows")
    return "flat cost: its standard error is wide"


def residual_against_noise(rms_m: float, noise_m: float | None) -> tuple[dict[str, Any], list[str]]:
    """``residual_vs_noise`` (the fit's residual RMS / the tracker's noise per coordinate, both m)
    and the warnings it calls for: above :data:`RESIDUAL_FLAG` the fitted model does not explain
    the data (a parameter missing from ``--fit`` or a wrong one), so the intervals do not hold."""
    if noise_m is None:
        return {"residual_vs_noise": None,
                "residual_judged": "cannot be judged: no --noise-m (the tracker's noise) given"}, []
    ratio = rms_m / noise_m
    verdict = {"residual_vs_noise": ratio, "noise_m": noise_m,
               "residual_judged": "above the noise" if ratio > RESIDUAL_FLAG else "at the noise"}
    if ratio <= RESIDUAL_FLAG:
        return verdict, []
    return verdict, [
        f"the residual RMS {1e3 * rms_m:.4g} mm is {ratio:.1f} x the tracker's noise "
        f"({1e3 * noise_m:.4g} mm): the fitted model does not explain the data (a value that "
        "differs is missing from --fit, or a fitted one is wrong), so the fitted values may be "
        "biased and their intervals do not hold"]


def residual_against_body(rms_m: float, length_m: float) -> str | None:
    """Why values fitted with a residual RMS of ``rms_m`` (m) on a body ``length_m`` (m) long are
    not judged, where it passes :data:`RESIDUAL_BODY_FLAG` of the length (the model explains none
    of the motion: a tracker in millimetres read as metres, another robot or recording), else
    ``None``. It needs no ``--noise-m``."""
    if not rms_m > RESIDUAL_BODY_FLAG * length_m:
        return None
    return (f"not judged: the fitted robot misses the tracked points by {1e3 * rms_m:.4g} mm RMS, "
            f"{rms_m / length_m:.2g} x its {1e3 * length_m:.4g} mm body: the model does not explain "
            "this motion (values in millimetres given as metres? another robot than the spec's, or "
            "another recording than the waveform's?)")
