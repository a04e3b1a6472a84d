"""Rounds 10 and 11 of held-out tries (issue 48), what the command line says (the design folder's rules
are tested in tests/rl/design/test_design_run.py, the [design] table's checks in
tests/rl/cases/test_design_space.py, the field maps' in tests/test_field_maps.py)."""

from __future__ import annotations

from elastica_magnetic_rl.cases.case import case_from_dict, load_case
from elastica_magnetic_rl.cli.train_commands import _warn_unstable_steps

from elastica_magnetic.cli import main as msr
from elastica_magnetic.specfile import dumps


def test_msr_train_warns_about_a_step_msr_case_check_calls_likely_unstable(tmp_path, capsys):
    """S6: msr train took a spec whose training dt case check reports as an error in silence.
    1.25e-4 s divides the control period and lies between the estimated stable step of the
    paper's robot (~1.05e-4 s) and its bare limit (~1.5e-4 s), which the parser refuses."""
    spec = load_case("m1-4mT").to_dict()
    spec["physics"]["training"]["dt"] = 1.25e-4
    path = tmp_path / "coarse.toml"
    path.write_text(dumps(spec))
    case = case_from_dict(spec, str(path))
    _warn_unstable_steps([case], "training")
    err = capsys.readouterr().err
    assert f"warning: {path}: [physics.training] dt: dt = 0.000125 s" in err and "likely unstable" in err
    _warn_unstable_steps([load_case("m1-4mT")], "training")
    assert capsys.readouterr().err == ""
    # the step check needs no sag simulation (minutes of the accurate physics on a cold JIT)
    assert msr(["case", "check", str(path), "--no-sag"]) == 1
    assert "likely unstable" in capsys.readouterr().out


def test_a_run_without_a_finished_episode_is_plotted_without_a_python_warning(tmp_path):
    """V8: msr policy figures printed matplotlib's "No artists with labels found" UserWarning."""
    import warnings

    from elastica_magnetic_rl.reports.figures import plot_learning_curves
    from elastica_magnetic_rl.runfiles.rundir import RunDir

    run = tmp_path / "seed_000"
    run.mkdir()
    RunDir(run).episodes_csv.write_text("global_step,return\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert plot_learning_curves([run], tmp_path / "curves.png").is_file()


def test_a_negative_poisson_ratio_is_not_explained_as_percent():
    """V9: poisson_ratio = -0.9 was warned with "0.9 percent is 0.009"."""
    from elastica_magnetic.plausibility import judge

    finding = judge("poisson ratio", -0.9)
    assert finding is not None and "auxetic" in finding.text and "percent" not in finding.text


def test_sigterm_during_a_loop_step_is_said_like_ctrl_c(tmp_path, monkeypatch, capsys):
    """Round 9, V7: msr loop stopped by SIGTERM in its train step exited 143 without a word (the
    train step ran without msr's signal handling)."""
    import os
    import signal

    import elastica_magnetic_rl.loop.runner as runner

    def terminated(*args, **kwargs):
        os.kill(os.getpid(), signal.SIGTERM)
        raise AssertionError("SIGTERM did not stop the step")

    monkeypatch.setattr(runner, "run_loop", terminated)
    code = msr(["loop", "m1-4mT", "--out", str(tmp_path / "lp"), "--quick", "--no-progress"])
    assert code == 128 + signal.SIGTERM
    err = capsys.readouterr().err
    assert "loop: interrupted; the finished steps are recorded in" in err and "SIGTERM" in err
    assert signal.getsignal(signal.SIGTERM) == signal.SIG_DFL  # the handler is put back


def test_an_option_a_command_does_not_take_is_named_by_that_command(capsys):
    """Round 11, V3: msr field simulate --case m1-4mT was answered by the top-level parser
    ("usage: msr [-h] COMMAND ..."), without a word on --robot."""
    import pytest

    with pytest.raises(SystemExit) as info:
        msr(["field", "simulate", "--case", "m1-4mT", "--duration", "0.2"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "usage: msr field simulate" in err
    assert ("msr field simulate: error: unrecognized arguments: --case m1-4mT; this command takes "
            "the robot as --robot") in err
