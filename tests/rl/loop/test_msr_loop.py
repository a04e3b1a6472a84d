"""``msr loop`` (issue 49): the whole path of a robot that is none of the shipped cases (four
``segments`` of magnetization, a Poisson ratio) as a smoke run (``--quick``), interrupted and
resumed; ``--redo`` and ``--skip``; a changed spec refused; the plan's rules."""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import pytest
import tomli_w
from elastica_magnetic_rl.loop import steps as loop_steps
from elastica_magnetic_rl.loop.state import STEPS, LoopError, LoopState, plan_loop

from elastica_magnetic.cli import main as msr

#: A robot none of the shipped cases has: four magnetized segments, moduli from a Poisson ratio.
SPEC = {
    "name": "seg4",
    "robot": {
        "name": "seg4", "length": 0.02, "n_elements": 24, "width": 0.008, "thickness": 0.0008,
        "density": 1860.0, "youngs_modulus": 84500.0, "poisson_ratio": 0.45,
        "magnetization": {"kind": "segments", "magnitude": 60000.0, "segments": [
            {"elements": 6, "direction": [0.0, 1.0, 0.0]},
            {"elements": 6, "direction": [1.0, 0.0, 0.0]},
            {"elements": 6, "direction": [0.0, -1.0, 0.0]},
            {"elements": 6, "direction": [-1.0, 0.0, 0.0]},
        ]},
        "ground": {"static_mu": 0.8, "kinetic_mu": 0.6},
    },
    "actuation": {"field_limit": 0.004},
    "task": {"kind": "crawl"},
}


def _write_spec(path: Path, **actuation: float) -> Path:
    spec = json.loads(json.dumps(SPEC))
    spec["actuation"].update(actuation)
    path.write_bytes(tomli_w.dumps(spec).encode())
    return path


