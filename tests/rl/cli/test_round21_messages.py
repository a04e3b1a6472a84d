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
