"""Round 27 of held-out tries (issue 48), the findings of the commands: each test fails without its
fix (docs/errors.md, "A twenty-seventh round of tries")."""

from __future__ import annotations

import json
import shutil
from types import SimpleNamespace

import numpy as np
import pytest
from elastica_magnetic_rl.shipping import shipped
from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR

from elastica_magnetic import read_field_csv


@pytest.mark.parametrize("quick", [False, True])
def test_a_distance_recorded_over_another_duration_fails_the_full_check(tmp_path, monkeypatch, quick):
    """S1: ``msr validate shipped`` compared a policy's distance only when policy.json recorded it over
    the re-run's 10 s, and passed one that claimed 500 mm in 9 s without a word. Now the full check
    fails it, naming the file and both durations; a quick run says it compared no distance."""
    folder = tmp_path / "m1-4mT"
    shutil.copytree(POLICIES_DIR / "m1-4mT", folder, ignore=shutil.ignore_patterns("seeds"))
    info = json.loads((folder / "policy.json").read_text())
    info["evaluation"].update(duration_s=9.0, mid_dx_m=0.5)
    (folder / "policy.json").write_text(json.dumps(info))
    rollout = SimpleNamespace(mid_dx=0.0228, fields=read_field_csv(folder / "fields.csv"),
                              positions=np.zeros((2, 3, 17)), meta={"diverged": None})
    monkeypatch.setattr(shipped, "run_policy", lambda *a, **k: rollout)
    monkeypatch.setattr(shipped, "_replayed_distance", lambda *a: 0.0228)
    duration = 0.3 if quick else 10.0
    result = shipped.verify_shipped("m1-4mT", duration=duration, policies_dir=tmp_path, quick=quick)
    if quick:
        assert result["passed"] and "problem" not in result
        assert result["distance_check"] == "not compared: a 0.3 s quick run (policy.json records 9 s)"
    else:
        assert result["passed"] is False
        assert "policy.json: evaluation.duration_s is 9 s, not the 10 s this re-run" in result["problem"]


@pytest.mark.parametrize("inside", ["seed3", "seed9", "gen"])
def test_nothing_goes_inside_a_committed_seed_campaign(tmp_path, inside):
    """D1, D2: the seed campaigns committed with the shipped policies carry no marker, so a policy
    shipped as ``POLICY/seeds/pink-ln/seed3 --force`` replaced a campaign seed (its logs and the
    campaign's seeds.json left claiming the old distance), and a seed9/ or a generate result went
    inside. A campaign is now recognised by its files as a result of export-seeds, as one with a
    marker is."""
    from elastica_magnetic.io import OutputPathError
    from elastica_magnetic.results import check_result_folder

    policy = tmp_path / "m1-4mT"
    shutil.copytree(POLICIES_DIR / "m1-4mT", policy)
    campaign = policy / "seeds" / "pink-ln"
    with pytest.raises(OutputPathError, match=r"lies in .*pink-ln, which holds a result of `msr policy "
                                              r"export-seeds` for case m1-4mT: .*nothing goes inside"):
        check_result_folder(campaign / inside, kind="ship", subject="case m1-4mT", force=True)


def test_a_calibration_is_no_result_of_the_policy_s_case(tmp_path):
    """S2: ``msr real calibrate --out POLICY/seeds/cal.json`` wrote a calibration (a result of no
    case) into a shipped policy's seeds/, where every other result of no case is refused; the
    hardware's result files (calibration, board log, expected codes) now say they are of no case."""
    from elastica_magnetic.hardware.calibration import CALIBRATION_FILE
    from elastica_magnetic.hardware.export import EXPECTED_CODES_FILE
    from elastica_magnetic.hardware.stream import BOARD_LOG_FILE
    from elastica_magnetic.io import OutputPathError
    from elastica_magnetic.result_file import check_result_file

    policy = tmp_path / "m1-4mT"
    shutil.copytree(POLICIES_DIR / "m1-4mT", policy, ignore=shutil.ignore_patterns("seeds"))
    (policy / "seeds").mkdir()
    for kind in (CALIBRATION_FILE, EXPECTED_CODES_FILE, BOARD_LOG_FILE):
        with pytest.raises(OutputPathError, match=r"whose seeds/ holds its own case's results .* and this "
                                                  r"result is of no case: it goes beside the policy"):
            check_result_file(policy / "seeds" / "cal.json", kind=kind)
    check_result_file(tmp_path / "cal.json", kind=CALIBRATION_FILE)  # beside the policy: fine
