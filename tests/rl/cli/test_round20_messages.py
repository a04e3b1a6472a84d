"""Round 20 of held-out tries (issue 48), the findings of the commands: each test fails without its
fix (docs/errors.md, "A twentieth round of tries")."""

from __future__ import annotations

import json

from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR, policy_holder

from elastica_magnetic.cli import main as msr
from elastica_magnetic.result_markers import MANIFEST, manifest_holder

MEASUREMENTS = ("current_x_A,current_y_A,current_z_A,field_x_mT,field_y_mT,field_z_mT\n"
                "1,0,0,2,0,0\n0,1,0,0,2,0\n0,0,1,0,0,2\n1,1,0,2,2,0\n")


def _snapshot(folder):
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _ship(trained, tmp_path):
    run = trained / "m1-4mT" / "seed0"
    assert msr(["policy", "ship", str(run), "--no-measure", "--checkpoint", "final", "--name", "p1", "--out",
                str(tmp_path / "ship")]) == 0
    return run, tmp_path / "ship" / "p1"


def test_a_shipped_policy_s_folder_holds_its_files_alone(trained, tmp_path, capsys):
    """D1, S2, S4: ``msr real calibrate --out POLICY/policy.json --force`` replaced the policy's own
    file with a calibration (and recorded it as msr's); ``--out POLICY/cal.json`` and ``policy seeds
    --figure POLICY`` put their files among the policy's, recorded as its own."""
    run, policy = _ship(trained, tmp_path)
    assert manifest_holder(policy) == policy_holder("m1-4mT")
    before = _snapshot(policy)
    (tmp_path / "meas.csv").write_text(MEASUREMENTS)
    capsys.readouterr()
    for name, extra in (("policy.json", ["--force"]), ("MODEL_CARD.md", ["--force"]), ("cal.json", [])):
        calibrate = ["real", "calibrate", str(tmp_path / "meas.csv"), "--out", str(policy / name)]
        assert msr([*calibrate, *extra]) == 2
        err = capsys.readouterr().err
        assert f"lies in {policy}, which holds a shipped policy of case 'm1-4mT'" in err, err
    assert msr(["field", "baseline", "--case", "m1-4mT", "--periods", "1", "--duration", "10", "--out",
                str(tmp_path / "b"), "--set-yardstick", str(policy / "MODEL_CARD.md"), "--force",
                "--no-progress"]) == 2
    assert "which holds a shipped policy" in capsys.readouterr().err and not (tmp_path / "b").exists()
    assert msr(["policy", "seeds", "m1-4mT", "--figure", str(policy)]) == 2
    assert "holds a shipped policy of case 'm1-4mT' (msr policy ship), whose files are its own" in (
        capsys.readouterr().err)
    assert _snapshot(policy) == before
    # its own writers still work: notes, and a ship --force of the same case
    (tmp_path / "notes.md").write_text("made on the test bench\n")
    assert msr(["policy", "notes", str(policy), "--file", str(tmp_path / "notes.md")]) == 0
    assert msr(["policy", "ship", str(run), "--no-measure", "--checkpoint", "final", "--name", "p1", "--out",
                str(tmp_path / "ship"), "--force"]) == 0
    assert manifest_holder(policy) == policy_holder("m1-4mT")


def test_a_figure_msr_recorded_is_not_replaced_by_a_calibration(trained, tmp_path, capsys):
    """The same round: ``msr real calibrate --out figs/learning_curves_m1-4mT.png --force`` replaced
    a figure ``msr policy figures`` wrote (recorded, unchanged) with a calibration JSON."""
    figures = tmp_path / "figs"
    assert msr(["policy", "figures", str(trained / "m1-4mT" / "seed0"), "--out", str(figures)]) == 0
    png = next(figures.glob("*.png"))
    before = png.read_bytes()
    (tmp_path / "meas.csv").write_text(MEASUREMENTS)
    capsys.readouterr()
    assert msr(["real", "calibrate", str(tmp_path / "meas.csv"), "--out", str(png), "--force"]) == 2
    assert "another command's result; --force replaces only a calibration JSON" in capsys.readouterr().err
    assert png.read_bytes() == before
    # a calibration replaces a calibration
    cal = tmp_path / "cal.json"
    assert msr(["real", "calibrate", str(tmp_path / "meas.csv"), "--out", str(cal)]) == 0
    assert msr(["real", "calibrate", str(tmp_path / "meas.csv"), "--out", str(cal), "--force"]) == 0


