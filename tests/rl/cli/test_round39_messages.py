"""Round 39 of held-out tries (issue 48): what they found, each fixed with the message it gives."""

from __future__ import annotations

import re

import pytest

from elastica_magnetic.cli import main as msr

TINY = ["--seeds", "1", "--steps", "100", "--episode-duration", "0.5", "--set", "learning_starts=60",
        "--set", "batch_size=32", "--set", "hidden_sizes=32,32", "--workers", "1", "--no-progress"]


def test_an_evaluation_shorter_than_a_step_is_refused_before_any_folder(tmp_path, capsys):
    """V1: ``--set eval_duration=0.005`` passed the setting check; every seed then failed with
    "duration must be at least one 0.01 s step" (no setting named), and the summary reported a 10 s
    evaluation."""
    out = tmp_path / "e6"
    with pytest.raises(SystemExit) as refused:  # refused where the options are parsed
        msr(["train", "--case", "m1-4mT", *TINY, "--set", "eval_every=50", "--set", "eval_duration=0.005",
             "--out", str(out)])
    assert refused.value.code == 2
    assert "eval_duration must be 0" in capsys.readouterr().err
    assert not out.exists()


def test_policy_notes_help_gives_one_rule_for_removing_the_notes(capsys):
    """V2: the help's description said an empty --file removes the notes; an empty --file is refused
    (--clear removes them)."""
    try:
        msr(["policy", "notes", "--help"])
    except SystemExit:
        pass
    text = " ".join(capsys.readouterr().out.split())
    assert "empty file removes" not in text and "--clear removes them" in text


def test_a_skipped_step_names_every_step_it_holds_back():
    """V4: ``--skip train`` advised "skip generate, refine too"; followed, it was refused again for
    robustness, robustness-refined and firmware (which need generate)."""
    from elastica_magnetic_rl.loop.state import LoopError, plan_loop

    with pytest.raises(LoopError, match=r"step generate needs step train, which is skipped .*: skip "
                                        r"generate, robustness, refine, robustness-refined, firmware too, "
                                        r"or run train"):
        plan_loop(None, {}, {}, ("train",), (), False)
    plan = plan_loop(None, {}, {}, ("train", "generate", "robustness", "refine", "robustness-refined",
                                    "firmware"), (), False)
    assert plan.run == ("check", "yardstick")


def test_a_loop_started_over_for_another_case_records_and_titles_it(tmp_path, monkeypatch):
    """S1: ``msr loop m2-4mT --force`` over a loop of m1-4mT (some steps skipped) ran every step for
    m2-4mT, but loop.json's case and the report's title stayed m1-4mT, and the old loop's spec copy
    m1-4mT.toml stayed beside m2-4mT.toml."""
    import io

    from elastica_magnetic_rl.cases.case import load_case
    from elastica_magnetic_rl.loop import runner
    from elastica_magnetic_rl.loop.settings import LoopSettings
    from elastica_magnetic_rl.loop.state import STEPS, LoopState

    from elastica_magnetic.results import result_folder

    def fake(step):
        def run(ctx):
            with result_folder(ctx.folder / step, kind=step, force=True) as folder:
                (folder.path / "result.txt").write_text(step)
            if step == "yardstick":
                ctx.path(f"{ctx.case.name}.toml").write_text(f"name = '{ctx.case.name}'\n")
                return {"spec_file": f"{ctx.case.name}.toml"}
            return {}
        return run

    titles: list[str] = []
    monkeypatch.setattr(runner, "write_report", lambda ctx: titles.append(ctx.state.case))
    monkeypatch.setattr(runner, "headline", lambda step, summary: step)
    functions = {step: fake(step) for step in STEPS}
    out, skip = tmp_path / "lp2", ("robustness", "robustness-refined", "refine")
    runner.run_loop(load_case("m1-4mT"), out, LoopSettings(), skip=skip, progress=False, log=io.StringIO(),
                    steps=functions)
    (out / "notes.txt").write_text("the user's")
    runner.run_loop(load_case("m2-4mT"), out, LoopSettings(), skip=skip, force=True, progress=False,
                    log=io.StringIO(), steps=functions)
    assert LoopState.read(out).case == "m2-4mT" and titles[-1] == "m2-4mT"
    assert (out / "m2-4mT.toml").exists() and not (out / "m1-4mT.toml").exists()
    assert (out / "notes.txt").read_text() == "the user's"


def test_two_cases_of_one_name_are_told_where_the_name_comes_from(tmp_path):
    """V3: "two different cases are named 'm1-4mT-designed': rename one spec file"; renaming the
    file changed nothing (its ``name`` key names it, as msr design's best.toml does)."""
    from elastica_magnetic_rl.cases.case import SPECS_DIR
    from elastica_magnetic_rl.sweep.sweep_plan import load_cases

    mine = tmp_path / "mybest.toml"  # another robot (m1-4mT's) under the shipped design's name
    mine.write_text('name = "m1-4mT-designed"\n' + (SPECS_DIR / "m1-4mT.toml").read_text())
    named = (r"two different cases are named 'm1-4mT-designed': the shipped case m1-4mT-designed and "
             r".*mybest.toml \(its `name = 'm1-4mT-designed'`\); change one spec's top-level `name`")
    with pytest.raises(ValueError, match=named):
        load_cases(["m1-4mT-designed", mine])


@pytest.mark.parametrize("header, times", [("t_s", ["0", "0.02", "0.04"]), ("time [ms]", ["0", "20", "40"]),
                                           ("t_s", ["0", "0.01", "0.03"])])
def test_a_clock_column_of_other_steps_is_refused(tmp_path, header, times):
    """A borderline of round 39: a ``t_s`` column stepping 0.02 s in last place was only warned "not
    read", and the waveform played at 100 Hz, twice as fast as its own times say."""
    from elastica_magnetic.field_csv import FieldCSVError, read_field_csv

    rows = [f"mag_x,mag_y,mag_z,{header}"] + [f"1,0,0,{t}" for t in times]
    (tmp_path / "f.csv").write_text("\n".join(rows) + "\n")
    with pytest.raises(FieldCSVError, match=rf"column '{re.escape(header)}' reads as a clock stepping "
                                            r"0.0[12] s at line [34].* played 0.01 s apart whatever it says"):
        read_field_csv(tmp_path / "f.csv")


def test_a_clock_column_of_the_rows_steps_is_read_as_before(tmp_path):
    from elastica_magnetic.field_csv import read_field_csv

    (tmp_path / "f.csv").write_text("mag_x,mag_y,mag_z,t_s\n1,0,0,0.5\n1,0,0,0.51\n2,0,0,0.52\n")
    with pytest.warns(UserWarning, match=r"column\(s\) 't_s' are not read"):
        assert read_field_csv(tmp_path / "f.csv")[:, 0].tolist() == [1e-3, 1e-3, 2e-3]
