"""``msr figures`` (rl/reports/figures.py) of training runs."""

from __future__ import annotations

from pathlib import Path

from smoke import run_msr


def test_figures_from_training_runs(trained, tmp_path, capsys):
    result = run_msr(capsys, "figures", str(trained), "--out", str(tmp_path))
    assert Path(result["learning_curves_m1-4mT"]).stat().st_size > 1000
