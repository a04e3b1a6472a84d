"""Round 21 of held-out tries (issue 48), the findings of the commands: each test fails without its
fix (docs/errors.md, "A twenty-first round of tries")."""

from __future__ import annotations

import json
import shutil

from elastica_magnetic_rl.shipping.policy_files import policy_holder

from elastica_magnetic.cli import main as msr
from elastica_magnetic.result_markers import MANIFEST, manifest_holder

MEASUREMENTS = ("current_x_A,current_y_A,current_z_A,field_x_mT,field_y_mT,field_z_mT\n"
                "1,0,0,2,0,0\n0,1,0,0,2,0\n0,0,1,0,0,2\n1,1,0,2,2,0\n")


def _snapshot(folder):
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _ship(trained, tmp_path, name="p1"):
    run = trained / "m1-4mT" / "seed0"
    assert msr(["policy", "ship", str(run), "--no-measure", "--checkpoint", "final", "--name", name, "--out",
                str(tmp_path / "ship")]) == 0
    return run, tmp_path / "ship" / name


def test_a_policy_whose_record_names_no_holder_or_that_has_none_is_held_all_the_same(trained, tmp_path,
                                                                                      capsys):
    """D F4: a policy shipped before records named a holder (a user's own, not migrated), or copied
    without its record, took a calibration, an export and figures among its files; the figures then
    wrote a record of their own, after which ``ship --force`` refused the policy's own files."""
    run, old = _ship(trained, tmp_path, "old")
    record = json.loads((old / MANIFEST).read_text())
    record.pop("holder"), record.pop("results_in")
    (old / MANIFEST).write_text(json.dumps(record))
    _, bare = _ship(trained, tmp_path, "bare")
    (bare / MANIFEST).unlink()
    (tmp_path / "meas.csv").write_text(MEASUREMENTS)
    for policy in (old, bare):
        assert manifest_holder(policy) == policy_holder("m1-4mT")
        before = _snapshot(policy)
        capsys.readouterr()
        for argv in (["real", "calibrate", str(tmp_path / "meas.csv"), "--out", str(policy / "cal.json")],
                     ["policy", "export", str(policy), "--out", str(policy / "exp")],
                     ["policy", "figures", str(run), "--out", str(policy)]):
            assert msr(argv) != 0, argv
            assert "holds a shipped policy of case 'm1-4mT'" in capsys.readouterr().err, argv
        assert _snapshot(policy) == before
    # its own writer still replaces it (a record-less MODEL_CARD.md stays refused: it may hold edits)
    assert msr(["policy", "ship", str(run), "--no-measure", "--checkpoint", "best", "--name", "old", "--out",
                str(tmp_path / "ship"), "--force"]) == 0
    assert json.loads((old / MANIFEST).read_text())["holder"] == policy_holder("m1-4mT")


def test_export_seeds_writes_a_campaign_under_a_policy_s_seeds_folder(trained, tmp_path, capsys):
    """S F7: ``msr policy export-seeds --out POLICY/seeds/<recipe>``, the place the docs and the
    policy's record name for its case's seed campaigns, was refused as a policy inside another,
    after the evaluations; inside the policy elsewhere it is refused before them."""
    _, policy = _ship(trained, tmp_path)
    case_dir = tmp_path / "runs" / "m1-4mT"
    shutil.copytree(trained / "m1-4mT", case_dir)
    capsys.readouterr()
    assert msr(["policy", "export-seeds", str(case_dir), "--out", str(policy / "elsewhere"), "--duration",
                "0.05", "--workers", "1", "--no-progress"]) != 0
    err = capsys.readouterr().err
    assert "is a shipped policy: a policy goes beside another, not inside it (its seeds/" in err, err
    assert "accurate physics" not in err  # refused before any evaluation
    assert msr(["policy", "export-seeds", str(case_dir), "--out", str(policy / "seeds" / "smoke"),
                "--duration", "0.05", "--workers", "1", "--no-progress"]) == 0, capsys.readouterr().err
    entries = json.loads((policy / "seeds" / "smoke" / "seeds.json").read_text())
    assert [e["seed"] for e in entries] == [0, 1]
    assert (policy / "seeds" / "smoke" / "seed0" / "actor.pt").is_file()


def _spec(tmp_path, case: str, name: str, edit) -> str:
    from elastica_magnetic_rl.cases.case import load_case

    text = edit(load_case(case).toml())
    (tmp_path / name).write_text(text)
    return str(tmp_path / name)


def test_values_in_the_wrong_unit_are_named_by_their_key(tmp_path):
    """S F1: an interaction cutoff in mm written as m (2.0 for a 0.02 m robot) switched the
    interaction off without a word. V F2: a relative damping a million times too large was refused
    as a dt, with the advice dt = 1e-10 s. S F3: a catheter's [yardstick] distance_10s was taken,
    ignored, and the training said the spec had none."""
    from elastica_magnetic_rl.cases.case import load_case

    from elastica_magnetic.specfile import SpecError

    cutoff = _spec(tmp_path, "m1-4mT", "cut.toml", lambda t: t + "\n[robot.interaction]\ncutoff = 2.0\n")
    try:
        load_case(cutoff)
        raise AssertionError("a 2 m cutoff on a 0.02 m robot was accepted")
    except SpecError as exc:
        assert "cutoff: 2 m is at or beyond the rod's length (0.02 m)" in str(exc)
        assert "2 mm is 0.002 m" in str(exc)
    damped = _spec(tmp_path, "m1-4mT", "rel.toml", lambda t: t.replace("relative = 20.0", "relative = 2e7"))
    try:
        load_case(damped)
        raise AssertionError("a relative damping of 2e7 was accepted")
    except SpecError as exc:
        assert "[robot.damping] relative: this robot's relative damping alone needs a time step" in str(exc)
        assert "Set dt" not in str(exc)
    catheter = _spec(tmp_path, "catheter-magnet-reach", "cy.toml",
                     lambda t: t.replace("distance_10s = 0.0 ", "distance_10s = 0.02 "))
    try:
        load_case(catheter)
        raise AssertionError("a catheter's distance_10s was accepted")
    except SpecError as exc:
        assert "[yardstick] distance_10s: 0.02 m is a crawl's distance in 10 s, and a tip-reach" in str(exc)


def test_options_are_judged_as_the_spec_keys_they_replace(trained, tmp_path, capsys):
    """S F6: ``msr train --episode-duration 0.3`` on a goto case trained without the warning its spec's
    ``episode_duration = 0.3`` gets. V F8: ``--resume --randomize default`` named the spec's key."""
    import shutil

    assert msr(["train", "--case", "m1-4mT-goto", "--episode-duration", "0.3", "--steps", "30", "--set",
                "learning_starts=10", "--seeds", "1", "--out", str(tmp_path / "g")]) != 0  # its minibatch
    err = capsys.readouterr().err
    assert "warning: --episode-duration 0.3 s for the distance 0.015 m" in err and "'m1-4mT-goto'" in err
    assert "faster than the paper's fastest gait" in err
    runs = tmp_path / "runs"
    shutil.copytree(trained, runs)
    assert msr(["train", "--case", "m1-4mT", "--resume", "--seeds", "2", "--out", str(runs), "--randomize",
                "default", "--steps", "10000"]) != 0
    err = capsys.readouterr().err
    assert "--randomize (or the spec's [training] randomize) gives case 'm1-4mT' robots" in err, err
    assert "the run trained on its nominal robot (no randomization)" in err and "leave --randomize out" in err
