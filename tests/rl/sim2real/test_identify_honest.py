"""msr real identify, honestly (issue 49): several starts within one simulation budget, the residual
judged against the tracker's noise, and a value the trajectory does not determine reported as not
identifiable instead of with a tight interval. The longer recovery runs (two waveforms, four
robots) are in ``benchmarks/identify_recovery.py``; their numbers in docs/sim_to_real.md."""

import json

import numpy as np
import pytest
from elastica_magnetic_rl.sim2real.fit_model import FitModel
from elastica_magnetic_rl.sim2real.identifiability import (
    INTERVAL_SIGMAS,
    first_halfwidths,
    judge_values,
    profile_halfwidths,
    residual_against_noise,
    uncertainty,
)
from elastica_magnetic_rl.sim2real.identify import (
    START_SPREAD,
    identify,
    load_spec,
    parse_fit,
    start_points,
    write_identified,
)
from elastica_magnetic_rl.sim2real.tracking import MeasuredTrajectory

from elastica_magnetic.cli import main
from elastica_magnetic.field_csv import read_field_csv, write_field_csv

CASE = "m1-4mT"
NOISE_M = 5e-5
FRACTIONS = (0.0, 0.5, 1.0)


@pytest.fixture(scope="module")
def spec():
    return load_spec(CASE)


def rotating(duration):
    """A 10 mT field turning at 2 Hz (T, 100 rows/s, 0.1 s ramp)."""
    t = np.arange(int(round(100 * duration))) / 100
    a = 10e-3 * np.minimum(t / 0.1, 1.0)
    phase = -4 * np.pi * t + np.pi / 2
    return np.stack([a * np.cos(phase), a * np.sin(phase), 0 * t], axis=1)


def synthetic(spec, keys, truth, fields, duration, seed=0):
    """Three points of the robot whose ``keys`` have factors ``truth``, 30 frames/s, NOISE_M of
    Gaussian noise per coordinate."""
    times = np.arange(0.0, duration - 0.01 + 1e-9, 1 / 30)
    names = tuple(f"s={s:g}" for s in FRACTIONS)
    blank = MeasuredTrajectory("synthetic", "tracker", times, np.zeros((times.size, 3, 2)), names,
                               FRACTIONS)
    moved = FitModel(spec, parse_fit(keys, spec), fields, blank).displacements(truth)
    start = np.array([[s * spec["robot"]["length"], 0.0] for s in FRACTIONS])
    noise = np.random.default_rng(seed).normal(0.0, NOISE_M, moved.shape)
    return MeasuredTrajectory("synthetic", "tracker", times, moved + start + noise, names, FRACTIONS)


def test_a_value_the_residuals_do_not_depend_on_has_no_finite_standard_error():
    rng = np.random.default_rng(0)
    residual = rng.normal(0.0, 1e-4, 200)
    jac = np.stack([rng.normal(0.0, 1e-3, 200), np.zeros(200)], axis=1)
    sigma, _ = uncertainty(residual, jac)
    # the pseudo-inverse the fit used gave this value a standard error of 0: a tight interval
    assert np.isfinite(sigma[0]) and sigma[1] == np.inf
    halves, sources = first_halfwidths(sigma, np.zeros(2), [np.zeros(2)], [True])
    judged = judge_values(["magnetization", "flat"], np.zeros(2), halves, sources,
                          np.eye(2), jac, float(residual @ residual) / 198)
    assert judged[0]["identifiable"] and judged[1]["interval"] is None
    assert not judged[1]["identifiable"] and judged[1]["reason"].startswith("flat cost")


def test_two_values_that_act_only_as_a_product_are_reported_correlated():
    rng = np.random.default_rng(1)
    column = rng.normal(0.0, 1e-3, 200)
    jac = np.stack([column, column], axis=1)  # log(a) + log(b): only the product is seen
    residual = rng.normal(0.0, 1e-4, 200)
    sigma, corr = uncertainty(residual, jac)
    assert np.all(sigma == np.inf)
    halves, sources = first_halfwidths(sigma, np.zeros(2), [np.zeros(2)], [True])
    judged = judge_values(["a", "b"], np.zeros(2), halves, sources, corr, jac,
                          float(residual @ residual) / 198)
    assert [j["identifiable"] for j in judged] == [False, False]
    assert "correlated with b" in judged[0]["reason"] and "correlated with a" in judged[1]["reason"]


