"""Round 6 of held-out tries (issue 48): values that were accepted without a word and messages
that did not name the problem. Each test fails without its fix."""

from __future__ import annotations

import json

import pytest

from elastica_magnetic.cli import main as msr
from elastica_magnetic.field_csv import write_field_csv
from elastica_magnetic.plausibility import ImplausibleValueWarning
from elastica_magnetic.specfile import SpecError, read_spec


def test_a_duration_in_milliseconds_is_warned(tmp_path, capsys):
    """O01/O16: ``--duration 3000`` (ms meant) ran 50 minutes of simulated time without a word."""
    from elastica_magnetic.cli.options import duration_option

    with pytest.warns(ImplausibleValueWarning, match=r"--duration = 3000 s is above 600 s.*"
                                                     r"3000 ms is 3 s"):
        assert duration_option()("3000") == 3000.0
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert duration_option()("10") == 10.0  # a usual duration: no warning


def test_case_show_takes_one_printed_form(capsys):
    """V04: ``--toml --json`` printed TOML and ignored --json."""
    with pytest.raises(SystemExit):
        msr(["case", "show", "m1-4mT", "--toml", "--json"])
    assert "argument --json: not allowed with argument --toml" in capsys.readouterr().err


def test_a_spec_not_in_utf8_is_named_with_the_fix(tmp_path):
    """S_latin1/S_utf16: the codec's raw message, no line, no advice."""
    text = '# a spéc\nname = "x"\n'
    (tmp_path / "latin.toml").write_bytes(text.encode("latin-1"))
    (tmp_path / "wide.toml").write_bytes(text.encode("utf-16"))
    with pytest.raises(SpecError, match=r"latin.toml: not UTF-8 text: saved in another encoding "
                                        r"\(byte 0xe9 on line 1 is not UTF-8.*save it as UTF-8"):
        read_spec(tmp_path / "latin.toml")
    with pytest.raises(SpecError, match=r"wide.toml: not UTF-8 text: saved in UTF-16"):
        read_spec(tmp_path / "wide.toml")


def test_a_field_out_of_plane_on_a_rolling_band_says_which_model_a_flat_band_has(tmp_path, capsys):
    """G08b: a field with a z component on a band with the default rolling model, no word."""
    csv = write_field_csv(tmp_path / "f.csv", [[0.0, 1e-3, 1e-3]] * 5)
    assert msr(["field", "replay", str(csv), "--physics", "training", "--out", str(tmp_path / "r"),
                "--no-progress", "--json"]) == 0
    err = capsys.readouterr().err
    assert 'sideways is "rolling" (the default): the band rolls sideways' in err
    planar = write_field_csv(tmp_path / "p.csv", [[0.0, 1e-3, 0.0]] * 5)
    assert msr(["field", "replay", str(planar), "--physics", "training", "--out",
                str(tmp_path / "p"), "--no-progress", "--json"]) == 0
    assert "sideways" not in capsys.readouterr().err


def test_a_seedless_summary_is_strict_json():
    """D05: a seed that failed made ``summary.json`` hold a bare ``NaN``."""
    from elastica_magnetic_rl.sweep.stop_settings import stop_summary

    summary = stop_summary([{"seed": 0, "error": "failed"}], 300, None)
    assert summary["steps_run_fraction"] is None
    json.loads(json.dumps(summary), parse_constant=lambda c: pytest.fail(f"non-strict JSON {c}"))
