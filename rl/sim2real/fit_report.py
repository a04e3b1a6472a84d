"""The report of a fit of :mod:`.identify`: each fitted value with its standard error, interval and
verdict (:mod:`.identifiability`), each start's record and whether the starts agree, and the
warnings on the best start, the values not identifiable and a fit whose confirmation in the other
physics tells the two apart."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..cases.variations import Variation, get_value, scaled
from .identifiability import INTERVAL_SIGMAS, NEAR_BEST_CHI2

__all__ = ["AGREE_WITHIN", "AT_BOUND_LOG", "CONFIRM_RATIO", "SPEC_BETTER_BY", "at_bound", "fit_warnings",
           "fitted_values", "physics_warning", "spec_fits_better", "starts_report"]

#: Fraction by which the spec's own values must beat the fitted ones in the accurate physics for the
#: fit to be called an artifact of the training physics (a noisy fit of a robot that is the spec's
#: leaves the two about equal).
SPEC_BETTER_BY = 0.05
#: Two starts agree when their factors differ by less than this fraction.
AGREE_WITHIN = 0.01


def fitted_values(spec: Mapping[str, Any], fits: Sequence[Variation], x, sigma, bounds,
                  judged: Sequence[Mapping[str, Any]],
                  profile: Sequence[Mapping[str, Any]] = ()) -> dict[str, Any]:
    """Per fit: its keys, factor and its standard error, fitted and nominal values (SI) and their
    standard errors, whether the factor ended on a bound of the fit, its interval (factors) and
    whether it is identifiable (:func:`~.identifiability.judge_values`). A value not judged, or
    whose point the profile undercut (``stopped_short``), has no standard error (``None``); where
    the profile widened the interval, the standard error is its half-width (log factor) over
    ``INTERVAL_SIGMAS``, not the Jacobian's."""
    out = {}
    for k, fit in enumerate(fits):
        factor = float(np.exp(x[k]))
        # a point the profile undercut is not the minimum: the Jacobian there says nothing of it
        sigma_k = float(sigma[k]) if np.isfinite(sigma[k]) and "stopped_short" not in judged[k] else None
        interval = judged[k].get("interval")
        if sigma_k is not None and judged[k].get("interval_from") == "profile" and interval is not None:
            # the cost rose slower than the Jacobian said: the standard error the interval implies
            sigma_k = float(np.log(interval[1] / interval[0])) / (2.0 * INTERVAL_SIGMAS)
        out[fit.name] = {
            "keys": list(fit.keys),
            "factor": factor,
            "factor_sigma": None if sigma_k is None else factor * sigma_k,
            "values": {key: scaled(get_value(spec, key), factor) for key in fit.keys},
            "nominal_values": {key: get_value(spec, key) for key in fit.keys},
            "sigma": {key: None if sigma_k is None else scaled(get_value(spec, key), factor * sigma_k)
                      for key in fit.keys},
            "at_bound": at_bound(x[k], bounds),
            **judged[k],
        }
        # on the search's wall with a cost that rises away from it (the profile): the wall, not the
        # data, ended the fit (a flat value wanders to a wall too: its verdict stands)
        rises = any(p["value"] == k and p["cost_rise_over_s2"] >= NEAR_BEST_CHI2 for p in profile)
        if out[fit.name]["at_bound"] and rises:
            edge = float(np.exp(bounds[0] if x[k] - bounds[0] < bounds[1] - x[k] else bounds[1]))
            out[fit.name].update(identifiable=None, interval=None, reason=(
                f"not judged: the fit ended on the search's bound (x{edge:g} of the spec's value): the data "
                "ask for a value beyond it (a unit mistake in the spec, or another robot than the spec's?)"))
        if out[fit.name]["identifiable"] is None:  # not judged: no standard error either
            out[fit.name].update(factor_sigma=None, sigma=dict.fromkeys(fit.keys))
    return out


#: A fitted log factor this close to a bound of the search ended on it (0.1 % of the factor).
AT_BOUND_LOG = 1e-3


def at_bound(x: float, bounds: tuple[float, float]) -> bool:
    """Whether the log factor ``x`` ended on a bound of the search (``bounds``, log factors)."""
    return bool(x - bounds[0] <= AT_BOUND_LOG or bounds[1] - x <= AT_BOUND_LOG)


