"""Round 40 of held-out tries (issue 48): what they found, each fixed with the message it gives."""

from __future__ import annotations

import math
import re

import pytest


def _fifty_hertz(header: str, blank_last: bool = False, step: float = 0.02) -> str:
    angles = [6 * i * 0.02 for i in range(60)]
    rows = [f"mag_x,mag_y,mag_z,{header}"] + [
        f"{3 * math.cos(a):.3f},{3 * math.sin(a):.3f},0,{i * step:.2f}" for i, a in enumerate(angles)]
    if blank_last:
        rows[-1] = rows[-1].rsplit(",", 1)[0] + ","
    return "\n".join(rows) + "\n"


@pytest.mark.parametrize("header", ["time/s", "timestamp_s", "t/s", "elapsed_s", "Time (s)", "t"])
def test_a_clock_column_in_any_notation_is_checked(tmp_path, header):
    """S1: a 0.02 s clock headed ``time/s`` or ``timestamp_s`` escaped round 39's check (only
    ``t_s``-like spellings matched): the 50 Hz waveform played twice as fast."""
    from elastica_magnetic.field_csv import FieldCSVError, read_field_csv

    (tmp_path / "f.csv").write_text(_fifty_hertz(header))
    named = rf"column '{re.escape(header)}' reads as a clock stepping 0.02 s"
    with pytest.raises(FieldCSVError, match=named):
        read_field_csv(tmp_path / "f.csv")


def test_a_clock_column_missing_a_time_is_refused(tmp_path):
    """S1: one blank clock cell made the check skip the column."""
    from elastica_magnetic.field_csv import FieldCSVError, read_field_csv

    (tmp_path / "f.csv").write_text(_fifty_hertz("t_s", blank_last=True, step=0.01))
    with pytest.raises(FieldCSVError, match=r"column 't_s' reads as a clock, but line 61 has no time there"):
        read_field_csv(tmp_path / "f.csv")


def test_a_column_of_words_named_like_a_time_is_only_warned(tmp_path):
    from elastica_magnetic.field_csv import read_field_csv

    (tmp_path / "f.csv").write_text("mag_x,mag_y,mag_z,time\n1,0,0,morning\n1,0,0,noon\n")
    with pytest.warns(UserWarning, match=r"column\(s\) 'time' are not read"):
        assert read_field_csv(tmp_path / "f.csv").shape == (2, 3)


def test_a_reference_starting_late_is_compared_over_its_own_window():
    """S2: a reference identical to the replay but starting at 0.3 s (a tracker started late) gave
    ``mid_dx_relative_error`` 0.69: the reference's distance was from 0.3 s, the simulation's from 0."""
    import numpy as np
    import pandas as pd

    from elastica_magnetic.cli.commands import compare_trajectories

    t = np.arange(0.0, 0.61, 0.01)
    columns = ("mid_x_m", "mid_y_m", "back_x_m", "front_x_m", "height_max_m", "span_m")
    run = pd.DataFrame({"t_s": t, **{c: 1e-3 * t ** 2 + k for k, c in enumerate(columns)}})
    late = run[run.t_s >= 0.3 - 1e-9].reset_index(drop=True)
    diff = compare_trajectories(run, late)
    assert abs(diff["mid_dx_relative_error"]) < 1e-9
    assert diff["compared_from_s"] == pytest.approx(0.3) and diff["compared_to_s"] == pytest.approx(0.6)
