"""Round 37 of held-out tries (issue 48): what they found, each fixed with the message it gives."""

from __future__ import annotations

import numpy as np
import pytest
from elastica_magnetic_rl.sim2real.tracking import TrajectoryError, read_trajectory

from elastica_magnetic.field_csv import FieldCSVError, read_field_csv

LENGTH = 0.02  # m


def _csv(path, columns: dict[str, np.ndarray]) -> None:
    t = 0.01 * np.arange(30)
    table = {"t_s": t, **columns}
    lines = [",".join(table)] + [",".join(f"{table[c][k]:.6g}" for c in table) for k in range(len(t))]
    path.write_text("\n".join(lines) + "\n")


def _moving(at: float) -> np.ndarray:
    return at + 0.05 * 0.01 * np.arange(30)


@pytest.mark.parametrize("spelled", [("mid_x_mm", "mid_y_mm"), ("Mid_x_m", "Mid_y_m"), ("mid_X_m", "mid_Y_m"),
                                     ("front x", "front y")])
def test_a_marker_column_misspelled_is_named(tmp_path, spelled):
    """S1: ``mid_x_mm, mid_y_mm`` beside back and front: the mid marker was left out without a word."""
    columns = {"back_x_m": _moving(0.0), "back_y_m": 0 * _moving(0), "front_x_m": _moving(LENGTH),
               "front_y_m": 0 * _moving(0), spelled[0]: _moving(LENGTH / 2), spelled[1]: 0 * _moving(0)}
    _csv(tmp_path / "t.csv", columns)
    named = f"column\\(s\\) {spelled[0]}, {spelled[1]} look like a marker's"
    with pytest.raises(TrajectoryError, match=named):
        read_trajectory(tmp_path / "t.csv")


def test_msr_s_own_trajectory_columns_are_no_misspelling(tmp_path):
    """``height_max_m``, ``span_m`` and the markers' ``z`` columns of msr's trajectory.csv are no
    markers' misspellings."""
    zero = 0 * _moving(0)
    columns = {"mid_x_m": _moving(LENGTH / 2), "mid_y_m": zero, "back_x_m": _moving(0), "back_y_m": zero,
               "front_x_m": _moving(LENGTH), "front_y_m": zero, "height_max_m": zero, "span_m": zero + LENGTH,
               "mid_z_m": zero, "back_z_m": zero, "front_z_m": zero}
    _csv(tmp_path / "t.csv", columns)
    assert read_trajectory(tmp_path / "t.csv").points == ("back", "mid", "front")


@pytest.mark.parametrize("extra", [("x_0.5_m", "y_0.5_m"), ("mid_x_m", "mid_y_m")])
def test_a_tip_path_with_tracked_points_beside_it_is_refused(tmp_path, extra):
    """S2: a catheter's tip path with ``x_0.5_m, y_0.5_m`` beside it: the points were unused without
    a word."""
    zero = 0 * _moving(0)
    columns = {"tip_x_m": zero + 0.05, "tip_y_m": _moving(0), "tip_z_m": zero, extra[0]: zero + 0.025,
               extra[1]: _moving(0)}
    _csv(tmp_path / "tip.csv", columns)
    with pytest.raises(TrajectoryError, match=f"holds a catheter's tip path .* and tracked points' columns "
                                              f"\\({extra[0]}, {extra[1]}\\)"):
        read_trajectory(tmp_path / "tip.csv")


@pytest.mark.parametrize("line", ["   ", "\t", ""])
def test_a_blank_line_between_samples_is_named(tmp_path, line):
    """S3: a line of spaces, a tab or nothing between samples was dropped: every later sample played
    10 ms early (round 36 refused ``,,`` alone)."""
    rows = [f"{0.1 * k:.3f},0.200,0.000" for k in range(20)]
    (tmp_path / "f.csv").write_text("\n".join([*rows[:4], line, *rows[4:]]) + "\n")
    with pytest.raises(FieldCSVError, match="f.csv: line 5: a blank line between rows of values"):
        read_field_csv(tmp_path / "f.csv")


@pytest.mark.parametrize("key, value", [("hidden_sizes", [-256, 256]), ("hidden_sizes", [256, 0]),
                                        ("act_dim", -2), ("obs_dim", 0)])
def test_a_policy_file_with_an_impossible_size_is_named(tmp_path, capsys, key, value):
    """T1: a negative layer size in policy.json ended ``msr policy generate``/``export`` in torch's
    traceback."""
    import json
    import shutil
    from pathlib import Path

    from elastica_magnetic.cli import main as msr

    policy = tmp_path / "p"
    shutil.copytree(Path(__file__).resolve().parents[3] / "rl" / "policies" / "m1-4mT", policy)
    record = json.loads((policy / "policy.json").read_text())
    record["architecture"][key] = value
    (policy / "policy.json").write_text(json.dumps(record))
    shown = next(v for v in value if v < 1) if isinstance(value, list) else value
    for command in (["policy", "generate", str(policy), "--duration", "0.05", "--out", str(tmp_path / "g")],
                    ["policy", "export", str(policy), "--out", str(tmp_path / "e")]):
        assert msr(command) == 2
        err = capsys.readouterr().err
        assert f"policy.json: architecture.{key}: {shown} is not a size" in err and "Traceback" not in err


def test_spec_fits_better_in_the_accurate_physics():
    from elastica_magnetic_rl.sim2real.fit_report import spec_fits_better

    worse = {"physics": "accurate", "rms_m": 1.6e-5, "nominal_rms_m": 0.0}
    assert "the spec's own values reproduce the motion better (0.0000 mm RMS) than the fitted ones " \
           "(0.0160 mm)" in spec_fits_better(worse)
    assert spec_fits_better({**worse, "nominal_rms_m": 1.55e-5}) is None  # within noise of each other
    assert spec_fits_better({**worse, "physics": "training"}) is None  # a fit in the accurate physics


def test_identify_judges_nothing_the_training_physics_made_up(tmp_path, capsys):
    """S4: ``--fit robot.length`` on the accurate physics' own trajectory of the nominal robot: x0.945
    "identifiable" in [0.935, 0.954], the truth 12 standard errors away. In the accurate physics the
    spec's values reproduce the motion better than the fitted ones: nothing is judged."""
    import json
    from pathlib import Path

    from elastica_magnetic.cli import main as msr

    shipped = Path(__file__).resolve().parents[3] / "rl" / "policies" / "m1-4mT" / "fields.csv"
    fields = tmp_path / "f20.csv"
    fields.write_text("".join(shipped.read_text().splitlines(keepends=True)[:21]))
    assert msr(["field", "replay", str(fields), "--out", str(tmp_path / "R"), "--no-progress"]) == 0
    capsys.readouterr()
    assert msr(["real", "identify", str(fields), str(tmp_path / "R" / "trajectory.csv"), "--robot", "m1-4mT",
                "--fit", "robot.length", "--out", str(tmp_path / "X"), "--no-progress", "--max-evaluations",
                "20", "--starts", "1"]) == 0
    assert "NOT JUDGED: in the accurate physics the spec's own values reproduce the motion better" in (
        capsys.readouterr().out)
    fitted = json.loads((tmp_path / "X" / "identify.json").read_text())["fitted"]["robot.length"]
    assert fitted["identifiable"] is None and fitted["interval"] is None and fitted["factor_sigma"] is None
