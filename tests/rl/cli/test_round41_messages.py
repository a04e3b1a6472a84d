"""Round 41 of held-out tries (issue 48): what they found, each fixed with the message it gives."""

from __future__ import annotations

import re

import pytest


@pytest.mark.parametrize("header, scale", [("t_us", 1e6), ("time (min)", 1 / 60), ("time [µs]", 1e6),
                                           ("t_ns", 1e9), ("time_h", 1 / 3600)])
def test_a_clock_in_any_unit_is_checked(tmp_path, header, scale):
    """S1: a clock in microseconds or minutes stepping 0.02 s was only warned "not read" (round 40
    knew s and ms): the 50 Hz waveform played at 100 Hz."""
    from elastica_magnetic.field_csv import FieldCSVError, read_field_csv

    rows = [f"mag_x,mag_y,mag_z,{header}"] + [f"1,0,0,{i * 0.02 * scale:.9g}" for i in range(5)]
    (tmp_path / "f.csv").write_text("\n".join(rows) + "\n")
    named = rf"column '{re.escape(header)}' reads as a clock stepping 0.02 s"
    with pytest.raises(FieldCSVError, match=named):
        read_field_csv(tmp_path / "f.csv")


def test_a_clock_in_an_unknown_unit_is_refused(tmp_path):
    from elastica_magnetic.field_csv import FieldCSVError, read_field_csv

    (tmp_path / "f.csv").write_text("mag_x,mag_y,mag_z,time [fortnights]\n1,0,0,0\n1,0,0,1\n")
    with pytest.raises(FieldCSVError, match=r"reads as a clock in an unknown unit 'fortnights'"):
        read_field_csv(tmp_path / "f.csv")


@pytest.mark.parametrize("order", ["reversed", "repeated"])
def test_a_reference_out_of_time_order_is_refused(tmp_path, order):
    """S2: a reference with its rows reversed was compared "from 0.3 to 0 s" with its distance's sign
    flipped; rows shuffled, over a third of the motion; two frames of one time, without a word."""
    import numpy as np
    import pandas as pd

    from elastica_magnetic.cli.commands import CommandError, _read_reference

    t = np.arange(0.0, 0.31, 0.01)
    frame = pd.DataFrame({"t_s": t, "mid_x_m": 1e-3 * t, "mid_y_m": 0 * t + 4e-4, "back_x_m": 1e-3 * t - 0.01,
                          "back_y_m": 0 * t + 4e-4, "front_x_m": 1e-3 * t + 0.01, "front_y_m": 0 * t + 4e-4,
                          "height_max_m": 0 * t + 8e-4, "span_m": 0 * t + 0.02})
    if order == "reversed":
        frame = frame.iloc[::-1]
    else:
        frame.loc[5, "t_s"] = frame.loc[4, "t_s"]
    frame.to_csv(tmp_path / "ref.csv", index=False)
    named = r"ref.csv: line [37]: t_s .* does not come after the line before's"
    with pytest.raises(CommandError, match=named):
        _read_reference(tmp_path / "ref.csv", 0.3, 0.02)


def _measurements(tmp_path, copies: int):
    import numpy as np

    rng = np.random.default_rng(7)
    matrix = np.diag([2.9, 3.1, 1.2]) + 0.05 * rng.standard_normal((3, 3))  # mT/A
    currents = np.array([[0.1, -0.8, 0.3], [0.9, 0.2, -0.1], [-0.2, 0.4, 1.1]])
    fields = currents @ matrix.T + 0.01 * rng.standard_normal((3, 3))
    rows = ["current_x_A,current_y_A,current_z_A,field_x_mT,field_y_mT,field_z_mT"]
    rows += [",".join(f"{v:.6g}" for v in (*c, *f)) for c, f in zip(currents, fields, strict=True)] * copies
    (tmp_path / "meas.csv").write_text("\n".join(rows) + "\n")
    return tmp_path / "meas.csv"


@pytest.mark.parametrize("copies", [1, 4])
def test_a_calibration_from_three_settings_says_its_errors_are_unknown(tmp_path, capsys, copies):
    """S4: three settings each copied four times were "12 measurements", residual 0, standard errors
    0, "warnings: none"; the three rows once gave standard errors nan, also without a word."""
    import json
    import math

    from elastica_magnetic.cli import main as msr

    measurements = _measurements(tmp_path, copies)
    assert msr(["real", "calibrate", str(measurements), "--out", str(tmp_path / "cal.json"), "--name", "t1",
                "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["measurements"] == 3
    assert all(math.isnan(v) if isinstance(v, float) else v is None for row in summary["std_error_mT_per_A"]
               for v in row)
    assert any("their standard errors cannot be estimated" in w for w in summary["warnings"])
    assert any("9 row(s) repeat another row exactly" in w for w in summary["warnings"]) == (copies == 4)


def test_the_firmware_step_runs_again_after_a_robustness_step_that_runs_later():
    """S3: a loop run with the robustness steps skipped, then without --skip, ran them but kept its
    firmware ("no robustness step ran"), though the loop's rule now picks the waveform they judge."""
    from pathlib import Path

    from elastica_magnetic_rl.loop.state import STEPS, LoopState, plan_loop

    skipped = ("robustness", "refine", "robustness-refined")
    steps = {s: {"status": "skipped"} if s in skipped else {"status": "done", "summary": {}} for s in STEPS}
    state = LoopState(Path("lp/loop.json"), "m1-4mT", {}, {}, steps)
    plan = plan_loop(state, {}, {}, (), (), False)
    assert plan.run == ("robustness", "refine", "robustness-refined", "firmware") and "firmware" in plan.redo
    assert plan_loop(state, {}, {}, skipped, (), False).run == ()  # still skipped: the firmware stands
    done = LoopState(Path("lp/loop.json"), "m1-4mT", {}, {}, {s: {"status": "done"} for s in STEPS})
    assert plan_loop(done, {}, {}, (), ("robustness",), False).run == ("robustness", "firmware")
    assert plan_loop(None, {}, {}, ("robustness", "robustness-refined"), (), False).run[-1] == "firmware"
