"""Spec values from a measured trajectory (what ``msr real identify`` runs).

The robot of a spec is simulated under the waveform that was played, and chosen spec values
(dotted keys, groups varied together by one factor: see :mod:`.variations`) are fitted so that the
simulated points move as the measured ones (:mod:`.tracking`): a bounded nonlinear least-squares
fit (scipy's ``least_squares``, trust-region reflective, forward-difference Jacobian) of the log
factors of the nominal values, in the training physics; the residuals are the differences of the
points' displacements from the first frame (x and y, m) at every measured frame. The fitted robot
is then run in the accurate physics to confirm the fit.

The fit runs from several starts (the nominal values and ``starts - 1`` perturbed ones, seeded),
sharing ``max_evaluations``; the start with the lowest cost is kept and every start is reported.

Uncertainty: the standard error of each factor from a central-difference Jacobian at the best
solution (``s^2 (J^T J)^-1``, ``s^2`` the residual variance), and the spread of the starts that
end as good as the best: the stated interval is the larger of the two, and a value whose interval
is wide is reported as not identifiable, with the reason (:mod:`.identifiability`). The residual
is compared with the tracker's noise where it is given (``noise_m``). The standard error assumes
independent residuals; a tracker's errors are correlated from frame to frame, so take it as a
lower bound.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic.specfile import SpecError, describe_robot, read_spec

from ..cases.variations import (
    Variation,
    apply_values,
    get_value,
    magnitude_of,
    parse_group,
    resolve_variations,
)
from .fit_model import FieldDrive, FitModel
from .fit_report import fit_warnings, fitted_values, physics_warning, spec_fits_better, starts_report
from .tracking import MIN_DURATION_S, MeasuredTrajectory, check_against_robot

__all__ = ["DIFF_STEP", "FIT_BOUNDS", "MAX_EVALUATIONS", "STARTS", "FitBudgetExceeded", "drive_recorder",
           "fit_horizons", "identify", "load_spec", "parse_fit", "start_points", "write_identified"]

#: Bounds of a fitted factor (x the nominal value).
FIT_BOUNDS = (0.2, 5.0)
#: Relative step of the forward-difference Jacobian (of the log factors).
DIFF_STEP = 1e-2
#: Fits on growing horizons (each twice the last, the last the whole trajectory): the motion over
#: a short time depends smoothly on the values, the whole of it less so (contacts switch).
STAGES = 3
#: Scale of the fitted log factors and the relative step that ends a fit.
X_SCALE = 1.0
XTOL = 1e-6
#: Relative decrease of the cost that ends a fit (least squares, polish): far below the noise's
#: share of it (1 / number of residuals), so stopping there loses nothing the data can tell.
FTOL = 1e-6
#: Step of the log factors that ends the polish (0.1 %), and how far the polish may go from the
#: least-squares solution (log factor).
POLISH_XTOL = 1e-3
POLISH_REACH = 0.2
#: Simulations of a fit, every start together (about 200 per start: what a start needs for
#: two or three values on a second of motion).
MAX_EVALUATIONS = 600
#: Starts of the fit (the nominal values, then perturbed ones) and how far the perturbed ones lie
#: (log factor: x0.74 ... x1.35, about the spread of a built robot's values).
STARTS = 3
START_SPREAD = 0.3
#: Step (log factor) of the central-difference Jacobian of the uncertainty: wider than
#: DIFF_STEP so that the roughness of a motion with contacts does not pass for a slope.
UNCERTAINTY_STEP = 0.05


#: What each recorded drive steers, in words, by the actuation kind it drives.
STEERED_BY = {
    "magnet-pose": ("a magnet path", "a magnet on an arm", "a magnet arm's recorded path (magnet_x_m, ...)"),
    "coil-currents": ("a coil path", "coil currents", "the coils' recorded currents (current_0_A, ...)"),
}


def drive_recorder(case: Any) -> Any:
    """The :class:`~.recorded_paths.DriveRecorder` of a steered ``case``'s actuation kind (a magnet
    arm's path, the coils' currents); ValueError for a case driven by a uniform field."""
    from .coil_path import COIL_RECORDER
    from .magnet_path import MAGNET_RECORDER

    recorders = {"magnet-pose": MAGNET_RECORDER, "coil-currents": COIL_RECORDER}
    kind = getattr(case.actuation, "kind", "field")
    if kind not in recorders:
        raise ValueError(f"case {case.name!r} is driven by a uniform field: no drive to record")
    return recorders[kind]


def load_spec(robot: str | Path, steered_by: str | None = None) -> dict[str, Any]:
    """The complete spec (every default written out) of a spec file or a shipped case name: a case
    spec as ``Case.to_dict()`` without its name, a robot-only spec with its ``[robot]`` and
    ``[physics]`` tables completed. SpecError names a bad file and key. A waveform is played as a
    uniform field, so a case steered by a source is refused; with ``steered_by`` (the drive is a
    recorded path of an actuation kind of :data:`STEERED_BY`: ``"magnet-pose"``, ``"coil-currents"``)
    only a case of that kind is taken."""
    from ..cases.case import case_names, load_case
    from ..cases.steered import field_only_refusal

    def field_actuated(case: Any) -> Any:
        """The case the drive can play: a field for a waveform, its kind for a recorded path."""
        kind = getattr(case.actuation, "kind", "field")
        if steered_by is not None and kind != steered_by:
            path_words, source_words, _ = STEERED_BY[steered_by]
            raise SpecError(f"--robot {text}: {path_words} drives a case steered by {source_words} "
                            f"([actuation] kind = \"{steered_by}\"); {text}'s actuation is "
                            + ("a uniform field: give the field CSV played (mag_x, mag_y, mag_z in mT)"
                               if case.field_actuated else repr(kind)))
        if steered_by is None and not case.field_actuated:
            instead = f"; {STEERED_BY[kind][2]} is fitted in its place" if kind in STEERED_BY else ""
            raise SpecError("--robot " + field_only_refusal(text, case.actuation.kind) + instead)
        return case

    text = str(robot)
    if text in case_names():
        data = field_actuated(load_case(text)).to_dict()
        del data["name"]
        return data
    path = Path(robot)
    if path.suffix != ".toml" and not path.exists():
        raise SpecError(f"--robot {text}: not a shipped case ({', '.join(case_names())}) and not a "
                        "spec file (.toml)")
    raw = read_spec(path)
    if steered_by is not None and "actuation" not in raw:
        path_words, source_words, _ = STEERED_BY[steered_by]
        raise SpecError(f"--robot {text}: {path_words} drives a case steered by {source_words}; "
                        f"{text} describes a robot without an [actuation] table")
    if "actuation" in raw:
        data = field_actuated(load_case(path)).to_dict()
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


def _compared(fitted: float, nominal: float) -> str:
    """How a fit's residual RMS compares with the spec's, for the note that keeps the spec:
    ``"4.4x worse"`` or ``"less than 0.1 % better"``."""
    if fitted > nominal * (1.0 + MIN_IMPROVEMENT):  # the search ended far from the spec's values
        return f"{fitted / nominal:.3g}x worse" if nominal > 0.0 else "worse"
    return f"less than {100 * MIN_IMPROVEMENT:g} % better"


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


@dataclass
class _Problem:
    """What every start of a fit shares: the spec, the fitted values, the drive (a waveform, a
    magnet's path), the
    measurement, the physics, the bounds of the log factors, the Jacobian step, the number of
    horizons, the progress callback, and the model of the whole trajectory (its cache shared)."""

    spec: dict[str, Any]
    fits: list[Variation]
    drive: Any
    measured: MeasuredTrajectory
    physics: str
    bounds: tuple[float, float]
    diff_step: float
    stages_count: int
    progress: Callable[[int, float], None] | None
    whole: FitModel = field(init=False)

    def __post_init__(self) -> None:
        self.whole = FitModel(self.spec, self.fits, self.drive, self.measured, self.physics)

    def model(self, horizon: float) -> FitModel:
        if horizon >= self.measured.duration:
            return self.whole
        return FitModel(self.spec, self.fits, self.drive, self.measured.until(horizon), self.physics)


class _Budget:
    """The simulations a start may run (``limit``), counted over the models it uses; the best
    log factors seen on the current model (so that a start stopped by the budget keeps them)."""

    def __init__(self, limit: int, done: int, progress: Callable[[int, float], None] | None):
        self.limit, self.done, self.progress = limit, done, progress
        self.used = self.diverged = 0
        self.best: tuple[float, NDArray[np.float64]] | None = None

    def evaluate(self, model: FitModel, log_factors: NDArray[np.float64]) -> NDArray[np.float64]:
        before, diverged = model.evaluations, model.diverged
        if (tuple(float(f) for f in np.exp(log_factors)), model.physics) not in model._cache \
                and self.used >= self.limit:
            raise FitBudgetExceeded("this start's share of the simulations ran out")
        r = model.residuals(np.exp(log_factors))
        self.used += model.evaluations - before
        self.diverged += model.diverged - diverged
        cost = float(r @ r)
        if self.best is None or cost < self.best[0]:
            self.best = (cost, np.array(log_factors, dtype=np.float64))
        if self.progress is not None:
            self.progress(self.done + self.used, _rms(r))
        return r


def _least_squares(model: FitModel, x0, problem: _Problem, budget: _Budget):
    """One ``least_squares`` run on ``model`` from ``x0`` (log factors) within ``budget``."""
    from scipy.optimize import least_squares

    return least_squares(lambda x: budget.evaluate(model, x), x0, bounds=problem.bounds,
                         method="trf", diff_step=problem.diff_step, x_scale=X_SCALE, ftol=FTOL,
                         xtol=XTOL, gtol=1e-10)


def _polish(problem: _Problem, x0, budget: _Budget) -> tuple[NDArray[np.float64], dict[str, Any]]:
    """Powell's derivative-free line searches from the least-squares solution, on the whole
    trajectory: the forward-difference Jacobian of a motion with contacts is rough at the 1 %
    scale, so least squares can stop short of the minimum along a weak direction (friction)."""
    from scipy.optimize import minimize

    model, start = problem.whole, budget.used
    lo, hi = problem.bounds
    reach = [(max(lo, v - POLISH_REACH), min(hi, v + POLISH_REACH)) for v in x0]
    budget.best = None
    try:
        r0 = budget.evaluate(model, np.asarray(x0, dtype=np.float64))
        result = minimize(lambda x: float(np.sum(budget.evaluate(model, x) ** 2)), x0,
                          method="Powell", bounds=reach,
                          options={"xtol": POLISH_XTOL, "ftol": FTOL,
                                   "maxfev": max(budget.limit - budget.used, 1),
                                   "direc": np.eye(len(x0)) * 0.02})
        x = result.x if result.fun <= float(r0 @ r0) else np.asarray(x0)
        message, converged = str(result.message), bool(result.success)
    except FitBudgetExceeded:
        if budget.best is None:
            raise
        x, converged = budget.best[1], False
        message = "stopped: this start's share of the simulations ran out"
    return x, {"method": "scipy.optimize.minimize (Powell)", "simulations": budget.used - start,
               "message": message, "converged": converged}


def _fit_one_start(problem: _Problem, x0: NDArray[np.float64], budget: _Budget) -> dict[str, Any]:
    """The least-squares fit over growing horizons (:func:`fit_horizons`) from ``x0`` (log
    factors), each stage starting from the last one's solution, then the polish. Returns the
    start's record: its log factors ``x``, cost (m^2) and RMS (m) over the whole trajectory,
    whether it converged, one record per stage and the polish's."""
    x = np.asarray(x0, dtype=np.float64)
    stages, converged, status, message = [], True, None, ""
    for horizon in fit_horizons(problem.measured, problem.stages_count):
        model = problem.model(horizon)
        budget.best, before, diverged = None, budget.used, budget.diverged
        try:
            result = _least_squares(model, x, problem, budget)
            x, status, message = result.x, int(result.status), str(result.message)
            converged = converged and status > 0
        except FitBudgetExceeded:
            if budget.best is None:
                return {"x": None, "converged": False, "stages": stages,
                        "message": "no simulation left for this start"}
            x, status, converged = budget.best[1], None, False
            message = "stopped: this start's share of the simulations ran out"
        stages.append({"horizon_s": horizon, "factors": np.exp(x).tolist(), "status": status,
                       "message": message, "simulations": budget.used - before,
                       "diverged": budget.diverged - diverged})
        if status is None:
            break
    polish = None
    if status is not None:
        x, polish = _polish(problem, x, budget)
        if converged and not polish["converged"]:  # name the step that stopped short
            message = f"the least-squares stages converged, the polish (Powell) did not: {polish['message']}"
        converged = converged and polish["converged"]
    r = problem.whole.residuals(np.exp(x))  # cached: the polish evaluated it
    return {"x": x, "cost": float(r @ r), "rms_m": _rms(r), "converged": converged,
            "status": status, "message": message, "stages": stages, "polish": polish}


def start_points(n_values: int, starts: int, seed: int) -> list[NDArray[np.float64]]:
    """The log factors each start begins from: the nominal values (0), then ``starts - 1`` points
    whose every coordinate takes the levels of ``[-START_SPREAD, START_SPREAD]`` once, in a
    seeded order (so the starts lie on both sides of the nominal value of each fitted value)."""
    rng = np.random.default_rng(seed)
    points = [np.zeros(n_values)]
    extra = starts - 1
    if extra == 1:
        return [*points, START_SPREAD * rng.choice([-1.0, 1.0], n_values)]
    if extra > 1:
        levels = np.linspace(-START_SPREAD, START_SPREAD, extra)
        columns = np.stack([rng.permutation(levels) for _ in range(n_values)], axis=1)
        points += list(columns)
    return points


def _accepted_start(problem: _Problem, x0: NDArray[np.float64]) -> NDArray[np.float64]:
    """``x0`` moved towards the nominal values (halving) until the spec parser accepts its values
    (a start with kinetic friction above static would begin on the refused side of the cost)."""
    for _ in range(6):
        try:
            describe_robot(apply_values(problem.spec, problem.whole.values(np.exp(x0))), "start")
            return x0
        except SpecError:
            x0 = x0 / 2
    return np.zeros_like(x0)


def _run_starts(problem: _Problem, starts: int, seed: int, max_evaluations: int
                ) -> list[dict[str, Any]]:
    """Fit from every start (:func:`start_points`), each given an even share of what the earlier
    ones left of ``max_evaluations``. Raises FitBudgetExceeded when no start got anywhere."""
    records, used = [], 0
    points = start_points(len(problem.fits), starts, seed)
    for i, x0 in enumerate(points):
        x0 = _accepted_start(problem, x0)
        budget = _Budget((max_evaluations - used) // (len(points) - i), used, problem.progress)
        record = _fit_one_start(problem, x0, budget)
        used += budget.used
        records.append({"start_factors": np.exp(x0).tolist(), "simulations": budget.used,
                        "diverged": budget.diverged, **record})
    if all(r["x"] is None for r in records):
        raise FitBudgetExceeded(f"the fit used its {max_evaluations} simulations without a result; "
                                "raise --max-evaluations, or fit fewer keys or from fewer --starts")
    return records


def _central_jacobian(model: FitModel, x, step: float) -> NDArray[np.float64]:
    """Central-difference Jacobian of the residuals in the log factors at ``x``."""
    columns = []
    for k in range(len(x)):
        up, down = np.array(x, dtype=np.float64), np.array(x, dtype=np.float64)
        up[k] += step
        down[k] -= step
        columns.append((model.residuals(np.exp(up)) - model.residuals(np.exp(down))) / (2 * step))
    return np.stack(columns, axis=1)


@dataclasses.dataclass(frozen=True)
class FitOptions:
    """How :func:`identify` fits: in ``physics`` (``"training"`` or ``"accurate"``), from
    ``starts`` starts (:func:`start_points`, ``seed``), at most ``max_evaluations`` simulations of
    all starts together (Jacobian ones included), finite differences of ``diff_step`` (log
    factor), ``stages_count`` stages of growing trajectory length, then confirmed in the accurate
    physics (``confirm``); ``noise_m`` (m): the tracker's noise per coordinate, to judge the
    residual by (``None``: not judged)."""

    physics: str = "training"
    confirm: bool = True
    max_evaluations: int = MAX_EVALUATIONS
    diff_step: float = DIFF_STEP
    stages_count: int = STAGES
    starts: int = STARTS
    seed: int = 0
    noise_m: float | None = None


def identify(
    drive: NDArray[np.float64] | Any,
    measured: MeasuredTrajectory,
    spec: Mapping[str, Any],
    fits: Sequence[Variation],
    options: FitOptions | None = None,
    /,
    progress: Callable[[int, float], None] | None = None,
    **changes: Any,
) -> dict[str, Any]:
    """Fit the values of ``fits`` (one factor per fit, within :data:`FIT_BOUNDS`) so that the robot
    of ``spec`` (complete, see :func:`load_spec`) under ``drive`` moves its points as ``measured``:
    ``drive`` a uniform field waveform (``(n, 3)`` T, 100 Hz, or a :class:`~.fit_model.FieldDrive`) or, for a
    case steered by a magnet on an arm, its recorded path
    (:class:`~elastica_magnetic_rl.sim2real.magnet_path.MagnetDrive`, ``measured`` the tip's path
    in 3D); as ``options`` (:class:`FitOptions`, with ``changes``: its fields by
    name) say. The simulations' budget covers the fit; the uncertainty's Jacobian takes two more
    per fitted value, the nominal robot's residual one. ``progress(evaluations, rms_m)`` is called
    after each simulation of the fit.

    Returns the content of ``identify.json``: per fit its factor, values, standard errors,
    interval and identifiability, the residual RMS and largest absolute residual (m) of the
    nominal and the fitted robot and their ratio to the noise, warnings, every start's result, the
    accurate-physics confirmation, the optimizer's report, and ``predicted`` (nominal and fitted
    displacements, for the figure; not written to JSON).
    """
    o = dataclasses.replace(options or FitOptions(), **changes)
    spec = dict(spec)
    if isinstance(drive, np.ndarray):
        drive = FieldDrive(np.asarray(drive, dtype=np.float64))
    drive.check_spec(spec)
    drive.check_measured(measured, spec)
    check_against_robot(measured, float(spec["robot"]["length"]), drive.duration)
    began = time.perf_counter()
    bounds = (np.log(FIT_BOUNDS[0]), np.log(FIT_BOUNDS[1]))
    problem = _Problem(spec, list(fits), drive, measured, o.physics, bounds, o.diff_step,
                       o.stages_count, progress)
    records = _run_starts(problem, o.starts, o.seed, o.max_evaluations)
    report = _fit_report(problem, records, o, began)
    x, model = report.pop("_x"), problem.whole
    predicted = {"nominal": model.displacements(np.ones(len(fits))),
                 "fitted": model.displacements(np.exp(x))}
    if o.confirm:
        report["confirm"] = _confirmation(model, np.exp(x), o.physics)
        if (warning := physics_warning(report["residual_m"]["rms"], report["confirm"], o.physics)):
            report["warnings"].append(warning)
        if (reason := spec_fits_better(report["confirm"])) is not None:
            report["warnings"].append(reason)
            for entry in report["fitted"].values():  # the fit made up for the physics: nothing judged
                entry.update(identifiable=None, interval=None, reason=f"not judged: {reason}",
                             factor_sigma=None, sigma=dict.fromkeys(entry["sigma"]))
    report["predicted"] = predicted
    return report


#: A fit whose residual RMS is not at least this fraction below the spec's own keeps the spec's
#: values: a flat cost moves the values anywhere without telling anything about them.
MIN_IMPROVEMENT = 1e-3


def _fit_report(problem: _Problem, records: list[dict[str, Any]], o: FitOptions,
                began: float) -> dict[str, Any]:
    """The report of the best start of ``records``: the fitted values and their uncertainty, the
    residuals, warnings, identifiability and the optimizer's record (``_x``: the best log factors,
    for the caller)."""
    from .identifiability import (
        IDENTIFIABLE_WITHIN,
        INTERVAL_SIGMAS,
        NEAR_BEST_CHI2,
        residual_against_body,
        residual_against_noise,
    )

    fits, spec, measured, bounds = problem.fits, problem.spec, problem.measured, problem.bounds
    finished = [i for i, r in enumerate(records) if r["x"] is not None]
    best = min(finished, key=lambda i: records[i]["cost"])
    x = records[best]["x"]
    model = problem.whole
    residual = model.residuals(np.exp(x))  # cached
    nominal = model.residuals(np.ones(len(fits)))
    kept = _rms(residual) > _rms(nominal) * (1.0 - MIN_IMPROVEMENT)
    if kept:  # the search ended no better than it began (over the whole trajectory): never written
        kept_note = (f"the fit did not improve on the spec: over the whole trajectory its best "
                     f"values leave a residual RMS of {1e3 * _rms(residual):.4g} mm, the spec's own "
                     f"{1e3 * _rms(nominal):.4g} mm ({_compared(_rms(residual), _rms(nominal))}); the "
                     "spec's values are kept (more evaluations, more starts or a longer trajectory "
                     "may find better)")
        x, residual = np.zeros(len(fits)), nominal
    before = model.evaluations
    sigma, corr, judged, near, profile, variance = _judge(model, x, residual, fits,
                                                          [records[i] for i in finished], bounds, o.noise_m)
    starts_public, agree = starts_report(records, near, best)
    judged_residual, warnings = residual_against_noise(_rms(residual), o.noise_m)
    if (missed := residual_against_body(_rms(residual), float(spec["robot"]["length"]))) is not None:
        judged = [{"interval": None, "interval_from": entry["interval_from"], "identifiable": None,
                   "reason": missed} for entry in judged]
    fitted = fitted_values(spec, fits, x, sigma, bounds, judged, profile)  # the verdicts, a bound's too
    warnings += fit_warnings(records[best], list(fitted.values()), fits)
    warnings += _implausible_fitted(model, x)
    if kept:
        warnings.insert(0, kept_note)
    return {
        "_x": x,
        "physics": o.physics,
        "fitted": fitted,
        "correlation": [[None if not np.isfinite(c) else round(float(c), 6) for c in row]
                        for row in corr],
        "residual_m": {"rms": _rms(residual), "max_abs": float(np.abs(residual).max()),
                       "nominal_rms": _rms(nominal), "nominal_max_abs": float(np.abs(nominal).max()),
                       "count": int(residual.size)},
        **judged_residual,
        "warnings": warnings,
        "kept_spec_values": kept,
        "identifiability": {**variance, "near_best_chi2": NEAR_BEST_CHI2, "interval_sigmas": INTERVAL_SIGMAS,
                            "identifiable_within": IDENTIFIABLE_WITHIN, "profile": profile,
                            "simulations": model.evaluations - before},
        "optimizer": _optimizer_report(records, best, agree, o.diff_step,
                                       time.perf_counter() - began, starts_public),
        "measured": {"source": measured.source, "kind": measured.kind, "frames": int(measured.times.size),
                     "points": list(measured.points), "duration_s": measured.duration},
    }


def _judge(model: FitModel, x: NDArray[np.float64], residual: NDArray[np.float64],
           fits: Sequence[Variation], finished: Sequence[dict[str, Any]],
           bounds: tuple[float, float], noise_m: float | None) -> tuple[Any, ...]:
    """The uncertainty of the best fit ``x`` (log factors; ``residual`` its residuals, m) from the
    Jacobian, the ``finished`` starts and the profile (:mod:`.identifiability`). Returns the
    standard errors and correlation of the log factors, each value's verdict, which starts ended
    as good as the best, the profile's records and the variance they are measured in (the residual's,
    or the stated tracker noise ``noise_m``'s where larger)."""
    from .identifiability import (
        IDENTIFIABLE_WITHIN,
        first_halfwidths,
        judge_values,
        near_best,
        profile_halfwidths,
        residual_variance,
        uncertainty,
    )

    jac = _central_jacobian(model, x, UNCERTAINTY_STEP)
    s2, variance_from = residual_variance(residual, len(fits), noise_m)
    sigma, corr = uncertainty(residual, jac, s2)
    near = near_best([r["cost"] for r in finished], s2)
    # only a start that converged tells where the cost is flat: one the budget stopped ended
    # anywhere on its way (one such start made "factor unbounded (from the starts)")
    settled = [ok and bool(r["converged"]) for ok, r in zip(near, finished, strict=True)]
    halves, sources = first_halfwidths(sigma, x, [r["x"] for r in finished], settled)
    profiled, profile = profile_halfwidths(lambda y: model.residuals(np.exp(y)), x, s2, halves,
                                           corr, sigma, bounds)
    widened = (profiled > halves) & (halves <= np.log1p(IDENTIFIABLE_WITHIN))  # by the profile
    sources = ["profile" if widened[k] else src for k, src in enumerate(sources)]
    judged = judge_values([f.name for f in fits], x, profiled, sources, corr, jac, s2, profile)
    return sigma, corr, judged, near, profile, {"variance_m2": s2, "variance_from": variance_from}


def _optimizer_report(records: Sequence[dict[str, Any]], best: int, agree: bool | None, diff_step: float,
                      wall_s: float, starts_public: list[dict[str, Any]]) -> dict[str, Any]:
    """The optimizer's part of ``identify.json``: the method, the best start's status, whether
    it converged and the starts agree, the simulations of the fit (every start) and of the
    uncertainty, and every start's record."""
    used = sum(r["simulations"] for r in records)
    return {"method": "scipy.optimize.least_squares (trf, 2-point Jacobian) on growing horizons, "
                      "then scipy.optimize.minimize (Powell), from several starts",
            "diff_step": diff_step, "uncertainty_step": UNCERTAINTY_STEP,
            "bounds_factor": list(FIT_BOUNDS), "best_start": best,
            "status": records[best]["status"], "message": records[best]["message"],
            "converged": records[best]["converged"], "starts_agree": agree,
            "simulations": used, "diverged_simulations": sum(r["diverged"] for r in records),
            "wall_s": wall_s, "starts": starts_public,
            "stages": records[best]["stages"], "polish": records[best]["polish"]}


def _confirmation(model: FitModel, factors: NDArray[np.float64], physics: str) -> dict[str, Any]:
    """The fitted robot's residuals in the other physics (the accurate one after a fit in the
    training physics): RMS and largest absolute residual (m), the spec's own values' RMS there
    (m), wall time (s)."""
    other = "accurate" if physics == "training" else "training"
    t0 = time.perf_counter()
    confirmed = model.residuals(factors, other)
    nominal = model.residuals(np.ones_like(factors), other)  # the spec's own values, there
    return {"physics": other, "rms_m": _rms(confirmed), "max_abs_m": float(np.abs(confirmed).max()),
            "nominal_rms_m": _rms(nominal), "wall_s": time.perf_counter() - t0}


def _implausible_fitted(model: FitModel, x: NDArray[np.float64]) -> list[str]:
    """The plausibility warnings of the fitted robot (``x``: the log factors; the trial values the
    optimizer tried on its way are not judged): a value no lab's robot has is said once, of the
    result."""
    import warnings as python_warnings

    from elastica_magnetic.plausibility import ImplausibleValueWarning

    with python_warnings.catch_warnings(record=True) as caught:
        python_warnings.simplefilter("always", ImplausibleValueWarning)
        try:
            describe_robot(apply_values(model.spec, model.values(np.exp(x))), "the fitted values")
        except SpecError:
            return []
    return [str(w.message) for w in caught if issubclass(w.category, ImplausibleValueWarning)]


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
