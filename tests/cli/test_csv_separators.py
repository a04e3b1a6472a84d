"""Round 4, V8: a CSV written with semicolons or tabs (a spreadsheet's export in a locale with a
decimal comma) is named as such by every CSV reader, not only as "missing columns"."""

from __future__ import annotations

import pytest

from elastica_magnetic.cli import main

FIELD = "t;mag_x;mag_y;mag_z\n0;1;0;0\n1;1;0;0\n"
TRACK = "t_s\tx_0_m\ty_0_m\n0\t0\t0\n0.5\t0.001\t0\n"
MEASUREMENTS = "current_x_A;current_y_A;current_z_A;field_x_mT;field_y_mT;field_z_mT\n1;0;0;2;0;0\n"


def _commands(tmp_path):
    good_field = tmp_path / "good.csv"
    good_field.write_text("mag_x,mag_y,mag_z\n" + "1,0,0\n" * 60)
    return {
        "field replay": (["field", "replay", "{bad}", "--out", "{out}"], FIELD, "semicolons"),
        "replay --reference": (["field", "replay", str(good_field), "--reference", "{bad}",
                                "--out", "{out}"], "t_s;x;y\n0;0;0\n", "semicolons"),
        "identify": (["real", "identify", str(good_field), "{bad}", "--robot", "m1-4mT", "--fit",
                      "magnetization", "--out", "{out}"], TRACK, "tabs"),
        "calibrate": (["real", "calibrate", "{bad}", "--out", "{out}.json"], MEASUREMENTS,
                      "semicolons"),
    }


@pytest.mark.parametrize("name", ["field replay", "replay --reference", "identify", "calibrate"])
def test_another_separator_is_named_by_every_csv_reader(tmp_path, capsys, name):
    argv, text, separators = _commands(tmp_path)[name]
    bad = tmp_path / "bad.csv"
    bad.write_text(text)
    out = tmp_path / "out"
    argv = [a.replace("{bad}", str(bad)).replace("{out}", str(out)) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"{bad}" in err and f"its columns are separated by {separators}, not commas" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.csv", "good.csv"]
