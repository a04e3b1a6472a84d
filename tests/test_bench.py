"""``msr bench --quick --json`` reports every figure, positive and finite (no timing assertions)."""

from __future__ import annotations

import json
import math

import pytest

from elastica_magnetic.cli import main as msr


@pytest.mark.slow
def test_bench_quick_json_keys(capsys):
    capsys.readouterr()
    assert msr(["bench", "--quick", "--json", "--vector-envs", "4", "--train-seeds", "2"]) == 0
    captured = capsys.readouterr()
    result = json.loads(captured.out)
    # round 18 V50: the timing run's own few steps are no training to advise on
    assert "no training episode ends" not in captured.err
    scalars = ("step_us", "naive_step_us", "speedup", "env_steps_per_s", "vector_env_steps_per_s",
               "td3_updates_per_s", "train_1e5_steps_s", "train_1e5_steps_vector_s")
    for key in scalars:
        assert math.isfinite(result[key]) and result[key] > 0, key
    assert set(result["per_robot_step_us"]) == {"1", "4", "16", "64"}
    assert all(math.isfinite(v) and v > 0 for v in result["per_robot_step_us"].values())
    assert result["train_1e5_steps_s"] == 1e5 * (1 / result["env_steps_per_s"]
                                                 + 1 / result["td3_updates_per_s"])
    assert result["training"]["step_us"] == result["step_us"] and result["quick"] is True
    for physics in ("training", "accurate"):  # fields in space next to the uniform field (issue 33)
        spatial, ratio = result[physics]["spatial_step_us"], result[physics]["spatial_ratio_to_uniform"]
        assert set(spatial) == set(ratio) == {"uniform", "point_dipole", "moving_dipole", "helmholtz_pair"}
        assert all(math.isfinite(v) and v > 0 for v in spatial.values())
        assert all(ratio[k] == spatial[k] / spatial["uniform"] for k in spatial)
    batched = result["batched_spatial"]  # issue 53: each robot its own source, or its own arm's magnet
    assert set(batched["per_robot_step_us"]) == {"uniform", "point_dipole", "moving_dipole",
                                                 "helmholtz_pair", "field_map", "arm_magnet",
                                                 "arm_finite_magnet", "coil_currents"}
    assert all(math.isfinite(v) and v > 0 for v in batched["per_robot_step_us"].values())
    assert batched["ratio_to_uniform"]["arm_magnet"] == (batched["per_robot_step_us"]["arm_magnet"]
                                                         / batched["per_robot_step_us"]["uniform"])
    ground = result["ground_models"]  # issue 51: the implicit friction of a band beside PyElastica's
    assert set(ground["per_robot_step_us"]) == {"explicit_rolling", "explicit_sliding", "implicit_sliding"}
    assert all(math.isfinite(v) and v > 0 for v in ground["per_robot_step_us"].values())
    assert ground["ratio_to_explicit_rolling"]["implicit_sliding"] == (
        ground["per_robot_step_us"]["implicit_sliding"] / ground["per_robot_step_us"]["explicit_rolling"])
    assert result["recipe"] == "paper"  # the series of measurements is the paper recipe's
    roof = result["td3_roofline"]
    assert roof["achieved_gflops"] == roof["gflop_per_update"] * result["td3_updates_per_s"]
    assert math.isfinite(roof["sgemm_gflops"]) and roof["sgemm_gflops"] > 0
    assert math.isfinite(roof["bf16_gemm_gflops"]) and roof["bf16_gemm_gflops"] > 0
    for precision in ("fp32", "bf16"):
        assert set(result["td3_stacked_updates_per_s"][precision]) == {"1", "4"}
    # the 8-seed figure comes from a real run: two groups side by side on this 2-core machine's
    # default layout, each reporting where its time went
    timing = result["training_time"]
    assert result["train_8_seeds_1e5_s"] == timing["projected_s"] > 0
    # round 18 V51: how many seeds the figure is of, and the quick run's settings over the recipe
    assert result["train_seeds"] == 2 and timing["settings_over_recipe"]["hidden_sizes"] == [32, 32]
    assert len(timing["groups"]) * timing["seeds_per_simulator"] >= timing["seeds"] == 2
    assert all(g["update_per_step_s"] > 0 and g["env_per_step_s"] > 0 for g in timing["groups"])
    assert result["floor_8_seeds_1e5_s"] == pytest.approx(
        roof["floor_1e5_updates_s"] * 2 / result["cpu_count"])


