"""Round 49 of held-out tries (issue 48): the advice for a shipped policy's file given as a run's
``--checkpoint`` works when followed (V1); borderline cases. The D1 (an interrupted start-over of a
finished loop) is tested in tests/rl/loop/test_msr_loop.py."""

from __future__ import annotations

import shutil

from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR

from elastica_magnetic.cli import main


def run(argv: list[str]) -> int:
    """``msr argv``'s exit status (a parser's refusal exits through SystemExit)."""
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code)


def test_a_shipped_policys_file_as_a_runs_checkpoint_is_told_how_it_plays(trained, tmp_path, capsys):
    """V1: "a file of the shipped policy pol1; give its folder" -- and ``--checkpoint pol1`` was
    refused as a folder."""
    shipped = tmp_path / "pol1"
    shutil.copytree(POLICIES_DIR / "m1-4mT", shipped)
    run_dir = str(trained / "m1-4mT" / "seed0")
    assert run(["policy", "export", run_dir, "--checkpoint", str(shipped / "actor.pt"),
                "--out", str(tmp_path / "ex")]) == 2
    err = capsys.readouterr().err
    assert (f"a file of the shipped policy {shipped}, played by naming that folder as the policy (msr policy "
            f"generate {shipped}), not as a checkpoint of a run") in err, err
    assert run(["policy", "generate", str(shipped), "--duration", "0.05", "--no-figures", "--no-gif",
                "--out", str(tmp_path / "g")]) == 0  # the advice, followed


def test_a_target_written_in_mm_is_told_in_its_own_numbers(capsys):
    """Borderline of round 49: ``--target 50,10,0`` of a catheter was told "(15 mm is 0.015)"."""
    assert run(["field", "baseline", "--case", "catheter-magnet-reach", "--target", "50,10,0",
                "--out", "x"]) == 2
    assert "metres, not mm (50 mm is 0.05)" in capsys.readouterr().err


def test_a_design_resumed_below_its_generations_warns_as_msr_does(tmp_path, capsys):
    """Borderline of round 49: the warning was Python's ``file:line: UserWarning`` form."""
    common = ["design", "m1-4mT", "--out", str(tmp_path / "d"), "--quick", "--popsize", "3", "--workers", "1",
              "--no-gif", "--no-progress"]
    assert run([*common, "--generations", "2"]) == 0
    capsys.readouterr()
    assert run([*common, "--generations", "1", "--resume"]) == 0
    err = capsys.readouterr().err
    assert "msr design: warning: --generations 1: the search has 2 generations already" in err, err
    assert "UserWarning" not in err


def test_a_fit_kept_for_being_worse_says_how_much_worse():
    """Round 51 V1: a fit 4.4x worse than the spec's values was told "(less than 0.1 % better)"."""
    from elastica_magnetic_rl.sim2real.identify import _compared

    assert _compared(0.02761, 0.006225) == "4.44x worse"
    assert _compared(0.0062245, 0.006225) == "less than 0.1 % better"
    assert _compared(0.006226, 0.006225) == "less than 0.1 % better"  # a hair either way: the same fit
