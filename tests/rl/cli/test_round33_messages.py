"""Round 33 of held-out tries (issue 48): what they found, each fixed with the message it gives."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from elastica_magnetic.cli import main as msr

REPO = Path(__file__).resolve().parents[3]


def _tree(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("force", [False, True])
@pytest.mark.parametrize("which", ["SPEC", "--calibration"])
def test_a_loop_s_input_inside_its_folder_is_refused(tmp_path, capsys, which, force):
    """D1: ``msr loop L/c16.toml --out L --force`` took the loop's own spec copy as its input and
    rewrote it (each run appended to its yardstick source, so the loop could never resume). The
    loop writes into its folder on every run: a SPEC or --calibration inside it is refused, with
    or without --force, before any work, the folder left as it was."""
    loop = tmp_path / "L"
    loop.mkdir()
    spec = loop / "c16.toml"
    shutil.copy(REPO / "rl" / "specs" / "m1-4mT.toml", spec)
    calibration = loop / "cal.json"
    shutil.copy(REPO / "stm32" / "calibration" / "default.json", calibration)
    args = ["loop", str(spec) if which == "SPEC" else "m1-4mT", "--out", str(loop), "--quick",
            "--no-progress", *(["--calibration", str(calibration)] if which == "--calibration" else []),
            *(["--force"] if force else [])]
    before = _tree(loop)
    assert msr(args) == 2
    err = capsys.readouterr().err
    assert f"{which} {calibration if which == '--calibration' else spec}: lies in --out {loop}" in err, err
    assert "copy it elsewhere first" in err
    assert _tree(loop) == before


def test_a_tracker_header_split_at_decimal_commas_is_named_as_such(tmp_path, capsys):
    """V2: ``t_s,x_0,5_m,y_0,5_m`` (points named with a decimal comma) was told "its header names
    5_m twice"; now the split name is named, with the dot that mends it."""
    from elastica_magnetic_rl.sim2real.tracking import TrajectoryError, read_trajectory

    track = tmp_path / "tk.csv"
    track.write_text("t_s,x_0,5_m,y_0,5_m\n0,0,010,0\n0.0333,0,011,0\n")
    with pytest.raises(TrajectoryError, match=r"'x_0' and '5_m' look like one name written with a "
                                              r"decimal comma \(x_0,5_m\) .* with a dot \(x_0.5_m\)"):
        read_trajectory(track)