def test_seed_figures_go_into_no_training_s_case_folder(trained, tmp_path, capsys):
    """S4: ``msr policy seeds CASE --figure RUNS/<case>`` put figures into a training's case folder,
    which holds its runs alone."""
    case_folder = trained / "m1-4mT"
    before = sorted(p.name for p in case_folder.iterdir())
    assert msr(["policy", "seeds", "m1-4mT", "--figure", str(case_folder)]) == 2
    assert "holds the runs of a training" in capsys.readouterr().err
    assert sorted(p.name for p in case_folder.iterdir()) == before


def test_the_repository_s_shipped_policies_record_their_holder():
    """Every shipped policy's record names it as its folder's holder, so that the rule above holds
    for them too (they were shipped before msr recorded holders)."""
    for folder in sorted(p for p in POLICIES_DIR.iterdir() if (p / "policy.json").is_file()):
        case = json.loads((folder / "policy.json").read_text())["case"]
        assert manifest_holder(folder) == policy_holder(case), folder
        assert (folder / MANIFEST).is_file()


def test_a_calibration_that_is_another_msr_file_is_named_so(tmp_path, capsys):
    """V: ``msr real firmware --calibration POLICY/policy.json`` said "format: unknown key", not
    that the file is no calibration."""
    assert msr(["real", "firmware", str(POLICIES_DIR / "m1-4mT" / "fields.csv"), "--calibration",
                str(POLICIES_DIR / "m1-4mT" / "policy.json"), "--out", str(tmp_path / "fw")]) == 2
    err = capsys.readouterr().err
    assert "policy.json: not a calibration JSON: its format is 'msr-policy-v1'" in err, err
    assert not (tmp_path / "fw").exists()


