"""``[checks] accept`` in a case (issue 48): the accepted keys are kept in the case's spec (so a
run's stored spec accepts the same values), ``msr case show --toml`` writes them back, ``msr``
prints an unusual value's warning once as ``msr CMD: warning: ...``, and no shipped spec warns."""

from __future__ import annotations

import warnings
from importlib import resources
from pathlib import Path

import pytest
from elastica_magnetic_rl.cases.case import SPECS_DIR, case_from_dict, case_names, load_case

from elastica_magnetic.cli import main
from elastica_magnetic.plausibility import ImplausibleValueWarning
from elastica_magnetic.specfile import SpecError, read_spec


def _toml(tmp_path: Path, **edits: str) -> Path:
    text = load_case("m1-4mT").toml()
    for old, new in edits.items():
        assert old in text
        text = text.replace(old, new)
    path = tmp_path / "my.toml"
    path.write_text(text)
    return path


def test_no_shipped_spec_warns():
    examples = resources.files("elastica_magnetic") / "data" / "examples"
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImplausibleValueWarning)
        for name in case_names():  # read afresh: load_case caches the shipped cases
            case_from_dict(read_spec(SPECS_DIR / f"{name}.toml"), name, default_name=name)
        from elastica_magnetic.field_spec import load_field
        from elastica_magnetic.specfile import load_robot

        for spec in examples.iterdir():
            if spec.name.endswith(".toml"):
                load_robot(Path(str(spec)))
                load_field(Path(str(spec)))


def test_accepted_keys_round_trip_through_case_show_toml(tmp_path, capsys):
    path = _toml(tmp_path, **{"magnitude = 61300.0": "magnitude = 3000.0\n[checks]\n"
                                                    "accept = [\"robot.magnetization.magnitude\"]"})
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImplausibleValueWarning)
        case = load_case(path)
    assert case.to_dict()["checks"] == {"accept": ["robot.magnetization.magnitude"]}
    assert main(["case", "show", str(path), "--toml"]) == 0
    text = capsys.readouterr().out
    assert '[checks]\naccept = [\n    "robot.magnetization.magnitude",\n]' in text or (
        '[checks]\naccept = ["robot.magnetization.magnitude"]' in text)
    again = tmp_path / "again.toml"
    again.write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImplausibleValueWarning)
        assert load_case(again).to_dict() == {**case.to_dict(), "name": "again"}
    # the stored spec of a run (to_dict) reads back with the same acceptance
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImplausibleValueWarning)
        assert case_from_dict(case.to_dict(), "run.json (case_spec)").to_dict() == case.to_dict()


def test_msr_prints_an_unusual_value_once_as_a_warning_line(tmp_path, capsys):
    path = _toml(tmp_path, **{"magnitude = 61300.0": "magnitude = 61.3"})
    assert main(["case", "show", str(path)]) == 0
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if "warning:" in line]
    assert len(lines) == 1, err
    assert lines[0].startswith(f"msr case show: warning: {path}: [robot.magnetization] magnitude = 61.3 A/m "
                               "is below 1000 A/m")
    assert "it looks like kA/m written where A/m is expected (61.3 kA/m is 61300 A/m)" in lines[0]


def test_a_field_limit_below_the_earths_field_is_refused_in_a_case():
    data = load_case("m1-4mT").to_dict()
    data["actuation"]["field_limit"] = 4e-6
    with pytest.raises(SpecError, match=r"my\.toml: \[actuation\] field_limit = 4e-06 T is below "
                                        r"5e-05 T, the Earth's field"):
        case_from_dict(data, "my.toml")


def test_a_reward_scale_per_mm_written_as_per_m_warns_and_accept_silences_it(tmp_path):
    path = _toml(tmp_path, **{"reward_scale = 10000.0": "reward_scale = 10.0"})
    with pytest.warns(ImplausibleValueWarning, match=r"my\.toml: \[task\] reward_scale: 10 per m gives "
                      r"a reward of 0\.2 for crawling one body length \(0\.02 m\).*looks like a reward "
                      r"per mm or per cm written as per m \(10 per mm is 10000 per m") as record:
        case_from_dict(read_spec(path), str(path.name), default_name="my")
    assert record[0].message.key == "task.reward_scale"
    accepted = tmp_path / "accepted.toml"
    accepted.write_text(path.read_text() + '\n[checks]\naccept = ["task.reward_scale"]\n')
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImplausibleValueWarning)
        case = case_from_dict(read_spec(accepted), "accepted.toml", default_name="my")
    assert case.task.reward_scale == 10.0
