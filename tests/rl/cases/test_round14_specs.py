"""Round 14 of held-out tries (issue 48): the findings in the spec tables of steered catheters, the
[field] sources and the summary of msr case check, each refused, warned or named."""

from __future__ import annotations

import json
import tomllib
import warnings

import pytest
from elastica_magnetic_rl.cases.case import load_case
from spec_texts import CATHETER_MAGNET_REACH

from elastica_magnetic.cli import main as msr
from elastica_magnetic.specfile import SpecError


def spec(**changes: object) -> dict:
    """The test catheter (an insertion stage added) with ``changes`` ("table.key": value)."""
    data = tomllib.loads(CATHETER_MAGNET_REACH)
    data["name"] = "catheter"
    data["actuation"].update(insertion=[-0.01, 0.01], insertion_speed=0.01)
    for dotted, value in changes.items():
        table, key = dotted.split(".")
        data[table][key] = value
    return data


def warned(data) -> list[str]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_case(data)
    return [str(w.message) for w in caught]


@pytest.mark.parametrize(("key", "value", "expected"), [
    # S1: speeds under the hard caps, in mm/s or deg/s
    ("actuation.insertion_speed", 5.0, r"insertion_speed: 5 m/s is faster than a lab.*5 mm/s is 0.005 m/s"),
    ("actuation.insertion_speed", 0.5, r"insertion_speed: 0.5 m/s crosses the stage's 20 mm travel in 40 ms"),
    ("actuation.max_speed", 3.0, r"max_speed: 3 m/s is faster.*mm/s written as m/s"),
    ("actuation.max_turn_rate", 15.0, r"max_turn_rate: 15 rad/s is more than a turn per second.*15 deg/s is "
                                      r"0.262 rad/s"),
    # S5: a target box behind the clamped base
    ("task.target_box", [[-0.05, -0.01, -0.01], [-0.04, 0.01, 0.01]], r"target_box.*behind the clamped base"),
    # S6: the slow zone in mm covers every target from the first step
    ("task.slow_zone", 3.0, r"slow_zone: 3 m is not smaller.*mm written where m is expected"),
])
def test_unusual_values_are_warned_naming_the_slip(key, value, expected):
    import re

    messages = warned(spec(**{key: value}))
    assert any(re.search(expected, m) for m in messages), messages


def test_the_shipped_catheters_warn_of_nothing():
    for name in ("catheter-magnet-reach", "catheter-coils-reach"):
        assert warned(name) == []


@pytest.mark.parametrize(("changes", "message"), [
    # S1: beyond the caps, the slip named
    ({"actuation.insertion_speed": 10.0}, r"insertion_speed: 10 m/s is beyond any.*10 mm/s is 0.01 m/s"),
    ({"actuation.max_turn_rate": 90.0}, r"max_turn_rate: 90 rad/s is beyond any arm.*degrees"),
    # S3: a magnet that would enclose the rod
    ({"actuation.moment": 1.2e3}, r"min_clearance: 10 mm is less than half the side of a 1200 A m\^2 magnet"),
    # S5: a tolerance the straight tip already meets for every target
    ({"task.tolerance": 0.03}, r"tolerance: 0.03 m: the straight tip at the start is within .* staying"),
    # V5: min_clearance in mm, named as its own fault
    ({"actuation.min_clearance": 10.0}, r"\[actuation\] min_clearance: 10 m is no magnet's.*10 mm is "
                                        r"0.01 m"),
])
def test_values_that_cannot_be_meant_are_refused_by_name(changes, message):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(SpecError, match=message):
            load_case(spec(**changes))


