"""Round 31 of held-out tries (issue 48), the findings of the commands: each test fails without its
fix (docs/errors.md, "A thirty-first round of tries"). S1 (identify) is tested in
tests/rl/sim2real/test_identify_honest.py, V2 and V3 (current columns) in
tests/hardware/test_stream_currents.py."""

from __future__ import annotations

import shutil

import pytest

from elastica_magnetic.cli import main as msr


def _tree(folder):
    return sorted((p.relative_to(folder).as_posix(), p.stat().st_size if p.is_file() else -1,
                   p.stat().st_mtime_ns) for p in folder.rglob("*"))


def test_ship_names_a_user_s_own_file_where_the_policy_would_go(tmp_path, trained, capsys, monkeypatch):
    """V1: ``msr policy ship --out . --name mine`` where ``mine/`` held only the user's MODEL_CARD.md
    said it "already holds a policy (MODEL_CARD.md); pass --force", and with --force refused the file
    as not msr's. Now the first refusal names the user's file and what to do, and the file stays."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "MODEL_CARD.md").write_text("my own file\n")
    run = str(trained / "m1-4mT" / "seed0")
    for force in ((), ("--force",)):
        assert msr(["policy", "ship", run, "--no-measure", "--out", ".", "--name", "mine", "--no-progress",
                    *force]) == 2
        err = capsys.readouterr().err
        assert "holds MODEL_CARD.md, which msr did not write" in err and "pass --force" not in err, err
    assert (tmp_path / "mine" / "MODEL_CARD.md").read_text() == "my own file\n"
    assert sorted(p.name for p in (tmp_path / "mine").iterdir()) == ["MODEL_CARD.md"]


def test_a_resume_with_a_new_regularization_is_refused_for_the_resume_first(tmp_path, trained, capsys):
    """V5: ``msr train --resume --set yardstick_regularization=1`` advised "set yardstick_warmup too",
    and following it was refused: a resumed run keeps its hyperparameters. That refusal comes first."""
    out = tmp_path / "runs"
    shutil.copytree(trained, out)
    before = _tree(out)
    assert msr(["train", "--case", "m1-4mT", "--seeds", "1", "--steps", "400", "--resume",
                "--set", "yardstick_regularization=1", "--out", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "cannot resume" in err and "yardstick_regularization: the run's 0.0, given 1" in err, err
    assert "set yardstick_warmup too" not in err
    assert _tree(out) == before


def test_train_into_a_folder_it_cannot_write_names_the_out_given_and_the_folder(tmp_path, capsys,
                                                                               monkeypatch):
    """V6: ``msr train --out rodir/runs`` under a folder that cannot be written named "--out
    /abs/rodir/runs/m1-4mT/seed0: cannot write in /abs/rodir/runs/m1-4mT/seed0" (a folder that does
    not exist, and not the path given). Now the --out given, and the folder that refuses."""
    import elastica_magnetic.io as io_module

    monkeypatch.chdir(tmp_path)
    (tmp_path / "rodir").mkdir()
    real_mkdir = io_module.Path.mkdir

    def refusing(self, *args, **kwargs):  # root writes anywhere: the refusal of a read-only folder
        if "rodir" in str(self):
            raise PermissionError(13, "Permission denied")
        return real_mkdir(self, *args, **kwargs)

    monkeypatch.setattr(io_module.Path, "mkdir", refusing)
    assert msr(["train", "--case", "m1-4mT", "--seeds", "1", "--steps", "100", "--set", "learning_starts=60",
                "--set", "batch_size=32", "--out", "rodir/runs", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "--out rodir/runs: cannot write in rodir: Permission denied" in err, err


def test_a_loop_too_short_to_learn_is_refused_before_the_sweep(tmp_path, capsys):
    """V7: ``msr loop m1-4mT --quick --steps 5`` ran the check and the yardstick sweep, then failed
    advising ``--set learning_starts``, an option msr loop does not have. Now refused at the start,
    in the loop's words, nothing written."""
    out = tmp_path / "lp"
    assert msr(["loop", "m1-4mT", "--quick", "--steps", "5", "--out", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "--steps 5: within the training's warm-up (--quick's learning_starts 60" in err, err
    assert "--set" not in err and "give --steps above 60" in err
    assert not out.exists()


def test_design_names_a_shipped_case_as_given(capsys):
    """V8: ``msr design catheter-magnet-reach`` was refused naming "catheter-magnet-reach.toml", a file
    that is nowhere the user can see; the shipped case is named as given."""
    with pytest.raises(SystemExit) as ended:  # argparse's refusal of SPEC
        msr(["design", "catheter-magnet-reach", "--quick", "--out", "ds"])
    assert ended.value.code == 2
    err = capsys.readouterr().err
    assert "catheter-magnet-reach (a shipped case): [task] kind = 'tip-reach'" in err, err
    assert "catheter-magnet-reach.toml" not in err


def test_a_loop_s_robustness_physics_is_redone_by_the_steps_that_read_it():
    """V9: a loop whose ``--physics-robustness`` changed was sent to ``--force`` (the whole loop again,
    training included), and ``--redo robustness,robustness-refined`` refused. Only the robustness
    steps read it: they are named, and redoing them is accepted, the rest kept."""
    from pathlib import Path

    from elastica_magnetic_rl.loop.state import STEPS, LoopError, LoopState, plan_loop

    done = {s: {"status": "done", "summary": {}} for s in STEPS}
    state = LoopState(Path("out/loop.json"), "c", {}, {"robustness_physics": "training"}, done)
    with pytest.raises(LoopError, match="which only steps robustness, robustness-refined use: pass --redo "
                                        "robustness,robustness-refined"):
        plan_loop(state, {}, {"robustness_physics": "accurate"}, (), (), False)
    plan = plan_loop(state, {}, {"robustness_physics": "accurate"}, (), ("robustness", "robustness-refined"),
                     False)
    assert plan.run == ("robustness", "robustness-refined", "firmware") and "train" in plan.done


def test_a_stop_option_without_a_rule_names_the_rule_it_belongs_to(tmp_path, capsys):
    """V10: ``--stop-patience`` without ``--stop-when`` was told "needs --stop-when target or plateau",
    and with target refused as plateau's; each option now names its one rule."""
    common = ["train", "--case", "m1-4mT", "--seeds", "1", "--steps", "100", "--set", "learning_starts=60",
              "--set", "eval_every=50", "--out", str(tmp_path / "t")]
    for option, rule in (("--stop-patience", "plateau"), ("--stop-consecutive", "target")):
        assert msr([*common, option, "3"]) == 2
        err = capsys.readouterr().err
        assert f"{option} needs --stop-when {rule}" in err and "target or plateau" not in err, err


def test_diagnose_puts_no_figure_among_another_result_s_files(tmp_path, trained, capsys):
    """D1: ``msr policy diagnose RUN --figure DIR`` drew its health figure into another command's
    result (a simulation, which ``--force`` then replaced without it), a seed campaign, the run itself
    or a training's case folder (whose resume then refused it). Now refused before the run is read,
    as ``msr policy seeds --figure`` is, nothing written there."""
    from elastica_magnetic.result_markers import mark_folder

    sim = tmp_path / "sim"
    sim.mkdir()
    (sim / "trajectory.csv").write_text("t_s\n0\n")
    mark_folder(sim, kind="simulate", subject="case m1-4mT")
    run = trained / "m1-4mT" / "seed0"
    before_sim, before_runs = _tree(sim), _tree(trained)
    for figure, said in ((sim, "holds a result of `msr field simulate`"),
                         (trained / "m1-4mT", "holds the runs of a training"),
                         (run, "holds a result of `msr train`")):
        assert msr(["policy", "diagnose", str(run), "--figure", str(figure)]) == 2
        err = capsys.readouterr().err
        assert said in err and "choose another --figure" in err, err
    assert _tree(sim) == before_sim and _tree(trained) == before_runs


def test_self_contact_damping_without_a_contact_is_refused_by_name():
    """S2: ``self_contact_damping`` without ``self_contact_stiffness`` was accepted and dropped (the
    contact is left out at zero stiffness): a trajectory byte-identical to no damping."""
    from elastica_magnetic_rl.cases.case import case_from_dict, load_case

    from elastica_magnetic.specfile import SpecError

    spec = load_case("m1-4mT").to_dict()
    spec["robot"]["interaction"] = {"self_contact_damping": 1000.0}
    with pytest.raises(SpecError, match=r"self_contact_damping: 1000 N s/m with self-contact off "
                                        r"\(self_contact_stiffness = 0"):
        case_from_dict(spec, "scd.toml")
    spec["robot"]["interaction"] = {"self_contact_damping": 0.004, "self_contact_stiffness": 40.0}
    case_from_dict(spec, "scd.toml")  # with a contact, it acts


@pytest.mark.parametrize("count", ["1000000000000", "100000000000000000000"])
def test_a_rod_of_absurdly_many_elements_is_refused_by_name(count):
    """T1, V11: ``n_elements = 1000000000000`` ended ``msr case check`` in numpy's ArrayMemoryError, and
    a count beyond 64 bits in "invalid robot_option value"; now refused where the spec is read."""
    from elastica_magnetic_rl.cases.case import load_case

    from elastica_magnetic.spec_format import loads
    from elastica_magnetic.specfile import SpecError, describe_robot

    text = load_case("m1-4mT").toml()
    spec = loads(text.replace("n_elements = 64", f"n_elements = {count}"))
    assert spec["robot"]["n_elements"] == int(count)
    with pytest.raises(SpecError, match=rf"n_elements: {count} elements is more than 10000"):
        describe_robot(spec, "big.toml")


def test_a_training_of_absurdly_many_steps_is_refused_before_any_work(tmp_path, capsys):
    """The round's note: ``msr train --steps 99999999999999999999`` started training (stopped after
    ten minutes); a count beyond 1e8 steps per seed is refused, from --steps and from the spec."""
    out = tmp_path / "t"
    assert msr(["train", "--case", "m1-4mT", "--steps", "99999999999999999999", "--out", str(out)]) == 2
    assert "more than 1e+08" in capsys.readouterr().err
    assert not out.exists()
