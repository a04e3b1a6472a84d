"""Round 16 of held-out tries (issue 48): the vague messages it found, each named now."""

from __future__ import annotations

import shutil
from types import SimpleNamespace

import pytest
from elastica_magnetic_rl.cases.case import case_from_dict, load_case
from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR
from elastica_magnetic_rl.shipping.tip_reach import target_notes
from elastica_magnetic_rl.sweep.summaries import summarize_run

from elastica_magnetic.cli import main as msr
from elastica_magnetic.specfile import SpecError


def test_c09_a_tolerance_beyond_the_reach_names_the_reach_not_the_length():
    data = load_case("catheter-magnet-reach").to_dict()
    data["task"]["tolerance"] = 1.0
    with pytest.raises(SpecError, match=r"is the rod's reach \(0.06 m from its base, a stage's travel "
                                        r"included\) or more"):
        case_from_dict(data, "c09.toml")


def test_y03_a_tip_reach_task_on_a_crawler_names_the_actuation_first():
    data = load_case("m1-4mT").to_dict()
    data["task"] = {"kind": "tip-reach"}  # its default target box: beyond a crawler's reach too
    with pytest.raises(SpecError, match="set \\[actuation\\] kind = \"magnet-pose\""):
        case_from_dict(data, "y03.toml")


def test_t04_cases_with_different_recipes_name_the_option(tmp_path, capsys):
    other = tmp_path / "cm.toml"
    data = load_case("m2-4mT").to_dict()
    data["training"]["recipe"] = "fast"
    other.write_text(case_from_dict(data, str(other)).toml())
    assert msr(["train", "--case", "m1-4mT", str(other), "--steps", "300", "--out", str(tmp_path / "r")]) == 2
    assert "give --recipe (one value for every case), or train the cases apart" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


def test_h05_a_run_folder_given_as_a_case_is_named_as_a_folder(tmp_path, capsys):
    (tmp_path / "seed0").mkdir()
    with pytest.raises(SystemExit):
        msr(["policy", "seeds", str(tmp_path / "seed0")])
    err = capsys.readouterr().err
    assert "a folder, not a spec file: give a shipped case's name or a spec file (.toml)" in err
    assert "Errno" not in err


def test_x01_notes_refusing_an_edited_card_names_no_force_option(tmp_path, capsys):
    shutil.copytree(POLICIES_DIR / "m1-4mT", tmp_path / "p")
    card = tmp_path / "p" / "MODEL_CARD.md"
    card.write_text(card.read_text() + "\nmy own line\n")
    notes = tmp_path / "notes.md"
    notes.write_text("coil set B")
    assert msr(["policy", "notes", str(tmp_path / "p"), "--file", str(notes)]) == 2
    err = capsys.readouterr().err
    assert "msr policy notes replaces only files msr wrote" in err and "--force" not in err


def test_b01_a_catheter_runs_summary_gives_no_distance(tmp_path):
    run = tmp_path / "seed0"
    run.mkdir()
    (run / "episodes.csv").write_text("episode,global_step,return,length,terminated,truncated,wall_time_s\n"
                                      "0,300,-73.0,300,0,1,1.0\n")
    assert summarize_run(run)["final_mean_distance_m"] == pytest.approx(-0.0073)
    assert summarize_run(run, travels=False)["final_mean_distance_m"] is None


def test_l04_a_target_beyond_any_tips_reach_is_named():
    notes = target_notes(load_case("catheter-coils-reach"), [[0.2, 0.0, 0.0], [0.045, 0.005, 0.0]])
    assert len(notes) == 1
    assert "is 0.2 m from the clamped base's start, beyond any tip's reach (0.06 m" in notes[0]


def test_o05_robustness_of_a_catheter_policy_is_its_tip_reach_study(monkeypatch):
    """Round 16 O05 refused it by name; now a tip-reach policy has its own study
    (tests/rl/sim2real/test_tip_robustness.py): the policy goes there, not to the field study."""
    import elastica_magnetic_rl.sim2real.robustness as robustness

    catheter = SimpleNamespace(case=load_case("catheter-magnet-reach"), kind="checkpoint", source="r")
    monkeypatch.setattr(robustness, "resolve_policy", lambda source: catheter)
    assert robustness._tip_reach_policy("runs/c/seed0", robustness.StudySettings()) is catheter
