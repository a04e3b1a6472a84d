"""Round 9 of held-out tries (issue 48): results reported as right that were not (S1, S3, S4).
Each test fails without its fix (D1-D3 and S2 are tested where their mechanisms live:
tests/test_results.py, tests/test_filesets.py, tests/rl/loop/test_msr_loop.py,
tests/rl/shipping/test_ship.py)."""

from __future__ import annotations

import warnings

import pytest
from elastica_magnetic_rl.cases.case import case_from_dict, load_case

from elastica_magnetic.cli import main as msr
from elastica_magnetic.plausibility import ImplausibleValueWarning
from elastica_magnetic.specfile import SpecError, dumps


def _task(case: str, **changes) -> dict:
    spec = load_case(case).to_dict()
    spec["task"] = {**spec["task"], **changes}
    return spec


def test_a_speed_penalty_that_makes_the_task_unlearnable_is_refused():
    """S1: speed_penalty = 50 (50 % meant) passed every check; at 1 or more a step toward the
    target inside the slow zone earns nothing."""
    for case in ("m1-4mT-reach", "m1-4mT-goto"):
        with pytest.raises(SpecError, match=r"\[task\] speed_penalty: 50 >= 1.*50 % is 0.5"):
            case_from_dict(_task(case, speed_penalty=50.0), "my.toml")
        with pytest.raises(SpecError, match="speed_penalty: 1 >= 1"):
            case_from_dict(_task(case, speed_penalty=1.0), "my.toml")
    case_from_dict(_task("m1-4mT-reach", speed_penalty=0.9), "my.toml")


def test_a_slow_zone_in_mm_written_as_m_is_warned_about():
    """S1: slow_zone = 2.0 (2 mm meant) passed in silence."""
    for case in ("m1-4mT-reach", "m1-4mT-goto"):
        with pytest.warns(ImplausibleValueWarning, match=r"slow_zone: 2 m is not smaller than the "
                                                         r"target's distance.*2 mm is 0.002 m"):
            case_from_dict(_task(case, slow_zone=2.0), "my.toml")
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImplausibleValueWarning)
        case_from_dict(_task("m1-4mT-reach", slow_zone=0.003), "my.toml")


@pytest.mark.parametrize("argv, named", [
    (["policy", "generate", "m1-4mT", "--workers", "2", "--duration", "0.05", "--out", "OUT"],
     "--workers is the number of --ring targets"),
    (["train", "--case", "m1-4mT", "--seeds", "1", "--seeds-per-simulator", "4", "--out", "OUT"],
     "--seeds-per-simulator 4 is more than --seeds 1"),
    (["real", "stream", "FIELD", "--port", "loop://", "--force"],
     "--force replaces an existing --log or --codes-out file"),
    (["bench", "--quick", "--memory-steps", "10", "--train-seeds", "0"],
     "--memory-steps sets the steps of the --memory-seeds"),
    # round 12, S4: one rollout took --workers without a word
    (["field", "baseline", "--case", "m1-4mT", "--period", "0.2", "--workers", "2", "--duration", "0.3",
      "--out", "OUT"], "--period runs one rollout, in one process"),
    (["field", "baseline", "--case", "m1-4mT-goto", "--workers", "2", "--duration", "0.3", "--out",
      "OUT"], "one target runs one rollout, in one process"),
    (["field", "baseline", "--case", "m1-4mT-goto", "--period", "1", "--duration", "0.3", "--out",
      "OUT"], "--period 1 s is longer than --duration 0.3 s: the steering field would not turn"),
])
def test_options_that_cannot_act_are_refused(tmp_path, capsys, argv, named):
    """S3: four options were accepted and did nothing."""
    field = tmp_path / "f.csv"
    field.write_text("index,mag_x,mag_y,mag_z\n0,0,0,0\n1,0,0,0\n")
    argv = [str(field) if a == "FIELD" else str(tmp_path / "o") if a == "OUT" else a for a in argv]
    try:
        status = msr(argv)
    except SystemExit as exc:
        status = exc.code
    assert status == 2 and named in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("magnetization", [
    {"kind": "uniform", "magnitude": 0.0},
    {"kind": "table", "values": [[0.0] * 64, [0.0] * 64, [0.0] * 64]},
])
def test_a_robot_without_magnetization_is_named(tmp_path, magnetization):
    """S4: magnitude 0 (or a table of zeros) passed every check while 61.3 A/m was warned about:
    no field can move such a robot."""
    spec = load_case("m1-4mT").to_dict()
    spec["robot"]["magnetization"] = magnetization
    path = tmp_path / "zero.toml"
    path.write_text(dumps(spec))
    with pytest.raises(SpecError, match="no magnetization: no field can move it"):
        load_case(path)


def test_figures_of_a_generate_result_are_regenerated_with_force(tmp_path, capsys):
    """V8: each refusal pointed to the other (--force, then "not written by msr"): the figures a
    generate result lists in its marker are msr's."""
    out = tmp_path / "gen"
    assert msr(["policy", "generate", "m1-4mT", "--duration", "0.05", "--physics", "training",
                "--no-gif", "--no-progress", "--out", str(out)]) == 0
    assert msr(["policy", "figures", str(out), "--no-gif"]) == 2
    assert "pass --force" in capsys.readouterr().err
    assert msr(["policy", "figures", str(out), "--no-gif", "--force"]) == 0, capsys.readouterr().err


def test_vary_factors_written_as_percent_are_named():
    """V2: --vary modulus=80:120 (percent meant) ended in advice to lower the spec's dt."""
    from elastica_magnetic_rl.cases.variations import VariationError, parse_variation

    with pytest.raises(VariationError, match="80:120 looks like percent: 0.8:1.2"):
        parse_variation("modulus=80:120")
    assert parse_variation("modulus=0.8:1.2").high == 1.2


def test_a_poisson_ratio_in_percent_and_bearings_in_degrees_are_named():
    """V1: only the bound was given (poisson_ratio = 48, angle_low = -180)."""
    spec = load_case("m1-4mT").to_dict()
    spec["robot"] = {k: v for k, v in spec["robot"].items() if k != "shear_modulus"} | {"poisson_ratio": 48.0}
    with pytest.raises(SpecError, match=r"poisson_ratio: must be <= 0.5.*48 percent is 0.48"):
        case_from_dict(spec, "nu.toml")
    with pytest.raises(SpecError, match=r"angle_low: .*degrees\? give rad \(-180 degrees = -3.14159 rad\)"):
        case_from_dict(_task("m1-4mT-goto", angle_low=-180.0), "g.toml")
