"""Round 53 of held-out tries (issue 48): a goto run's ring plays the actor ``--checkpoint`` names
(S1); borderline cases."""

from __future__ import annotations

import pytest
from smoke import NOT_RESIDUAL, SMOKE

from elastica_magnetic.cli import main


def run(argv: list[str]) -> int:
    """``msr argv``'s exit status (a parser's refusal exits through SystemExit)."""
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code)


@pytest.fixture(scope="module")
def goto_run(tmp_path_factory):
    """A goto run whose ``best.pt`` is another actor than its final one (seed 1's, which a smoke
    run's own best.pt need not be)."""
    import shutil

    out = tmp_path_factory.mktemp("goto")
    assert run(["train", "--case", "m1-4mT-goto", "--seeds", "2", "--workers", "1", "--steps", "240",
                *SMOKE, *NOT_RESIDUAL, "--out", str(out)]) == 0
    seed = out / "m1-4mT-goto" / "seed0"
    shutil.copy(out / "m1-4mT-goto" / "seed1" / "checkpoint.pt", seed / "best.pt")
    return seed


def test_a_ring_plays_the_actor_checkpoint_names_and_says_which(goto_run, tmp_path, capsys):
    """S1: ``msr policy generate RUN --ring --checkpoint best`` played checkpoint.pt, and ``auto``
    compared nothing and named no actor."""
    import shutil

    ring = ["--ring", "2", "--duration", "0.1", "--physics", "training", "--no-progress", "--workers", "1"]
    for which, file in (("best", "best.pt"), ("final", "checkpoint.pt")):
        assert run(["policy", "generate", str(goto_run), "--checkpoint", which, *ring,
                    "--out", str(tmp_path / which)]) == 0
        assert "actor: " in capsys.readouterr().out
        # outside its run: a run's checkpoint.pt names the run, whose actor --checkpoint auto chooses
        alone = shutil.copy(goto_run / file, tmp_path / f"{which}-actor.pt")
        assert run(["policy", "generate", str(alone), *ring, "--out", str(tmp_path / file)]) == 0
        assert (tmp_path / which / "ring.csv").read_bytes() == (tmp_path / file / "ring.csv").read_bytes()
    assert (tmp_path / "best" / "ring.csv").read_bytes() != (tmp_path / "final" / "ring.csv").read_bytes()
    assert run(["policy", "generate", str(goto_run), *ring, "--out", str(tmp_path / "auto")]) == 0
    out = capsys.readouterr().out
    assert "actor: " in out and "the nearer of the two to the target" in out, out


def test_checkpoint_paths_and_result_folders_are_named(goto_run, tmp_path, monkeypatch, capsys):
    """V1: ``--checkpoint missing/../run/best.pt`` was a bare "no such checkpoint file"; V2: ``msr
    refine --checkpoint nope`` said "nope: no checkpoint.pt (expected a run directory...)"; V4, V5: an
    export or replay result given as a policy was advised a fields.csv it lacks, or not named."""
    monkeypatch.chdir(goto_run.parent)
    through = ["policy", "export", "seed0", "--checkpoint", "missing/../seed0/best.pt", "--out",
               str(tmp_path / "e")]
    assert "(the folder missing does not exist" in run_err(through, capsys)
    err = run_err(["refine", "seed0", "--checkpoint", "nope", "--steps", "3", "--out", str(tmp_path / "r")],
                  capsys)
    assert "--checkpoint nope: no such checkpoint file (or auto, final, best)" in err, err
    assert run(["policy", "export", "seed0", "--checkpoint", "final", "--out", str(tmp_path / "exp1")]) == 0
    capsys.readouterr()
    err = run_err(["policy", "notes", str(tmp_path / "exp1")], capsys)
    assert "holds a result of `msr policy export`" in err and "fields.csv" not in err, err


def run_err(argv: list[str], capsys) -> str:
    """A refused ``msr argv``'s stderr."""
    assert run(argv) == 2, argv
    return capsys.readouterr().err
