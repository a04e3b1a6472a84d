"""``msr bench --quick --json`` reports every figure, positive and finite (no timing assertions)."""

from __future__ import annotations

import json
import math

from elastica_magnetic.cli import main as msr


def test_bench_quick_json_keys(capsys):
    capsys.readouterr()
    assert msr(["bench", "--quick", "--json", "--vector-envs", "4"]) == 0
    result = json.loads(capsys.readouterr().out)
    scalars = ("step_us", "naive_step_us", "speedup", "env_steps_per_s", "vector_env_steps_per_s",
               "td3_updates_per_s", "train_1e5_steps_s", "train_1e5_steps_vector_s")
    for key in scalars:
        assert math.isfinite(result[key]) and result[key] > 0, key
    assert set(result["per_robot_step_us"]) == {"1", "4", "16", "64"}
    assert all(math.isfinite(v) and v > 0 for v in result["per_robot_step_us"].values())
    assert result["train_1e5_steps_s"] == 1e5 * (1 / result["env_steps_per_s"]
                                                 + 1 / result["td3_updates_per_s"])
    assert result["training"]["step_us"] == result["step_us"] and result["quick"] is True
