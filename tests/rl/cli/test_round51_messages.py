"""Round 51 of held-out tries (issue 48): the waveform ``msr policy generate`` writes replays its
own trajectory to the last bit (S1: the CSV's mT round trip had changed one value in ~50 by one
ulp, which the accurate physics' contact amplified to 5.6e-8 m in 0.2 s)."""

from __future__ import annotations

import numpy as np
import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from elastica_magnetic import read_field_csv, write_field_csv
from elastica_magnetic.cli import main
from elastica_magnetic.field_csv import millitesla_text_to_tesla, tesla_to_millitesla_text


def run(argv: list[str]) -> int:
    """``msr argv``'s exit status (a parser's refusal exits through SystemExit)."""
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code)


finite_fields = arrays(np.float64, st.tuples(st.integers(1, 40), st.just(3)),
                       elements=st.floats(-1e300, 1e300, allow_nan=False, width=64))  # T; mT stays finite


@settings(max_examples=200, deadline=None)
@given(field=finite_fields)
def test_a_field_written_and_read_is_the_same_float_to_the_last_bit(tmp_path_factory, field):
    path = write_field_csv(tmp_path_factory.mktemp("csv") / "f.csv", field)
    back = read_field_csv(path)
    assert np.array_equal(back.view(np.int64), field.view(np.int64))  # -0.0 kept too


def test_fields_made_by_increments_come_back_where_the_old_round_trip_moved_some():
    """A policy's fields (float32 actions times 0.3 mT, summed and clipped): the old reading of
    the old writing (``float(repr(B / 1e-3)) * 1e-3``) moved some of them by one ulp."""
    rng = np.random.default_rng(51)
    increments = 0.3e-3 * rng.uniform(-1, 1, size=(2000, 3)).astype(np.float32).astype(np.float64)
    field = np.clip(np.cumsum(increments, axis=0), -4e-3, 4e-3)
    moved = [v for v in field.ravel().tolist() if float(repr(v / 1e-3)) * 1e-3 != v]
    assert moved  # values the old round trip did change
    assert all(millitesla_text_to_tesla(tesla_to_millitesla_text(v)) == v for v in moved)


def test_a_hand_written_millitesla_reads_as_the_nearest_double():
    assert millitesla_text_to_tesla("3.9876") == float("3.9876e-3")
    assert millitesla_text_to_tesla(" -0.3 ") == -3e-4


def test_generate_and_the_replay_of_its_fields_csv_give_one_trajectory(tmp_path, capsys):
    """S1: 0.136395 against 0.136445 mm in 0.2 s of the accurate physics."""
    spec = tmp_path / "m1.toml"
    assert run(["case", "show", "m1-4mT", "--toml"]) == 0
    spec.write_text(capsys.readouterr().out)
    assert run(["policy", "generate", "m1-4mT", "--duration", "0.3", "--physics", "accurate",
                "--out", str(tmp_path / "pg"), "--no-figures", "--no-progress"]) == 0
    assert run(["field", "replay", str(tmp_path / "pg" / "fields.csv"), "--robot", str(spec),
                "--physics", "accurate", "--out", str(tmp_path / "rp"), "--no-progress"]) == 0
    played = pd.read_csv(tmp_path / "pg" / "trajectory.csv")
    replayed = pd.read_csv(tmp_path / "rp" / "trajectory.csv")
    assert played.shape == replayed.shape
    assert (played.to_numpy() == replayed.to_numpy()).all()
