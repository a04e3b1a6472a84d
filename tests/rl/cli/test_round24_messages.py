"""Round 24 of held-out tries (issue 48), the findings of the commands: each test fails without its
fix (docs/errors.md, "A twenty-fourth round of tries")."""

from __future__ import annotations

import errno
import hashlib
import os
import shutil
import warnings

import pytest
from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.cases.variations import VariationError, parse_variation
from elastica_magnetic_rl.runner.stopping import StopRule
from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR
from elastica_magnetic_rl.sim2real.tip_robustness import plan_tip_robustness
from elastica_magnetic_rl.sweep.inert_settings import (
    SettingSources,
    check_stop_rule_decides,
    evaluations_with_episodes,
)
from elastica_magnetic_rl.td3.config import TD3Config
from recorded_files import write_coil_currents

from elastica_magnetic.cli import main as msr
from elastica_magnetic.locks import FolderLock
from elastica_magnetic.plausibility import SettingNotAppliedWarning


def _status(args: list[str]) -> int:
    """``msr`` 's exit status, also where argparse refuses an argument (it exits)."""
    try:
        return msr(args)
    except SystemExit as stop:
        return int(stop.code)


def _hashes(folder) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _spec(tmp_path, case: str, name: str, old: str, new: str):
    text = load_case(case).toml()
    assert old in text
    path = tmp_path / name
    path.write_text(text.replace(old, new).replace(f'name = "{case}"', f'name = "{path.stem}"'))
    return path


def test_refine_refuses_what_the_batched_simulator_leaves_out_before_any_folder(trained, tmp_path, capsys):
    """D1: ``msr refine --spec`` of a spec with a Kelvin-Voigt viscosity made its --out folder (by
    default inside the user's run) with run.json, a log and a marker, then refused, naming "the
    batched simulator" as the command. Now refused first, naming msr refine and --spec."""
    run = tmp_path / "seed1"
    shutil.copytree(trained / "m1-4mT" / "seed1", run)
    before = _hashes(run)
    spec = _spec(tmp_path, "m1-4mT", "kv.toml", "kelvin_voigt = 0.0", "kelvin_voigt = 1.0")
    for out in ([], ["--out", str(tmp_path / "kvref")]):
        assert msr(["refine", str(run), "--checkpoint", "final", "--spec", str(spec), "--steps", "5",
                    "--physics", "training", "--no-progress", *out]) == 2
        err = capsys.readouterr().err
        assert f"--spec {spec}: msr refine runs many robots in one batched simulator, which does not model " \
               "[robot.damping] kelvin_voigt = 1 Pa s" in err, err
    assert _hashes(run) == before and not (tmp_path / "kvref").exists()


def test_a_lock_file_that_could_not_be_written_is_not_left_behind(tmp_path, monkeypatch):
    """D2: on a full disk ``msr policy notes`` said it could not create the lock file, and left it
    there, empty, beside the policy. Now a lock file made by the failed attempt goes again; one
    that was there before (a stale lock) stays."""
    folder = tmp_path / "policy"
    folder.mkdir()

    def full(*args):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "pwrite", full)
    with pytest.raises(OSError, match="cannot create the lock file .*No space left on device"):
        FolderLock(folder, option="policy").acquire()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["policy"]
    stale = tmp_path / ".policy.msr-lock"
    stale.write_text("")
    with pytest.raises(OSError, match="No space left on device"):
        FolderLock(folder, option="policy").acquire()
    assert stale.exists()


@pytest.mark.parametrize("radius", [0.02, 0.05, 0.01])
def test_a_catheter_reaching_the_magnet_s_clearance_is_refused_naming_the_radius(tmp_path, radius):
    """S1: a catheter of 20 or 50 mm radius (cm or mm written as m) with a 10 mm min_clearance (the
    magnet inside the rod) passed msr case check; the warnings blamed the magnet's moment. Now
    refused, naming [robot] radius."""
    spec = _spec(tmp_path, "catheter-magnet-reach", "thick.toml", "radius = 0.0005", f"radius = {radius}")
    assert _status(["case", "check", str(spec)]) == 2
    with pytest.raises(ValueError, match=r"\[robot\] radius: the rod's radius, .* mm, reaches the "
                                         r"\[actuation\] min_clearance of 10 mm from its axis"):
        load_case(spec)
    load_case(_spec(tmp_path, "catheter-magnet-reach", "ok.toml", "radius = 0.0005", "radius = 0.001"))


