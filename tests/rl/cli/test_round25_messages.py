"""Round 25 of held-out tries (issue 48), the findings of the commands: each test fails without its
fix (docs/errors.md, "A twenty-fifth round of tries")."""

from __future__ import annotations

import hashlib
import json
import shutil
import warnings

import pytest
from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.runner.stopping import StopRule
from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR
from elastica_magnetic_rl.sweep.inert_settings import (
    SettingSources,
    check_run_learns,
    check_stop_rule_decides,
)
from elastica_magnetic_rl.td3.config import TD3Config

from elastica_magnetic.cli import main as msr
from elastica_magnetic.plausibility import ImplausibleValueWarning, SettingNotAppliedWarning


def _hashes(folder) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _spec(tmp_path, case: str, name: str, old: str, new: str, extra: str = ""):
    text = load_case(case).toml()
    assert old in text
    path = tmp_path / name
    path.write_text(text.replace(old, new).replace(f'name = "{case}"', f'name = "{path.stem}"') + extra)
    return path


@pytest.mark.parametrize("radius", ["0.005", "0.006", "0.0099"])
def test_a_catheter_that_reaches_the_magnet_s_face_is_refused_naming_the_radius(tmp_path, radius):
    """S1: a catheter of 5 to 9.9 mm radius with a 1 A m^2 magnet (at least a 10 mm NdFeB cube) at
    a 10 mm min_clearance passed the check (at 6 mm without a word): the magnet's face, turned to
    the rod, would be inside it. Refused now, naming [robot] radius and the half thickness."""
    spec = _spec(tmp_path, "catheter-magnet-reach", "thick.toml", "radius = 0.0005", f"radius = {radius}")
    with pytest.raises(ValueError, match=r"\[robot\] radius: the rod's radius, .* mm, reaches the magnet: "
                                         r".* min_clearance of 10 mm .* reaches 5 mm from its centre \(half "
                                         r"the side of the smallest NdFeB cube of 1 A m\^2, turned "
                                         r"face-on\)"):
        load_case(spec)
    load_case(_spec(tmp_path, "catheter-magnet-reach", "ok.toml", "radius = 0.0005", "radius = 0.0045"))


@pytest.mark.parametrize("cutoff, elements", [("0.00031251", "1"), ("0.000625", "2"), ("0.001", "3.2")])
def test_a_cutoff_below_four_radii_is_warned_about_in_the_spec_check(tmp_path, cutoff, elements):
    """S2: a cutoff a hair above one element, or of two, passed ``msr case check`` with nothing said,
    and every simulation of it turned to NaN at once. A cutoff below the default four radii is
    warned about where the spec is read (msr case check shows it), naming cutoff; the default and
    a cutoff beyond it are silent."""
    spec = _spec(tmp_path, "m1-4mT", "cut.toml", "[yardstick]\n", "[yardstick]\n",
                 f"\n[robot.interaction]\ncutoff = {cutoff}\n")
    words = rf"\[robot.interaction\] cutoff: {cutoff} m \({elements} elements\) is below the default of 4"
    with pytest.warns(ImplausibleValueWarning, match=words):
        load_case(spec)
    for quiet in ("", "cutoff = 0.002\n"):
        ok = _spec(tmp_path, "m1-4mT", "ok.toml", "[yardstick]\n", "[yardstick]\n",
                   f"\n[robot.interaction]\n{quiet}")
        with warnings.catch_warnings():
            warnings.simplefilter("error", ImplausibleValueWarning)
            load_case(ok)


