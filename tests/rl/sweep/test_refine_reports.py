"""``msr refine`` says what it did (issue 49): its progress counts its own steps, not its parent
run's; it checkpoints from its first minute on; a refinement on randomized robots says how many it
ran; a refinement shorter than one episode says why it has no mean return; an interruption names
only checkpoints that exist."""

from __future__ import annotations

import json

from elastica_magnetic_rl.cli.train_commands import _interrupted
from elastica_magnetic_rl.sweep.refine import REFINE_CHECKPOINT_STEPS

from elastica_magnetic.cli import main as msr


def test_a_short_randomized_refinement_says_what_it_did(trained, tmp_path, capsys):
    out = tmp_path / "ft"
    assert msr(["refine", str(trained / "m1-4mT" / "seed0"), "--checkpoint", "final", "--steps",
                "4", "--physics", "training", "--randomize", "default", "--episode-duration",
                "0.5", "--out", str(out), "--json"]) == 0
    captured = capsys.readouterr()
    result = json.loads(captured.out)
    assert result["episodes"] == 0 and result["randomized_robots"] == 1
    assert set(result["randomize"]) == {"magnetization", "modulus", "friction", "density"}
    assert "no episode finished" in result["note"] and "50 steps" in result["note"]
    # the progress lines count this refinement's 4 steps, not the parent's 240 + 4
    assert "(4/4 step)" in captured.err and "/244" not in captured.err, captured.err


def test_a_refinement_checkpoints_from_its_first_minute_on():
    from elastica_magnetic_rl.sweep.refine import _refinement_config
    from elastica_magnetic_rl.td3.config import TD3Config

    run = {"config": TD3Config().to_dict()}  # the run's own interval: 10000 steps
    for physics in ("accurate", "training"):
        config = _refinement_config(run, None, "run", physics)
        assert config.checkpoint_every == REFINE_CHECKPOINT_STEPS[physics] < 10_000
    often = {"config": TD3Config(checkpoint_every=80).to_dict()}
    assert _refinement_config(often, None, "run", "accurate").checkpoint_every == 80


def test_an_interruption_names_only_checkpoints_that_exist(trained, tmp_path, capsys):
    seed0 = trained / "m1-4mT" / "seed0"
    fresh = tmp_path / "refined"
    fresh.mkdir()
    assert _interrupted([fresh]) == 130
    err = capsys.readouterr().err
    assert "before its first checkpoint" in err and "--resume" in err and str(fresh) not in err
    assert _interrupted([seed0, fresh]) == 130
    err = capsys.readouterr().err
    assert "seed0" in err and "refined" not in err and "continue with the same command" in err


def test_an_interruption_by_sigterm_exits_143(tmp_path, capsys):
    """Every command exits 128 + the signal (docs/errors.md): training said 130 after SIGTERM."""
    import signal

    assert _interrupted([tmp_path], signal.SIGTERM) == 143
    assert _interrupted([tmp_path]) == 130