def _loop(*argv: str) -> tuple[int, str, str]:
    """``msr loop ... --quick --workers 1``: exit status, stdout, stderr."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = msr(["loop", *argv, "--quick", "--workers", "1"])
        except SystemExit as exc:  # argparse
            status = exc.code
    return status, out.getvalue(), err.getvalue()


def _interrupt(ctx):
    raise KeyboardInterrupt


@pytest.fixture(scope="module")
def interrupted_then_resumed(tmp_path_factory):
    """The loop interrupted at its robustness step (a Ctrl-C), then the same command again."""
    root = tmp_path_factory.mktemp("loop")
    spec = _write_spec(root / "seg4.toml")
    folder = root / "out"
    with pytest.MonkeyPatch.context() as patch:
        patch.setitem(loop_steps.STEP_FUNCTIONS, "robustness", _interrupt)
        first = _loop(str(spec), "--out", str(folder))
    partial = {"state": json.loads((folder / "loop.json").read_text()),
               "report": (folder / "report.md").read_text()}
    second = _loop(str(spec), "--out", str(folder))
    return {"spec": spec, "folder": folder, "first": first, "partial": partial, "second": second}


def test_an_interrupted_loop_keeps_its_finished_steps(interrupted_then_resumed):
    status, _, err = interrupted_then_resumed["first"]
    assert status == 130, err
    assert "loop: [5/8] robustness: started" in err
    assert "run the same command again" in err
    partial = interrupted_then_resumed["partial"]
    state, report = partial["state"], partial["report"]
    assert [s for s in STEPS if state["steps"].get(s, {}).get("status") == "done"] == [
        "check", "yardstick", "train", "generate"]
    assert "4 of 8 steps done" in report and "Not run yet." in report  # a partial report


def test_the_same_command_skips_finished_steps_and_runs_the_rest(interrupted_then_resumed):
    status, out, err = interrupted_then_resumed["second"]
    assert status == 0, err
    for number, step in enumerate(STEPS[:4], start=1):
        assert f"loop: [{number}/8] {step}: already done (loop.json), skipped" in err
    for number, step in enumerate(STEPS[4:], start=5):
        assert f"loop: [{number}/8] {step}: started" in err
        assert f"loop: [{number}/8] {step}: done in " in err
    assert "\r" not in err  # no progress bars: stderr is not a terminal
    # but plain progress lines within the steps (a log of a run of hours shows where it is)
    assert "robustness: 100% (18/18 run)" in err, err
    assert "8 of 8 steps done" in out


def test_each_step_writes_its_folder_and_the_report_is_complete(interrupted_then_resumed):
    folder = interrupted_then_resumed["folder"]
    state = LoopState.read(folder)
    assert all(state.done(s) for s in STEPS)
    for step in STEPS:
        assert (folder / step).is_dir(), step
        assert isinstance(state.steps[step]["wall_s"], float)
    assert (folder / "firmware" / "waveform_table.c").is_file()
    # the coils play the waveform that goes farther on average over the varied robots, not the later one
    from elastica_magnetic_rl.loop.steps import open_loop_mean

    loops = {name: state.summary(step) for name, step in
             (("learned", "robustness"), ("refined", "robustness-refined"))}
    chosen = state.summary("firmware")
    better = max(loops, key=lambda n: (open_loop_mean(loops[n]),
                                       loops[n]["summary"]["open_loop"]["nominal_m"]))
    assert chosen["which"] == better and "open-loop mean over the varied robots" in chosen["why"]
    assert chosen["waveform"] == state.summary(
        {"learned": "robustness", "refined": "robustness-refined"}[better])["fields_csv"]
    assert (folder / "refine" / "checkpoint.pt").is_file()
    assert len(state.summary("train")["seeds"]) == 2
    # the spec the loop trained on carries the sweep's distance, labelled as a smoke run's
    copy = (folder / "seg4.toml").read_text()
    assert "not a yardstick" in copy and "training physics" in copy
    for step in ("robustness", "robustness-refined"):
        summary = state.summary(step)
        assert summary["physics"] == "training" and summary["yardstick_comparable"] is False
        assert {"open_loop", "closed_loop"} <= set(summary["summary"])
        labels = {v["label"].split(" x")[0] for v in summary["variants"]}
        assert {"magnetization", "modulus", "friction", "density"} <= labels
    report = (folder / "report.md").read_text()
    assert "8 of 8 steps done" in report and "Not run yet." not in report
    assert "open loop (training)" in report and "closed loop (training)" in report
    assert "the yardstick" in report
    page = (folder / "report.html").read_text()
    assert page.count("data:image/png;base64,") >= 4  # sweep, gait, waveform, robustness x2
    assert 'src="generate/' not in page  # self-contained: no figure linked


def test_redo_runs_a_step_again_and_those_that_need_it(interrupted_then_resumed):
    folder, spec = interrupted_then_resumed["folder"], interrupted_then_resumed["spec"]
    before = LoopState.read(folder)
    status, _, err = _loop(str(spec), "--out", str(folder), "--redo", "robustness")
    assert status == 0, err
    assert "loop: [5/8] robustness: started" in err
    assert "loop: [8/8] firmware: started" in err  # it plays the waveform robustness judges better
    after = LoopState.read(folder)
    assert after.steps["robustness"]["finished_utc"] >= before.steps["robustness"]["finished_utc"]
    assert after.steps["train"] == before.steps["train"]


def test_a_changed_spec_or_setting_is_refused(interrupted_then_resumed, tmp_path):
    folder = interrupted_then_resumed["folder"]
    before = (folder / "loop.json").read_bytes()
    changed = _write_spec(tmp_path / "seg4.toml", field_limit=0.005)
    status, _, err = _loop(str(changed), "--out", str(folder))
    assert status == 2
    assert "spec.actuation.field_limit" in err and "--force" in err
    status, _, err = _loop(str(interrupted_then_resumed["spec"]), "--out", str(folder), "--seeds", "3")
    assert status == 2 and "settings.seeds" in err
    assert (folder / "loop.json").read_bytes() == before


def test_skip_is_recorded_and_a_step_that_needs_a_skipped_one_is_refused(tmp_path):
    spec = _write_spec(tmp_path / "seg4.toml")
    folder = tmp_path / "out"
    status, _, err = _loop(str(spec), "--out", str(folder), "--skip", "yardstick")
    assert status == 2
    assert "step train needs step yardstick" in err
    assert not folder.exists()  # refused before any work
    rest = ",".join(STEPS[1:])
    status, _, err = _loop(str(spec), "--out", str(folder), "--skip", rest)
    assert status == 0, err
    state = LoopState.read(folder)
    assert state.done("check")
    assert all(state.steps[s]["status"] == "skipped" for s in STEPS[1:])
    assert "Skipped (`--skip`)." in (folder / "report.md").read_text()
    status, _, err = _loop(str(spec), "--out", str(folder), "--skip", rest)
    assert status == 0 and "check: already done" in err


@pytest.mark.parametrize("argv, message", [
    (["--skip", "trian"], "--skip: unknown step 'trian'"),
    (["--skip", "train", "--redo", "train"], "--skip and --redo both name train"),
    (["--calibration", "missing.json"], "--calibration missing.json: no such file"),
])
def test_bad_options_are_refused_before_any_work(tmp_path, argv, message):
    spec = _write_spec(tmp_path / "seg4.toml")
    status, _, err = _loop(str(spec), "--out", str(tmp_path / "out"), *argv)
    assert status == 2 and message in err, err
    assert not (tmp_path / "out").exists()


def test_a_folder_holding_other_files_is_refused(tmp_path):
    spec = _write_spec(tmp_path / "seg4.toml")
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "notes.txt").write_text("mine")
    status, _, err = _loop(str(spec), "--out", str(tmp_path / "out"), "--force")
    assert status == 2 and "does not write (notes.txt)" in err, err
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["notes.txt"]


def test_redo_plans_every_step_that_needs_the_redone_one(tmp_path):
    state = LoopState(tmp_path / "loop.json", "c", {}, {},
                      {s: {"status": "done"} for s in STEPS})
    plan = plan_loop(state, {}, {}, (), ("train",), False)
    assert plan.done == ("check", "yardstick")
    assert plan.run == ("train", "generate", "robustness", "refine", "robustness-refined",
                        "firmware")
    plan = plan_loop(state, {}, {}, (), ("refine",), False)
    assert plan.run == ("refine", "robustness-refined", "firmware")  # firmware reads the robustness verdict
    with pytest.raises(LoopError, match="step robustness needs step generate"):
        plan_loop(None, {}, {}, ("generate", "firmware"), (), False)


def test_a_quick_loop_resumed_without_quick_says_so():
    """Round 12: a loop made with --quick, re-run without it, was refused listing internal
    setting names (settings.check_sag, ... and 13 more)."""
    from elastica_magnetic_rl.loop.settings import LoopSettings

    quick, full = LoopSettings.smoke().recorded(), LoopSettings().recorded()
    state = LoopState(Path("out/loop.json"), "c", {}, quick, {s: {"status": "done"} for s in STEPS})
    with pytest.raises(LoopError, match=r"holds a loop made with --quick: add --quick to go on "
                                        r"with it, or pass --force to start it over without --quick"):
        plan_loop(state, {}, full, (), (), False)
    state = LoopState(Path("out/loop.json"), "c", {}, full, {})
    with pytest.raises(LoopError, match=r"made without --quick: leave out --quick"):
        plan_loop(state, {}, quick, (), (), False)


def test_a_training_killed_before_its_record_is_resumed_not_restarted(interrupted_then_resumed,
                                                                      tmp_path):
    """Killed after the training ended but before ``loop.json`` recorded it: the train step
    resumes the runs (``msr train --resume``: nothing left to train), keeping their checkpoints,
    and measures the seeds again."""
    import shutil

    folder = tmp_path / "out"
    shutil.copytree(interrupted_then_resumed["folder"], folder)
    state = LoopState.read(folder)
    for step in STEPS[2:]:
        del state.steps[step]
    state.write()
    checkpoint = folder / "train" / "seg4" / "seed0" / "checkpoint.pt"
    before = checkpoint.read_bytes()
    status, _, err = _loop(str(interrupted_then_resumed["spec"]), "--out", str(folder), "--skip",
                           ",".join(STEPS[3:]))
    assert status == 0, err
    assert "loop: [3/8] train: done in" in err
    state = LoopState.read(folder)
    assert state.summary("train")["resumed"] is True
    assert len(state.summary("train")["seeds"]) == 2
    assert checkpoint.read_bytes() == before


def _terminated_while_workers_run(ctx):
    """A step killed with SIGTERM while its worker processes run (as k4/k5: `kill -TERM` during
    the training step), through the handler that stops the workers."""
    import os
    import signal
    import time

    from elastica_magnetic_rl.sweep.backends import _termination_as_interrupt

    with _termination_as_interrupt():
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(5)  # the handler raises before this ends
    raise AssertionError("SIGTERM did not interrupt the step")


def test_a_loop_killed_with_sigterm_says_sigterm_and_exits_143(tmp_path, monkeypatch):
    # issue 48 k4/k5: it said "interrupted (SIGINT)" and exited 130
    spec = _write_spec(tmp_path / "seg4.toml")
    monkeypatch.setitem(loop_steps.STEP_FUNCTIONS, "check", _terminated_while_workers_run)
    status, _, err = _loop(str(spec), "--out", str(tmp_path / "out"))
    assert status == 143, err
    assert "msr loop: interrupted (SIGTERM)" in err and "SIGINT" not in err, err


def test_a_quick_sweep_that_finds_no_forward_distance_blames_its_length(tmp_path, monkeypatch):
    """Round 4, V10: a --quick loop (one 0.5 s sweep) whose robot went backwards was told to check
    its magnetization; the message says the sweep is too short to judge and how to judge it."""
    from elastica_magnetic_rl.shipping import baseline_sweep

    def backwards(*args, **kwargs):
        return {"best": {"mid_dx_m": -4e-4}, "duration_s": 0.5, "physics": "training"}

    spec = _write_spec(tmp_path / "seg4.toml")
    monkeypatch.setitem(loop_steps.STEP_FUNCTIONS, "check", lambda ctx: {"text": "", "warnings": []})
    monkeypatch.setattr(baseline_sweep, "sweep_baseline", backwards)
    status, _, err = _loop(str(spec), "--out", str(tmp_path / "out"))
    assert status == 2, err
    assert "moved seg4 -0.4 mm in 0.5 s of the training physics" in err, err
    assert "(1 period(s), 0.5 s, training physics, --quick) is too short to judge the robot" in err
    assert "check the magnetization" not in err


def test_an_interrupted_redo_leaves_the_later_steps_results(interrupted_then_resumed, tmp_path,
                                                            monkeypatch):
    """Round 7, K09: Ctrl-C during ``--redo train`` removed generate's, robustness's, refine's and
    firmware's results before their replacements existed. Now each redone step's folder goes at
    its own turn: the steps after the interrupted one keep their results (loop.json no longer
    calls them done, so the next run redoes them)."""
    import hashlib
    import shutil

    folder = tmp_path / "out"
    shutil.copytree(interrupted_then_resumed["folder"], folder)
    later = [s for s in STEPS[3:] if (folder / s).is_dir()]
    assert later, "the fixture ran the steps after train"

    def digest(step: str) -> str:
        files = sorted(p for p in (folder / step).rglob("*") if p.is_file())
        return hashlib.sha256(b"".join(p.read_bytes() for p in files)).hexdigest()

    before = {s: digest(s) for s in later}
    monkeypatch.setitem(loop_steps.STEP_FUNCTIONS, "train", _interrupt)
    status, _, err = _loop(str(interrupted_then_resumed["spec"]), "--out", str(folder), "--redo",
                           "train")
    assert status != 0, err
    assert {s: digest(s) for s in later} == before
    assert not any(LoopState.read(folder).done(s) for s in STEPS[2:])


def test_changed_training_settings_train_again_on_the_sweep_the_loop_has(interrupted_then_resumed, tmp_path):
    """A spec's ``[training]`` changed (a loop's training to try again with other settings) was
    refused as another spec: only --force, the yardstick's sweep again. The check and the training
    read it alone: ``--redo check,train`` trains on the sweep's spec copy with the new table."""
    import shutil

    from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint

    folder = tmp_path / "out"
    shutil.copytree(interrupted_then_resumed["folder"], folder)
    before = LoopState.read(folder)
    spec = json.loads(json.dumps(SPEC))
    spec["training"] = {"td3": {"exploration_noise": 0.15}}
    changed = tmp_path / "seg4.toml"
    changed.write_bytes(tomli_w.dumps(spec).encode())
    status, _, err = _loop(str(changed), "--out", str(folder))
    assert status == 2
    assert "changed: spec.training.td3, which only steps check, train use: pass --redo check,train" in err
    status, _, err = _loop(str(changed), "--out", str(folder), "--redo", "check,train")
    assert status == 0, err
    after = LoopState.read(folder)
    assert after.steps["yardstick"] == before.steps["yardstick"]
    assert after.steps["train"]["finished_utc"] > before.steps["train"]["finished_utc"]
    config = load_checkpoint(folder / "train" / "seg4" / "seed0")["config"]
    assert config["exploration_noise"] == 0.15