def test_the_profile_widens_an_interval_the_cost_does_not_confirm():
    """A linear model: re-fitting the other value, the cost rises by 3.84 s^2 at 1.96 standard
    errors; started from a quarter of a standard error, the profile grows to there."""
    rng = np.random.default_rng(2)
    a = rng.normal(0.0, 1.0, (200, 2))
    a[:, 1] += 0.8 * a[:, 0]  # correlated values
    b = rng.normal(0.0, 0.1, 200)
    x_best = np.linalg.lstsq(a, b, rcond=None)[0]
    residual = a @ x_best - b
    sigma, corr = uncertainty(residual, a)
    s2 = float(residual @ residual) / 198
    halves, records = profile_halfwidths(lambda x: a @ x - b, x_best, s2, 0.25 * sigma, corr,
                                         sigma, (-10.0, 10.0))
    assert np.all(halves >= 1.96 * sigma) and np.all(halves <= 1.5 * 1.96 * sigma)
    assert len(records) > 4


def test_a_point_the_profile_undercut_keeps_its_interval_but_no_standard_error(spec):
    """Round 33 (S1): a one-value fit stopped by its budget at x1.041 whose profile found a cost
    290 residual variances lower at x1.052 (inside its interval, which held the truth x1.05) was
    stated as "63830.8 +- 30": the truth 18 standard errors away. The interval stands (the
    profile rose past the threshold on both sides), the standard error is withdrawn, the lower
    cost named."""
    from elastica_magnetic_rl.sim2real.fit_report import fit_warnings, fitted_values

    x_best = np.log([1.0413])
    halves = np.array([0.023])  # [1.0177, 1.0655]: the profile's, confirmed on both sides
    profile = [{"value": 0, "log_step": -0.023, "cost_rise_over_s2": 5.0},
               {"value": 0, "log_step": 0.01, "cost_rise_over_s2": -289.9},
               {"value": 0, "log_step": 0.015, "cost_rise_over_s2": -94.9},
               {"value": 0, "log_step": 0.023, "cost_rise_over_s2": 4.1}]
    jac = np.full((60, 1), 1e-2)
    (judged,) = judge_values(["magnetization"], x_best, halves, ["profile"], np.eye(1), jac, 1e-9,
                             profile)
    assert judged["identifiable"] and judged["interval"][0] < 1.05 < judged["interval"][1]
    short = judged["stopped_short"]
    assert short["factor"] == pytest.approx(1.0413 * np.exp(0.01))
    assert "289.9" not in short["note"] and "290 residual variances lower" in short["note"]
    fits = parse_fit("magnetization", spec)
    (fitted,) = fitted_values(spec, fits, x_best, np.array([4.7e-4]), (np.log(0.2), np.log(5.0)),
                              [judged], profile).values()
    assert fitted["factor_sigma"] is None and set(fitted["sigma"].values()) == {None}
    (warning,) = fit_warnings({"converged": True}, [judged], fits)
    assert "stopped short of its minimum" in warning and "x1.052" in warning
    # without a lower point the standard error stands
    (plain,) = judge_values(["magnetization"], x_best, halves, ["profile"], np.eye(1), jac, 1e-9,
                            [p for p in profile if p["cost_rise_over_s2"] > 0])
    assert "stopped_short" not in plain
    # round 34 (S3): an identifiable value has no reason ("flat cost" had been written beside it),
    # and the standard error of an interval the profile widened is the interval's (printed "+- 12"
    # had put the truth 10 of them away)
    assert "reason" not in plain and "reason" not in judged
    (shown,) = fitted_values(spec, fits, x_best, np.array([4.7e-4]), (np.log(0.2), np.log(5.0)),
                             [plain], profile).values()
    assert shown["factor_sigma"] == pytest.approx(1.0413 * 0.023 / INTERVAL_SIGMAS)


