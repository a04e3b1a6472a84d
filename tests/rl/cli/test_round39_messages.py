"""Round 39 of held-out tries (issue 48): what they found, each fixed with the message it gives."""

from __future__ import annotations

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
