"""Round 28 of held-out tries (issue 48), the findings of the commands: each test fails without its
fix."""

from __future__ import annotations

import json
import shutil

import pytest
from elastica_magnetic_rl.shipping import shipped
from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR


@pytest.mark.parametrize("drop", ["evaluation", "duration_s", "tip_reach"])
def test_a_catheter_policy_json_without_its_targets_is_a_failing_verdict(tmp_path, monkeypatch, drop):
    """Round 28 T1: ``msr validate shipped`` of a tip-reach policy whose policy.json lacks
    ``evaluation`` (or its ``duration_s`` or ``tip_reach``) ended in a KeyError; now a failing verdict
    naming the file and keys, as for a crawler."""
    folder = tmp_path / "catheter-magnet-reach"
    shutil.copytree(POLICIES_DIR / "catheter-magnet-reach", folder)
    info = json.loads((folder / "policy.json").read_text())
    if drop == "evaluation":
        del info["evaluation"]
    else:
        del info["evaluation"][drop]
    (folder / "policy.json").write_text(json.dumps(info))
    judged = {"duration_s": 0.05, "policy": {"successes": 0, "targets_m": [[0.05, 0, 0]] * 20,
                                             "final_distance_m": [0.01] * 20, "ended_by": ["time"] * 20}}
    monkeypatch.setattr("elastica_magnetic_rl.shipping.tip_reach.judge_held_out", lambda *a, **k: judged)
    result = shipped.verify_shipped("catheter-magnet-reach", duration=0.05, policies_dir=tmp_path, quick=True)
    assert result["passed"] is False
    assert "policy.json: no evaluation with duration_s and tip_reach.policy" in result["problem"]