def test_a_value_not_judged_has_no_standard_error(spec):
    """Round 34 (S1): a value made "not judged" by a lower cost in its profile (x1.128, the truth
    x1.3) still printed "61372 +- 1.1e+03" (17 of them from the truth) and wrote its sigma."""
    from elastica_magnetic_rl.sim2real.fit_report import fitted_values

    x_best = np.log([1.0012])
    profile = [{"value": 0, "log_step": -0.0953, "cost_rise_over_s2": 1.0},
               {"value": 0, "log_step": 0.0953, "cost_rise_over_s2": -201.0}]
    (judged,) = judge_values(["magnetization"], x_best, np.array([np.inf]), ["jacobian"], np.eye(1),
                             np.full((60, 1), 1e-2), 1e-9, profile)
    assert judged["identifiable"] is None and judged["reason"].startswith("not judged")
    (fitted,) = fitted_values(spec, parse_fit("magnetization", spec), x_best, np.array([0.0177]),
                              (np.log(0.2), np.log(5.0)), [judged], profile).values()
    assert fitted["factor_sigma"] is None and set(fitted["sigma"].values()) == {None}


def test_a_fit_that_misses_the_points_by_a_body_length_judges_nothing(spec):
    """Round 33 (S2): one tracked point in millimetres read as metres (under the tracker checks'
    limits) was fitted to magnetization x4.6 and called "flat cost: the motion hardly depends on
    it", the fitted robot missing the points by 1.9 body lengths RMS, without a word unless
    --noise-m was given. A residual past a quarter of the body is named, and no value judged."""
    fields = 0.4 * rotating(0.3)  # 4 mT: the back moves under a millimetre (0.5 m read as metres)
    moved = synthetic(spec, "magnetization", np.array([1.0]), fields, 0.3)
    back = MeasuredTrajectory("mm.csv", "tracker", moved.times, 1e3 * moved.positions[:, :1], ("s=0",),
                              (0.0,))
    report = identify(fields, back, spec, parse_fit("magnetization", spec), confirm=False,
                      max_evaluations=6, starts=1, stages_count=1)
    (fit,) = report["fitted"].values()
    assert report["residual_m"]["rms"] > 0.25 * spec["robot"]["length"]
    assert fit["identifiable"] is None and fit["interval"] is None
    assert "misses the tracked points by" in fit["reason"] and "millimetres given as metres" in fit["reason"]
    assert any("misses the tracked points" in w for w in report["warnings"])


def test_the_residual_is_judged_only_against_a_stated_noise():
    verdict, warnings = residual_against_noise(1e-4, None)
    assert verdict["residual_vs_noise"] is None and "cannot be judged" in verdict["residual_judged"]
    assert warnings == []
    verdict, warnings = residual_against_noise(0.9e-4, 5e-5)
    assert verdict["residual_vs_noise"] == pytest.approx(1.8) and warnings == []
    verdict, warnings = residual_against_noise(3e-4, 5e-5)
    assert verdict["residual_vs_noise"] == pytest.approx(6.0)
    assert "does not explain the data" in warnings[0]


def test_starts_lie_on_both_sides_of_the_nominal_values_and_are_seeded():
    points = start_points(2, 3, seed=0)
    assert np.all(points[0] == 0.0)
    for k in range(2):
        assert sorted(p[k] for p in points[1:]) == pytest.approx([-START_SPREAD, START_SPREAD])
    assert all(np.array_equal(a, b) for a, b in zip(points, start_points(2, 3, seed=0), strict=True))


def test_a_step_to_kinetic_friction_above_static_is_a_bad_fit_not_a_crash(spec):
    """kinetic_mu 0.6 under static_mu 0.8: a factor past x1.33 is a robot the spec parser refuses
    (it raised SpecError out of the fit); now it costs as much as a diverged simulation."""
    fields = rotating(0.2)
    measured = MeasuredTrajectory("synthetic", "tracker", np.arange(0.0, 0.2, 1 / 30),
                                  np.zeros((6, 1, 2)), ("s=0",), (0.0,))
    model = FitModel(spec, parse_fit("robot.ground.kinetic_mu", spec), fields, measured)
    assert np.all(model.residuals([1.4]) == 1.0) and model.refused == 1