def test_td3_update_flop_count_matches_torch_flop_counter():
    """The analytical FLOP count behind the TD3 roofline equals what torch counts for real updates
    (two updates: one without and one with the delayed actor step). It would differ if the actor
    step still computed the critic's weight gradients."""
    import numpy as np
    from elastica_magnetic_rl.reports.bench import td3_update_flops
    from elastica_magnetic_rl.td3.agent import TD3Agent
    from elastica_magnetic_rl.td3.config import TD3Config
    from elastica_magnetic_rl.td3.replay_buffer import Batch
    from torch.utils.flop_counter import FlopCounterMode

    agent = TD3Agent(260, 2, -np.ones(2), np.ones(2), TD3Config(seed=0, hidden_sizes=(64, 32)))
    rng = np.random.default_rng(0)
    b = 16
    batch = Batch(obs=rng.normal(size=(b, 260)).astype(np.float32),
                  actions=rng.uniform(-1, 1, (b, 2)).astype(np.float32),
                  rewards=rng.normal(size=b).astype(np.float32),
                  next_obs=rng.normal(size=(b, 260)).astype(np.float32),
                  terminated=np.zeros(b, np.float32))
    counted = 0
    for _ in range(agent.config.policy_delay):
        with FlopCounterMode(display=False) as counter:
            agent.update(batch)
        counted += counter.get_total_flops()
    assert counted / agent.config.policy_delay == td3_update_flops(agent, b)


def test_training_peak_memory_of_a_two_seed_run():
    """A real 2-seed run in 2 worker processes: the sampled peak of the process tree exceeds the
    parent's own memory by at least the two workers' interpreters, and the projection adds exactly
    the replay-buffer growth to 1e5 transitions per seed."""
    from elastica_magnetic_rl.reports.bench import replay_buffer_bytes, training_peak_memory

    result = training_peak_memory(seeds=2, steps=30, interval=0.05)
    assert result["peak_bytes"] > result["parent_baseline_bytes"] + 2 * 50e6
    assert replay_buffer_bytes(100_000) == 100_000 * (2 * 260 + 2 + 2) * 4  # 209.6 MB
    growth = 2 * (replay_buffer_bytes(100_000) - replay_buffer_bytes(30))
    assert result["projected_full_run_peak_bytes"] == result["peak_bytes"] + growth


def test_bench_text_prints_the_spatial_step_cost_and_its_ratio():
    """``msr bench`` in plain text: one line per source and physics with its cost and its ratio to
    the uniform field, flagged against the 2x target; a setting measured without the spatial
    sources is left out, and the nested dicts are not dumped raw."""
    from elastica_magnetic_rl.reports.bench import benchmark_text

    def cost(step: float, spatial: dict[str, float] | None) -> dict:
        out = {"step_us": step, "naive_step_us": 40 * step, "bare_step_us": 0.9 * step,
               "speedup_vs_naive": 40.0, "overhead_vs_bare": 1 / 0.9, "action_ms": step * 0.1,
               "substeps_per_action": 100}
        if spatial is not None:
            out["spatial_step_us"] = spatial
            out["spatial_ratio_to_uniform"] = {k: v / spatial["uniform"] for k, v in spatial.items()}
        return out

    result = {"step_us": 10.0, "training": cost(10.0, {"uniform": 10.0, "point_dipole": 14.0,
                                                       "helmholtz_pair": 25.0}),
              "accurate": cost(20.0, None)}
    text = benchmark_text(result)
    lines = text.splitlines()
    assert lines[0] == "step_us: 10.0"
    assert not any(line.startswith(("training:", "accurate:")) for line in lines)
    assert "fields in space, training physics" in text and "target <= 2x" in text
    assert "fields in space, accurate physics" not in text  # measured without the spatial sources
    dipole = next(line for line in lines if line.strip().startswith("point_dipole"))
    assert "14.00 us" in dipole and "1.40x" in dipole and dipole.endswith("ok")
    pair = next(line for line in lines if line.strip().startswith("helmholtz_pair"))
    assert "2.50x" in pair and pair.endswith("ABOVE TARGET")
    assert any(line.startswith("step cost, accurate physics: 20.00 us") for line in lines)
