"""Round 35 of held-out tries (issue 48): what they found, each fixed with the message it gives."""

from __future__ import annotations

from elastica_magnetic.cli import main as msr


def test_refine_puts_nothing_into_another_run(trained, capsys):
    """D1: ``msr refine RUN --out OTHER_RUN/x`` was accepted: the refinement landed inside another
    training's run (a loop's: its next ``--redo train`` deleted it without a word). A refinement
    goes in the run it refines, or in a folder of no command's."""
    seed0, seed1 = trained / "m1-4mT" / "seed0", trained / "m1-4mT" / "seed1"
    before = sorted(p.name for p in seed1.iterdir())
    assert msr(["refine", str(seed0), "--checkpoint", "final", "--steps", "3", "--out",
                str(seed1 / "x")]) == 2
    err = capsys.readouterr().err
    assert f"lies in {seed1}, which holds" in err and f"not the run refined ({seed0})" in err, err
    assert sorted(p.name for p in seed1.iterdir()) == before
