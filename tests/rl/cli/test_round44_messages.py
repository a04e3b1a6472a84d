"""Round 44 of held-out tries (issue 48): what they found, each fixed with the message it gives."""

from __future__ import annotations

import re
import warnings

import pytest


@pytest.mark.parametrize("times", [[f"00:00:{0.02 * k:05.2f}" for k in range(5)],
                                   [f"2026-12-05T10:00:{0.02 * k:06.3f}" for k in range(5)],
                                   [f'"{0.02 * k:.2f}"'.replace(".", ",") for k in range(5)]])
def test_a_clock_written_as_a_clock_reads_it_is_checked(tmp_path, times):
    """S1: a ``time`` column of ``00:00:00.02`` steps (a 50 Hz waveform) was only "not read" and
    played at 100 Hz; the same times as numbers were refused."""
    from elastica_magnetic.field_csv import FieldCSVError, read_field_csv

    rows = ["time,mag_x,mag_y,mag_z"] + [f"{t},1,0,0" for t in times]
    (tmp_path / "f.csv").write_text("\n".join(rows) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(FieldCSVError, match=r"column 'time' reads as a clock stepping 0.02 s at line 3"):
            read_field_csv(tmp_path / "f.csv")
        rows = ["time,mag_x,mag_y,mag_z"] + [f"00:00:{0.01 * k:05.2f},1,0,0" for k in range(5)]
        (tmp_path / "g.csv").write_text("\n".join(rows) + "\n")
        assert read_field_csv(tmp_path / "g.csv").shape == (5, 3)


def test_a_named_first_column_that_is_not_an_index_is_not_read_as_one(tmp_path):
    """V1: ``I_A,mag_x,mag_y,mag_z`` was refused as "index '0.500' out of sequence ... not as a
    time", a current called a time, the column not named; placed last it only warned. A first
    column is the row index only under an index's header; an index out of sequence names it."""
    from elastica_magnetic.field_csv import FieldCSVError, read_field_csv
    from elastica_magnetic.plausibility import ImplausibleValueWarning

    (tmp_path / "f.csv").write_text("I_A,mag_x,mag_y,mag_z\n0.5,1,0,0\n0.5,1,0,0\n")
    with pytest.warns(ImplausibleValueWarning, match=r"column\(s\) 'I_A' are not read"):
        assert read_field_csv(tmp_path / "f.csv").shape == (2, 3)
    (tmp_path / "g.csv").write_text("index,mag_x,mag_y,mag_z\n0,1,0,0\n2,1,0,0\n")
    with pytest.raises(FieldCSVError, match=r"line 3: index '2' out of sequence, expected 1; the first "
                                            r"column, 'index', is read as a row index 0, 1, 2...: number "
                                            r"the rows, or drop it"):
        read_field_csv(tmp_path / "g.csv")


def test_a_field_map_with_another_header_is_told_its_header(tmp_path):
    """V2: a field map headed ``Bx_T`` was told "every row must hold 6 numbers" (the header's own
    message caught and re-worded as a row's)."""
    from elastica_magnetic.field_maps import FieldMap
    from elastica_magnetic.spatial_fields import SpatialFieldError

    (tmp_path / "m.csv").write_text("x_m,y_m,z_m,Bx_T,By_T,Bz_T\n0,0,0,0.001,0,0\n")
    with pytest.raises(SpatialFieldError, match=re.escape(
            "header must be x_m,y_m,z_m,Bx_mT,By_mT,Bz_mT, got x_m,y_m,z_m,Bx_T,By_T,Bz_T (found 'Bx_T', "
            "'By_T', 'Bz_T': positions in m and the field in mT")) as info:
        FieldMap.from_csv(tmp_path / "m.csv")
    assert "every row" not in str(info.value)


@pytest.mark.parametrize("argv, message", [
    (["--episode-duration", "500ms"], "argument --episode-duration: expected a finite number of s > 0, got "
                                      "'500ms'"),
    (["--set", "eval_every=40", "--set", "eval_duration=500ms"],
     "eval_duration=500ms: expected a number of s (0: the case's evaluation), e.g. 0.5 for 500 ms"),
])
def test_durations_with_a_unit_are_told_the_unit(tmp_path, capsys, argv, message):
    """V3: ``--episode-duration 500ms`` was "invalid float value", ``eval_duration=500ms`` "expected
    a number", neither naming s (``--duration`` did)."""
    from elastica_magnetic.cli import main as msr

    with pytest.raises(SystemExit):
        msr(["train", "--case", "m1-4mT", "--seeds", "1", "--steps", "80", *argv, "--out",
             str(tmp_path / "r")])
    assert message in capsys.readouterr().err


def test_a_clock_in_milliseconds_under_a_seconds_header_is_told_its_unit(tmp_path):
    """V5: ``t_s`` = 0, 10, 20 (a logger's ms; the rows 0.01 s apart) was told to "resample the
    waveform to 0.01 s steps", which would stretch it a thousandfold."""
    from elastica_magnetic.field_csv import FieldCSVError, read_field_csv

    for header, step, factor in (("t_s", 10, "1000"), ("time (ms)", 10000, "1000"), ("t_s", 10000, "1e+06")):
        rows = [f"{header},mag_x,mag_y,mag_z"] + [f"{k * step},1,0,0" for k in range(4)]
        (tmp_path / "f.csv").write_text("\n".join(rows) + "\n")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with pytest.raises(FieldCSVError, match=re.escape(
                    f"its times step 0.01 s in a unit {factor} times smaller than '{header}' says: name that "
                    f"unit in the header or divide its times by {factor}")):
                read_field_csv(tmp_path / "f.csv")


def test_a_randomize_table_with_unquoted_dotted_keys_is_read_as_written(tmp_path):
    """V4: ``robot.ground.kinetic_mu = "abs:0.4:0.7"`` unquoted in ``[training.randomize]`` (TOML's
    nested tables) was refused as "robot = {...}: expected a string", though the value is one."""
    from elastica_magnetic_rl.cases.case import load_case

    text = load_case("m1-4mT").toml()
    cut = text.index("[yardstick]")
    spec = tmp_path / "r.toml"
    spec.write_text(text[:cut] + '[training.randomize]\nrobot.ground.kinetic_mu = "abs:0.4:0.7"\n\n'
                    + text[cut:])
    case = load_case(str(spec))
    (variation,) = case.training.randomize
    assert variation.keys == ("robot.ground.kinetic_mu",) and (variation.low, variation.high) == (0.4, 0.7)


def test_the_loop_plays_the_waveform_that_goes_farther_on_the_varied_robots():
    """Found by mybot's loop this session: the firmware step chose the refined waveform (+19.9 mm
    nominal, a gait lost everywhere) over the learned one (+322 mm) by its open-loop 10th percentile
    (+0.1 mm against -11.7 mm, both stalled there). It now takes the larger mean over the varied
    robots."""
    from pathlib import Path
    from types import SimpleNamespace

    from elastica_magnetic_rl.loop.state import STEPS, LoopState
    from elastica_magnetic_rl.loop.steps import _waveform_to_play

    def record(nominal, others, p10):
        return {"status": "done", "summary": {
            "fields_csv": "f.csv", "summary": {"open_loop": {"nominal_m": nominal, "p10_m": p10}},
            "variants": [{"label": "nominal", "open_loop": nominal}] + [{"label": str(k), "open_loop": d}
                                                                         for k, d in enumerate(others)]}}
    steps = {s: {"status": "done", "summary": {}} for s in STEPS}
    steps["robustness"] = record(0.322, [0.3] * 20 + [-0.047, -0.02, -0.01, 0.005], -0.0117)
    steps["robustness-refined"] = record(0.0199, [0.01] * 20 + [0.0001] * 4, 0.0001)
    state = LoopState(Path("lp/loop.json"), "mybot", {}, {}, steps)
    which, _, why = _waveform_to_play(SimpleNamespace(state=state))
    assert which == "learned" and "open-loop mean" in why, why


def test_a_range_in_percent_signs_is_told_the_factors():
    """Borderline of round 44: ``--vary robot.density=90%:110%`` was "'90%' is not a number"."""
    from elastica_magnetic_rl.cases.variations import VariationError, parse_variation

    with pytest.raises(VariationError, match=r"LOW:HIGH are factors of the nominal value \(1 = nominal\): "
                                             r"0.9:1.1 for 90% to 110%"):
        parse_variation("robot.density=90%:110%")


def test_a_case_named_twice_is_said_to_train_once():
    """Borderline of round 44: ``msr train --case m1-4mT m1-4mT`` trained the case once without a
    word."""
    from elastica_magnetic_rl.sweep.sweep_plan import load_cases

    from elastica_magnetic.plausibility import SettingNotAppliedWarning

    named_twice = r"--case: m1-4mT is named twice .*: it is trained once"
    with pytest.warns(SettingNotAppliedWarning, match=named_twice):
        assert list(load_cases(["m1-4mT", "m1-4mT"])) == ["m1-4mT"]
