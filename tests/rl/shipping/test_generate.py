"""``msr generate`` and ``msr demo`` (rl/shipping/generate.py)."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from elastica_magnetic_rl.shipping import generate
from smoke import run_msr

from elastica_magnetic import read_field_csv
from elastica_magnetic.cli import main as msr
from elastica_magnetic.simulation import TRAJECTORY_COLUMNS


def test_best_actor_generates_but_does_not_refine(trained, tmp_path, capsys):
    best = trained / "m1-4mT" / "seed0" / "best.pt"
    result = run_msr(capsys, "generate", str(best), "--duration", "0.05", "--physics", "training",
                     "--out", str(tmp_path / "gen"), "--no-figures", "--no-progress")
    assert result["case"] == "m1-4mT" and result["policy"] == str(best)
    assert msr(["refine", str(best), "--steps", "2", "--no-progress"]) == 2
    assert "best evaluation" in capsys.readouterr().err


def test_generate_json_and_files(refined, tmp_path, capsys):
    out = tmp_path / "gen"
    result = run_msr(capsys, "generate", str(refined), "--duration", "0.2", "--out", str(out),
                     "--no-progress")
    for key in ("mid_dx_m", "fields_csv", "trajectory_csv"):
        assert key in result
    assert np.isfinite(result["mid_dx_m"]) and result["physics"] == "accurate"
    assert not result["diverged"]
    header = Path(result["fields_csv"]).read_text().splitlines()[0]
    assert header == ",mag_x,mag_y,mag_z"
    fields = read_field_csv(result["fields_csv"])
    assert fields.shape == (20, 3)
    assert np.all(np.abs(fields[0, :2]) <= 0.3e-3 + 1e-12)  # from zero, one increment
    assert np.all(np.abs(np.diff(fields[:, :2], axis=0)) <= 0.3e-3 + 1e-12)
    with open(result["trajectory_csv"]) as f:
        rows = list(csv.reader(f))
    assert tuple(rows[0]) == TRAJECTORY_COLUMNS and len(rows) == 22 and float(rows[1][0]) == 0.0
    assert float(rows[-1][0]) == pytest.approx(0.2)
    figures = result["figures"]
    for name in ("positions_velocities", "field_waveforms", "field_polar", "height_span_contact",
                 "q_values", "filmstrip", "gait_gif"):
        assert Path(figures[name]).stat().st_size > 1000, name
    assert Path(figures["gait_gif"]).read_bytes()[:3] == b"GIF"
    with open(result["gait_csv"]) as f:
        gait = list(csv.DictReader(f))
    assert len(gait) == 21 and float(gait[0]["contact_back"]) == 1.0


def test_demo_names_the_missing_policy(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(generate, "POLICIES_DIR", tmp_path / "none")
    assert msr(["demo", "--out", str(tmp_path / "demo"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "m1-4mT" in err and "actor.pt" in err and "msr ship" in err
