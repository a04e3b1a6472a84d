"""The stop rules decide from a seed's evaluation history alone."""

from __future__ import annotations

import pytest
from elastica_magnetic_rl.runner.stopping import StopRule, stop_reason


def test_target_stops_after_k_consecutive_evaluations_at_the_threshold():
    rule = StopRule("target", threshold=1370.0, consecutive=2)
    assert rule.decide([100.0, 1400.0]) is None  # one is not two
    assert rule.decide([100.0, 1400.0, 900.0]) is None  # not in a row
    assert rule.decide([100.0, 1400.0, 900.0, 1370.0, 1380.0]) is not None
    assert "target" in rule.decide([1370.0, 1370.0])


def test_target_needs_a_threshold():
    with pytest.raises(ValueError, match="yardstick"):
        StopRule("target")


def test_plateau_stops_after_patience_evaluations_without_improvement():
    rule = StopRule("plateau", patience=3, tolerance=0.02, abs_tolerance=1.0, min_evaluations=1)
    assert rule.decide([10.0, 20.0, 30.0, 40.0]) is None  # still improving
    # 100 then three evaluations that improve by less than 2 %: stop
    assert rule.decide([10.0, 100.0, 101.0, 101.5, 99.0]) is not None
    # the third evaluation improves by 5 %: the count restarts
    assert rule.decide([10.0, 100.0, 101.0, 105.0, 104.0]) is None


def test_plateau_waits_for_min_evaluations():
    rule = StopRule("plateau", patience=1, min_evaluations=5)
    assert rule.decide([5.0, 5.0, 5.0, 5.0]) is None
    assert rule.decide([5.0, 5.0, 5.0, 5.0, 5.0]) is not None


def test_a_rule_round_trips_through_its_dict_and_refuses_unknown_keys():
    rule = StopRule("target", threshold=200.0, consecutive=3)
    assert StopRule.from_dict(rule.to_dict()) == rule
    with pytest.raises(ValueError, match="unknown stop-rule keys: patiense"):
        StopRule.from_dict({"kind": "plateau", "patiense": 3})


@pytest.mark.parametrize("bad, message", [
    ({"kind": "early"}, "one of target, plateau"),
    ({"kind": "plateau", "patience": 0}, "stop-patience"),
    ({"kind": "plateau", "tolerance": -0.1}, "stop-tolerance"),
    ({"kind": "target", "threshold": 1.0, "consecutive": 0}, "stop-consecutive"),
])
def test_bad_rules_are_refused_by_name(bad, message):
    with pytest.raises(ValueError, match=message):
        StopRule(**bad)


def test_no_rule_never_stops():
    assert stop_reason(None, [1e9] * 100) is None
