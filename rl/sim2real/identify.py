"""Spec values from a measured trajectory (what ``msr identify`` runs).

The robot of a spec is simulated under the waveform that was played, and chosen spec values
(dotted keys, groups varied together by one factor: see :mod:`.variations`) are fitted so that the
simulated points move as the measured ones (:mod:`.tracking`): a bounded nonlinear least-squares
fit (scipy's ``least_squares``, trust-region reflective, forward-difference Jacobian) of the log
factors of the nominal values, in the training physics; the residuals are the differences of the
points' displacements from the first frame (x and y, m) at every measured frame. The fitted robot
is then run in the accurate physics to confirm the fit.

Uncertainty: the standard error of each factor from the Jacobian at the solution
(``s^2 (J^T J)^-1``, ``s^2`` the residual variance), propagated to the value. It assumes
independent residuals; a tracker's errors are correlated from frame to frame, so take it as a
lower bound.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic.presets import ACTION_PERIOD
from elastica_magnetic.specfile import SpecError, describe_robot, read_spec

from ..cases.variations import (
    Variation,
    apply_values,
    get_value,
    magnitude_of,
    parse_group,
    resolve_variations,
    scaled,
)
from .tracking import MIN_DURATION_S, MeasuredTrajectory, check_against_robot, points_at_rows

__all__ = ["DIFF_STEP", "FIT_BOUNDS", "FitBudgetExceeded", "FitModel", "fit_horizons", "identify",
           "load_spec", "parse_fit", "write_identified"]

#: Bounds of a fitted factor (x the nominal value).
FIT_BOUNDS = (0.2, 5.0)
#: Relative step of the forward-difference Jacobian (of the log factors).
DIFF_STEP = 1e-2
#: Fits on growing horizons (each twice the last, the last the whole trajectory): the motion over
#: a short time depends smoothly on the values, the whole of it less so (contacts switch).
STAGES = 3
#: Scale of the fitted log factors and the relative step that ends a fit.
X_SCALE = 1.0
XTOL = 1e-8
#: Step of the log factors that ends the polish (0.1 %), and how far the polish may go from the
#: least-squares solution (log factor).
POLISH_XTOL = 1e-3
POLISH_REACH = 0.2
#: Residual of every frame of a simulation that diverged, m.
DIVERGED_RESIDUAL_M = 1.0


def load_spec(robot: str | Path) -> dict[str, Any]:
    """The complete spec (every default written out) of a spec file or a shipped case name: a case
    spec as ``Case.to_dict()`` without its name, a robot-only spec with its ``[robot]`` and
    ``[physics]`` tables completed. SpecError names a bad file and key."""
    from ..cases.case import case_names, load_case

    text = str(robot)
    if text in case_names():
        data = load_case(text).to_dict()
        del data["name"]
        return data
    path = Path(robot)
    if path.suffix != ".toml" and not path.exists():
        raise SpecError(f"--robot {text}: not a shipped case ({', '.join(case_names())}) and not a "
                        "spec file (.toml)")
    raw = read_spec(path)
    if "actuation" in raw:
        data = load_case(path).to_dict()
        if "name" not in raw:
            del data["name"]
        return data
    return {**raw, **describe_robot(raw, str(path)).tables}


def parse_fit(text: str, spec: Mapping[str, Any]) -> list[Variation]:
    """``--fit KEY[,KEY...]``: each item a dotted key, keys joined by ``+`` (fitted as one factor)
    or a group name; checked against ``spec``."""
    items = [item.strip() for item in text.split(",")]
    if not text.strip() or any(not item for item in items):
        raise ValueError(f"--fit {text!r}: expected KEY[,KEY...] (dotted spec keys such as "
                         "robot.magnetization.magnitude, keys joined by + fitted together, or groups)")
    fits = []
    for item in items:
        name, keys = parse_group(item, f"--fit {item!r}")
        fits.append(Variation(name, keys, *FIT_BOUNDS))
    return resolve_variations(fits, spec, "--fit")


@dataclass
class FitModel:
    """The simulated motion of the measured points for given factors of the fitted values."""

    spec: dict[str, Any]
    fits: list[Variation]
    fields: NDArray[np.float64]  # (n, 3) T, the waveform played
    measured: MeasuredTrajectory
    physics: str = "training"
    evaluations: int = 0
    diverged: int = 0
    _cache: dict = field(default_factory=dict, repr=False)

    def values(self, factors: Sequence[float]) -> dict[str, Any]:
        """Dotted key -> value for one factor per fit (a table key's value: the scaled table)."""
        return {key: scaled(get_value(self.spec, key), float(f))
                for fit, f in zip(self.fits, factors, strict=True) for key in fit.keys}

    def displacements(self, factors: Sequence[float], physics: str | None = None) -> NDArray[np.float64]:
        """``(n_frames, k, 2)`` simulated displacements (m) of the points from the first measured
        frame, at the measured frames' times (cached per factors and physics)."""
        from elastica_magnetic.fields import TabulatedField
        from elastica_magnetic.openloop import run_open_loop

        key = (tuple(float(f) for f in factors), physics or self.physics)
        if key in self._cache:
            return self._cache[key]
        self.evaluations += 1
        spec = apply_values(self.spec, self.values(factors))
        robot = describe_robot(spec, "fitted spec").robot(physics or self.physics)
        rows = max(int(np.ceil(self.measured.duration / ACTION_PERIOD - 1e-9)), 1)
        result = run_open_loop(robot, TabulatedField(self.fields), rows * ACTION_PERIOD,
                               n_shapes=rows + 1)
        at_rows = points_at_rows(self.measured, result.trajectory, result.shapes)
        t_rows = result.trajectory.t_s.to_numpy()
        sampled = np.empty((self.measured.times.shape[0], at_rows.shape[1], 2))
        for j in range(at_rows.shape[1]):
            for c in range(2):
                sampled[:, j, c] = np.interp(self.measured.times, t_rows, at_rows[:, j, c])
        self._cache[key] = sampled - sampled[:1]
        return self._cache[key]

    def residuals(self, factors: Sequence[float], physics: str | None = None) -> NDArray[np.float64]:
        """Simulated minus measured displacements at every frame, each point's x and y centred on
        its mean over the frames (the tracker's origin is free, and a centred residual does not
        carry the first frame's tracking error into every other frame), flattened (m)."""
        from elastica_magnetic.simulation import SimulationDiverged

        measured = self.measured.displacements()
        try:
            simulated = self.displacements(factors, physics)
        except SimulationDiverged:  # values far from the robot's: as bad as a residual can be
            self.diverged += 1
            return np.full(measured.size, DIVERGED_RESIDUAL_M)
        return ((simulated - simulated.mean(axis=0)) - (measured - measured.mean(axis=0))).ravel()


def _rms(residuals: NDArray[np.float64]) -> float:
    return float(np.sqrt(np.mean(residuals**2)))


def fit_horizons(measured: MeasuredTrajectory, stages: int) -> list[float]:
    """The growing horizons of the fit (s): the last is the whole trajectory, each earlier one half
    the next (at least :data:`~.tracking.MIN_DURATION_S` past the first frame)."""
    out = [measured.duration]
    while len(out) < stages and out[0] / 2 - measured.times[0] >= MIN_DURATION_S:
        out.insert(0, out[0] / 2)
    return out


class FitBudgetExceeded(ValueError):
    """The fit used its simulations without converging."""


def _least_squares(model: FitModel, x0, bounds, diff_step: float, budget: int, progress, done: int):
    """One ``least_squares`` run on ``model`` from ``x0`` (log factors), at most ``budget``
    simulations."""
    from scipy.optimize import least_squares

    def fun(log_factors: NDArray[np.float64]) -> NDArray[np.float64]:
        if model.evaluations >= budget:
            raise FitBudgetExceeded(
                f"the fit used its {done + budget} simulations without converging; raise "
                "--max-evaluations or fit fewer keys")
        r = model.residuals(np.exp(log_factors))
        if progress is not None:
            progress(done + model.evaluations, _rms(r))
        return r

    return least_squares(fun, x0, bounds=bounds, method="trf", diff_step=diff_step, x_scale=X_SCALE,
                         ftol=1e-10, xtol=XTOL, gtol=1e-10)


def _polish(model: FitModel, x0, bounds, budget: int, progress, done: int):
    """Powell's derivative-free line searches from the least-squares solution, on the whole
    trajectory: the forward-difference Jacobian of a motion with contacts is rough at the 1 %
    scale, so least squares can stop short of the minimum along a weak direction (friction)."""
    from scipy.optimize import minimize

    start = model.evaluations

    def cost(log_factors: NDArray[np.float64]) -> float:
        r = model.residuals(np.exp(log_factors))
        if progress is not None:
            progress(done + model.evaluations - start, _rms(r))
        return float(r @ r)

    n = len(x0)
    reach = [(max(bounds[0], v - POLISH_REACH), min(bounds[1], v + POLISH_REACH)) for v in x0]
    result = minimize(cost, x0, method="Powell", bounds=reach,
                      options={"xtol": POLISH_XTOL, "ftol": 1e-6, "maxfev": max(budget, 1),
                               "direc": np.eye(n) * 0.02})
    x = result.x if result.fun <= cost(x0) else np.asarray(x0)
    return x, {"method": "scipy.optimize.minimize (Powell)", "simulations": model.evaluations - start,
               "rms_m": _rms(model.residuals(np.exp(x))), "message": str(result.message)}


def _jacobian(model: FitModel, x, residual, step: float) -> NDArray[np.float64]:
    """Forward-difference Jacobian of the residuals in the log factors at ``x``."""
    columns = []
    for k in range(len(x)):
        shifted = np.array(x, dtype=np.float64)
        shifted[k] += step
        columns.append((model.residuals(np.exp(shifted)) - residual) / step)
    return np.stack(columns, axis=1)


def _uncertainty(residual: NDArray[np.float64], jac: NDArray[np.float64]):
    """Standard errors of the log factors and their correlation matrix: ``s^2 (J^T J)^-1`` with
    ``s^2`` the residual variance (residuals minus unknowns degrees of freedom)."""
    dof = max(residual.size - jac.shape[1], 1)
    cov = float(residual @ residual) / dof * np.linalg.pinv(jac.T @ jac)
    sigma = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    return sigma, cov / np.outer(np.maximum(sigma, 1e-300), np.maximum(sigma, 1e-300))


def _fitted(spec: Mapping[str, Any], fits: Sequence[Variation], x, sigma, bounds) -> dict[str, Any]:
    """Per fit: its keys, factor and its standard error, fitted and nominal values (SI) and their
    standard errors, whether the factor ended on a bound of the fit."""
    out = {}
    for k, fit in enumerate(fits):
        factor = float(np.exp(x[k]))
        out[fit.name] = {
            "keys": list(fit.keys),
            "factor": factor,
            "factor_sigma": factor * float(sigma[k]),
            "values": {key: scaled(get_value(spec, key), factor) for key in fit.keys},
            "nominal_values": {key: get_value(spec, key) for key in fit.keys},
            "sigma": {key: scaled(get_value(spec, key), factor * float(sigma[k]))
                      for key in fit.keys},
            "at_bound": bool(np.isclose(x[k], bounds[0]) or np.isclose(x[k], bounds[1])),
        }
    return out


def identify(
    fields: NDArray[np.float64],
    measured: MeasuredTrajectory,
    spec: Mapping[str, Any],
    fits: Sequence[Variation],
    *,
    physics: str = "training",
    confirm: bool = True,
    max_evaluations: int = 300,
    diff_step: float = DIFF_STEP,
    stages_count: int = STAGES,
    progress: Callable[[int, float], None] | None = None,
) -> dict[str, Any]:
    """Fit the values of ``fits`` (one factor per fit, within :data:`FIT_BOUNDS`) so that the robot
    of ``spec`` (complete, see :func:`load_spec`) under ``fields`` (``(n, 3)`` T, 100 Hz) moves its
    points as ``measured``; in ``physics`` (training), then confirmed in the accurate physics
    (``confirm``). ``max_evaluations`` bounds the fit's simulations (Jacobian ones included; the
    polish gets what the least squares left, the uncertainty's Jacobian one more per fitted value).
    ``progress(evaluations, rms_m)`` is called after each simulation of the fit.

    Returns the content of ``identify.json``: per fit its factor, values and standard errors,
    the residual RMS and largest absolute residual (m) of the nominal and the fitted robot, the
    accurate-physics confirmation, the optimizer's report, and ``predicted`` (nominal and fitted
    displacements, for the figure; not written to JSON).
    """
    spec = dict(spec)
    length = float(spec["robot"]["length"])
    check_against_robot(measured, length, fields.shape[0] * ACTION_PERIOD)
    fields = np.asarray(fields, dtype=np.float64)
    start = time.perf_counter()
    bounds = (np.log(FIT_BOUNDS[0]), np.log(FIT_BOUNDS[1]))
    model, x, result, stages, nominal, used = _fit_in_stages(
        spec, fits, fields, measured, physics, bounds, diff_step, max_evaluations, stages_count,
        progress)
    status, message = int(result.status), str(result.message)
    x, polish = _polish(model, x, bounds, max_evaluations - used, progress, used)
    residual = model.residuals(np.exp(x))  # cached
    jac = _jacobian(model, x, residual, diff_step)
    fit_wall = time.perf_counter() - start
    total = model.evaluations + sum(stage["simulations"] for stage in stages[:-1])
    diverged = model.diverged + sum(stage["diverged"] for stage in stages[:-1])
    sigma, corr = _uncertainty(residual, jac)
    factors = np.exp(x)
    report: dict[str, Any] = {
        "physics": physics,
        "fitted": _fitted(spec, fits, x, sigma, bounds),
        "correlation": corr.round(6).tolist(),
        "residual_m": {"rms": _rms(residual), "max_abs": float(np.abs(residual).max()),
                       "nominal_rms": _rms(nominal), "nominal_max_abs": float(np.abs(nominal).max()),
                       "count": int(residual.size)},
        "optimizer": {"method": "scipy.optimize.least_squares (trf, 2-point Jacobian)",
                      "diff_step": diff_step, "bounds_factor": list(FIT_BOUNDS), "status": status,
                      "message": message, "simulations": total,
                      "stages": stages, "polish": polish, "diverged_simulations": diverged,
                      "wall_s": fit_wall},
        "measured": {"source": measured.source, "kind": measured.kind, "frames": int(measured.times.size),
                     "points": list(measured.points), "duration_s": measured.duration},
    }
    predicted = {"nominal": model.displacements(np.ones(len(fits))),
                 "fitted": model.displacements(factors)}
    if confirm:
        report["confirm"] = _confirmation(model, factors, physics)
    report["predicted"] = predicted
    return report


def _fit_in_stages(spec: dict[str, Any], fits: Sequence[Variation], fields: NDArray[np.float64],
                   measured: MeasuredTrajectory, physics: str, bounds: tuple[float, float],
                   diff_step: float, max_evaluations: int, stages_count: int,
                   progress: Callable[[int, float], None] | None) -> tuple[Any, ...]:
    """The least-squares fit over growing horizons (:func:`fit_horizons`), each stage starting
    from the last one's log-factors. Returns the last stage's model, the log-factors, the
    optimizer's result, one record per stage, the nominal robot's residuals over the whole
    measurement (m) and the simulations used."""
    x = np.zeros(len(fits))
    used = 0
    stages = []
    for horizon in fit_horizons(measured, stages_count):
        model = FitModel(spec, list(fits), fields, measured.until(horizon), physics)
        if horizon == measured.duration:
            nominal = model.residuals(np.ones(len(fits)))
        result = _least_squares(model, x, bounds, diff_step, max_evaluations - used, progress,
                                used)
        used += model.evaluations
        x = result.x
        stages.append({"horizon_s": horizon, "factors": np.exp(x).tolist(),
                       "rms_m": _rms(result.fun), "simulations": model.evaluations,
                       "diverged": model.diverged})
    return model, x, result, stages, nominal, used


def _confirmation(model: FitModel, factors: NDArray[np.float64], physics: str) -> dict[str, Any]:
    """The fitted robot's residuals in the other physics (the accurate one after a fit in the
    training physics): RMS and largest absolute residual (m), wall time (s)."""
    other = "accurate" if physics == "training" else "training"
    t0 = time.perf_counter()
    confirmed = model.residuals(factors, other)
    return {"physics": other, "rms_m": _rms(confirmed), "max_abs_m": float(np.abs(confirmed).max()),
            "wall_s": time.perf_counter() - t0}


def write_identified(report: dict[str, Any], spec: Mapping[str, Any], measured: MeasuredTrajectory,
                     out: str | Path, force: bool = False, header: str = "") -> Path:
    """Write ``out/identified.toml`` (``spec`` with the fitted values, units in comments),
    ``out/identify.json`` (``report`` without its arrays) and ``out/identify.png`` as one folder
    (built whole, see :func:`~.output.write_folder_whole`). Returns ``out``."""
    from elastica_magnetic.io import atomic_write_json, atomic_write_text
    from elastica_magnetic.specfile import dumps

    from ..cases.case import CASE_UNITS
    from .output import write_folder_whole
    from .report import plot_identify

    values = {key: value for fit in report["fitted"].values() for key, value in fit["values"].items()}
    identified = apply_values(spec, values)

    def fill(folder: Path) -> None:
        lines = [f"# {line}" for line in header.splitlines()] + [
            f"# {key} = {magnitude_of(value):.6g} (nominal {magnitude_of(get_value(spec, key)):.6g})"
            for key, value in values.items()]
        atomic_write_text(folder / "identified.toml", "\n".join(lines) + "\n" + dumps(identified, CASE_UNITS))
        plot_identify(report, measured, folder / "identify.png")
        atomic_write_json(folder / "identify.json", {k: v for k, v in report.items() if k != "predicted"})

    write_folder_whole(out, fill, force, kind="identify")
    return Path(out)
