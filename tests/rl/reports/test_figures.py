"""``msr policy figures`` (rl/reports/figures.py) of training runs."""

from __future__ import annotations

from pathlib import Path

from smoke import run_msr


def test_figures_from_training_runs(trained, tmp_path, capsys):
    result = run_msr(capsys, "policy", "figures", str(trained), "--out", str(tmp_path))
    assert Path(result["learning_curves_m1-4mT"]).stat().st_size > 1000


def test_learning_curves_name_the_runs_physics(trained, tmp_path):
    import json

    from elastica_magnetic_rl.reports.figures import _runs_physics

    runs = sorted((trained / "m1-4mT").glob("seed*"))
    assert _runs_physics(runs) == "training"
    other = tmp_path / "seed9"
    other.mkdir()
    (other / "run.json").write_text(json.dumps({"physics": "accurate"}))
    assert _runs_physics([*runs, other]) == "training, accurate"
