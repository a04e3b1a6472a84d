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


def test_hardware_inputs_inside_what_force_replaces_are_refused(tmp_path, capsys):
    """The review of round 33's D1: ``msr real firmware DIR/fields.csv --out DIR --force``
    and ``msr real calibrate meas.csv --out meas.csv --force`` replaced their own input (the
    waveform deleted with the folder, the measurements overwritten by the fit)."""
    out = tmp_path / "fw"
    out.mkdir()
    field = out / "fields.csv"
    field.write_text("mag_x,mag_y,mag_z\n0,0,0\n1,0,0\n")
    calibration = REPO / "stm32" / "calibration" / "default.json"
    before = _tree(out)
    assert msr(["real", "firmware", str(field), "--calibration", str(calibration), "--out", str(out),
                "--force"]) == 2
    assert f"FIELD_CSV {field}: lies in --out {out}" in capsys.readouterr().err
    assert _tree(out) == before
    measurements = tmp_path / "meas.csv"
    measurements.write_text("current_x_A,current_y_A,current_z_A,field_x_mT,field_y_mT,field_z_mT\n"
                            "1,0,0,2,0,0\n0,1,0,0,2,0\n0,0,1,0,0,2\n1,1,0,2,2,0\n")
    kept = measurements.read_bytes()
    assert msr(["real", "calibrate", str(measurements), "--out", str(measurements), "--force"]) == 2
    assert f"MEASUREMENTS {measurements}: lies in --out {measurements}" in capsys.readouterr().err
    assert measurements.read_bytes() == kept
