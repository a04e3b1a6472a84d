"""Round 17 of held-out tries (issue 48): a ``[yardstick] period`` in ms or beyond any field's
turn is warned about or refused by name (a training from the yardstick would play it)."""

from __future__ import annotations

import copy
import re
import warnings

import pytest
from elastica_magnetic_rl.cases.case import load_case, warmup_refusal

from elastica_magnetic.specfile import SpecError


def with_period(period: float) -> dict:
    data = copy.deepcopy(load_case("m1-4mT").to_dict())
    data["name"] = "ys"
    data["yardstick"] = {**data["yardstick"], "period": period, "clockwise": True}
    return data


def test_a_period_in_ms_is_warned_about():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        case = load_case(with_period(2500.0))
    messages = [str(w.message) for w in caught]
    assert case.yardstick.period == 2500.0
    assert any("[yardstick] period" in m and "ms" in m for m in messages), messages


def test_a_period_of_a_turn_per_day_or_more_is_refused():
    with pytest.raises(SpecError, match=r"\[yardstick\] period"):
        load_case(with_period(1e9))


def test_a_too_short_period_names_no_unit_slip_it_cannot_be():
    with pytest.raises(SpecError, match="once in 0.5 to 6 s") as raised:
        load_case(with_period(0.02))
    assert "ms written as s" not in str(raised.value)


def test_a_warm_up_from_the_yardstick_without_a_controller_is_refused_by_the_training():
    """Round 17 S and V: msr case check passed a spec whose [training.td3] yardstick_warmup msr
    train refused (no [yardstick] period: no controller), and train named it `--set
    yardstick_warmup=100` though the spec set it."""
    data = copy.deepcopy(load_case("m1-4mT").to_dict())
    data["name"] = "ys"
    data["training"] = {**data["training"], "td3": {"yardstick_warmup": 100}}
    # the spec reads (a sweep records the period); the training refuses it, case check warns
    # (tests/rl/cases/test_warmup_before_yardstick.py)
    assert re.search(r"\[training.td3\] yardstick_warmup = 100: the warm-up is played by the case's "
                     r"hand-designed controller, and this case has none", warmup_refusal(load_case(data)))
    data["yardstick"] = {**data["yardstick"], "period": 2.5}
    assert load_case(data).has_yardstick_controller


def test_a_segment_given_a_length_names_the_key_it_does_not_have():
    """Round 17 V: `{length = 0.01, ...}` was told 'give either elements or fraction', without a
    word that length is no key of a segment."""
    data = copy.deepcopy(load_case("m1-4mT").to_dict())
    data["name"] = "seg"
    data["robot"]["magnetization"] = {"kind": "segments", "segments": [
        {"length": 0.01, "direction": [1.0, 0.0, 0.0]}, {"fraction": 0.5, "direction": [0.0, 1.0, 0.0]}]}
    with pytest.raises(SpecError, match=r"not both or neither \(length: not a key of a segment, whose keys "
                                        r"are elements or fraction, direction and magnitude\)"):
        load_case(data)
