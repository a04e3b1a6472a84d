"""``msr refine --resume`` (rl/sweep/refine_resume.py, issue 48): a refinement made on a --spec's
randomized robot is continued as its run.json records it, never with the options' defaults; a
resume at its target changes no file; options that contradict the record are refused by name."""

from __future__ import annotations

import hashlib
import json

import pytest
from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint
from smoke import TRAIN_STEPS

from elastica_magnetic.cli import main as msr

#: run.json's record of a refinement on a --spec (what a resume used to drop).
_PROVENANCE = ("spec_from", "physical_changes", "refine_randomize", "case_spec", "refined_from",
               "refine_start_step", "physics", "episode_duration_s")


def _hashes(folder) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.iterdir()) if p.is_file()}


@pytest.fixture(scope="module")
def refined_on_spec(trained, tmp_path_factory):
    """A 2-step refinement of ``trained``'s seed 0 on a spec with another kinetic_mu and a
    [training.randomize] table, in the training physics: ``(run, spec, out, base options)``."""
    from elastica_magnetic_rl.cases.case import load_case

    from elastica_magnetic.specfile import dumps

    folder = tmp_path_factory.mktemp("refine_resume")
    spec = load_case("m1-4mT").to_dict()
    spec["robot"]["ground"]["kinetic_mu"] = 0.5
    spec["training"]["randomize"] = {"friction": "0.5:1.5"}
    rnd = folder / "rnd.toml"
    rnd.write_text(dumps(spec))
    run = trained / "m1-4mT" / "seed0"
    out = folder / "rf"
    base = ["refine", str(run), "--checkpoint", "final", "--no-progress", "--out", str(out)]
    assert msr([*base, "--spec", str(rnd), "--physics", "training", "--steps", "2",
                "--episode-duration", "0.04"]) == 0
    return run, rnd, out, base


def test_a_resume_at_its_target_says_nothing_to_refine_and_changes_no_file(refined_on_spec, capsys):
    """Try rf5: the same command without --spec used to train nothing, print "episodes: 1" and
    rewrite run.json without spec_from, refine_randomize and physical_changes."""
    _, _, out, base = refined_on_spec
    before = _hashes(out)
    capsys.readouterr()
    for extra in ([], ["--steps", "2"], ["--steps", "2", "--physics", "training",
                                          "--episode-duration", "0.04"]):
        assert msr([*base, "--resume", *extra]) == 2
        err = capsys.readouterr().err
        assert f"msr refine: error: nothing to refine: {out} is already at step {TRAIN_STEPS + 2}" \
            in err, err
        assert f"from step {TRAIN_STEPS}" in err and "give --steps above 2" in err
        assert _hashes(out) == before


def test_a_resume_continues_the_refinement_as_recorded(refined_on_spec, tmp_path, capsys):
    """Without --spec, --physics or --episode-duration a resume continues on the spec's
    randomized robot in the training physics with 0.04 s episodes, and keeps the record."""
    import shutil

    _, _, out, base = refined_on_spec
    resumed = tmp_path / "rf"
    shutil.copytree(out, resumed)
    record = json.loads((resumed / "run.json").read_text())
    base = [*base[:-1], str(resumed)]
    assert msr([*base, "--resume", "--steps", "4"]) == 0
    capsys.readouterr()
    after = json.loads((resumed / "run.json").read_text())
    for key in _PROVENANCE:
        assert after[key] == record[key], key
    assert after["refine_steps"] == 4 and after["steps"] == TRAIN_STEPS + 4
    ckpt = load_checkpoint(resumed, with_buffer=False)
    assert ckpt["global_step"] == TRAIN_STEPS + 4
    assert ckpt["metadata"]["case_spec"]["robot"]["ground"]["kinetic_mu"] == 0.5
    assert ckpt["metadata"]["case_spec"]["training"]["randomize"] == {"friction": "0.5:1.5"}


def test_a_resume_whose_options_contradict_the_record_is_refused_naming_them(
        refined_on_spec, trained, tmp_path, capsys):
    from elastica_magnetic_rl.cases.case import load_case

    from elastica_magnetic.specfile import dumps

    run, rnd, out, base = refined_on_spec
    before = _hashes(out)
    other = load_case("m1-4mT").to_dict()
    other["robot"]["ground"]["kinetic_mu"] = 0.7
    other_spec = tmp_path / "other.toml"
    other_spec.write_text(dumps(other))
    capsys.readouterr()
    cases = [
        (["--physics", "accurate"], "--physics accurate: the refinement's training"),
        (["--episode-duration", "0.5"], "--episode-duration 0.5 s: the refinement's 0.04 s"),
        (["--spec", str(other_spec)], f"--spec {other_spec}: its robot differs from the "
                                      "refinement's at [robot.ground] kinetic_mu (the "
                                      f"refinement's: --spec {rnd}, randomize spec)"),
        (["--randomize", "none"], "--randomize none: the refinement's [training.randomize] is "
                                  "{friction = '0.5:1.5'}"),
    ]
    for extra, expected in cases:
        assert msr([*base, "--resume", "--steps", "4", *extra]) == 2
        err = capsys.readouterr().err
        assert f"msr refine: error: cannot resume the refinement in {out} with other settings" \
            in err and expected in err, err
        assert _hashes(out) == before
    # another run's checkpoint is no checkpoint of this run's (round 17: it was played in its place)
    other_checkpoint = trained / "m1-4mT" / "seed1" / "checkpoint.pt"
    assert msr([*base, "--resume", "--steps", "4", "--checkpoint", str(other_checkpoint)]) == 2
    assert f"--checkpoint {other_checkpoint}: not one of {run}'s checkpoints" in capsys.readouterr().err
    assert _hashes(out) == before
    from elastica_magnetic_rl.sweep.refine import refine

    # the runner resumes a checkpoint on its own device: another one is refused, not ignored
    with pytest.raises(ValueError, match=r"on --device cuda:0: it trains on 'cpu' \(a resume "
                                         r"keeps its checkpoint's device\)"):
        refine(run, steps=4, out=out, resume=True, progress=False, device="cuda:0")
    assert _hashes(out) == before
    # the spec it was made with, given again, agrees with the record: only the steps are checked
    assert msr([*base, "--resume", "--spec", str(rnd)]) == 2
    assert "nothing to refine" in capsys.readouterr().err


def test_a_resume_without_a_refined_checkpoint_is_refused(trained, tmp_path, capsys):
    run = trained / "m1-4mT" / "seed0"
    out = tmp_path / "empty"
    assert msr(["refine", str(run), "--checkpoint", "final", "--no-progress", "--resume",
                "--steps", "2", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"cannot resume: {out} holds no refined checkpoint.pt (drop --resume" in err
    assert not out.exists()