def test_another_robot_of_the_shipped_case_s_name_is_refused_in_its_seeds(trained, tmp_path, capsys):
    """S3: a run of a spec named as the shipped case but with other values went into the shipped
    policy's ``seeds/`` through generate, export and export-seeds (ship refused it). The seeds/
    check now compares the specs as ship does and names the first key where they differ."""
    policy = tmp_path / "m1-4mT"
    shutil.copytree(POLICIES_DIR / "m1-4mT", policy, ignore=shutil.ignore_patterns("seeds", ".*"))
    info = json.loads((policy / "policy.json").read_text())
    info["case_spec"]["robot"]["youngs_modulus"] *= 2.0  # the shipped robot is another one of that name
    (policy / "policy.json").write_text(json.dumps(info))
    (policy / "seeds").mkdir()
    before = _hashes(policy)
    run = trained / "m1-4mT" / "seed0"
    capsys.readouterr()
    seeds = policy / "seeds"
    for argv in (["policy", "export", str(run), "--checkpoint", "final", "--out", str(seeds / "e")],
                 ["policy", "generate", str(run), "--checkpoint", "final", "--duration", "0.05", "--out",
                  str(seeds / "g"), "--no-progress"],
                 ["policy", "export-seeds", str(trained / "m1-4mT"), "--duration", "0.05", "--out",
                  str(seeds / "x"), "--no-progress"]):
        assert msr(argv) == 2, argv
        err = capsys.readouterr().err
        assert "a case of the same name with another spec (they differ at [robot] youngs_modulus)" in err, err
    assert _hashes(policy) == before


def _shipped_result(passed: bool) -> dict:
    return {"name": "m1-4mT-designed", "case": "m1-4mT-designed", "duration_s": 0.3, "rows_compared": 30,
            "max_field_diff_mT": 0.0 if passed else 0.5, "field_atol_mT": 1e-6,
            "first_row_apart": None if passed else 5, "waveform_check": "exact",
            "mid_dx_m": 1e-4, "diverged": False, "passed": passed}


@pytest.mark.parametrize("passed", [True, False])
def test_the_shipped_verdicts_are_printed_and_reported_beside_other_cases(tmp_path, capsys, monkeypatch,
                                                                          passed):
    """S4, V5: ``msr validate shipped CASE`` re-ran the shipped policies and let them decide the exit
    status, but printed their verdicts nowhere and left them out of report.md and results.json; a
    failing waveform read "FAIL: waveform within 5.0e-01 mT". Now their verdicts are printed and
    reported, a failure naming the difference, the tolerance and the first row apart."""
    import elastica_magnetic_validation.cli as validation_cli

    monkeypatch.setattr(validation_cli, "verify_all_shipped", lambda quick: [_shipped_result(passed)])
    monkeypatch.setattr(validation_cli, "run_cases", lambda names, out, quick: [])
    status = msr(["validate", "shipped", "cantilever", "--quick", "--out", str(tmp_path / "v")])
    out = capsys.readouterr().out
    assert status == (0 if passed else 1)
    line = ("shipped m1-4mT-designed: pass: waveform within 0.0e+00 mT of fields.csv over 30 rows (exact)"
            if passed else "shipped m1-4mT-designed: FAIL: the waveform differs from fields.csv by 0.5 mT "
                           "(at most 1e-06 mT on the machine that recorded it) from row 5 of 30")
    assert line in out, out
    assert line in (tmp_path / "v" / "report.md").read_text()
    assert json.loads((tmp_path / "v" / "results.json").read_text())["shipped"][0]["passed"] is passed


def test_dagger_beyond_the_run_is_warned_about():
    """S5: yardstick_dagger of 1000 steps in an 80-step run was accepted without a word: the run
    ends inside DAgger and no TD3 step follows. Warned now, naming both numbers."""
    sources = SettingSources(given={"yardstick_dagger": 1000, "learning_starts": 40})
    config = TD3Config(learning_starts=40, batch_size=32, yardstick_warmup=10, yardstick_dagger=1000)
    with pytest.warns(SettingNotAppliedWarning, match=r"--set yardstick_dagger=1000 after --set "
                                                      r"learning_starts=40 ends at step 1040, and --steps 80 "
                                                      r"ends the run inside DAgger: no TD3 step follows.*"
                                                      r"--set yardstick_dagger of at most 39 to end"):
        check_run_learns(config, 80, sources)
    # the advice followed (round 26, V4: it had said 40, which ends the run at the end of DAgger)
    with warnings.catch_warnings():
        warnings.simplefilter("error", SettingNotAppliedWarning)
        within = TD3Config(learning_starts=40, batch_size=32, yardstick_warmup=10, yardstick_dagger=39)
        check_run_learns(within, 80, sources)
    with warnings.catch_warnings():
        warnings.simplefilter("error", SettingNotAppliedWarning)
        check_run_learns(config, 1100, sources)