def test_more_steps_train_the_loop_s_seeds_further(interrupted_then_resumed, tmp_path):
    """A loop whose learned waveform fell short of its yardstick is trained further with a larger
    ``--steps``: the seeds resume from their checkpoints to the new budget (not afresh), the sweep
    is kept, and the steps after the training run again; fewer steps are refused."""
    import shutil

    from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint

    folder = tmp_path / "out"
    shutil.copytree(interrupted_then_resumed["folder"], folder)
    spec = str(interrupted_then_resumed["spec"])
    before = LoopState.read(folder)
    trained = before.steps["train"]["summary"]["steps"]
    episodes = (folder / "train" / "seg4" / "seed0" / "episodes.csv").read_text().splitlines()
    status, _, err = _loop(spec, "--out", str(folder), "--steps", str(trained - 40))
    assert status == 2 and f"its training has {trained} steps per seed" in err and "never shortened" in err
    status, _, err = _loop(spec, "--out", str(folder), "--steps", str(trained + 120))
    assert status == 0, err
    after = LoopState.read(folder)
    assert after.steps["yardstick"] == before.steps["yardstick"]
    train = after.steps["train"]["summary"]
    assert train["resumed"] and train["steps"] == trained + 120
    assert after.steps["generate"]["finished_utc"] > before.steps["generate"]["finished_utc"]
    assert load_checkpoint(folder / "train" / "seg4" / "seed0")["global_step"] == trained + 120
    # the seed went on: its first episodes are the same lines, more came after them
    longer = (folder / "train" / "seg4" / "seed0" / "episodes.csv").read_text().splitlines()
    assert longer[:len(episodes)] == episodes and len(longer) > len(episodes)


