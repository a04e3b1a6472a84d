"""Where ``msr refine`` starts (rl/sweep/refine_start.py): best.pt's networks in its run's training
state."""

from __future__ import annotations

import shutil

import pytest
import torch
from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint
from elastica_magnetic_rl.runfiles.rundir import RunDir
from elastica_magnetic_rl.sweep.refine_start import refine_source, starting_file


def _equal(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


@pytest.fixture()
def run_with_other_best(trained, tmp_path):
    """A copy of seed 0 whose best.pt holds seed 1's final networks (so they differ from its own)."""
    run = tmp_path / "seed0"
    shutil.copytree(trained / "m1-4mT" / "seed0", run)
    files = RunDir(run)
    other = torch.load(RunDir(trained / "m1-4mT" / "seed1").checkpoint, weights_only=True)
    best = torch.load(files.best, weights_only=True)
    best["agent"] = {"actor": other["agent"]["actor"], "critic": other["agent"]["critic"]}
    torch.save(best, files.best)
    return run, best


def test_best_networks_start_in_the_runs_training_state(run_with_other_best):
    run, best = run_with_other_best
    files = RunDir(run)
    own = load_checkpoint(files.checkpoint)
    assert not _equal(own["agent"]["actor"], best["agent"]["actor"])
    start, provenance = refine_source(files.best)
    assert provenance == {"actor": "best", "actor_step": best["global_step"],
                          "state_from": str(files.checkpoint)}
    for name in ("actor", "critic"):  # best.pt's networks, its targets starting equal to them
        assert _equal(start["agent"][name], best["agent"][name])
        assert _equal(start["agent"][f"{name}_target"], best["agent"][name])
    # the rest is the run's: optimisers, counters, replay buffer, step
    assert start["agent"]["num_updates"] == own["agent"]["num_updates"]
    for name in ("actor_optimizer", "critic_optimizer"):
        assert start["agent"][name]["step"] == own["agent"][name]["step"] > 0
        assert _equal(start["agent"][name]["exp_avg"], own["agent"][name]["exp_avg"])
    assert start["global_step"] == own["global_step"]
    assert torch.equal(start["buffer"]["obs"], own["buffer"]["obs"])
    with starting_file(start, provenance, run) as path:  # a temporary file that loads back alike
        again = load_checkpoint(path)
        assert _equal(again["agent"]["actor"], best["agent"]["actor"])
        assert torch.equal(again["buffer"]["obs"], own["buffer"]["obs"])
    assert not path.exists()
    final, about = refine_source(files.checkpoint)  # the final actor: the checkpoint as it is
    assert about["actor"] == "final" and _equal(final["agent"]["actor"], own["agent"]["actor"])
    with starting_file(final, about, run) as path:
        assert path == files.checkpoint


def test_best_without_its_runs_checkpoint_is_named(run_with_other_best):
    run, _ = run_with_other_best
    RunDir(run).checkpoint.unlink()
    with pytest.raises(FileNotFoundError, match="training state of its run's checkpoint.pt"):
        refine_source(RunDir(run).best)


def test_resuming_a_refinement_given_as_the_source_names_the_command_that_continues_it(
        refined, capsys):
    """Round 5, K09: `msr refine REFINED --resume` (the refinement's folder given as what to
    refine) said "drop --resume to start the refinement", which starts a refinement of the
    refinement; the message names the command that continues it."""
    from elastica_magnetic.cli import main as msr

    before = sorted(p.name for p in refined.iterdir())
    assert msr(["refine", str(refined), "--resume", "--steps", "6", "--no-progress"]) == 2
    err = capsys.readouterr().err
    origin = refined.parent
    assert f"cannot resume: {refined} is itself a refinement (of {origin})" in err, err
    assert f"to continue {refined}: msr refine {origin} --out {refined} --resume" in err
    assert sorted(p.name for p in refined.iterdir()) == before