def test_a_field_source_with_a_zero_strength_is_refused_and_a_negligible_one_warned():
    """S4: frequency 0 with phase pi/2 makes cos(phase) = 0 at every time; a 1e-30 A m^2 moment
    gives next to no field on the rod."""
    from elastica_magnetic.field_spec import describe_field
    from elastica_magnetic.spec_format import loads

    base = CATHETER_MAGNET_REACH.split("[actuation]")[0]
    zero = base + ('[field]\nkind = "point-dipole"\nmoment = [2.0, 0.0, 0.0]\nposition = [0.09, 0.04, 0.0]\n'
                   'phase = 1.5707963267948966\n')
    with pytest.raises(SpecError, match=r"\[field\] phase: 1.5708 rad with frequency 0.*makes no field"):
        describe_field(loads(zero, "z.toml"), "z.toml")
    weak = base + '[field]\nkind = "point-dipole"\nmoment = [1e-30, 0.0, 0.0]\nposition = [0.09, 0.04, 0.0]\n'
    with pytest.warns(UserWarning, match=r"below 1e-09 T.*next to nothing"):
        describe_field(loads(weak, "w.toml"), "w.toml")


def test_msr_field_simulate_refuses_a_steered_catheter(tmp_path, capsys):
    """S2: a magnet-arm spec was played as a free rod in a uniform field."""
    path = tmp_path / "cat.toml"
    assert msr(["case", "show", "catheter-magnet-reach", "--toml"]) == 0
    path.write_text(capsys.readouterr().out)
    for command in (["field", "simulate", "--robot", str(path), "--duration", "0.05"],):
        with pytest.raises(SystemExit):
            msr([*command, "--out", str(tmp_path / "o")])
        err = capsys.readouterr().err
        assert 'kind = "magnet-pose": a rod clamped at its base and steered by a source' in err
        assert not (tmp_path / "o").exists()


def test_case_check_counts_and_lists_the_warnings_of_the_spec(tmp_path, capsys):
    """V1: the summary said "no errors, no warnings" after a warning, and --json listed none."""
    path = tmp_path / "weak.toml"
    data = CATHETER_MAGNET_REACH.replace("magnitude = 1.0e5", "magnitude = 800.0")
    assert data != CATHETER_MAGNET_REACH
    path.write_text(data)
    assert msr(["case", "check", str(path), "--json"]) == 0
    issues = json.loads(capsys.readouterr().out)["issues"]
    assert {"level": "warning", "key": "[robot.magnetization] magnitude"} == {
        k: issues[0][k] for k in ("level", "key")} and "800 A/m is below 1000 A/m" in issues[0]["message"]
    assert msr(["case", "check", str(path)]) == 0
    assert "no errors, no warnings" not in capsys.readouterr().out


