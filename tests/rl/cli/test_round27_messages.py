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
                                                  r"result is none of them .*: it goes beside the policy"):
            check_result_file(policy / "seeds" / "cal.json", kind=kind)
    check_result_file(tmp_path / "cal.json", kind=CALIBRATION_FILE)  # beside the policy: fine


def test_ship_names_the_folder_it_refuses_as_given(tmp_path, monkeypatch, capsys):
    """V4: ``msr policy ship`` refused an existing policy naming it absolutely and without the
    options that made it; it names the folder relative to the current one, with --out and --name."""
    from elastica_magnetic.cli import main as msr

    monkeypatch.chdir(tmp_path)
    shutil.copytree(POLICIES_DIR / "m1-4mT", tmp_path / "pols" / "m1-4mT",
                    ignore=shutil.ignore_patterns("seeds"))
    assert msr(["policy", "ship", "runs/m1-4mT/seed0", "--name", "m1-4mT", "--out", "pols",
                "--no-measure"]) == 2
    err = capsys.readouterr().err
    assert "error: pols/m1-4mT (--out pols, --name m1-4mT): already holds a policy" in err, err


def test_a_design_says_it_took_over_a_stale_lock(tmp_path):
    """V2: ``msr design`` took over the stale lock of a killed design without a word, where every
    other writer prints that it did."""
    import subprocess
    import sys

    from elastica_magnetic_rl.design.run import DesignSettings, run_design

    from elastica_magnetic.locks import host_name, lock_path
    from elastica_magnetic.results import LeftoverWarning

    out = tmp_path / "d"
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    lock_path(out).write_text(json.dumps({"pid": dead.pid, "host": host_name(), "command": "msr design",
                                          "started_utc": "2026-01-01T00:00:00Z"}))
    tiny = DesignSettings(physics="training", search_duration=0.3, final_physics="training",
                          final_duration=0.3, final_periods=(0.5,), generations=1, minutes=None,
                          popsize=3, workers=1, gif=False)
    with pytest.warns(LeftoverWarning, match=rf"took over the stale lock of pid {dead.pid} .*no longer"):
        run_design("m1-4mT", out, tiny)
    assert not lock_path(out).exists()


def test_refine_names_the_table_its_simulator_leaves_out(tmp_path):
    """V1: ``msr refine --spec`` of a spec with ``[robot.interaction]`` (only ``cutoff`` written) was
    refused naming ``robot.interaction.band_source``, a key not in the file; now the reason: the
    batched simulator does not model the table."""
    from elastica_magnetic_rl.cases.case import load_case
    from elastica_magnetic_rl.sweep.refine import _other_robot

    spec = tmp_path / "sp_int.toml"
    spec.write_text(load_case("m1-4mT").toml() + "\n[robot.interaction]\ncutoff = 0.002\n")
    with pytest.raises(ValueError, match=r"sp_int.toml: msr refine runs many robots in one batched "
                                         r"simulator, which does not model \[robot.interaction\]") as refused:
        _other_robot(load_case("m1-4mT"), spec, None)
    assert "band_source" not in str(refused.value)


def test_a_loop_in_a_policy_s_seeds_is_refused_for_its_true_reason(tmp_path):
    """V5: a loop in a policy's seeds/ was refused as "a result of no case", though it is of the
    policy's case; the reason that holds is its firmware step, a result of no case."""
    from elastica_magnetic_rl.loop.runner import check_loop_folder

    from elastica_magnetic.io import OutputPathError

    policy = tmp_path / "m1-4mT"
    shutil.copytree(POLICIES_DIR / "m1-4mT", policy, ignore=shutil.ignore_patterns("seeds"))
    (policy / "seeds").mkdir()
    with pytest.raises(OutputPathError, match=r"this result is of a loop of case m1-4mT, whose firmware step "
                                              r"is a result of no case: it goes beside the policy"):
        check_loop_folder(policy / "seeds" / "loop", "m1-4mT")

