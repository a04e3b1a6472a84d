"""Every command on robots the tests do not contain (issue 49): specs drawn from the spec matrix
(``tests/rl/spec_matrix.py``: segments, per-element tables, named patterns; Poisson ratio or
shear modulus; band or round; crawl or reach; two field axes or three) go through train ->
refine (randomized by the default set) -> generate -> robustness of the refined run -> export,
baseline and its yardstick copy, and identify with every default group, at tiny durations. Each
step checks what could be false: every default group present and applied, the same robot in
every command (robustness's nominal run is generate's run), the files a later step reads back
through the parser."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.cases.variations import DEFAULT_RANGES
from elastica_magnetic_rl.shipping.baseline_sweep import yardstick_spec
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from smoke import SMOKE
from spec_matrix import ACTUATIONS, user_specs

from elastica_magnetic.cli import main as msr
from elastica_magnetic.field_csv import write_field_csv
from elastica_magnetic.specfile import describe_robot, dumps, read_spec

#: A few drawn specs per test, the same ones every run (derandomized): each runs whole commands.
DRAWN = settings(max_examples=2, derandomize=True, database=None, deadline=None,
                 phases=[Phase.generate],
                 suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
#: One drawn spec per form (the rest of it drawn): the magnetizations a user's own robot most
#: often has and the paper's cases lack, each with the other moduli, section and task.
FORMS = [pytest.param(dict(kinds=("segments",), poisson=True, round_section=False, task="crawl",
                           actuation=ACTUATIONS[3]),
                      id="segments-poisson-band-crawl-xyz"),
         pytest.param(dict(kinds=("table",), poisson=False, round_section=True, task="reach",
                           actuation=ACTUATIONS[0]),
                      id="table-shear-round-reach-xy")]


def _json(capsys, *argv: str) -> dict:
    capsys.readouterr()
    status = msr([*argv, "--json"])
    captured = capsys.readouterr()
    assert status == 0, captured.err
    return json.loads(captured.out)


def _write(spec: dict, folder: Path) -> Path:
    path = folder / "drawn.toml"
    path.write_text(dumps(spec))
    return path


def _rotating_field(path: Path, duration: float = 0.3, amplitude_mT: float = 4.0) -> Path:
    t = np.arange(int(round(100 * duration))) / 100
    a = 1e-3 * amplitude_mT * np.minimum(t / 0.1, 1.0)
    phase = -4 * np.pi * t + np.pi / 2
    write_field_csv(path, np.stack([a * np.cos(phase), a * np.sin(phase), 0 * t], axis=1))
    return path


@pytest.mark.parametrize("form", FORMS)
@settings(DRAWN, max_examples=1)
@given(data=st.data())
def test_train_refine_generate_robustness_export_on_a_drawn_robot(form, data, capsys):
    spec = data.draw(user_specs(**form))
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        path = _write(spec, folder)
        runs = folder / "runs"
        assert msr(["train", "--case", str(path), "--seeds", "1", "--workers", "1", "--steps", "120",
                    "--out", str(runs), *SMOKE]) == 0
        seed = runs / "drawn" / "seed0"
        refined = _json(capsys, "refine", str(seed), "--checkpoint", "final", "--steps", "3",
                        "--episode-duration", "0.02", "--physics", "training", "--randomize",
                        "default", "--no-progress")
        assert set(refined["randomize"]) == set(DEFAULT_RANGES) and refined["randomized_robots"] >= 1
        # the refined run's stored spec reads back through its own parser, randomization kept
        stored = json.loads((seed / "refined" / "run.json").read_text())["case_spec"]
        assert set(stored["training"]["randomize"]) == set(DEFAULT_RANGES)

        generated = _json(capsys, "policy", "generate", str(seed / "refined"), "--duration", "0.05", "--out",
                          str(folder / "gen"), "--no-figures", "--no-progress")
        robust = _json(capsys, "real", "robustness", str(seed / "refined"), "--duration", "0.05",
                       "--physics", "accurate", "--no-corners", "--workers", "1", "--out",
                       str(folder / "rob"), "--no-progress")
        assert {v["name"] for v in robust["variations"]} == set(DEFAULT_RANGES)
        assert len(robust["variants"]) == 1 + 2 * len(DEFAULT_RANGES)  # nominal, each group low/high
        # the nominal robot of robustness is generate's robot: the same run, the same distance
        for loop in ("closed_loop", "open_loop"):
            assert robust["summary"][loop]["nominal_m"] == pytest.approx(generated["mid_dx_m"],
                                                                          rel=1e-9, abs=1e-15)
        moved = {v["label"]: v["open_loop"]["distance_m"] for v in robust["variants"]}
        assert len(set(moved.values())) > 1, moved  # the variants are different robots

        exported = _json(capsys, "policy", "export", str(seed / "refined"), "--out", str(folder / "exp"),
                         "--no-progress")
        assert exported["max_abs_diff"] < 1e-5 and exported["case"] == "drawn"


@DRAWN
@given(spec=user_specs())
def test_baseline_and_its_yardstick_copy_on_a_drawn_robot(spec, capsys):
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        path = _write(spec, folder)
        result = _json(capsys, "field", "baseline", "--case", str(path), "--period", "0.04", "--duration",
                       "0.05", "--out", str(folder / "base"), "--no-figures", "--no-gif",
                       "--no-progress")
        assert result["case"] == "drawn" and np.isfinite(result["mid_dx_m"])
        best = {"period_s": 0.04, "clockwise": True, "period_achieved_s": 0.04,
                "mid_dx_m": 0.0123}
        copy = load_case(yardstick_spec(load_case(path), best, folder / "mine.toml"))
        assert copy.yardstick.distance_10s == 0.0123
        assert copy.robot.tables == load_case(path).robot.tables  # the robot as the user wrote it


@settings(DRAWN, max_examples=1)  # ~30 s a spec: one, of a form the pipeline test does not draw
@given(spec=user_specs(kinds=("two-segment", "sinusoid", "uniform"), poisson=True, round_section=True))
def test_identify_fits_every_default_group_on_a_drawn_robot(spec, capsys):
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        path = _write(spec, folder)
        fields = _rotating_field(folder / "fields.csv")
        assert msr(["field", "replay", str(fields), "--robot", str(path), "--physics", "training",
                    "--out", str(folder / "measured")]) == 0
        report = _json(capsys, "real", "identify", str(fields), str(folder / "measured" / "trajectory.csv"),
                       "--robot", str(path), "--fit", ",".join(DEFAULT_RANGES), "--out",
                       str(folder / "id"), "--starts", "1", "--max-evaluations", "16",
                       "--no-confirm", "--physics", "training", "--no-progress")
        assert set(report["fitted"]) == set(DEFAULT_RANGES)
        # the identified spec is the user's spec with the fitted factors applied to what each group
        # names, and reads back through the parser
        identified = describe_robot(read_spec(folder / "id" / "identified.toml"), "identified.toml")
        nominal = describe_robot(spec, "drawn.toml").robot("training")
        robot = identified.robot("training")
        factors = {name: fit["factor"] for name, fit in report["fitted"].items()}
        np.testing.assert_allclose(robot.magnetization, factors["magnetization"] *
                                   nominal.magnetization, rtol=1e-6)
        assert robot.youngs_modulus == pytest.approx(factors["modulus"] * nominal.youngs_modulus,
                                                     rel=1e-6)
        assert robot.density == pytest.approx(factors["density"] * nominal.density, rel=1e-6)
        assert robot.ground.kinetic_mu == pytest.approx(factors["friction"] *
                                                        nominal.ground.kinetic_mu, rel=1e-6)


@pytest.mark.slow
@settings(DRAWN, max_examples=3)
@given(spec=user_specs(task="goto"))
def test_goto_commands_on_a_drawn_robot(spec, capsys):
    """A user's own goto robot (any magnetization form, moduli, section, three-axis actuation,
    sideways model and share of heading episodes): trained (smoke), sent to a point and along a
    heading by its policy, and along a heading by the steering yardstick; every course's numbers
    finite and in the start frame."""
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        path = _write(spec, folder)
        runs = folder / "runs"
        assert msr(["train", "--case", str(path), "--seeds", "1", "--workers", "1", "--steps", "120",
                    "--out", str(runs), *SMOKE]) == 0
        seed = runs / "drawn" / "seed0"
        point = _json(capsys, "policy", "generate", str(seed), "--checkpoint", "final", "--target", "0,0.005",
                      "--duration", "0.2", "--physics", "training", "--out", str(folder / "point"),
                      "--no-figures", "--no-progress")
        assert point["goto"]["target_left_m"] == 0.005 and np.isfinite(point["final_distance_to_target_m"])
        for who, argv in (("policy", ["policy", "generate", str(seed), "--checkpoint", "final"]),
                          ("yardstick", ["field", "baseline", "--case", str(path)])):
            result = _json(capsys, *argv, "--heading", "-0.5", "--duration", "0.2", "--physics", "training",
                           "--out", str(folder / who), "--no-progress", "--no-gif")
            course = result["heading"]
            assert course["heading_rad"] == -0.5, who
            if who == "yardstick":  # the spec's [yardstick] turn_in_place, true where not given
                walks = spec.get("yardstick", {}).get("turn_in_place") is False
                assert ("never turning in place" in result["policy"]) == walks
            assert np.isfinite(course["distance_along_m"]) and np.isfinite(course["cross_track_m"]), who
            assert (folder / who / "top_view.png").stat().st_size > 0, who