def test_a_lengthened_loop_interrupted_starts_its_later_steps_afresh_and_keeps_its_steps(
        interrupted_then_resumed, tmp_path, monkeypatch):
    """Round 22, D2: a loop given more ``--steps`` and interrupted after its training (the steps
    after it not yet run again) failed on every later run at the refinement, which resumed the
    one made from the earlier actor ("nothing to refine"). Now the steps a run was to start afresh
    are recorded so, and the next run starts them afresh. V2: the plain command (no ``--steps``)
    then keeps the loop's lengthened training instead of refusing "--steps 240"."""
    import shutil

    folder = tmp_path / "out"
    shutil.copytree(interrupted_then_resumed["folder"], folder)
    spec = str(interrupted_then_resumed["spec"])
    trained = LoopState.read(folder).steps["train"]["summary"]["steps"]
    refined_before = (folder / "refine" / "run.json").read_text()
    longer = str(trained + 60)
    with monkeypatch.context() as patch:
        patch.setitem(loop_steps.STEP_FUNCTIONS, "generate", _interrupt)
        status, _, err = _loop(spec, "--out", str(folder), "--steps", longer)
    assert status != 0, err
    pending = LoopState.read(folder).steps
    assert pending["refine"]["status"] == "to start afresh", pending["refine"]
    status, _, err = _loop(spec, "--out", str(folder), "--steps", longer)
    assert status == 0, err
    after = LoopState.read(folder)
    assert all(after.done(step) for step in STEPS), after.steps
    assert (folder / "refine" / "run.json").read_text() != refined_before  # a new refinement
    status, _, err = _loop(spec, "--out", str(folder))
    assert status == 0, err
    assert f"its loop trains {longer} steps per seed" in err
    assert LoopState.read(folder).steps == after.steps  # nothing ran again