def test_a_stop_rule_refusal_with_long_episodes_gives_advice_that_works():
    """V1: with 300-step episodes the refusal advised eval_every of at most 99 or --steps of at
    least 901; either was accepted and then warned undecided (evaluations come once per episode at
    most). Now the advice counts episodes, and following it is silent."""
    rule, config = StopRule("plateau"), TD3Config(eval_every=150)
    sources = SettingSources(source="spec.toml", steps_given=True)
    with pytest.raises(ValueError, match=r"at most one per episode of 3 s \(300 steps\), so a shorter "
                                         r"eval_every cannot add enough: give --steps of at least 2100"):
        check_stop_rule_decides(rule, config, 600, 1, sources, episode_duration=3.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", SettingNotAppliedWarning)
        check_stop_rule_decides(rule, config, 2100, 1, sources, episode_duration=3.0)


def test_a_goto_spec_with_dagger_and_a_crawl_s_are_accepted(tmp_path, capsys):
    """V2, V3 (round 25) filed a DAgger refusal under yardstick_warmup. Since round 28 a crawl's
    rotating field gives DAgger's labels, and since the goto task observes its clock, a goto case's
    memoryless steering law does too: both specs are accepted."""
    from elastica_magnetic_rl.cases.case import load_case

    # the shipped goto spec as it was before it trained a residual learner: a clone and DAgger
    goto = _spec(tmp_path, "m1-4mT-goto", "goto-dagger.toml",
                 "residual = 0.5\nyardstick_warmup = 0\nyardstick_dagger = 0\n",
                 "residual = 0.0\nyardstick_warmup = 16000\nyardstick_dagger = 6000\n")
    goto.write_text(goto.read_text().replace("correction_penalty = 0.4\n", ""))  # a residual learner's hold
    assert load_case(str(goto)).training.td3["yardstick_dagger"] == 6000
    assert msr(["case", "check", "--no-sag", str(goto)]) == 0
    crawl = _spec(tmp_path, "m1-4mT", "dg.toml", "[yardstick]\n", "[yardstick]\nperiod = 2.5\n",
                  "\n[training.td3]\nyardstick_warmup = 10\nyardstick_dagger = 10\n")
    assert msr(["case", "check", "--no-sag", str(crawl)]) == 0
    assert "msr train refuses it" not in capsys.readouterr().out


def test_identify_names_a_crawler_s_field_csv_and_trajectory_given_the_wrong_way_round(tmp_path, capsys):
    """V4: with a crawler's trajectory first and its field CSV second, identify asked the trajectory
    for mag_x, mag_y, mag_z. Now it says the files are the wrong way round."""
    fields = tmp_path / "f.csv"
    fields.write_text(",mag_x,mag_y,mag_z\n" + "".join(f"{i},1.0,0.0,0.0\n" for i in range(30)))
    trajectory = tmp_path / "trajectory.csv"
    trajectory.write_text("t_s,mid_x_m,mid_y_m\n" + "".join(f"{0.01 * i:.2f},0,0\n" for i in range(30)))
    assert msr(["real", "identify", "--robot", "m1-4mT", "--fit", "robot.youngs_modulus", "--out",
                str(tmp_path / "id"), str(trajectory), str(fields)]) == 2
    err = capsys.readouterr().err
    assert "the two files are the wrong way round" in err and "swap them" in err, err
    assert "lacks column" not in err and not (tmp_path / "id").exists()
