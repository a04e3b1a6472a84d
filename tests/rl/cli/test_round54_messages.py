"""Round 54 of held-out tries (issue 48; D0 S0 T0 V4): refine given another command's result is
told so first (V1); a spec file given as a calibration is named (V2)."""

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