def test_a_users_file_in_a_step_folder_stops_a_redo_or_a_restart(interrupted_then_resumed, tmp_path):
    """Round 9, D3: ``--redo STEP`` and ``--force`` (a changed spec) removed the user's files in
    the step folders (train/, yardstick/, robustness/) with the step's earlier result. Now the
    loop refuses before any work, naming them; without them it runs as before."""
    import shutil

    folder = tmp_path / "out"
    shutil.copytree(interrupted_then_resumed["folder"], folder)
    spec = interrupted_then_resumed["spec"]
    (folder / "robustness" / "mine.txt").write_text("my notes\n")
    before = (folder / "loop.json").read_bytes()
    status, _, err = _loop(str(spec), "--out", str(folder), "--redo", "robustness")
    assert status == 2 and "robustness/ holds files msr did not write (robustness/mine.txt)" in err
    (folder / "train" / "notes.txt").write_text("my notes\n")
    changed = _write_spec(tmp_path / "seg4.toml", field_limit=0.005)
    status, _, err = _loop(str(changed), "--out", str(folder), "--force")
    assert status == 2 and "train/notes.txt" in err
    assert (folder / "loop.json").read_bytes() == before
    assert (folder / "robustness" / "mine.txt").read_text() == "my notes\n"
    (folder / "robustness" / "mine.txt").unlink()
    (folder / "train" / "notes.txt").unlink()
    status, _, err = _loop(str(spec), "--out", str(folder), "--redo", "robustness")
    assert status == 0, err


