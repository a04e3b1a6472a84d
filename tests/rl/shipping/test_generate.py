"""``msr policy generate`` and ``msr policy demo`` (rl/shipping/generate.py)."""

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


def test_best_actor_generates(trained, tmp_path, capsys):
    best = trained / "m1-4mT" / "seed0" / "best.pt"
    result = run_msr(capsys, "policy", "generate", str(best), "--duration", "0.05", "--physics", "training",
                     "--out", str(tmp_path / "gen"), "--no-figures", "--no-progress")
    assert result["case"] == "m1-4mT" and result["policy"] == str(best)


def test_generate_json_and_files(refined, tmp_path, capsys):
    out = tmp_path / "gen"
    result = run_msr(capsys, "policy", "generate", str(refined), "--duration", "0.2", "--out", str(out),
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
    assert msr(["policy", "demo", "--out", str(tmp_path / "demo"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "m1-4mT" in err and "actor.pt" in err and "msr policy ship" in err


def test_output_names_its_physics_and_claims_no_target_without_a_yardstick(tmp_path, capsys):
    from elastica_magnetic_rl.cases.case import load_case

    from elastica_magnetic.specfile import dumps

    spec = load_case("m1-4mT").to_dict()
    spec["yardstick"] = {"distance_10s": 0.0, "source": ""}
    del spec["name"]
    (tmp_path / "nostick.toml").write_text(dumps(spec))
    result = run_msr(capsys, "field", "baseline", "--case", str(tmp_path / "nostick.toml"), "--period",
                     "0.05",
                     "--duration", "0.05", "--physics", "training", "--out", str(tmp_path / "b"),
                     "--no-figures", "--no-progress")
    assert "meets_target" not in result and result["target"].startswith("none")
    assert "yardstick_10s_m" not in result and "authors_mid_dx_10s_m" not in result
    assert (result["physics"], result["initial_field"]) == ("training", "zero")
    assert "mid_node_dx_m" in result and "node32_dx_m" not in result
    with_stick = run_msr(capsys, "field", "baseline", "--case", "m1-4mT", "--period", "0.05", "--duration",
                         "0.05", "--out", str(tmp_path / "c"), "--no-figures", "--no-progress")
    assert with_stick["yardstick_10s_m"] == 0.0205
    assert "meets_target" not in with_stick  # 0.05 s is not the yardstick's 10 s


def test_old_generate_json_keys_are_read(tmp_path):
    import json

    from elastica_magnetic_rl.shipping.generate import read_generate_json

    (tmp_path / "generate.json").write_text(json.dumps({"node32_dx_m": 0.01, "mid_dx_m": 0.02,
                                                        "authors_mid_dx_10s_m": 0.0205}))
    data = read_generate_json(tmp_path / "generate.json")
    assert data["mid_node_dx_m"] == 0.01 and data["yardstick_10s_m"] == 0.0205


def test_a_10s_accurate_run_of_a_case_without_a_yardstick_has_no_verdict():
    """Issue 34: ``meets_target`` is absent (not true for any forward motion) in generate's result
    of a case without a yardstick, and present for one with a yardstick."""
    from types import SimpleNamespace

    from elastica_magnetic_rl.cases.case import NO_TARGET, case_from_dict, load_case

    spec = load_case("m1-4mT").to_dict() | {"name": "nostick"}
    spec["yardstick"] = {"distance_10s": 0.0, "source": ""}
    nostick = case_from_dict(spec, "nostick.toml")
    positions = np.zeros((2, 3, 33))
    positions[1, 0, :] = 0.03  # every node 30 mm forward
    rollout = SimpleNamespace(times=np.array([0.0, 10.0]), mid_dx=0.03, positions=positions,
                              meta={"diverged": None})
    verdict = generate._verdict(nostick, rollout, "accurate")
    assert verdict == {"target": NO_TARGET}
    paper = generate._verdict(load_case("m1-4mT"), rollout, "accurate")
    assert paper["meets_target"] is True and paper["yardstick_10s_m"] == 0.0205
    assert "meets_target" not in generate._verdict(load_case("m1-4mT"), rollout, "training")