def test_noise_given_in_millimetres_is_refused_before_any_fitting(tmp_path, capsys):
    write_field_csv(tmp_path / "fields.csv", rotating(0.5))
    track = tmp_path / "track.csv"
    rows = [f"{k / 30:.4f},{0.001 * k:.6f},0,{0.02 + 0.001 * k:.6f},0" for k in range(12)]
    track.write_text("t_s,x_0_m,y_0_m,x_1_m,y_1_m\n" + "\n".join(rows) + "\n")
    base = ["real", "identify", str(tmp_path / "fields.csv"), str(track), "--robot", CASE, "--fit",
            "magnetization", "--out", str(tmp_path / "id")]
    assert main([*base, "--noise-m", "0.005"]) == 2
    err = capsys.readouterr().err
    assert "--noise-m 0.005" in err and "millimetres given for metres" in err
    # round 34, V4: 50 had been advised "50 mm is 0.05 m", refused next; a tracker's 50 is um
    with pytest.raises(SystemExit):
        main([*base, "--noise-m", "50"])
    err = capsys.readouterr().err
    assert "(um written where m is expected? 50 um is 5e-05 m)" in err, err
    with pytest.raises(SystemExit) as info:  # argparse: the range of the option
        main([*base, "--noise-m", "0"])
    assert info.value.code == 2 and "--noise-m: expected a finite number of m in (0" in (
        capsys.readouterr().err)
    assert not (tmp_path / "id").exists()


@pytest.mark.slow
def test_recovers_magnetization_and_kinetic_friction_within_3_percent_or_says_it_cannot(spec):
    """A robot the fit was not developed on (magnetization x1.1, kinetic friction x0.85) under a
    turning field: the nominal start alone ends in a local minimum (friction ~x1.1). Each value is
    either recovered within 3 % with a stated interval holding the truth, or declared not
    identifiable, without an interval (issue 49's "or declares the parameter unidentifiable"). The
    magnetization, which sets the motion, must be recovered; the friction, whose 0.5 s of motion
    leaves a valley of costs within the noise, is recovered on some machines (x0.85: measured before
    2026-12-02) and on others ends elsewhere in that valley (x0.780 on the 2026-12-02 machine and
    install), where it must be declared not identifiable rather than stated with a tight interval."""
    truth = np.array([1.1, 0.85])
    fields = rotating(0.5)
    measured = synthetic(spec, "magnetization,robot.ground.kinetic_mu", truth, fields, 0.5)
    fits = parse_fit("magnetization,robot.ground.kinetic_mu", spec)
    report = identify(fields, measured, spec, fits, confirm=False, max_evaluations=150,
                      stages_count=2, noise_m=NOISE_M)
    fitted = list(report["fitted"].values())
    assert fitted[0]["identifiable"] and abs(fitted[0]["factor"] / truth[0] - 1) < 0.03, fitted[0]
    for fit, true in zip(fitted, truth, strict=True):
        if abs(fit["factor"] / true - 1) >= 0.03:  # missed: it must say it cannot tell
            assert not fit["identifiable"] and fit["interval"] is None, fit
        elif fit["interval"] is not None:
            assert fit["interval"][0] <= true <= fit["interval"][1], fit
    assert report["residual_vs_noise"] < 2.0
    assert report["optimizer"]["simulations"] <= 150
    assert len(report["optimizer"]["starts"]) == 3


def test_a_value_the_motion_does_not_depend_on_is_not_identifiable(tmp_path, spec):
    """The slip velocity tolerance (1e-8 m/s) moves the points by 0.3 nm per 10 %: no trajectory
    determines it, and it must not come with a tight interval."""
    fields = rotating(0.3)
    measured = synthetic(spec, "magnetization", np.array([1.1]), fields, 0.3)
    fits = parse_fit("magnetization,robot.ground.slip_velocity_tolerance", spec)
    report = identify(fields, measured, spec, fits, confirm=False, max_evaluations=12, starts=1,
                      stages_count=1, noise_m=NOISE_M)
    flat = report["fitted"]["robot.ground.slip_velocity_tolerance"]
    assert not flat["identifiable"] and flat["reason"].startswith("flat cost")
    # no interval, or one wider than the bounds of the fit (x0.2 ... x5): not a tight one
    assert flat["interval"] is None or (flat["interval"][0] < 0.2 and flat["interval"][1] > 5.0)
    assert any("slip_velocity_tolerance is not identifiable" in w for w in report["warnings"])
    write_identified(report, spec, measured, tmp_path / "id")  # its figure has no interval to show
    written = json.loads((tmp_path / "id" / "identify.json").read_text())
    assert written["fitted"]["robot.ground.slip_velocity_tolerance"]["identifiable"] is False