def test_a_quick_sweep_with_no_forward_distance_uses_the_specs_own_yardstick(tmp_path, monkeypatch):
    """Round 11, V4: msr loop m1-4mT --quick (the documented smoke run) stopped at its yardstick
    step (0.5 s of the training physics moved the paper's robot nothing) and told the user to drop
    --quick; a spec with its own [yardstick] now has it stand in, said so in the report."""
    from elastica_magnetic_rl.cases.case import load_case
    from elastica_magnetic_rl.shipping import baseline_sweep

    def backwards(*args, **kwargs):
        return {"best": {"mid_dx_m": -4e-4, "period_s": 0.5, "clockwise": True,
                         "period_achieved_s": 0.5},
                "duration_s": 0.5, "physics": "training", "runs": []}

    monkeypatch.setitem(loop_steps.STEP_FUNCTIONS, "check", lambda ctx: {"text": "", "warnings": []})
    monkeypatch.setattr(baseline_sweep, "sweep_baseline", backwards)
    out = tmp_path / "out"
    status, _, err = _loop("m1-4mT", "--out", str(out), "--skip",
                           "train,generate,robustness,refine,robustness-refined,firmware")
    assert status == 0, err
    state = json.loads((out / "loop.json").read_text())
    summary = state["steps"]["yardstick"]["summary"]
    assert summary["distance_m"] == pytest.approx(0.0205)
    assert "the spec's own [yardstick] distance_10s (+20.5 mm) stands in" in summary["stand_in"]
    trained = load_case(out / "m1-4mT.toml")
    assert trained.yardstick.distance_10s == pytest.approx(0.0205)
    assert "standing in for a smoke run" in trained.yardstick.source
    # Round 17 S: the copy carried the smoke field (period 0.5 s, counter-clockwise: -0.0019 mm) as
    # "the rotating field that made distance_10s", which a training from the yardstick clones
    assert trained.yardstick.period is None
    assert "stands in for this smoke run" in (out / "report.md").read_text()
    # Round 12, S2: the progress line said "rotating field +20.5 mm (period 0.5 s)", as if measured
    assert "the sweep's best -0.4 mm in 0.5 s (a smoke run); the spec's own +20.5 mm in 10 s stands " \
           "in" in err, err
    assert "rotating field +20.5 mm" not in err