def starts_report(records: Sequence[dict[str, Any]], near: Sequence[bool], best: int
                  ) -> tuple[list[dict[str, Any]], bool | None]:
    """Each start's public record (factors, RMS, converged, near the best cost) and whether the
    starts agree (each ended near the best cost, its factors within AGREE_WITHIN of the best;
    ``None`` with fewer than two finished starts: nothing was compared)."""
    out, agree, x_best = [], True, records[best]["x"]
    finished = iter(near)
    for i, r in enumerate(records):
        entry = {"start_factors": r["start_factors"], "simulations": r["simulations"],
                 "converged": r["converged"], "message": r["message"], "stages": r["stages"],
                 "polish": r.get("polish"), "best": i == best}
        if r["x"] is not None:
            close = next(finished)
            same = bool(np.all(np.abs(np.exp(r["x"] - x_best) - 1) <= AGREE_WITHIN))
            entry.update(factors=np.exp(r["x"]).tolist(), rms_m=r["rms_m"], near_best=close)
            agree = agree and close and same
        out.append(entry)
    if sum(r["x"] is not None for r in records) < 2:
        return out, None
    return out, agree


def fit_warnings(best: Mapping[str, Any], judged: Sequence[Mapping[str, Any]],
                 fits: Sequence[Variation]) -> list[str]:
    """Warnings on the best start (stopped by the budget), on values whose profile found a lower
    cost (``stopped_short``) and on values not identifiable."""
    out = []
    if not best["converged"]:
        out.append(f"the best start did not converge ({best['message']}); raise --max-evaluations")
    for fit, entry in zip(fits, judged, strict=True):
        if "stopped_short" in entry:
            out.append(f"{fit.name}: {entry['stopped_short']['note']}")
        elif entry["identifiable"] is None:
            out.append(f"{fit.name}: identifiability {entry['reason']}")
        elif not entry["identifiable"]:
            out.append(f"{fit.name} is not identifiable from this trajectory: {entry['reason']}")
    return out


#: A confirmation residual this many times the fit's (or this many times smaller) says the two
#: physics tell the motion apart: values fitted in the training physics are then biased.
CONFIRM_RATIO = 2.0


def spec_fits_better(confirm: dict[str, Any]) -> str | None:
    """Why no fitted value is judged where the confirmation's physics (the accurate one, after a
    fit in the training physics) reproduces the motion better with the spec's own values than with
    the fitted ones: the fit moved the values to make up for its physics' error, not the robot's
    (on the accurate physics' own trajectory of a nominal robot, the length came out 5.5 % short,
    "identifiable"); ``None`` otherwise."""
    better = confirm["nominal_rms_m"] < (1.0 - SPEC_BETTER_BY) * confirm["rms_m"]
    if confirm["physics"] != "accurate" or not better:
        return None
    return (f"in the {confirm['physics']} physics the spec's own values reproduce the motion better "
            f"({1e3 * confirm['nominal_rms_m']:.4f} mm RMS) than the fitted ones "
            f"({1e3 * confirm['rms_m']:.4f} mm): the fit made up for its physics' error, not the "
            f"robot's; fit again with --physics {confirm['physics']}")


def physics_warning(fit_rms: float, confirm: dict[str, Any], physics: str) -> str | None:
    """The warning of a fit in the training physics whose accurate-physics confirmation leaves a
    residual :data:`CONFIRM_RATIO` times larger (the training physics' mass scaling matters for the
    motion) or smaller (the motion is the accurate physics', which the training physics cannot
    match); ``None`` otherwise, and for a fit in the accurate physics."""
    if physics != "training" or fit_rms <= 0.0:
        return None
    ratio = confirm["rms_m"] / fit_rms
    if 1.0 / CONFIRM_RATIO <= ratio <= CONFIRM_RATIO:
        return None
    how = ("fits the motion better" if ratio < 1.0 else "fits the motion worse")
    return (f"the fitted values leave {1e3 * confirm['rms_m']:.4f} mm RMS in the accurate physics and "
            f"{1e3 * fit_rms:.4f} mm in the training physics the fit ran in: the accurate physics {how}, "
            "so the two tell this motion apart and values fitted in the training physics are biased "
            "(their interval does not hold the model's error); fit again with --physics accurate")