def test_the_residual_flag_fires_when_the_value_that_differs_is_not_fitted(tmp_path, spec, capsys):
    """Magnetization off by 20 %, friction fitted: the residual is far above the noise, and the
    command says so on stderr and in identify.json."""
    fields = rotating(0.3)
    write_field_csv(tmp_path / "fields.csv", fields)
    fields = read_field_csv(tmp_path / "fields.csv")
    measured = synthetic(spec, "magnetization", np.array([1.2]), fields, 0.3)
    columns = ",".join(f"x_{s:g}_m,y_{s:g}_m" for s in FRACTIONS)
    lines = [",".join([f"{t:.6f}", *(f"{v:.9f}" for v in p.ravel())])
             for t, p in zip(measured.times, measured.positions, strict=True)]
    (tmp_path / "track.csv").write_text(f"t_s,{columns}\n" + "\n".join(lines) + "\n")
    out = tmp_path / "id"
    assert main(["real", "identify", str(tmp_path / "fields.csv"), str(tmp_path / "track.csv"), "--robot",
                 CASE, "--fit", "friction", "--out", str(out), "--no-confirm",
                 "--starts", "2", "--max-evaluations", "16", "--noise-m", "5e-5"]) == 0
    captured = capsys.readouterr()
    # round 4, V12: progress off a terminal is plain lines, not a "\r"-redrawn one
    assert "\r" not in captured.err and "msr real identify: 100% (16/16 simulation)" in captured.err
    report = json.loads((out / "identify.json").read_text())
    assert report["residual_vs_noise"] > 2.0
    assert "msr real identify: warning: the residual RMS" in captured.err
    # friction cannot explain the magnetization's 20 %: the fit keeps the spec's values (round 19)
    assert report["kept_spec_values"] is True
    assert any("does not explain the data" in w for w in report["warnings"])
    assert f"({report['residual_vs_noise']:.2f} x the noise)" in captured.out
    assert "2 start(s), " in captured.out


def _one_stopped_start(factor, cost_factor=None):
    """A ``_fit_one_start`` that ends, unconverged, at ``factor`` x the spec's value, its recorded cost
    that of ``cost_factor`` (default ``factor``): a start the budget stopped."""
    def stopped(problem, x0, budget):
        r = problem.whole.residuals(np.array([factor if cost_factor is None else cost_factor]))
        return {"x": np.array([np.log(factor)]), "cost": float(r @ r), "rms_m": float(np.sqrt(np.mean(r**2))),
                "converged": False, "status": None, "message": "stopped", "stages": [],
                "polish": {"converged": False, "message": "", "simulations": 0}}

    return stopped


def test_a_fit_that_ends_worse_than_the_spec_keeps_the_specs_values(spec, monkeypatch):
    """Round 11, S3: a search cut short (its stages judged on a short horizon) wrote a
    magnetization of 0.605 x nominal that fitted the whole trajectory worse than the nominal."""
    import elastica_magnetic_rl.sim2real.identify as identify_module

    fields = rotating(0.3)
    keys = "robot.magnetization.magnitude"
    measured = synthetic(spec, keys, np.array([1.0]), fields, 0.3)

    # a start that stopped far from the truth
    monkeypatch.setattr(identify_module, "_fit_one_start", _one_stopped_start(0.6))
    report = identify(fields, measured, spec, parse_fit(keys, spec), starts=1, max_evaluations=10,
                      noise_m=NOISE_M, confirm=False)
    assert report["kept_spec_values"] is True
    fitted = report["fitted"]["robot.magnetization.magnitude"]
    assert fitted["factor"] == 1.0
    assert report["residual_m"]["rms"] == report["residual_m"]["nominal_rms"]
    assert report["warnings"][0].startswith("the fit did not improve on the spec")


def test_a_start_the_budget_stopped_does_not_make_an_interval(spec, monkeypatch):
    """Round 30, S1: ``--starts 1`` whose one start stopped unconverged (its recorded cost as good as
    the spec's) made "factor unbounded (from the starts)" and "not identifiable": the start's end
    point, reached by no convergence, stood for a flat cost. Only converged starts widen an
    interval now; the verdict comes from the Jacobian and the profile at the kept values."""
    import elastica_magnetic_rl.sim2real.identify as identify_module

    fields = rotating(0.3)
    keys = "robot.magnetization.magnitude"
    measured = synthetic(spec, keys, np.array([1.0]), fields, 0.3)

    # stopped far away, its (short-horizon) cost the spec's
    monkeypatch.setattr(identify_module, "_fit_one_start", _one_stopped_start(0.6, cost_factor=1.0))
    report = identify(fields, measured, spec, parse_fit(keys, spec), starts=1, max_evaluations=10,
                      noise_m=NOISE_M, confirm=False)
    fitted = report["fitted"][keys]
    assert fitted["interval_from"] != "starts", fitted
    assert fitted["identifiable"] and fitted["interval"][0] <= 1.0 <= fitted["interval"][1], fitted
    assert any("did not converge" in w for w in report["warnings"]), report["warnings"]


