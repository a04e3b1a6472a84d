"""Round 54 of held-out tries (issue 48; D0 S0 T0 V4) and its borderlines: refine given another
command's result is told so first (V1); a spec file given as a calibration is named (V2); a period
of hundreds of seconds, ``ship --no-measure``'s actor and other results given to diagnose,
export-seeds and figures are named."""

from __future__ import annotations

from elastica_magnetic.cli import main


def run(argv: list[str]) -> int:
    """``msr argv``'s exit status (a parser's refusal exits through SystemExit)."""
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code)


def test_refine_of_a_generate_result_names_it_not_its_default_out(tmp_path, capsys):
    """V1: ``msr refine g4`` blamed the default ``--out g4/refined``; with another ``--out`` it said
    "g4: no checkpoint.pt"."""
    out = tmp_path / "g4"
    assert run(["policy", "generate", "m1-4mT", "--duration", "0.05", "--out", str(out), "--no-figures",
                "--no-progress"]) == 0
    capsys.readouterr()
    assert run(["refine", str(out), "--steps", "10"]) == 2
    err = capsys.readouterr().err
    assert "holds a result of `msr policy generate` for case m1-4mT, not a policy" in err.replace(
        err[err.find(", written"):err.find(", not a policy")], ""), err
    assert "--out" not in err


def test_a_spec_given_as_a_calibration_is_named(tmp_path, capsys):
    """V2: a case spec given as ``--calibration`` "reads as a CSV (measurements?)", and the advised
    ``msr real calibrate SPEC`` failed."""
    from elastica_magnetic.hardware.calibration import CalibrationError, load_calibration

    assert run(["case", "show", "m1-4mT", "--toml"]) == 0
    spec = tmp_path / "my.toml"
    spec.write_text(capsys.readouterr().out)
    try:
        load_calibration(spec)
    except CalibrationError as exc:
        assert ("it is a spec file (TOML with a [robot] table), a robot's, not its coils' calibration"
                in str(exc))
        assert "msr real calibrate my.toml" not in str(exc)
    else:
        raise AssertionError("a spec read as a calibration")


def test_a_design_says_what_runs_before_its_first_line(tmp_path, capsys):
    """V3: ``msr design --minutes 0.1`` printed nothing until its first generation and judgement
    ended (minutes on a large spec), and looked hung."""
    assert run(["design", "m1-4mT", "--out", str(tmp_path / "d"), "--quick", "--popsize", "3",
                "--workers", "1", "--generations", "1"]) == 0
    err = capsys.readouterr().err
    assert ("design: searching (up to 1 generations; a line after each generation); the first generation "
            "and the final judgement of the best run whatever the budget") in err, err


def test_shipping_a_goto_policy_says_it_measures_the_rings(tmp_path, monkeypatch, capsys):
    """V4: ``msr policy ship`` of a goto run measured 24 episodes of 30 s silently, whatever
    ``--duration``."""
    import elastica_magnetic_rl.shipping.ship as ship
    from smoke import NOT_RESIDUAL, SMOKE

    assert run(["train", "--case", "m1-4mT-goto", "--seeds", "1", "--workers", "1", "--steps", "120",
                *SMOKE, *NOT_RESIDUAL, "--set", "yardstick_warmup=10", "--set", "yardstick_dagger=0",
                "--out", str(tmp_path / "runs")]) == 0
    calls = []
    real = ship.evaluate_ring

    def short_ring(policy, duration, physics, **kwargs):  # one target for 0.05 s: not the cost tested
        calls.append(policy)
        return real(policy, 0.05, "training", targets=[(0.015, 0.0)])

    monkeypatch.setattr(ship, "evaluate_ring", short_ring)
    capsys.readouterr()
    run(["policy", "ship", str(tmp_path / "runs" / "m1-4mT-goto" / "seed0"), "--name", "g",
         "--out", str(tmp_path / "pols"), "--duration", "0.05"])
    err = capsys.readouterr().err
    assert len(calls) == 2
    assert ("ship: measuring the goto ring: 12 targets for the policy and 12 for the steering yardstick, "
            "30 s each in the accurate physics") in err, err


def test_a_period_of_hundreds_of_seconds_is_named_as_ms(capsys):
    """Round 54's borderline: ``msr field baseline --period 1500`` was refused as longer than the
    run, without the likelier slip (1500 ms meant)."""
    for case in ("m1-4mT", "m1-4mT-goto"):
        assert run(["field", "baseline", "--case", case, "--period", "1500", "--physics", "training",
                    "--duration", "1"]) == 2
        err = capsys.readouterr().err
        assert "--period 1500 s is longer than --duration 1 s" in err
        assert "(ms written for s? 1500 ms is 1.5 s)" in err
    assert run(["field", "baseline", "--case", "m1-4mT", "--period", "3", "--physics", "training",
                "--duration", "1"]) == 2  # a period merely longer than the run: no slip suggested
    assert "ms written" not in capsys.readouterr().err


def test_a_ship_without_measure_says_why_it_took_the_final_actor(trained, tmp_path, capsys):
    """Round 54's borderline: ``msr policy ship RUN --no-measure`` said its final actor was taken
    "(as asked)", though --checkpoint was left at auto."""
    import json

    seed = trained / "m1-4mT" / "seed0"
    assert main(["policy", "ship", str(seed), "--name", "p", "--out", str(tmp_path), "--no-measure",
                 "--json", "--no-progress"]) == 0
    summary = json.loads(capsys.readouterr().out)["actor_choice"]["summary"]
    assert summary == "the final actor (checkpoint.pt) (--no-measure: not compared with best.pt)"
    assert main(["policy", "ship", str(seed), "--name", "q", "--out", str(tmp_path), "--no-measure",
                 "--json", "--no-progress", "--checkpoint", "final"]) == 0
    assert json.loads(capsys.readouterr().out)["actor_choice"]["summary"].endswith("(as asked)")


def test_another_commands_result_is_named_by_diagnose_export_seeds_and_figures(tmp_path, capsys):
    """Round 54's borderline: a result of another command given to ``msr policy diagnose``,
    ``export-seeds`` or ``figures`` was "no checkpoint.pt", "no seed<k>/checkpoint.pt" or "neither
    a generate output nor training runs", not named."""
    ring = tmp_path / "ring"
    assert run(["field", "baseline", "--case", "m1-4mT-goto", "--ring", "1", "--duration", "0.05",
                "--physics", "training", "--no-progress", "--no-figures", "--out", str(ring)]) == 0
    capsys.readouterr()
    for argv, wanted in ((["policy", "diagnose", str(ring)], "not a training run"),
                         (["policy", "export-seeds", str(ring), "--out", str(tmp_path / "seeds")],
                          "not a case's training runs"),
                         (["policy", "figures", str(ring)], "not a generate output (rollout.npz)")):
        assert run(argv) == 2
        err = capsys.readouterr().err
        assert f"{ring}: holds a result of `msr field baseline`" in err and wanted in err, err
    assert not (tmp_path / "seeds").exists()