def test_round17_quick_with_more_steps_says_it_is_no_smoke_run(capsys):
    """Round 17 S: `msr loop --quick --steps 100000` trained 100000 steps per seed in "a smoke run
    of about a minute" without a word."""
    import argparse

    from elastica_magnetic_rl.loop.cli import _settings

    args = argparse.Namespace(calibration=None, quick=True, steps=100_000, seeds=1, workers=1,
                              physics_robustness="training")
    assert _settings(args).steps == 100_000
    assert "--steps 100000 replaces --quick's 240 training steps per seed" in capsys.readouterr().err
    args.steps = 100
    assert _settings(args).steps == 100 and "replaces" not in capsys.readouterr().err


@pytest.mark.slow
def test_an_interrupted_start_over_leaves_the_finished_loop_whole(interrupted_then_resumed, tmp_path,
                                                                  monkeypatch):
    """Round 49 D1: ``--force`` with other settings (a third seed), interrupted in its training,
    had removed the finished loop's trained runs and recorded the new settings beside the old
    steps' results. A loop started over is built beside and swapped in whole."""
    import shutil

    folder = tmp_path / "out"
    shutil.copytree(interrupted_then_resumed["folder"], folder)

    def fingerprint() -> dict[str, bytes]:
        return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*"))
                if p.is_file()}

    before = fingerprint()
    spec = str(interrupted_then_resumed["spec"])
    with monkeypatch.context() as m:
        m.setitem(loop_steps.STEP_FUNCTIONS, "train", _interrupt)
        status, _, err = _loop(spec, "--out", str(folder), "--seeds", "3", "--force")
    assert status == 130, err
    # round 50 V1: not "run the same command again to go on from there"
    assert "the loop started over with --force was not finished" in err and "go on from there" not in err
    assert fingerprint() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # nothing left beside it
    status, _, err = _loop(spec, "--out", str(folder), "--seeds", "3", "--force")
    assert status == 0, err
    assert LoopState.read(folder).settings["seeds"] == 3
    assert all(LoopState.read(folder).done(s) for s in STEPS if s not in ("refine", "robustness-refined"))
    # swapped in, it is a loop like any other: run again it skips its steps; a redo reads its runs
    status, _, err = _loop(spec, "--out", str(folder), "--seeds", "3", "--redo", "generate")
    assert status == 0 and "loop: [3/8] train: already done" in err and "[4/8] generate: done" in err, err


def test_a_redo_refuses_another_commands_result_inside_a_step(interrupted_then_resumed, tmp_path):
    """Round 50 D1: ``msr refine LOOP/train/CASE/seed0`` writes ``seed0/refined`` (its default);
    ``--redo train`` then removed that refinement without a word (files without a record were
    refused, another command's result was not)."""
    import shutil

    from elastica_magnetic.result_markers import mark_folder

    folder = tmp_path / "out"
    shutil.copytree(interrupted_then_resumed["folder"], folder)
    refined = folder / "train" / "seg4" / "seed0" / "refined"
    refined.mkdir()
    (refined / "run.json").write_text("{}\n")
    mark_folder(refined, kind="refine", subject="case seg4")
    status, _, err = _loop(str(interrupted_then_resumed["spec"]), "--out", str(folder), "--redo", "train")
    assert status == 2, err
    assert "step train runs again (its folder is written anew) but train/seg4/seed0/refined holds" in err
    assert "not the loop's: move it out of the loop's folder first" in err
    assert (refined / "run.json").is_file()


def test_a_changed_training_table_is_told_one_redo_that_covers_it(interrupted_then_resumed, tmp_path):
    """Round 50, V3: a changed ``[training.td3]`` key with ``--redo check`` was told "pass --redo
    train", and with ``--redo train`` "pass --redo check": advice that, followed, was refused again.
    Now each names the whole set that reads the key."""
    import shutil

    folder = tmp_path / "out"
    shutil.copytree(interrupted_then_resumed["folder"], folder)
    spec = json.loads(json.dumps(SPEC))
    spec["training"] = {"td3": {"exploration_noise": 0.15}}
    changed = tmp_path / "seg4.toml"
    changed.write_bytes(tomli_w.dumps(spec).encode())
    for given in ("check", "train"):
        status, _, err = _loop(str(changed), "--out", str(folder), "--redo", given)
        assert status == 2
        assert "which only steps check, train use: pass --redo check,train" in err, err


