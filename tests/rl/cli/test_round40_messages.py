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


def test_a_column_of_words_named_like_a_time_is_refused(tmp_path):
    """Round 40 had only warned of it; round 45 found clocks in forms msr did not read (h:m:s with a
    decimal comma, times with their unit) passed the same way: a clock is checked or refused."""
    from elastica_magnetic.field_csv import FieldCSVError, read_field_csv

    (tmp_path / "f.csv").write_text("mag_x,mag_y,mag_z,time\n1,0,0,morning\n1,0,0,noon\n")
    with pytest.warns(UserWarning, match=r"column\(s\) 'time' are not read"), pytest.raises(
            FieldCSVError, match=r"column 'time' reads as a clock, but its times \('morning' at line 2\) are "
                                 r"in a form msr does not read"):
        read_field_csv(tmp_path / "f.csv")


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


def _m1_4mT_policies(tmp_path):
    import shutil

    from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR

    policies = tmp_path / "pols"
    shutil.copytree(POLICIES_DIR / "m1-4mT", policies / "m1-4mT", ignore=shutil.ignore_patterns("*.gif"))
    return policies


def _spec(tmp_path, capsys, old: str, new: str):
    from elastica_magnetic.cli import main as msr

    assert msr(["case", "show", "m1-4mT", "--toml"]) == 0
    text = capsys.readouterr().out
    assert old in text
    (tmp_path / "m1-4mT.toml").write_text(text.replace(old, new))
    return tmp_path / "m1-4mT.toml"


def test_seeds_of_another_robot_of_the_same_name_are_refused(tmp_path, capsys):
    """S3: ``msr policy seeds SPEC.toml --card`` gave a 70 kA/m robot the 61.3 kA/m seeds' distances
    and verdicts and rewrote the shipped card for it (seeds were matched by name only)."""
    from elastica_magnetic.cli import main as msr

    policies = _m1_4mT_policies(tmp_path)
    card = (policies / "m1-4mT" / "MODEL_CARD.md").read_text()
    spec = _spec(tmp_path, capsys, "magnitude = 61300.0", "magnitude = 70000.0")
    assert msr(["policy", "seeds", str(spec), "--policies", str(policies), "--card"]) == 2
    assert ("were measured on another spec than the one given (they differ at [robot.magnetization] "
            "magnitude)" in capsys.readouterr().err)
    assert (policies / "m1-4mT" / "MODEL_CARD.md").read_text() == card


def test_a_card_is_not_judged_by_another_target(tmp_path, capsys):
    """S3: a spec whose yardstick says +30 mm rewrote the card's seeds section ("0 of 8") while its
    evaluation kept the policy's +20.5 mm target; without --card the table is judged by it."""
    from elastica_magnetic.cli import main as msr

    policies = _m1_4mT_policies(tmp_path)
    card = (policies / "m1-4mT" / "MODEL_CARD.md").read_text()
    spec = _spec(tmp_path, capsys, "distance_10s = 0.0205", "distance_10s = 0.03")
    assert msr(["policy", "seeds", str(spec), "--policies", str(policies), "--card"]) == 2
    assert "they differ at [yardstick] distance_10s" in capsys.readouterr().err
    assert (policies / "m1-4mT" / "MODEL_CARD.md").read_text() == card
    assert msr(["policy", "seeds", str(spec), "--policies", str(policies)]) == 0


def test_notes_say_the_card_is_unchanged_when_it_is(tmp_path, capsys):
    """S4: the same notes again, or ``--clear`` with no notes, printed ``card_updated: yes``."""
    import json
    import shutil

    from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR

    from elastica_magnetic.cli import main as msr

    policy = tmp_path / "p"
    shutil.copytree(POLICIES_DIR / "m1-4mT", policy, ignore=shutil.ignore_patterns("seeds", "*.gif"))
    (tmp_path / "n.md").write_text("plain\n")
    updated = []
    for extra in (["--file", str(tmp_path / "n.md")],) * 2 + (["--clear"],) * 2:
        assert msr(["policy", "notes", str(policy), *extra, "--json"]) == 0
        updated.append(json.loads(capsys.readouterr().out)["card_updated"])
    assert updated == [True, False, True, False]


def test_a_policy_of_another_robot_of_the_same_name_ships_without_the_case_s_seeds(tmp_path, capsys):
    """S3's second door: ``msr policy ship`` of a run of a spec named m1-4mT with another
    magnetization put the shipped robot's seeds table in the new card, and ``msr policy seeds
    m1-4mT --card`` then counted that card as the case's."""
    from elastica_magnetic.cli import main as msr

    policies = _m1_4mT_policies(tmp_path)
    spec = _spec(tmp_path, capsys, "magnitude = 61300.0", "magnitude = 70000.0")
    assert msr(["train", "--case", str(spec), "--seeds", "1", "--steps", "80", "--episode-duration", "0.5",
                "--set", "learning_starts=60", "--set", "batch_size=32", "--set", "hidden_sizes=32,32",
                "--set", "eval_every=0", "--workers", "1", "--no-progress",
                "--out", str(tmp_path / "runs")]) == 0
    assert msr(["policy", "ship", str(tmp_path / "runs" / "m1-4mT" / "seed0"), "--no-measure", "--out",
                str(policies), "--name", "mag70", "--no-progress"]) == 0
    assert "the model card carries no seeds table" in capsys.readouterr().err
    assert "## Every seed" not in (policies / "mag70" / "MODEL_CARD.md").read_text()
    assert msr(["policy", "seeds", "m1-4mT", "--policies", str(policies), "--card", "--json"]) == 0
    assert "mag70" not in capsys.readouterr().out
