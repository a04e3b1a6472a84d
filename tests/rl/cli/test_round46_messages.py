"""Round 46 of held-out tries (issue 48, stopped early): a column rising evenly as a clock does, by
a step that is not the rows' 0.01 s, is refused under any header (S1: ``micros``, ``Zeit``, ``ts``);
``generate SHIPPED --checkpoint FILE`` advises only what plays (V1)."""

from __future__ import annotations

import math
import shutil
import warnings

import pytest
from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint
from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR

from elastica_magnetic.cli import main as msr
from elastica_magnetic.field_csv import FieldCSVError, read_field_csv


def _field_csv(path, header: str, values: list[float]):
    rows = [f"{v:g},{4 * math.cos(0.1 * k):.4f},{4 * math.sin(0.1 * k):.4f},0" for k, v in enumerate(values)]
    path.write_text(f"{header},mag_x,mag_y,mag_z\n" + "\n".join(rows) + "\n")
    return path


def _read(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the unread-column warning of the columns that pass
        return read_field_csv(path)


@pytest.mark.parametrize("header, step", [("micros", 20000.0), ("nanos", 2e7), ("ts", 0.02), ("epoch", 0.02)])
def test_clock_words_of_loggers_are_read_as_clocks(tmp_path, header, step):
    """S1: these headers were unread columns, so a 50 Hz waveform played at 100 Hz."""
    with pytest.raises(FieldCSVError, match=rf"column '{header}' reads as a clock stepping 0.02 s at line 3"):
        _read(_field_csv(tmp_path / "f.csv", header, [step * k for k in range(6)]))


@pytest.mark.parametrize("header, step", [("Zeit", 0.02), ("zeit_us", 20000.0), ("counter", 2.0)])
def test_a_column_of_any_header_rising_evenly_by_another_step_is_refused(tmp_path, header, step):
    # (a unit named in the header is said with the step since round 47: "rises by 20000 us")
    refused = rf"column '{header}' rises by {step:g}( us)? every row \(from line 2\), evenly, as a clock does"
    with pytest.raises(FieldCSVError, match=refused):
        _read(_field_csv(tmp_path / "f.csv", header, [step * k for k in range(6)]))


@pytest.mark.parametrize("header, values", [
    ("Zeit", [0.01 * k for k in range(6)]),  # the rows' own clock in s
    ("zeit_us", [1e4 * k for k in range(6)]),  # ... in us
    ("frame", list(range(6))), ("frame_no", list(range(1, 7))),  # the rows counted
    ("temperature", [20.0, 20.5, 20.4, 21.0, 20.9, 21.3]),  # no even rise
    ("offset", [3.0] * 6)])  # no rise at all
def test_columns_a_clock_of_the_rows_or_no_clock_are_left_unread(tmp_path, header, values):
    assert _read(_field_csv(tmp_path / "f.csv", header, values)).shape == (6, 3)


def test_a_shipped_policy_given_a_checkpoint_is_advised_only_what_plays(trained, tmp_path, capsys):
    """V1: the advice "play that checkpoint itself" was given for a shipped policy's own actor.pt
    (no training checkpoint: it then failed) and for a field CSV."""
    shipped = tmp_path / "m1-4mT"
    shutil.copytree(POLICIES_DIR / "m1-4mT", shipped)
    out = str(tmp_path / "g")
    cases = [(str(shipped), str(shipped / "actor.pt"), f"({shipped} plays its own actor)"),
             ("m1-4mT", str(shipped / "actor.pt"), f"({shipped / 'actor.pt'} is no training checkpoint)"),
             ("m1-4mT", str(trained / "m1-4mT" / "seed0" / "checkpoint.pt"),
              ", or give that checkpoint itself in place of m1-4mT")]
    for policy, checkpoint, advice in cases:
        assert msr(["policy", "generate", policy, "--checkpoint", checkpoint, "--duration", "0.1",
                    "--out", out]) == 2
        err = capsys.readouterr().err
        assert "is not a run folder (a shipped policy or an actor file)" in err and advice in err, err
        assert "play that checkpoint itself" not in err and not (tmp_path / "g").exists()
    # (round 49 V1: "give its folder" was refused by --checkpoint: the folder is given as the policy)
    with pytest.raises(ValueError, match=rf"is not a TD3 checkpoint \(.*\): a file of the shipped policy "
                                         rf"{shipped}, played by naming that folder as the policy"):
        load_checkpoint(shipped / "actor.pt")