def _interrupted_seed(ctx):
    """The train step interrupted after its seeds' folders and ``run.json`` are written, before
    their markers list them (what a Ctrl-C early in a training leaves)."""
    from elastica_magnetic_rl.runfiles.locking import mark_run_folder

    for k in range(2):
        seed = ctx.folder / "train" / ctx.case.name / f"seed{k}"
        mark_run_folder(seed, "train", ctx.case.name)
        (seed / "run.json").write_text("{}\n")
    raise KeyboardInterrupt


def test_an_interrupted_redo_is_not_refused_for_its_own_seeds(interrupted_then_resumed, tmp_path,
                                                               monkeypatch):
    """Round 50, V2 (and round 51): after a Ctrl-C in the train step of ``--redo yardstick``, "run the
    same command again" was refused: "train/ holds files msr did not write (train/seg4/seed0/run.json,
    ...)", the loop's own interrupted seeds. Now the same command runs, and the interruption says
    that without --redo the loop goes on where it stopped."""
    import shutil

    folder = tmp_path / "out"
    shutil.copytree(interrupted_then_resumed["folder"], folder)
    spec = str(interrupted_then_resumed["spec"])
    with monkeypatch.context() as m:
        m.setitem(loop_steps.STEP_FUNCTIONS, "train", _interrupted_seed)
        status, _, err = _loop(spec, "--out", str(folder), "--redo", "train")
    assert status != 0
    assert "run it again without --redo to go on from there (the same command starts the steps of " \
           "--redo train again)" in err, err
    # a user's file still stops it
    (folder / "train" / "seg4" / "seed0" / "mine.txt").write_text("my notes\n")
    status, _, err = _loop(spec, "--out", str(folder), "--redo", "train")
    assert status == 2 and "train/seg4/seed0/mine.txt" in err and "seed0/run.json" not in err, err
    (folder / "train" / "seg4" / "seed0" / "mine.txt").unlink()
    status, _, err = _loop(spec, "--out", str(folder), "--redo", "train")
    assert status == 0, err


def test_a_changed_recipe_the_loop_does_not_train_with_asks_no_redo(interrupted_then_resumed, tmp_path):
    """Round 52, V5: a changed ``[training] recipe`` was told ``--redo check,train``, whose training
    then used the loop's own fast recipe again, bit for bit: the key acts on no step. Now it asks no
    redo, and the loop says the recipe is not used."""
    import shutil

    folder = tmp_path / "out"
    shutil.copytree(interrupted_then_resumed["folder"], folder)
    before = LoopState.read(folder).steps
    spec = json.loads(json.dumps(SPEC))
    spec["training"] = {"recipe": "paper"}
    changed = tmp_path / "seg4.toml"
    changed.write_bytes(tomli_w.dumps(spec).encode())
    status, _, err = _loop(str(changed), "--out", str(folder))
    assert status == 0, err
    assert "[training] recipe = 'paper' is not used: msr loop trains with the fast recipe" in err, err
    assert "--redo" not in err and LoopState.read(folder).steps["train"] == before["train"]


def test_a_smoke_loop_asks_no_redo_for_training_steps_it_does_not_train(interrupted_then_resumed, tmp_path):
    """Round 53, V6: a changed ``[training] steps`` was told ``--redo check,train`` in a ``--quick``
    loop, which trains its own 240 steps whatever the spec says."""
    import shutil

    folder = tmp_path / "out"
    shutil.copytree(interrupted_then_resumed["folder"], folder)
    before = LoopState.read(folder).steps
    spec = json.loads(json.dumps(SPEC))
    spec["training"] = {"steps": 5000}
    changed = tmp_path / "seg4.toml"
    changed.write_bytes(tomli_w.dumps(spec).encode())
    status, _, err = _loop(str(changed), "--out", str(folder))
    assert status == 0 and "--redo" not in err, err
    assert LoopState.read(folder).steps["train"] == before["train"]
