"""Round 26 of held-out tries (issue 48), the findings of the commands: each test fails without its
fix (docs/errors.md, "A twenty-sixth round of tries")."""

from __future__ import annotations

import json
import shutil

import pytest
from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR
from recorded_files import write_coil_currents

from elastica_magnetic.cli import main as msr
from elastica_magnetic.io import OutputPathError
from elastica_magnetic.result_markers import manifest_results_in
from elastica_magnetic.results import check_result_folder


@pytest.mark.parametrize("body", ['shape = "cylinder"\ndimension = [0.016, 0.002]',
                                  'shape = "cuboid"\ndimension = [0.014, 0.014, 0.002]'])
def test_a_disc_or_plate_magnet_whose_rim_reaches_the_rod_is_refused(tmp_path, body):
    """S1: the magnet-face check took a body's smallest extent, so a 16 x 2 mm disc or a 14 x 14 x 2
    mm plate at a 10 mm min_clearance passed beside a 3 mm rod: turned edge-on, its rim is inside
    the rod. The check now takes half the body's diagonal."""
    text = load_case("catheter-magnet-reach").toml()
    for old, new in (("radius = 0.0005", "radius = 0.003"), ("moment = 1.0", "moment = 0.35")):
        assert old in text
        text = text.replace(old, new)
    spec = tmp_path / "disc.toml"
    spec.write_text(text + f"\n[actuation.magnet]\n{body}\n")
    with pytest.raises(ValueError, match=r"\[robot\] radius: the rod's radius, 3 mm, reaches the magnet: .*"
                                         r"half its body's diagonal: a rim, edge or corner turned to"):
        load_case(spec)


def test_a_campaign_s_seed_keeps_no_results_folder_of_its_own(tmp_path):
    """S2: a result was refused in a campaign's seed (``POLICY/seeds/<recipe>/seed0/x``) and told to go
    in ``seed0/seeds/``, where it was accepted: inside the campaign, which export-seeds then could no
    longer replace. A seed inside a policy's seeds/ keeps no seeds/ of its own now."""
    policy = tmp_path / "m1-4mT"
    shutil.copytree(POLICIES_DIR / "m1-4mT", policy)
    seed = policy / "seeds" / "paper" / "seed0"
    assert manifest_results_in(policy) == ("seeds",) and manifest_results_in(seed) == ()
    for out in (seed / "b", seed / "seeds" / "b"):
        # the campaign that holds the seed is named (round 30), not the seed as a policy of its own
        with pytest.raises(OutputPathError, match=r"seeds/paper, which holds a result of `msr policy "
                                                  r"export-seeds`.*choose another --out") as refused:
            check_result_folder(out, kind="baseline", subject="case m1-4mT")
        assert "(or in" not in str(refused.value)
    check_result_folder(policy / "seeds" / "mine", kind="baseline", subject="case m1-4mT")  # still open


@pytest.mark.parametrize("evaluation", [None, {"duration_s": 10.0, "mid_dx_m": 0.0}])
def test_a_policy_json_without_a_distance_is_a_failing_verdict_not_a_traceback(tmp_path, monkeypatch,
                                                                               evaluation):
    """T1: ``msr validate shipped`` of a policy.json without ``evaluation`` ended in a KeyError, and of a
    recorded distance of 0 in a ZeroDivisionError. Now the first fails, naming the file and keys, and
    the second is compared (a moved robot is infinitely far from 0)."""
    from types import SimpleNamespace

    import numpy as np
    from elastica_magnetic_rl.shipping import shipped

    from elastica_magnetic import read_field_csv

    folder = tmp_path / "m1-4mT"
    shutil.copytree(POLICIES_DIR / "m1-4mT", folder, ignore=shutil.ignore_patterns("seeds"))
    info = json.loads((folder / "policy.json").read_text())
    if evaluation is None:
        del info["evaluation"]
    else:
        info["evaluation"].update(evaluation)
    (folder / "policy.json").write_text(json.dumps(info))
    positions = np.zeros((2, 3, 17))
    rollout = SimpleNamespace(mid_dx=0.02, fields=read_field_csv(folder / "fields.csv"), positions=positions,
                              meta={"diverged": None})
    monkeypatch.setattr(shipped, "run_policy", lambda *a, **k: rollout)
    monkeypatch.setattr(shipped, "_replayed_distance", lambda *a: 0.02)
    result = shipped.verify_shipped("m1-4mT", policies_dir=tmp_path)
    assert result["passed"] is False
    if evaluation is None:
        assert "policy.json: no evaluation with duration_s and mid_dx_m" in result["problem"]
    else:
        assert result["relative_diff"] == float("inf")


