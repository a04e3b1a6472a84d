"""``[actuation] max_increment`` (T per 0.01 s action) judged like ``field_limit`` (issue 48, a
held-out round of tries, u_inc_mT): ``max_increment = 0.3`` (mT meant) passed with no word, 75x the
0.004 T field limit, so the rate limit on the policy's field stopped acting. An increment above
the field limit is refused, naming the unit mistake and the paper's value; an unusual one warned
about (the quantity "field increment" of elastica_magnetic/plausibility.py)."""

from __future__ import annotations

import warnings

import pytest
from elastica_magnetic_rl.cases.case import case_from_dict, load_case

from elastica_magnetic.cli import main as msr
from elastica_magnetic.plausibility import ImplausibleValueWarning
from elastica_magnetic.specfile import SpecError, dumps


def _with_increment(increment: float) -> dict:
    data = load_case("m1-4mT").to_dict()
    data["actuation"]["max_increment"] = increment
    return data


def test_an_increment_in_mT_above_the_field_limit_is_refused_with_the_unit_hint():
    with pytest.raises(SpecError) as err:
        case_from_dict(_with_increment(0.3), "my.toml")
    assert str(err.value) == (
        "my.toml: [actuation] max_increment: 0.3 T per action is larger than the field limit "
        "0.004 T: it cannot act as a limit (one action may jump the field from zero past the limit); "
        "it looks like mT written where T is expected (0.3 mT is 0.0003 T); the paper's is 0.0003 T")


def test_msr_case_check_refuses_it_before_the_check(tmp_path, capsys):
    spec = tmp_path / "inc.toml"
    spec.write_text(dumps(_with_increment(0.3)))
    with pytest.raises(SystemExit) as info:
        msr(["case", "check", "--no-sag", str(spec)])
    assert info.value.code == 2
    assert "[actuation] max_increment: 0.3 T per action is larger than the field limit" in (
        capsys.readouterr().err)


def test_an_unusual_increment_within_the_limit_is_warned_about():
    data = _with_increment(2e-6)  # 2 uT per step: 20 s to build the 4 mT field
    with pytest.warns(ImplausibleValueWarning, match=r"my\.toml: \[actuation\] max_increment = 2e-06 T "
                                                     r"is below 1e-05 T"):
        case = case_from_dict(data, "my.toml")
    assert case.actuation.max_increment == 2e-6


def test_the_papers_increment_passes_without_a_word():
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImplausibleValueWarning)
        assert case_from_dict(_with_increment(3e-4), "my.toml").actuation.max_increment == 3e-4