def test_a_fit_stopped_short_of_its_minimum_is_not_judged(spec, monkeypatch):
    """Round 31, S1: a fit of a 1.3 x magnetization that stalled at x1.001 reported the value "NOT
    IDENTIFIABLE: flat cost" though the profile, 10 % away, found a much lower cost: the fit had not
    reached its minimum. Such a value is now not judged (``identifiable: null``, no interval), the
    reason naming where the lower cost lies."""
    import elastica_magnetic_rl.sim2real.identify as identify_module

    fields = rotating(0.3)
    keys = "robot.magnetization.magnitude"
    measured = synthetic(spec, keys, np.array([1.3]), fields, 0.3)

    # a hair from the spec's values, stopped by the budget
    monkeypatch.setattr(identify_module, "_fit_one_start", _one_stopped_start(1.001))
    report = identify(fields, measured, spec, parse_fit(keys, spec), starts=1, max_evaluations=10,
                      noise_m=NOISE_M, confirm=False)
    fitted = report["fitted"][keys]
    assert fitted["identifiable"] is None and fitted["interval"] is None, fitted
    assert fitted["reason"].startswith("not judged: the fit stopped short of its minimum"), fitted["reason"]
    assert not any("is not identifiable" in w for w in report["warnings"]), report["warnings"]


def test_a_fit_that_barely_improves_on_the_spec_keeps_the_specs_values(spec, monkeypatch):
    """Round 19, S17: a flat cost left the moment at x0.2 with the spec's own residual (reported
    not identifiable) and wrote it into identified.toml: an improvement below MIN_IMPROVEMENT
    keeps the spec's values."""
    import elastica_magnetic_rl.sim2real.identify as identify_module

    fields = rotating(0.3)
    keys = "robot.magnetization.magnitude"
    measured = synthetic(spec, keys, np.array([1.0]), fields, 0.3)

    def barely(problem, x0, budget):  # the lower of two factors a hair from the spec's
        options = []
        for factor in (1.0 - 1e-5, 1.0 + 1e-5):
            r = problem.whole.residuals(np.array([factor]))
            options.append((float(r @ r), np.array([np.log(factor)]), r))
        cost, x, r = min(options, key=lambda o: o[0])
        return {"x": x, "cost": cost, "rms_m": float(np.sqrt(np.mean(r**2))), "converged": True,
                "status": None, "message": "", "stages": [],
                "polish": {"converged": True, "message": "", "simulations": 0}}

    monkeypatch.setattr(identify_module, "_fit_one_start", barely)
    report = identify(fields, measured, spec, parse_fit(keys, spec), starts=1, max_evaluations=10,
                      noise_m=NOISE_M, confirm=False)
    assert report["kept_spec_values"] is True
    assert report["fitted"][keys]["factor"] == 1.0
    assert "less than 0.1 % better" in report["warnings"][0]


def test_a_fit_whose_confirmation_tells_the_physics_apart_is_warned_about():
    """A tip path made in the accurate physics (msr policy generate --target writes one), fitted in
    the training physics, came out at x0.947 +- 0.010 of the true moment, its interval missing the
    truth, with no warning: the fit left 0.073 mm RMS, the accurate confirmation 0.011 mm. A
    confirmation 2x apart from the fit, either way, now warns that the values are biased."""
    from elastica_magnetic_rl.sim2real.fit_report import physics_warning as _physics_warning

    better = _physics_warning(7.29e-5, {"rms_m": 1.11e-5}, "training")
    assert better is not None and "accurate physics fits the motion better" in better
    assert "--physics accurate" in better
    worse = _physics_warning(4.9e-5, {"rms_m": 4.1e-4}, "training")  # docs: a fast rolling robot
    assert worse is not None and "fits the motion worse" in worse
    assert _physics_warning(5e-5, {"rms_m": 6e-5}, "training") is None  # the physics agree
    assert _physics_warning(7.29e-5, {"rms_m": 1.11e-5}, "accurate") is None  # fitted where it belongs