def test_identify_refuses_one_file_given_twice(tmp_path, capsys):
    """V2: ``msr real identify tip.csv tip.csv`` said the files were the wrong way round."""
    tip = tmp_path / "tip.csv"
    tip.write_text("t_s,tip_x_m,tip_y_m,tip_z_m\n" + "".join(f"{0.02 * i:.2f},0.05,0,0\n" for i in range(16)))
    assert msr(["real", "identify", str(tip), str(tip), "--robot", "catheter-magnet-reach", "--fit", "moment",
                "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "the same file twice" in err and "wrong way round" not in err, err


def test_validate_shipped_with_cases_checks_its_report_folder_before_the_re_runs(tmp_path, capsys,
                                                                                 monkeypatch):
    """V1: ``msr validate shipped CASE --out DIR`` re-ran every shipped policy (minutes) before it
    refused a DIR holding the user's files."""
    import elastica_magnetic_validation.cli as validation_cli

    monkeypatch.setattr(validation_cli, "verify_all_shipped",
                        lambda quick: pytest.fail("the shipped policies re-run before --out was checked"))
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("mine\n")
    assert msr(["validate", "shipped", "cantilever", "--quick", "--out", str(mine)]) == 2
    assert "notes.txt" in capsys.readouterr().err
    assert (mine / "notes.txt").read_text() == "mine\n"


@pytest.mark.parametrize("old, new, found", [
    ("width = ", "widht = ", "found widht: a misspelling of width?"),
    ("length = ", "lenght = ", "found lenght: a misspelling of length?"),
])
def test_a_misspelt_required_key_is_named(tmp_path, old, new, found):
    """V6: a misspelt required key (``widht``) was answered "[robot] width: missing (required)"
    without naming it, where a misspelt optional key gets "did you mean"."""
    text = load_case("m1-4mT").toml()
    assert f"\n{old}" in text
    spec = tmp_path / "typo.toml"
    spec.write_text(text.replace(f"\n{old}", f"\n{new}", 1))
    with pytest.raises(ValueError, match=rf"\[robot\] {old.split()[0]}: missing \(required\); {found}"):
        load_case(spec)


def test_a_catheter_s_drive_with_a_field_csv_as_its_motion_asks_for_the_tip_path(tmp_path, capsys):
    """V3: with the coils' currents first and a field CSV second, identify asked for a crawler's
    ``t_s`` column and tracked points; a catheter's motion is its tip path, and the file is named."""
    coils = write_coil_currents(tmp_path / "coils.csv")
    field = tmp_path / "field.csv"
    field.write_text(",mag_x,mag_y,mag_z\n" + "".join(f"{i},1.0,0.0,0.0\n" for i in range(30)))
    assert msr(["real", "identify", str(coils), str(field), "--robot", "catheter-coils-reach", "--fit",
                "coils", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "field.csv: is a field CSV (mag_x, mag_y, mag_z in mT), not a motion measured" in err, err
    assert "the tip's path (t_s, tip_x_m, tip_y_m, tip_z_m)" in err and "tracked points" not in err, err


def test_refusals_of_export_seeds_and_train_name_out_as_given(tmp_path, monkeypatch, capsys):
    """V5: ``msr policy export-seeds`` and ``msr train`` named a relative ``--out`` absolutely in their
    refusals, where every other command names it relative to the current folder."""
    from pathlib import Path

    from elastica_magnetic_rl.shipping.seed_export import _check_dest

    monkeypatch.chdir(tmp_path)
    shutil.copytree(POLICIES_DIR / "m1-4mT" / "seeds" / "fast-v1", tmp_path / "es")
    earlier = json.loads((tmp_path / "es" / "seed0" / "policy.json").read_text())
    meta = {"case": "m1-4mT", "case_spec": earlier["case_spec"], "config": earlier["training"].get("config")}
    with pytest.raises(ValueError, match=r"^--out es: already holds seeds 0 of case m1-4mT; pass --force"):
        _check_dest(Path("es"), "case m1-4mT", {0}, meta, force=False)
    seed = tmp_path / "runs" / "m1-4mT" / "seed0"
    seed.mkdir(parents=True)
    (seed / "checkpoint.pt").write_bytes(b"")
    assert msr(["train", "--case", "m1-4mT", "--seeds", "1", "--steps", "60", "--out", "runs",
                "--no-progress", "--workers", "1"]) == 2
    err = capsys.readouterr().err
    assert "runs already exist: runs/m1-4mT/seed0 (use --resume" in err and str(tmp_path) not in err, err