def test_robustness_gives_no_percentages_of_a_nominal_robot_that_does_not_move(tmp_path, capsys):
    """V: a waveform that leaves the nominal robot still was reported as "worst -0.0 mm (-260 %) of
    nominal, 10th percentile +0.0 mm (134 %)": ratios of round-off."""
    import math

    rows = "".join(f"{3 * math.cos(i / 10):.4f},{3 * math.sin(i / 10):.4f},0\n" for i in range(50))
    (tmp_path / "f.csv").write_text("mag_x,mag_y,mag_z\n" + rows)
    out = tmp_path / "rb"
    assert msr(["real", "robustness", str(tmp_path / "f.csv"), "--case", "m1-4mT", "--duration", "0.3",
                "--no-corners", "--workers", "1", "--no-progress", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "the nominal robot does not move: no percentage of it" in text
    assert "%" not in text.split("open loop:")[-1]
    summary = json.loads((out / "robustness.json").read_text())["summary"]["open_loop"]
    assert summary["nominal_still"] and summary["worst_of_nominal"] is None
    assert summary["p10_of_nominal"] is None


def test_results_go_into_a_shipped_policy_only_in_its_seeds_folder(trained, tmp_path, capsys):
    """S3, S103, S130: ``policy export``, ``real firmware`` and ``refine`` with ``--out POLICY/x`` put
    their results among a shipped policy's files; its ``seeds/`` folder, where ``export-seeds``
    writes its case's seed campaigns, stays open to results."""
    run, policy = _ship(trained, tmp_path)
    before = _snapshot(policy)
    capsys.readouterr()
    for argv in (["policy", "export", str(run), "--out", str(policy / "exp")],
                 ["real", "firmware", str(POLICIES_DIR / "m1-4mT" / "fields.csv"), "--calibration",
                  "stm32/calibration/default.json", "--out", str(policy / "fw")],
                 ["refine", str(run), "--steps", "10", "--out", str(policy / "rf"), "--no-progress"]):
        assert msr(argv) != 0, argv
        err = capsys.readouterr().err
        assert f"lies in {policy}, which holds a shipped policy of case 'm1-4mT'" in err, (argv, err)
        # the seeds/ named only to a result of a case: a firmware export is of none (round 29, V4)
        assert (f"(or in {policy}/seeds/)" in err) == (argv[0] != "real"), err
    assert _snapshot(policy) == before
    # the same rule lets a result of the policy's case into its seeds/ (an export of a run of it); a
    # result of no case (a firmware export) goes beside the policy (round 24, S2)
    # (the final actor: the placement rule is under test, not the choice of actor, 10 s each)
    assert msr(["policy", "export", str(run), "--checkpoint", "final", "--out",
                str(policy / "seeds" / "exp")]) == 0
    assert (policy / "seeds" / "exp").is_dir()
    assert msr(["real", "firmware", str(POLICIES_DIR / "m1-4mT" / "fields.csv"), "--calibration",
                "stm32/calibration/default.json", "--out", str(policy / "seeds" / "fw")]) == 2
    assert not (policy / "seeds" / "fw").exists()


def test_a_run_still_being_trained_is_neither_studied_nor_exported(trained, tmp_path, capsys):
    """S7: ``msr real robustness RUN`` and ``msr policy export-seeds RUNS/<case>`` of a run a live
    ``msr train`` writes played a checkpoint that is a step of the training."""
    import shutil

    from lock_holder import held_elsewhere

    case_folder = tmp_path / "runs" / "m1-4mT"
    shutil.copytree(trained / "m1-4mT", case_folder)
    run = case_folder / "seed0"
    with held_elsewhere(run) as pid:
        for argv in (["real", "robustness", str(run), "--duration", "0.05", "--open-loop-only",
                      "--no-corners", "--workers", "1", "--no-progress", "--out", str(tmp_path / "rb")],
                     ["policy", "export-seeds", str(case_folder), "--out", str(tmp_path / "es"),
                      "--no-progress"]):
            capsys.readouterr()
            assert msr(argv) != 0, argv
            assert f"is being trained by pid {pid}" in capsys.readouterr().err, argv
    assert not (tmp_path / "rb").exists() and not (tmp_path / "es").exists()


def test_ship_holds_the_policy_s_folder_while_it_measures(trained, tmp_path, monkeypatch):
    """D12: ``msr policy ship --force`` took no lock while it evaluated the actors: a ``policy
    notes`` made meanwhile was accepted, then dropped by the ship's swap without a word."""
    import elastica_magnetic_rl.cli.policy_commands as commands

    from elastica_magnetic.locks import held_here

    run, policy = _ship(trained, tmp_path)
    seen = []
    real_choice = commands._actor_choice

    def choice(*args, **kwargs):
        seen.append(held_here(policy))  # while the actors are evaluated
        return real_choice(*args, **kwargs)

    monkeypatch.setattr(commands, "_actor_choice", choice)
    assert msr(["policy", "ship", str(run), "--checkpoint", "final", "--duration", "0.05", "--name", "p1",
                "--out", str(tmp_path / "ship"), "--force", "--no-progress"]) == 0
    assert seen == [True]


def test_figures_of_a_run_with_no_finished_episode_say_so(trained, tmp_path, capsys):
    """V9: an empty episodes.csv (a run whose first episode has not ended) was a "damaged log"."""
    import shutil

    run = tmp_path / "run"
    shutil.copytree(trained / "m1-4mT" / "seed0", run)
    (run / "episodes.csv").write_text("")
    assert msr(["policy", "figures", str(run), "--out", str(tmp_path / "figs")]) != 0
    err = capsys.readouterr().err
    assert "episodes.csv: empty: nothing was logged yet (no training episode of this run has ended" in err
    assert "damaged" not in err


def test_a_goto_episode_too_short_for_any_gait_is_warned_about(tmp_path):
    """S10: targets 15 mm away in 0.5 s episodes (1.5 body lengths per second) passed without a word."""
    import copy
    import warnings

    from elastica_magnetic_rl.cases.case import load_case

    data = copy.deepcopy(load_case("m1-4mT-goto").to_dict())
    data["name"] = "g"
    data["task"]["episode_duration"] = 0.5
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_case(data)
    assert any("[task] episode_duration: 0.5 s for the distance 0.015 m" in str(w.message)
               and "faster than the paper's fastest gait" in str(w.message) for w in caught)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_case("m1-4mT-goto")
    assert not any("fastest gait" in str(w.message) for w in caught)


def test_simulate_plays_no_z_field_on_a_spec_whose_coils_are_in_x_y(tmp_path, capsys):
    """S11: ``msr field simulate --robot SPEC --heading 1.5708`` played a field along z on a spec whose
    [actuation] drives x and y only (``msr field replay`` refuses the same)."""
    spec = tmp_path / "m1.toml"
    assert msr(["case", "show", "m1-4mT", "--toml"]) == 0
    spec.write_text(capsys.readouterr().out)
    assert msr(["field", "simulate", "--robot", str(spec), "--heading", "1.5708", "--duration", "0.02",
                "--out", str(tmp_path / "sim")]) == 2
    assert "drives the axes xy only (no coil pair along z)" in capsys.readouterr().err
    assert not (tmp_path / "sim").exists()
    # the plane turned half a turn stays in x-y
    assert msr(["field", "simulate", "--robot", str(spec), "--heading", "3.14159265358979", "--duration",
                "0.02", "--no-progress", "--out", str(tmp_path / "flat")]) == 0
