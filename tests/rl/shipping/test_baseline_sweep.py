"""``msr field baseline`` without ``--period``: the sweep (rl/shipping/baseline_sweep.py)."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.shipping.baseline_sweep import achieved_period, yardstick_spec
from smoke import run_msr

from elastica_magnetic.cli import main as msr
from elastica_magnetic.rotation import min_rotation_period

DOCS_EXAMPLES = Path(__file__).resolve().parents[3] / "docs" / "examples"

QUICK = ["--physics", "training", "--duration", "0.5", "--no-figures", "--no-progress"]


def test_the_sweep_picks_the_farthest_of_the_single_runs(tmp_path, capsys):
    single = {}
    for period in ("0.25", "0.5"):  # no longer than the 0.5 s runs: the field turns
        for direction in ((), ("--counterclockwise",)):
            r = run_msr(capsys, "field", "baseline", "--case", "m1-4mT", "--period", period, *direction,
                        "--out", str(tmp_path / f"p{period}{len(direction)}"), *QUICK)
            single[(float(period), not direction)] = r["mid_dx_m"]
    assert len(set(single.values())) == 4  # distinct: the answer is known
    sweep = run_msr(capsys, "field", "baseline", "--case", "m1-4mT", "--periods", "0.25,0.5", "--workers",
                    "2",
                    "--out", str(tmp_path / "sweep"), *QUICK)
    assert sweep["physics"] == "training" and sweep["duration_s"] == 0.5
    assert {(r["period_s"], r["clockwise"]): r["mid_dx_m"] for r in sweep["runs"]} == single
    best_key = max(single, key=single.get)
    assert (sweep["best"]["period_s"], sweep["best"]["clockwise"]) == best_key
    assert sweep["generate"]["mid_dx_m"] == single[best_key]  # the best one's files
    with open(sweep["table_csv"]) as f:
        assert len(list(csv.DictReader(f))) == 4
    assert Path(tmp_path / "sweep" / "fields.csv").is_file()
    # generate.json names the files where they are, not the sweep's temporary folder
    text = (tmp_path / "sweep" / "generate.json").read_text()
    assert ".msr-new-" not in text and str(tmp_path / "sweep" / "fields.csv") in text


def test_single_period_reports_the_period_achieved(tmp_path, capsys):
    case = load_case("m1-10mT")
    fastest = min_rotation_period(case.field_limit, case.actuation.max_increment)
    assert fastest > 1.0  # 10 mT at 0.3 mT per step cannot turn once a second
    r = run_msr(capsys, "field", "baseline", "--case", "m1-10mT", "--period", "1", "--out",
                str(tmp_path / "b"), "--physics", "training", "--duration", "3", "--no-figures",
                "--no-progress")
    assert r["period_asked_s"] == 1.0 and r["period_achieved_s"] > 1.05
    assert r["warning"] and "turned once per" in r["warning"]


def test_achieved_period_of_a_slow_turn_agrees():
    case = load_case("m1-4mT")
    t = np.arange(400) * 0.01
    field = 4e-3 * np.stack([np.cos(-2 * np.pi * t / 2.0), np.sin(-2 * np.pi * t / 2.0),
                             0 * t], axis=1)
    result = achieved_period(field, 2.0, case)
    assert result["period_achieved_s"] == pytest.approx(2.0, rel=1e-6) and result["warning"] is None
    assert math.isinf(achieved_period(np.zeros((10, 3)), 2.0, case)["period_achieved_s"])


def test_set_yardstick_writes_a_spec_copy(tmp_path, capsys):
    case = load_case("m1-4mT")
    best = {"period_s": 3.0, "clockwise": True, "period_achieved_s": 3.0, "mid_dx_m": 0.0421}
    path = yardstick_spec(case, best, tmp_path / "mine.toml")
    copy = load_case(path)
    assert copy.yardstick.distance_10s == 0.0421 and "period 3 s" in copy.yardstick.source
    assert (copy.yardstick.period, copy.yardstick.clockwise) == (3.0, True)  # the field, to start from
    assert copy.robot.tables == case.robot.tables and copy.name == "mine"
    # a spec that names itself keeps its name in the copy (it was dropped)
    own = tmp_path / "own.toml"
    own.write_text('name = "crawler"\n' + case.toml())
    named = yardstick_spec(load_case(own), best, tmp_path / "own-yardstick.toml")
    assert load_case(named).name == "crawler"
    # the yardstick is the accurate physics' 10 s: a quick sweep cannot set it
    assert msr(["field", "baseline", "--case", "m1-4mT", "--set-yardstick", str(tmp_path / "x.toml"),
                *QUICK]) == 2
    assert "--set-yardstick" in capsys.readouterr().err and not (tmp_path / "x.toml").exists()


def test_a_copy_of_a_rate_limited_turn_does_not_warn_about_its_own_period(tmp_path):
    """The loop's own copy of a sweep whose best field asked for a faster turn than the rate limit
    gives (0.5 s, turned once per 0.726 s) warned at every command that read it, about a value the
    sweep measured and its source states; a period the limit allows is not marked."""
    import warnings

    case = load_case(str(DOCS_EXAMPLES / "mybot_loop.toml"))  # its fastest uniform turn: 0.84 s
    fast = {"period_s": 0.5, "clockwise": True, "period_achieved_s": 0.726, "mid_dx_m": 0.02}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        copy = load_case(yardstick_spec(case, fast, tmp_path / "fast.toml"))
    assert copy.yardstick.period == 0.5 and "turned once per 0.726 s" in copy.yardstick.source
    assert "yardstick.period" in copy.to_dict()["checks"]["accept"]
    slow = {"period_s": 3.0, "clockwise": True, "period_achieved_s": 3.0, "mid_dx_m": 0.02}
    assert "yardstick.period" not in load_case(yardstick_spec(case, slow, tmp_path / "slow.toml")
                                              ).to_dict().get("checks", {}).get("accept", [])
    edited = (tmp_path / "fast.toml").read_text().replace('    "yardstick.period",\n', "")
    (tmp_path / "edited.toml").write_text(edited)
    with pytest.warns(UserWarning, match="shorter than the case's rate limit"):
        load_case(tmp_path / "edited.toml")


def test_a_yardstick_copy_says_what_it_was_measured_in(tmp_path):
    """``msr loop --quick`` writes its spec copy from a short training-physics sweep: the copy's
    source says so (it used to claim 10 s of the accurate physics whatever was run)."""
    case = load_case("m1-4mT")
    best = {"period_s": 1.0, "clockwise": True, "period_achieved_s": 1.0, "mid_dx_m": 0.005}
    copy = load_case(yardstick_spec(case, best, tmp_path / "quick.toml", physics="training",
                                    duration=0.5))
    assert "in 0.5 s, training physics" in copy.yardstick.source
    assert "not a yardstick" in copy.yardstick.source
    real = load_case(yardstick_spec(case, best, tmp_path / "real.toml"))
    assert "in 10 s, accurate physics" in real.yardstick.source
    assert "not a yardstick" not in real.yardstick.source


def test_periods_longer_than_the_run_are_refused_or_left_out(tmp_path, capsys):
    # issue 48 o15: --periods 1 --duration 0.02 ran, showed "turned s: inf", blamed the rate
    # limit and picked a "best" among -0.00 mm
    short = ["--physics", "training", "--duration", "0.3", "--no-figures", "--no-progress"]
    for argv in (["--periods", "1,2"], ["--period", "1"]):
        out = tmp_path / "refused"
        assert msr(["field", "baseline", "--case", "m1-4mT", *argv, "--out", str(out), *short]) == 2
        err = capsys.readouterr().err
        assert "longer than --duration 0.3 s" in err and "1" in err, err
        assert not out.exists()
    assert msr(["field", "baseline", "--case", "m1-4mT", "--periods", "0.3,1", "--workers", "1", "--out",
                str(tmp_path / "sweep"), *short, "--json"]) == 0
    captured = capsys.readouterr()
    assert "warning: --periods 1 s left out: longer than --duration 0.3 s" in captured.err
    sweep = json.loads(captured.out)
    assert {r["period_s"] for r in sweep["runs"]} == {0.3}
    assert sweep["dropped_periods_s"] == [1.0]
    # round 13 S3: a period given twice was simulated twice (duplicate rows, twice the cost)
    assert msr(["field", "baseline", "--case", "m1-4mT", "--periods", "0.3,0.5,0.3", "--out",
                str(tmp_path / "twice"), *short]) == 2
    assert "--periods: 0.3 s given twice; give each period once" in capsys.readouterr().err
    assert not (tmp_path / "twice").exists()


def test_the_rate_limit_is_blamed_only_when_it_is_the_cause():
    case = load_case("m1-4mT")
    fastest = min_rotation_period(case.field_limit, case.actuation.max_increment)
    rate_limit = "per axis per 0.01 s"
    t = np.arange(2) * 0.01  # a run shorter than the period: no turn
    still = 4e-3 * np.stack([np.ones_like(t), 0 * t, 0 * t], axis=1)
    warning = achieved_period(still, 1.0, case)["warning"]
    assert warning and rate_limit not in warning and "shorter than one period" in warning
    slow = achieved_period(still, 0.5 * fastest, case)["warning"]  # faster than the limit allows
    assert slow and rate_limit in slow


def test_a_turn_measured_faster_than_the_limit_says_the_field_was_still_growing():
    """Round 5, O20: "turned once per 0.7262 s (...: the shortest uniform turn takes 0.8376 s)"
    read as a contradiction; a weaker field (one still growing from zero) turns faster under the
    same per-axis limit, and the warning says so."""
    case = load_case("m1-4mT")
    fastest = min_rotation_period(case.field_limit, case.actuation.max_increment)
    t = np.arange(300) * 0.01
    weak = 1e-3 * np.stack([np.cos(-2 * np.pi * t / 0.6), np.sin(-2 * np.pi * t / 0.6), 0 * t],
                           axis=1)  # 1 mT turning in 0.6 s: within 0.3 mT per axis per step
    result = achieved_period(weak, 0.5, case)
    assert result["period_achieved_s"] == pytest.approx(0.6, rel=1e-3) and 0.6 < fastest
    assert f"it measured faster than {fastest:.4g} s because the field was still growing" in (
        result["warning"])
    assert "still growing" not in achieved_period(weak, 0.9, case)["warning"]  # not the limit's case