@pytest.mark.parametrize("command", [
    ["field", "simulate", "--duration", "0.02", "--physics", "training"],
    ["validate", "cantilever", "--quick"],
])
def test_results_of_no_case_are_refused_in_a_policy_s_seeds(tmp_path, capsys, command):
    """S2: ``msr field simulate``, ``field replay``, ``real firmware`` and ``validate`` wrote a
    robot's simulation or a report into a shipped policy's ``seeds/`` (where generate and export
    refuse another case's result). Now a result of no case is refused there, before any work."""
    policy = tmp_path / "catheter-magnet-reach"
    shutil.copytree(POLICIES_DIR / "catheter-magnet-reach", policy)
    before = _hashes(policy)
    out = policy / "seeds" / "x"
    assert _status([*command, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "whose seeds/ holds its own case's results" in err and "it goes beside the policy" in err, err
    assert _hashes(policy) == before


def test_a_stop_rule_that_full_length_episodes_leave_undecided_is_warned_about():
    """S3: evaluations come at episode ends, so with eval_every below an episode a run makes fewer
    than steps / eval_every; --stop-when plateau was accepted on that count and could never fire.
    Now the count with full-length episodes is judged, and warned about (early ends may add some);
    docs/training.md says when evaluations come."""
    assert evaluations_with_episodes(900, 100, 300) == 3  # at 300 and 600, and at the end
    assert evaluations_with_episodes(100_000, 5000, 2000) == 20
    rule, config = StopRule("plateau"), TD3Config(eval_every=100)
    sources = SettingSources(source="spec.toml", steps_given=True)
    with pytest.warns(SettingNotAppliedWarning, match=r"plateau may not decide .* 3 of the 7 the rule needs"):
        check_stop_rule_decides(rule, config, 900, 1, sources, episode_duration=3.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_stop_rule_decides(rule, config, 900, 1, sources, episode_duration=0.5)  # 50-step episodes


def test_notes_write_a_new_card_where_the_card_was_moved_away(tmp_path, capsys):
    """V1: notes told the user of a copied policy to move its card away, "msr policy ship writes a
    new card"; ship takes no policy, and notes then left the policy without a card. Now notes write
    a new card from policy.json (its seeds, evaluation and the notes given)."""
    copy = tmp_path / "m1-4mT-designed"  # copied without its record (.msr-files.json)
    shutil.copytree(POLICIES_DIR / "m1-4mT-designed", copy, ignore=shutil.ignore_patterns(".*"))
    notes = tmp_path / "notes.md"
    notes.write_text("## my notes\nhello\n")
    assert msr(["policy", "notes", str(copy), "--file", str(notes)]) == 2
    assert "msr policy notes then writes a new card" in capsys.readouterr().err
    (copy / "MODEL_CARD.md").rename(tmp_path / "mine.md")
    assert msr(["policy", "notes", str(copy), "--file", str(notes), "--json"]) == 0
    card = (copy / "MODEL_CARD.md").read_text()
    assert "hello" in card and "## Evaluation" in card and "seeds that succeeded: " in card
    assert "seeds that succeeded: 2 of 2" in card  # as policy.json recorded them at shipping
    assert "| `yardstick-warmup` | 1 of 4 |" in card  # the committed seeds' table


def test_a_catheter_study_refuses_a_variation_its_simulator_leaves_out_before_any_run():
    """V2: for a catheter policy, --vary robot.damping.kelvin_voigt was offered, accepted with an
    absolute range, ran part of the study and failed "leave it out of the spec". Now refused by the
    option check, naming --vary, and not offered among the variable keys."""
    from elastica_magnetic_rl.shipping.policy_files import resolve_policy

    policy = resolve_policy("catheter-magnet-reach")
    for text in ("robot.damping.kelvin_voigt=abs:0.1:0.2", "robot.damping.kelvin_voigt=0.5:2"):
        with pytest.raises(VariationError, match=r"--vary robot.damping.kelvin_voigt: "
                                                 r"robot.damping.kelvin_voigt: a catheter's study steers "
                                                 r"every target in one batched simulator.*leave it out of "
                                                 r"--vary"):
            plan_tip_robustness("catheter-magnet-reach", policy, [parse_variation(text)])
    with pytest.raises(VariationError) as unknown:
        plan_tip_robustness("catheter-magnet-reach", policy, [parse_variation("robot.nope=0.5:2")])
    assert "kelvin_voigt" not in str(unknown.value)


def test_identify_names_a_tip_path_and_a_drive_given_the_wrong_way_round(tmp_path, capsys):
    """V3: with the tip path first and the coil path second, identify read the tip path as a field
    CSV and asked for mag_x, mag_y, mag_z in mT. Now it says the files are the wrong way round."""
    coils = write_coil_currents(tmp_path / "coils.csv")
    tip = tmp_path / "tip.csv"
    tip.write_text("t_s,tip_x_m,tip_y_m,tip_z_m\n" + "".join(f"{0.02 * i:.2f},0.05,0,0\n" for i in range(16)))
    assert msr(["real", "identify", str(tip), str(coils), "--robot", "catheter-coils-reach", "--fit", "coils",
                "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "the two files are the wrong way round" in err and "current_0_A" in err and "swap them" in err, err
    assert "mag_x" not in err and not (tmp_path / "o").exists()


@pytest.mark.parametrize("cutoff", ["0", "1e-9", "0.0003125"])
def test_an_interaction_cutoff_of_an_element_or_less_is_refused_by_name(tmp_path, cutoff):
    """V4: a cutoff of 0, 1e-9 m or one element passed the spec check, and every run turned to NaN
    at once, the message saying "reduce dt". Now refused where the spec is read, naming cutoff;
    a cutoff below four radii that diverges is named in the divergence's message."""
    spec = tmp_path / f"cut{cutoff}.toml"
    spec.write_text(load_case("m1-4mT").toml().replace('name = "m1-4mT"', 'name = "cut"')
                    + f"\n[robot.interaction]\ncutoff = {cutoff}\n")
    with pytest.raises(ValueError, match=r"\[robot.interaction\] cutoff: .* at or below one element's length "
                                         r"\(0.0003125 m\)"):
        load_case(spec)


def test_a_divergence_under_a_short_cutoff_names_the_cutoff(tmp_path, capsys):
    spec = tmp_path / "near.toml"
    spec.write_text(load_case("m1-4mT").toml().replace('name = "m1-4mT"', 'name = "near"')
                    + "\n[robot.interaction]\ncutoff = 0.00063\n")
    assert msr(["field", "simulate", "--robot", str(spec), "--physics", "training", "--duration", "0.05",
                "--out", str(tmp_path / "s"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "diverged" in err and "the spec's [robot.interaction] cutoff, 0.00063 m, is below the default " \
                                 "four radii" in err, err


def test_diagnose_of_a_run_resumed_after_it_ended_names_its_cut_episodes():
    """V5: a run trained 300 steps and resumed to 600 was refused "the run has only 600 steps, fewer
    than the discount horizon of 459": its episodes were cut at the resume (300 steps each). Now the
    message names the longest stretch of one episode and the cut. (The message of the buffer such a
    run leaves: 600 transitions, none complete, the longest episode stretch 300, 20 s episodes.)"""
    import numpy as np
    from elastica_magnetic_rl.reports.diagnostics import _no_complete_return

    text = _no_complete_return("run", np.zeros(600, dtype=bool), 0, 0.99, 300, {"episode_duration_s": 20.0})
    assert "its longest stretch of one episode is 300 steps" in text and "fewer than" not in text, text
    assert "at least 459 more --steps" in text
    young = _no_complete_return("run", np.zeros(300, dtype=bool), 0, 0.99, 300, {"episode_duration_s": 20.0})
    assert "the run has only 300 steps, fewer than the discount horizon" in young