def test_commands_that_play_a_field_refuse_a_steered_case_at_once(tmp_path, capsys):
    """V2, V3: named at parse time, naming the case and the command; msr loop wrote its folder first."""
    with pytest.raises(SystemExit):
        msr(["loop", "catheter-magnet-reach", "--quick", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert "steers a rod clamped at its base by a source; this command plays a uniform field" in err, err
    assert not (tmp_path / "o").exists()


def test_the_baseline_of_a_steered_case_is_its_steering_yardstick(tmp_path, capsys):
    """Issue 53: msr field baseline of a catheter case steers to its 20 held-out targets; the
    rotating field's options are refused naming the case."""
    assert msr(["field", "baseline", "--case", "catheter-coils-reach", "--period", "1",
                "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "--period does not apply to case 'catheter-coils-reach', steered by a source" in err
    assert not (tmp_path / "o").exists()
    assert msr(["field", "baseline", "--case", "catheter-coils-reach", "--physics", "training", "--duration",
                "0.1", "--out", str(tmp_path / "o"), "--json", "--no-figures"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["targets"] == 20 and result["successes"] == 0 and result["duration_s"] == 0.1
    rows = json.loads((tmp_path / "o" / "targets.json").read_text())["targets_table"]
    assert len(rows) == 20 and all(r["ended_by"] == "time" for r in rows)
    # the straight tip moves a little in 0.1 s: no closer than 1 mm to any held-out target
    assert min(r["closest_distance_m"] for r in rows) > 1e-3
    assert sorted(p.name for p in (tmp_path / "o").iterdir() if not p.name.startswith(".")) == [
        "targets.csv", "targets.json"]


def test_a_weak_magnet_is_named_as_the_actuation_not_the_magnetization():
    """V4: the warning blamed [robot.magnetization] and a field limit the spec does not have."""
    from elastica_magnetic_rl.cases.check import check_case

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        case = load_case(spec(**{"actuation.moment": 1.0e-3}))
    issues = [i for i in check_case(case, sag=False).issues if "magnetic bending number" in i.message]
    assert issues and issues[0].key == "[actuation]" and "mA m^2 written as A m^2" in issues[0].message


def test_the_demo_without_a_duration_runs_its_ten_seconds(tmp_path, monkeypatch, capsys):
    """T2: `msr policy demo` (the README's main job, scripts/main.sh) passed no duration on to the
    rollout and stopped with a TypeError traceback."""
    from elastica_magnetic_rl.shipping import generate as generate_module

    asked = {}

    def fake_generate(name, duration, **kwargs):
        asked.update(name=name, duration=duration)
        return {"fields_csv": None, "notes": [], "diverged": False}

    monkeypatch.setattr(generate_module, "generate", fake_generate)
    assert msr(["policy", "demo", "--out", str(tmp_path / "demo"), "--json"]) == 0
    assert asked == {"name": "m1-4mT", "duration": 10.0}


def test_msr_train_refuses_to_write_into_another_commands_result(tmp_path, capsys):
    """Round 14 D2: its runs went into a `msr field simulate` result, which then could not be
    replaced whole."""
    from elastica_magnetic.result_markers import mark_folder

    result = tmp_path / "kk"
    result.mkdir()
    mark_folder(result, kind="field simulate", subject="robot yao2023-m1")
    before = sorted(p.name for p in result.iterdir())
    for out in (result, result / "sub"):
        assert msr(["train", "--case", "m1-4mT", "--seeds", "1", "--steps", "300", "--set",
                    "learning_starts=100", "--out", str(out), "--no-progress"]) == 2
        err = capsys.readouterr().err
        assert "a result of `msr field simulate` for robot yao2023-m1" in err
        assert "choose another --out" in err
    assert sorted(p.name for p in result.iterdir()) == before


def test_domain_randomization_of_a_steered_case_is_refused_before_any_folder(tmp_path, capsys):
    """Round 14 V10: it passed the checks, then every seed failed inside its worker (a seed folder
    left behind)."""
    data = spec()
    data["training"] = {"randomize": {"magnetization": "0.85:1.15"}}
    with pytest.raises(SpecError, match=r"\[training.randomize\]: domain randomization.*remove "
                                        r"\[training.randomize\]"):
        load_case(data)
    data["training"] = {"randomize": "default"}  # round 15 V7: the key, not a table, is named
    with pytest.raises(SpecError, match=r"\[training\] randomize: domain randomization.*remove \[training\] "
                                        r"randomize"):
        load_case(data)
    path = tmp_path / "cat.toml"
    path.write_text(CATHETER_MAGNET_REACH)
    for option in (["--recipe", "robust"], ["--randomize", "default"]):
        assert msr(["train", "--case", str(path), *option, "--seeds", "1", "--steps", "300", "--set",
                    "learning_starts=100", "--out", str(tmp_path / "runs"), "--no-progress"]) == 2
        assert "steered by a source" in capsys.readouterr().err
        assert not (tmp_path / "runs").exists()


def test_a_reach_episode_too_short_for_its_target_names_the_episode():
    """Round 14 V11: the message blamed the target ("0 body lengths ... more than 0.1") and
    offered a mm slip that was not there."""
    from elastica_magnetic_rl.cases.case import case_names

    assert "m1-4mT-reach" in case_names()
    data = load_case("m1-4mT-reach").to_dict()
    data["task"]["episode_duration"] = 0.01
    with pytest.raises(SpecError, match=r"\[task\] episode_duration: 0.01 s is too short for the "
                                        r"target 0.01 m \(0.5 body lengths"):
        load_case({**data, "name": "short"})
