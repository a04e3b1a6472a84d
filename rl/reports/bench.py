"""Learning benchmarks (``msr bench``): environment steps, TD3 updates against the machine's
matrix-product rate, the wall time of a real multi-seed training run, and its peak memory.

They sit on top of the physics package (its step-cost benchmarks are
:mod:`elastica_magnetic.bench`) and of :mod:`elastica_magnetic_rl`; :func:`benchmark` is everything ``msr
bench``
reports, measured in one run. Medians over repeated measurements; machines here are noisy, so
compare numbers within one run.
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time
import warnings
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from elastica_magnetic.bench import (
    BATCH_SIZES,
    batched_spatial_step_cost,
    benchmark_step_cost,
    ground_model_step_cost,
    per_robot_step_cost,
)

from ..runfiles.rundir import CaseDir
from ..runner.memory import process_tree_rss

#: The start of the training checks' warning that a run ends no episode: the measurements' own short
#: runs end none, as meant, and its advice names options of msr train, not of msr bench.
_NO_EPISODE_ENDS = "no training episode ends within the run"
#: The recipe every TD3 and training measurement here uses: the paper's, with which the series of
#: measurements began (docs/performance.md), whatever the cases' default recipe is now.
BENCH_RECIPE = "paper"

__all__ = [
    "benchmark",
    "benchmark_text",
    "env_steps_per_s",
    "gemm_gflops",
    "replay_buffer_bytes",
    "spatial_cost_lines",
    "step_cost_lines",
    "td3_roofline",
    "td3_update_flops",
    "td3_updates_per_s",
    "training_peak_memory",
    "training_time",
    "vector_env_steps_per_s",
]


# --------------------------------------------------------------------------------------------------
# Environment steps and TD3 updates
# --------------------------------------------------------------------------------------------------
def _timed_rate(step: Callable[[], Any], count: int, repeats: int, per_call: int = 1) -> float:
    """Median over ``repeats`` of ``count * per_call`` / wall time of ``count`` calls, per s."""
    step()  # warm
    rates = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(count):
            step()
        rates.append(count * per_call / (time.perf_counter() - start))
    return statistics.median(rates)


def env_steps_per_s(steps: int = 200, repeats: int = 3, physics: str = "training") -> float:
    """Steps per second of :class:`elastica_magnetic_rl.envs.env.MagneticCrawlerEnv` (pattern 1, 4 mT; 0.01 s
    each: 100 substeps in training physics), random actions, episodes never ending during the run."""
    from ..envs.env import MagneticCrawlerEnv

    env = MagneticCrawlerEnv(1, 4e-3, physics=physics, duration=1e6)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    return _timed_rate(lambda: env.step(rng.uniform(-1.0, 1.0, 2).astype(np.float32)), steps, repeats)


def vector_env_steps_per_s(
    n_envs: int = 16, vector_steps: int = 20, repeats: int = 3, physics: str = "training"
) -> float:
    """Environment transitions per second of
    :class:`elastica_magnetic_rl.envs.vector_env.MagneticCrawlerVectorEnv` with
    ``n_envs`` crawlers in one simulator (``n_envs`` transitions per vector step)."""
    from ..envs.vector_env import MagneticCrawlerVectorEnv

    env = MagneticCrawlerVectorEnv(n_envs, 1, 4e-3, physics=physics, duration=1e6)
    env.reset(seed=0)
    rng = np.random.default_rng(0)

    def step() -> None:
        env.step(rng.uniform(-1.0, 1.0, (n_envs, 2)).astype(np.float32))

    return _timed_rate(step, vector_steps, repeats, per_call=n_envs)


def _paper_obs_dim() -> int:
    """Observation size of the benchmarked case (``m1-4mT``, the paper's robot: 260)."""
    from ..cases.case import load_case

    return load_case("m1-4mT").obs_dim


def td3_updates_per_s(updates: int = 200, repeats: int = 3, threads: int = 1, seeds: int = 1,
                      precision: str = "fp32") -> float:
    """TD3 gradient updates per second *per seed* with the paper crawler's settings (260 observations, 2
    actions, 256-256 networks, minibatch 256, target-noise clip 0.8) on ``threads`` torch threads, ``seeds``
    seeds updated as one stacked computation (:class:`elastica_magnetic_rl.td3.algorithm.TD3`), from replay
    buffers of random transitions."""
    import torch

    from ..cases.recipes import crawler_config
    from ..runner.allocator import retain_freed_memory
    from ..td3.algorithm import TD3
    from ..td3.replay_buffer import ReplayBuffer

    retain_freed_memory()  # as training does (rl/runner/loop.py)
    previous = torch.get_num_threads()
    torch.set_num_threads(threads)
    try:
        configs = [crawler_config(s, BENCH_RECIPE, precision=precision) for s in range(seeds)]
        obs_dim, act_dim = _paper_obs_dim(), 2
        learner = TD3(obs_dim, act_dim, -np.ones(act_dim), np.ones(act_dim), configs)
        buffer = ReplayBuffer(10_000, obs_dim, act_dim)
        rng = np.random.default_rng(0)
        for _ in range(buffer.capacity):
            buffer.add(rng.normal(size=obs_dim), rng.uniform(-1, 1, act_dim), rng.normal(),
                       rng.normal(size=obs_dim), False)
        batch = configs[0].batch_size
        return _timed_rate(lambda: learner.update([buffer.sample(batch, learner.rngs[k])
                                                   for k in range(seeds)]),
                           updates, repeats, per_call=seeds)
    finally:
        torch.set_num_threads(previous)


def _linear_shapes(module: Any) -> list[tuple[int, int]]:
    """``(in_features, out_features)`` of the ``nn.Linear`` layers of ``module``, in order."""
    import torch.nn as nn

    return [(m.in_features, m.out_features) for m in module.modules() if isinstance(m, nn.Linear)]


def td3_update_flops(agent: Any, batch_size: int) -> float:
    """Floating-point operations of one seed's :meth:`elastica_magnetic_rl.td3.algorithm.TD3.update`, averaged
    over the policy delay, counting the matrix products only (``2 * batch * in * out`` per product; biases,
    activations and Adam are below 1 % here).

    Per update: the target (target actor and both target critics forward); the critics (forward,
    weight gradients, input gradients of every layer but the first); every ``policy_delay``-th
    update the actor (actor and Q1 forward, Q1 input gradients down to the action, actor weight
    gradients and input gradients of every layer but the first; the critic's weights are frozen).
    """
    actor = _linear_shapes(agent.actor)
    q1, q2 = _linear_shapes(agent.critic.q1_net), _linear_shapes(agent.critic.q2_net)

    def macs(layers: list[tuple[int, int]]) -> int:
        return sum(i * o for i, o in layers)

    target = macs(actor) + macs(q1) + macs(q2)
    critics = 2 * (macs(q1) + macs(q2)) + macs(q1[1:]) + macs(q2[1:])
    actor_step = 3 * macs(actor) + 2 * macs(q1) - macs(actor[:1])
    per_sample = target + critics + actor_step / agent.config.policy_delay
    return 2.0 * batch_size * per_sample


def gemm_gflops(shapes: Sequence[tuple[int, int, int]], repeats: int = 3, threads: int = 1,
                min_time: float = 0.2, dtype: str = "fp32") -> float:
    """Matrix-product rate of torch on this machine (GFLOP/s, ``threads`` threads, ``dtype``
    ``"fp32"`` or ``"bf16"``): the median over ``repeats`` of products ``(m, k) @ (k, n)`` cycled
    over ``shapes`` for at least ``min_time`` s. With the network's own shapes this is the
    ceiling of a TD3 update."""
    import torch

    previous = torch.get_num_threads()
    torch.set_num_threads(threads)
    try:
        gen = torch.Generator().manual_seed(0)
        torch_dtype = {"fp32": torch.float32, "bf16": torch.bfloat16}[dtype]
        pairs = [(torch.randn(m, k, generator=gen).to(torch_dtype),
                  torch.randn(k, n, generator=gen).to(torch_dtype)) for m, k, n in shapes]
        flop = sum(2.0 * m * k * n for m, k, n in shapes)
        for a, b in pairs:  # warm
            a @ b
        rates = []
        for _ in range(repeats):
            count, start = 0, time.perf_counter()
            while (elapsed := time.perf_counter() - start) < min_time or count == 0:
                for a, b in pairs:
                    a @ b
                count += 1
            rates.append(count * flop / elapsed / 1e9)
        return statistics.median(rates)
    finally:
        torch.set_num_threads(previous)


def td3_roofline(updates_per_s: float, repeats: int = 3, quick: bool = False) -> dict[str, float]:
    """Where the TD3 update stands against this machine's matrix-product rate (one thread).

    Returns ``gflop_per_update`` (:func:`td3_update_flops` of the crawler's agent, batch 256),
    ``sgemm_gflops`` and ``bf16_gemm_gflops`` (:func:`gemm_gflops` over the update's forward
    shapes, float32 and bfloat16), ``achieved_gflops`` (``gflop_per_update * updates_per_s``),
    ``fraction_of_sgemm`` and ``floor_1e5_updates_s`` (1e5 updates at the float32 rate: no
    float32 implementation on this core does them faster)."""
    from ..cases.recipes import crawler_config
    from ..td3.agent import TD3Agent

    cfg = crawler_config(0, BENCH_RECIPE)
    agent = TD3Agent(_paper_obs_dim(), 2, -np.ones(2), np.ones(2), cfg)
    flop = td3_update_flops(agent, cfg.batch_size)
    shapes = [(cfg.batch_size, i, o) for net in (agent.actor, agent.critic.q1_net)
              for i, o in _linear_shapes(net)]
    timing = {"repeats": 1 if quick else repeats, "min_time": 0.02 if quick else 0.2}
    rate = gemm_gflops(shapes, **timing)
    bf16_rate = gemm_gflops(shapes, dtype="bf16", **timing)
    gflop = flop / 1e9
    achieved = gflop * updates_per_s
    return {
        "gflop_per_update": gflop,
        "sgemm_gflops": rate,
        "bf16_gemm_gflops": bf16_rate,
        "achieved_gflops": achieved,
        "fraction_of_sgemm": achieved / rate,
        "floor_1e5_updates_s": 1e5 * flop / (rate * 1e9),
        "bf16_floor_1e5_updates_s": 1e5 * flop / (bf16_rate * 1e9),
    }


# --------------------------------------------------------------------------------------------------
# Memory of a multi-seed training run
# --------------------------------------------------------------------------------------------------
def replay_buffer_bytes(capacity: int, obs_dim: int = 260, act_dim: int = 2) -> int:
    """Bytes of a full :class:`elastica_magnetic_rl.td3.replay_buffer.ReplayBuffer`: float32 obs,
    next obs, action, reward and terminated per transition."""
    from ..runfiles.checkpoint import replay_row_width

    return int(capacity) * replay_row_width(obs_dim, act_dim) * 4


def training_peak_memory(
    seeds: int = 8,
    steps: int = 3000,
    full_steps: int = 100_000,
    case: str = "m1-4mT",
    out: str | os.PathLike | None = None,
    interval: float = 0.2,
) -> dict[str, Any]:
    """Peak resident memory of a real ``seeds``-seed training run in the default layout (``msr
    train --seeds N``: one worker process per core, the seeds shared among them), sampled every
    ``interval`` s over the whole process tree (Linux ``/proc``).

    The run lasts ``steps`` environment steps per seed (past the 2500 warm-up steps, so networks,
    optimisers and TD3 updates are live). The only memory that grows with the run length is the
    replay buffer, sized to the run and filled as it goes: ``projected_full_run_peak_bytes`` adds
    ``seeds`` x the buffer bytes of ``full_steps`` minus those of ``steps``.
    """
    import threading

    from ..sweep.training import train_case

    if not os.path.isdir("/proc"):
        raise RuntimeError("training_peak_memory reads /proc: Linux only")
    root = os.getpid()
    baseline = process_tree_rss(root)
    peak = [baseline]
    done = threading.Event()

    def sample() -> None:
        while not done.wait(interval):
            peak[0] = max(peak[0], process_tree_rss(root))

    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=_NO_EPISODE_ENDS)  # a measurement: no training advice
        monitor = threading.Thread(target=sample, daemon=True)
        monitor.start()
        try:
            # warm_up_only: a run shorter than the warm-up (a quick measure) is still measured
            summary = train_case(case, seeds=seeds, steps=steps, recipe=BENCH_RECIPE,
                                 out=out if out is not None else tmp, progress=False,
                                 warm_up_only=True)
        finally:
            done.set()
            monitor.join()
    if summary["failed"]:
        raise RuntimeError(f"seeds {summary['failed']} failed: "
                           + "; ".join(str(r.get("error")) for r in summary["seeds"] if "error" in r))
    growth = seeds * (replay_buffer_bytes(full_steps) - replay_buffer_bytes(steps))
    return {
        "seeds": seeds,
        "workers": summary["workers"],
        "seeds_per_simulator": summary["seeds_per_simulator"],
        "steps_per_seed": steps,
        "peak_bytes": peak[0],
        "parent_baseline_bytes": baseline,
        "replay_buffer_bytes_per_seed_at_full": replay_buffer_bytes(full_steps),
        "full_steps": full_steps,
        "projected_full_run_peak_bytes": peak[0] + growth,
        "wall_s": time.perf_counter() - start,
    }


# --------------------------------------------------------------------------------------------------
# Wall time of a real multi-seed training run
# --------------------------------------------------------------------------------------------------
def _group_timings(summary: dict[str, Any]) -> list[dict[str, float]]:
    """One timing dict per group of a summary (each seed of a group reports its group's)."""
    seen, out = set(), []
    for r in summary["seeds"]:
        key = tuple(r.get("group_seeds") or [r["seed"]])
        if key not in seen and r.get("group_timing_s"):
            seen.add(key)
            out.append({k: float(v) for k, v in r["group_timing_s"].items()})
    return out


def training_time(
    seeds: int = 8,
    case: str = "m1-4mT",
    window: int = 1000,
    full_steps: int = 100_000,
    precision: str | None = None,
    overrides: dict[str, Any] | None = None,
    recipe: str = BENCH_RECIPE,
) -> dict[str, Any]:
    """Wall time of ``seeds`` seeds x ``full_steps`` steps of ``case`` with ``recipe`` (without
    its stop rule: every seed runs the whole budget; ``precision``: the recipe's unless given) in
    the default layout
    (:func:`elastica_magnetic_rl.sweep.training.default_layout`), extrapolated from a real run: the warm-up,
    then ``window`` steps of learning (a resume of the same run), each group's time split by the training loop
    into acting, environment, storing, updates, logs, evaluations and checkpoints.

    Projection per group: the measured warm-up, plus the learning window's per-step cost x the
    remaining steps, plus one evaluation round per ``eval_every`` (crawler default 5000) and one
    checkpoint per ``checkpoint_every`` (10000) at their measured costs. Groups run side by side on
    the workers, so the wall time is the slowest group's x the number of rounds of groups.
    """
    from ..cases.recipes import crawler_config
    from ..sweep.training import train_case

    settings = {**({"precision": precision} if precision else {}), **(overrides or {})}
    cfg = crawler_config(0, recipe, **settings)
    warm = cfg.learning_starts
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        # a timing run, not a training: its few steps end no episode, as meant (the training
        # checks' advice names options of msr train, not of this measurement)
        warnings.filterwarnings("ignore", message=_NO_EPISODE_ENDS)
        start = time.perf_counter()
        first = train_case(case, seeds=seeds, steps=warm, out=tmp, config_overrides=settings,
                           recipe=recipe, stop_when="none", progress=False,
                           warm_up_only=True)  # the warm-up alone, timed; learning resumes it
        second = train_case(case, seeds=seeds, steps=warm + window, out=tmp, resume=True,
                            config_overrides=settings, recipe=recipe, stop_when="none",
                            progress=False)
        wall = time.perf_counter() - start
        evaluations = []
        for r in second["seeds"]:
            path = CaseDir.of(tmp, case).seed(r["seed"]).evaluations_csv
            evaluations.append(max(0, len(path.read_text().splitlines()) - 1) if path.is_file() else 0)
    if first["failed"] or second["failed"]:
        raise RuntimeError(f"seeds {first['failed'] or second['failed']} failed")
    groups, workers = len(_group_timings(second)), int(second["workers"])
    eval_rounds = max(evaluations) if evaluations else 0
    per_group = []
    for before, after in zip(_group_timings(first), _group_timings(second), strict=True):
        loop = ("act", "env", "store", "update", "log")
        learning = sum(after[k] - before[k] for k in loop)  # the window
        t_eval = after["evaluation"] / eval_rounds if eval_rounds else 0.0
        t_ckpt = after["checkpoint"] / 2  # the warm-up's final and the window's final checkpoint
        n_eval = full_steps // cfg.eval_every if cfg.eval_every else 0
        n_ckpt = full_steps // cfg.checkpoint_every
        projected = (sum(before[k] for k in loop) + (full_steps - warm) / window * learning
                     + n_eval * t_eval + n_ckpt * t_ckpt)
        per_group.append({"projected_s": projected, "warmup_s": sum(before[k] for k in loop),
                          "learning_per_step_s": learning / window,
                          "update_per_step_s": (after["update"] - before["update"]) / window,
                          "env_per_step_s": (after["env"] - before["env"]) / window,
                          "evaluation_round_s": t_eval, "checkpoint_s": t_ckpt})
    rounds = -(-groups // max(1, workers))
    return {
        "seeds": seeds, "case": case, "recipe": recipe, "precision": cfg.precision,
        "settings_over_recipe": {k: list(v) if isinstance(v, tuple) else v for k, v in settings.items()},
        "full_steps": full_steps,
        "window_steps": window, "workers": workers,
        "seeds_per_simulator": int(second["seeds_per_simulator"]),
        "threads_per_worker": int(second["torch_threads_per_worker"]),
        "groups": per_group,
        "projected_s": rounds * max(g["projected_s"] for g in per_group),
        "measured_wall_s": wall,
    }


#: The most steps per step-cost measurement and repeats of ``--quick`` (its tiny sizes).
QUICK_STEPS, QUICK_REPEATS = 200, 1


def _sizes(steps: int, repeats: int, quick: bool) -> dict[str, int]:
    """How much each measurement of :func:`benchmark` runs (``quick``: tiny, for tests)."""
    if quick:
        return {"steps": min(steps, QUICK_STEPS), "repeats": QUICK_REPEATS, "robot_steps": 100,
                "env_steps": 10, "vector_steps": 3, "updates": 10}
    return {"steps": steps, "repeats": repeats, "robot_steps": 6400, "env_steps": 200,
            "vector_steps": 20, "updates": 200}


def _simulation_rates(sizes: dict[str, int], vector_envs: int) -> dict[str, Any]:
    """Step cost of the paper's robot (both physics, with the fields in space next to the uniform
    one), per-robot-step cost of the batched simulator, and environment steps/s."""
    repeats = sizes["repeats"]
    cost = benchmark_step_cost(sizes["steps"], repeats)
    training = cost["training"]
    return {
        "step_us": training["step_us"],
        "naive_step_us": training["naive_step_us"],
        "speedup": training["speedup_vs_naive"],
        "per_robot_step_us": per_robot_step_cost(BATCH_SIZES, sizes["robot_steps"], repeats)["batched"],
        "batched_spatial": batched_spatial_step_cost(16, max(100, sizes["robot_steps"] // 16), repeats),
        "ground_models": ground_model_step_cost(16, max(100, sizes["robot_steps"] // 16), repeats),
        "env_steps_per_s": env_steps_per_s(sizes["env_steps"], repeats),
        "vector_envs": vector_envs,
        "vector_env_steps_per_s": vector_env_steps_per_s(vector_envs, sizes["vector_steps"], repeats),
        "training": cost["training"],
        "accurate": cost["accurate"],
    }


def _learning_rates(sizes: dict[str, int], quick: bool) -> dict[str, Any]:
    """TD3 updates/s (one seed; 1 and 4 seeds stacked, fp32 and bf16) and their roofline."""
    updates, repeats = sizes["updates"], sizes["repeats"]
    td3_rate = td3_updates_per_s(updates, repeats)
    stacked = {precision: {str(k): td3_updates_per_s(max(1, updates // k), repeats, seeds=k,
                                                     precision=precision) for k in (1, 4)}
               for precision in ("fp32", "bf16")}
    return {"td3_updates_per_s": td3_rate, "td3_stacked_updates_per_s": stacked,
            "td3_roofline": td3_roofline(td3_rate, repeats, quick)}


def _training_figures(train_seeds: int, quick: bool, floor_1e5_updates_s: float, cpus: int) -> dict[str, Any]:
    """The wall time of ``train_seeds`` seeds x 1e5 steps, from a real run (:func:`training_time`),
    next to the floor the matrix-product rate sets."""
    timing = (training_time(train_seeds, window=20, full_steps=100_000,
                            overrides={"learning_starts": 20, "hidden_sizes": (32, 32), "batch_size": 16})
              if quick else training_time(train_seeds))
    return {"training_time": timing, "train_seeds": train_seeds, "train_8_seeds_1e5_s": timing["projected_s"],
            "floor_8_seeds_1e5_s": floor_1e5_updates_s * train_seeds / cpus,
            "train_8_seeds_target_s": 45 * 60.0}


def benchmark(
    steps: int = 1000,
    repeats: int = 3,
    quick: bool = False,
    vector_envs: int = 16,
    train_seeds: int = 8,
) -> dict[str, Any]:
    """Everything ``msr bench`` reports, measured in one run (training physics unless noted).

    Keys: ``step_us``, ``naive_step_us``, ``speedup`` (one time step of the paper's robot, us, ours
    vs per-element Python loops, training physics; both physics in ``training`` / ``accurate``,
    each with ``spatial_step_us`` and ``spatial_ratio_to_uniform``: the step under a point dipole,
    a moving dipole and a Helmholtz pair next to the uniform field, target at most 2x),
    ``per_robot_step_us`` ``{"1", "4", "16", "64"}`` (us per robot-step, batched simulator),
    ``ground_models`` (:func:`~elastica_magnetic.bench.ground_model_step_cost`: the batched step on
    PyElastica's explicit friction, rolling or sliding, and on a band's implicit friction),
    ``env_steps_per_s`` (single environment, one 0.01 s action = 100 substeps),
    ``vector_env_steps_per_s`` (transitions/s, ``vector_envs`` crawlers in one simulator),
    ``td3_updates_per_s`` (one seed, one torch thread), ``td3_stacked_updates_per_s`` (per-seed
    update rates of 1 and 4 seeds stacked, fp32 and bf16, one thread: whether stacking pays),
    ``train_1e5_steps_s`` (projected wall time of a 1e5-step seed on one core:
    ``1e5 * (1 / env_steps_per_s + 1 / td3_updates_per_s)``, s), ``train_1e5_steps_vector_s``
    (the same with the vector environment's simulation cost),
    ``td3_roofline`` (:func:`td3_roofline`: the update's FLOP count against this core's
    matrix-product rates, and the floor they set on 1e5 updates), ``train_8_seeds_1e5_s`` (the
    wall time of ``train_seeds`` seeds x 1e5 steps in the default layout, from
    :func:`training_time`; details in ``training_time``), ``floor_8_seeds_1e5_s``
    (``floor_1e5_updates_s x train_seeds / cores``), the load average and the CPU count. Every TD3
    and training number uses ``recipe`` (:data:`BENCH_RECIPE`, the paper's).
    ``quick``: tiny measurements (for tests; numbers are rough). ``train_seeds = 0`` skips the
    training run. :func:`benchmark_text` writes the result as plain text.
    """
    sizes = _sizes(steps, repeats, quick)
    load_before = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    cpus = os.cpu_count() or 1
    start = time.perf_counter()
    result = _simulation_rates(sizes, vector_envs) | _learning_rates(sizes, quick)
    td3_rate = result["td3_updates_per_s"]
    result["train_1e5_steps_s"] = 1e5 * (1.0 / result["env_steps_per_s"] + 1.0 / td3_rate)
    result["train_1e5_steps_vector_s"] = 1e5 * (1.0 / result["vector_env_steps_per_s"] + 1.0 / td3_rate)
    result["per_robot_step_target_us_at_16"] = 12.0
    if train_seeds:
        result |= _training_figures(train_seeds, quick, result["td3_roofline"]["floor_1e5_updates_s"], cpus)
    return {
        **result,
        "steps": sizes["steps"],
        "repeats": sizes["repeats"],
        "quick": quick,
        "recipe": BENCH_RECIPE,
        "cpu_count": cpus,
        "load_average_1min": load_before,
        "wall_s": time.perf_counter() - start,
        "note": "wall-clock medians on this machine under its current load; train_1e5_steps_*: "
                "environment steps and TD3 updates of one seed on one core, one after the other; "
                "train_8_seeds_1e5_s: extrapolated from a real run in the default layout",
    }


# --------------------------------------------------------------------------------------------------
# Plain-text report
# --------------------------------------------------------------------------------------------------
#: Issue 33's target: a step under a point dipole or a coil pair costs at most this many times the
#: uniform field's.
SPATIAL_TARGET_RATIO = 2.0


def spatial_cost_lines(result: dict[str, Any]) -> list[str]:
    """The step cost under fields in space next to the uniform field, one line per physics setting
    and source: ``us`` per time step and the ratio to the uniform field of the same run, against
    :data:`SPATIAL_TARGET_RATIO`. ``result``: :func:`benchmark`'s (or
    :func:`elastica_magnetic.bench.benchmark_step_cost`'s) dict; settings without spatial numbers
    are left out."""
    lines = []
    for physics in ("training", "accurate"):
        cost = result.get(physics)
        if not isinstance(cost, dict) or "spatial_step_us" not in cost:
            continue
        step_us, ratio = cost["spatial_step_us"], cost["spatial_ratio_to_uniform"]
        uniform = step_us["uniform"]
        lines.append(f"fields in space, {physics} physics (us per time step of the paper's robot; "
                     f"ratio to the uniform field, target <= {SPATIAL_TARGET_RATIO:g}x):")
        lines.append(f"  {'uniform':16s} {uniform:9.2f} us")
        for name, value in step_us.items():
            if name == "uniform":
                continue
            verdict = "ok" if ratio[name] <= SPATIAL_TARGET_RATIO else "ABOVE TARGET"
            lines.append(f"  {name:16s} {value:9.2f} us  {ratio[name]:5.2f}x  {verdict}")
    batched = result.get("batched_spatial")
    if isinstance(batched, dict):
        step_us, ratio = batched["per_robot_step_us"], batched["ratio_to_uniform"]
        lines.append(f"fields in space, batched ({batched['robots']} robots, {batched['physics']} physics; "
                     f"us per robot-step, ratio to the uniform field, target <= {SPATIAL_TARGET_RATIO:g}x):")
        for name, value in step_us.items():
            verdict = "" if name == "uniform" else (
                "  ok" if ratio[name] <= SPATIAL_TARGET_RATIO else "  ABOVE TARGET")
            lines.append(f"  {name:16s} {value:9.2f} us  {ratio[name]:5.2f}x{verdict}")
    return lines


def ground_model_lines(result: dict[str, Any]) -> list[str]:
    """The batched step on each ground model, with its ratio to PyElastica's explicit friction."""
    models = result.get("ground_models")
    if not isinstance(models, dict):
        return []
    lines = [f"ground models, batched ({models['robots']} robots, {models['physics']} physics; us per "
             "robot-step, ratio to PyElastica's explicit rolling friction):"]
    for name, value in models["per_robot_step_us"].items():
        lines.append(f"  {name:16s} {value:9.2f} us  {models['ratio_to_explicit_rolling'][name]:5.2f}x")
    return lines


def step_cost_lines(result: dict[str, Any]) -> list[str]:
    """One line per physics setting: our step, the per-element Python loops' and the bare rod's."""
    lines = []
    for physics in ("training", "accurate"):
        cost = result.get(physics)
        if not isinstance(cost, dict) or "step_us" not in cost:
            continue
        lines.append(f"step cost, {physics} physics: {cost['step_us']:.2f} us per time step "
                     f"({cost['speedup_vs_naive']:.1f}x faster than per-element loops, "
                     f"{cost['overhead_vs_bare']:.2f}x the bare rod's), "
                     f"{cost['action_ms']:.2f} ms per action of {cost['substeps_per_action']} steps")
        if "held_step_us" in cost:
            lines.append(f"  on the batched kernel (the same trajectory): {cost['held_step_us']:.2f} us per "
                         f"time step under a held field ({cost['held_speedup']:.2f}x the per-rod "
                         f"{cost['per_rod_step_us']:.2f} us), {cost['rotating_step_us']:.2f} us under a "
                         f"rotating field ({cost['rotating_speedup']:.2f}x)")
    return lines


def benchmark_text(result: dict[str, Any]) -> str:
    """:func:`benchmark`'s result as plain text: ``key: value`` lines for the scalar figures, then
    the step cost of both physics settings and the fields-in-space table (:func:`spatial_cost_lines`)."""
    nested = ("training", "accurate", "batched_spatial", "ground_models")
    lines = [f"{key}: {value}" for key, value in result.items() if key not in nested]
    tables = step_cost_lines(result) + spatial_cost_lines(result) + ground_model_lines(result)
    return "\n".join(lines + tables)
