"""Step-cost benchmark of the paper's robot (``msr bench``, ``benchmarks/step_cost.py``).

Compares, in one run on one machine, the cost of one ``PositionVerlet`` step of the paper's robot:

- ``ours``: the numba forcing of this package;
- ``naive``: the same forcing written as per-element Python loops (the authors' style);
- ``bare``: the same robot with gravity and ground but no magnetic forcing and no damping.

Medians over repeated measurements; machines here are noisy, so compare ratios within one run.

:func:`benchmark` (``msr bench``) adds, in the same run: the per-robot-step cost of N robots in one
batched simulator (:func:`measure_batched`, shared with ``benchmarks/batched_step_cost.py``),
environment steps per second (single and vector environment), TD3 updates per second and the
projected wall time of a 1e5-step training seed on one core.
"""

from __future__ import annotations

import os
import statistics
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

import elastica as ea
import numpy as np
from elastica.external_forces import NoForces

from . import simulation as simulation_module
from .batch import BatchedRobots
from .fields import ControlledField, RotatingField
from .forcing import LegacyInternalDamping, MagneticTorques, RelativeVelocityDamping, evaluate_field
from .presets import RobotSpec, yao2023_robot
from .simulation import (
    MagneticRodSimulator,
    build_simulation,
    ground_plane,
    register_robot_forcing,
    robot_rod,
)

__all__ = [
    "BATCH_SIZES",
    "NaiveMagneticTorques",
    "NaiveRelativeVelocityDamping",
    "batched_fields",
    "benchmark",
    "benchmark_step_cost",
    "env_steps_per_s",
    "measure_batched",
    "per_robot_step_cost",
    "per_rod_simulator",
    "replay_buffer_bytes",
    "sgemm_gflops",
    "td3_roofline",
    "td3_update_flops",
    "td3_updates_per_s",
    "training_peak_memory",
    "vector_env_steps_per_s",
]

#: Numbers of robots per simulator of the batched benchmark.
BATCH_SIZES: tuple[int, ...] = (1, 4, 16, 64)


class NaiveMagneticTorques(MagneticTorques):
    """:class:`MagneticTorques` with a per-element Python loop (for the benchmark only)."""

    def apply_torques(self, system, time=0.0) -> None:
        moment = self.moment_in_material_frame(system)
        field = evaluate_field(self.field, time)
        for i in range(system.n_elems):
            b = system.director_collection[:, :, i] @ field
            system.external_torques[:, i] += np.cross(moment[:, i], b)


class NaiveRelativeVelocityDamping(RelativeVelocityDamping):
    """:class:`RelativeVelocityDamping` with a per-node Python loop (for the benchmark only)."""

    def apply_forces(self, system, time=0.0) -> None:
        v = system.velocity_collection
        k = self.node_offset
        for j in range(v.shape[1] - k):
            f = self.nu * system.lengths[j] * (v[:, j + k] - v[:, j])
            system.external_forces[:, j] += f
            system.external_forces[:, j + k] -= f


class NaiveLegacyInternalDamping(LegacyInternalDamping):
    """:class:`LegacyInternalDamping` with per-element Python loops (for the benchmark only)."""

    def apply_forces(self, system, time=0.0) -> None:
        v = system.velocity_collection
        for e in range(system.n_elems):
            f = 0.25 * self.force_coefficient * system.lengths[e] * (v[:, e] + v[:, e + 1])
            system.external_forces[:, e] -= f
            system.external_forces[:, e + 1] -= f

    def apply_torques(self, system, time=0.0) -> None:
        for e in range(system.n_elems):
            system.external_torques[:, e] -= (
                self.torque_coefficient * system.lengths[e] * system.omega_collection[:, e]
            )


class _Nothing(NoForces):
    def __init__(self, **kwargs) -> None:
        super().__init__()


def _step_cost(physics: str, variant: str, steps: int, repeats: int) -> float:
    """Median wall time of one step (us) for a variant: 'ours', 'naive' or 'bare'."""
    spec = yao2023_robot(1, physics)
    field = RotatingField(4e-3, -1.0, phase=0.5 * np.pi)
    classes = {
        "ours": (MagneticTorques, RelativeVelocityDamping, LegacyInternalDamping),
        "naive": (NaiveMagneticTorques, NaiveRelativeVelocityDamping, NaiveLegacyInternalDamping),
        "bare": (_Nothing, _Nothing, _Nothing),
    }[variant]
    saved = (
        simulation_module.MagneticTorques,
        simulation_module.RelativeVelocityDamping,
        simulation_module.LegacyInternalDamping,
    )
    try:
        (
            simulation_module.MagneticTorques,
            simulation_module.RelativeVelocityDamping,
            simulation_module.LegacyInternalDamping,
        ) = classes
        if variant == "bare":
            spec = replace(spec, damping=None)
        sim = build_simulation(spec, field)
    finally:
        (
            simulation_module.MagneticTorques,
            simulation_module.RelativeVelocityDamping,
            simulation_module.LegacyInternalDamping,
        ) = saved
    sim.step(50)  # JIT and caches warm
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        sim.step(steps)
        times.append((time.perf_counter() - start) / steps * 1e6)
    return statistics.median(times)


def benchmark_step_cost(
    steps: int = 2000, repeats: int = 5, physics_settings: Sequence[str] = ("training", "accurate")
) -> dict[str, object]:
    """Median step cost (us) of the paper's robot in both physics settings, and the ratios.

    Targets (issue 2): ``naive / ours >= 20`` and ``ours / bare <= 1.5``.
    """
    result: dict[str, object] = {"steps": steps, "repeats": repeats}
    for physics in physics_settings:
        naive_steps = max(steps // 10, 50)
        ours = _step_cost(physics, "ours", steps, repeats)
        naive = _step_cost(physics, "naive", naive_steps, repeats)
        bare = _step_cost(physics, "bare", steps, repeats)
        substeps = yao2023_robot(1, physics).steps_per_action
        result[physics] = {
            "step_us": ours,
            "naive_step_us": naive,
            "bare_step_us": bare,
            "speedup_vs_naive": naive / ours,
            "overhead_vs_bare": ours / bare,
            "action_ms": ours * substeps / 1e3,
            "substeps_per_action": substeps,
        }
    return result


# --------------------------------------------------------------------------------------------------
# Batched robots: per-robot-step cost of N robots in one simulator
# --------------------------------------------------------------------------------------------------
def batched_fields(n: int) -> np.ndarray:
    """``(n, 3)`` fields, T: 4-10 mT in varied directions (robots bend, lift off and slide)."""
    angle = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False) + 0.3
    amplitude = np.linspace(4e-3, 10e-3, n)
    return np.stack([amplitude * np.cos(angle), amplitude * np.sin(angle), np.zeros(n)], axis=1)


def per_rod_simulator(spec: RobotSpec, n: int) -> tuple[MagneticRodSimulator, list[ControlledField]]:
    """N rods in one simulator with the per-rod forcing of :func:`build_simulation` (same order)."""
    simulator = MagneticRodSimulator()
    rods = [robot_rod(spec) for _ in range(n)]
    for rod in rods:
        simulator.append(rod)
    plane = ground_plane(spec)
    if plane is not None:
        simulator.append(plane)
    sources = []
    for rod in rods:
        source = ControlledField(limit=1.0, max_increment=1.0)
        sources.append(source)
        register_robot_forcing(simulator, rod, spec, source, plane)
    simulator.finalize()
    return simulator, sources


def _us_per_robot_step(run: Callable[[int], Any], steps: int, n: int) -> float:
    """Wall time of ``run(steps)`` per robot-step, us."""
    start = time.perf_counter()
    run(steps)
    return (time.perf_counter() - start) / (steps * n) * 1e6


def _batched_runner(spec: RobotSpec, n: int) -> Callable[[int], None]:
    robots = BatchedRobots(spec, n, fields=batched_fields(n))
    robots.step(200)  # warm up: robots off the initial state, kernels loaded

    def run(n_steps: int) -> None:
        for _ in range(n_steps // 100):
            robots.step(100)  # one health check per 0.01 s, as an environment does

    return run


def _per_rod_runner(spec: RobotSpec, n: int) -> Callable[[int], None]:
    simulator, sources = per_rod_simulator(spec, n)
    for source, value in zip(sources, batched_fields(n), strict=True):
        source.set(value)
    stepper, dt = ea.PositionVerlet(), spec.dt
    clock = {"t": 0.0}

    def run(n_steps: int) -> None:
        t = clock["t"]
        for _ in range(n_steps):
            t = stepper.step(simulator, t, dt)
        clock["t"] = t

    run(200)
    return run


def _independent_runner(spec: RobotSpec) -> Callable[[int], None]:
    source = ControlledField(limit=1.0, max_increment=1.0, initial=batched_fields(1)[0])
    sim = build_simulation(spec, source)
    sim.step(200)
    return sim.step


def measure_batched(
    spec: RobotSpec,
    n: int,
    steps: int,
    repeats: int,
    paths: Sequence[str] = ("batched", "per_rod", "independent"),
) -> dict[str, float]:
    """Medians (us per robot-step) of the chosen paths, their repeats interleaved.

    Paths: ``batched`` (:class:`~elastica_magnetic.batch.BatchedRobots` with ``n`` robots, stepped
    100 steps = 0.01 s at a time, as an environment), ``per_rod`` (``n`` rods in one simulator with
    the per-rod forcing objects, :func:`per_rod_simulator`), ``independent`` (one
    :func:`build_simulation` robot). ``steps`` time steps per repeat (a multiple of 100) for the
    ``n``-robot paths; the independent path runs as many robot-steps. Interleaving makes the paths
    share the machine's load fluctuations, so their ratios hold even when the absolute figures drift.
    """
    makers = {
        "batched": lambda: (_batched_runner(spec, n), n),
        "per_rod": lambda: (_per_rod_runner(spec, n), n),
        "independent": lambda: (_independent_runner(spec), 1),
    }
    unknown = set(paths) - set(makers)
    if unknown:
        raise ValueError(f"unknown path(s) {sorted(unknown)}; choose from {sorted(makers)}")
    runners = {name: makers[name]() for name in paths}
    samples: dict[str, list[float]] = {name: [] for name in runners}
    for _ in range(repeats):
        for name, (run, robots) in runners.items():
            samples[name].append(_us_per_robot_step(run, steps * n // robots, robots))
    return {name: statistics.median(values) for name, values in samples.items()}


def per_robot_step_cost(
    ns: Sequence[int] = BATCH_SIZES,
    robot_steps: int = 6400,
    repeats: int = 3,
    paths: Sequence[str] = ("batched",),
    physics: str = "training",
) -> dict[str, dict[str, float]]:
    """Per-robot-step cost (us) of the paper's robot for each N, by path.

    ``robot_steps`` robot-steps per repeat (rounded to whole 0.01 s blocks, at least one).
    Returns ``{path: {str(N): us}}``.
    """
    spec = yao2023_robot(1, physics)
    out: dict[str, dict[str, float]] = {name: {} for name in paths}
    for n in ns:
        steps = max(100, (robot_steps // n) // 100 * 100)
        result = measure_batched(spec, n, steps, repeats, paths)
        for name in paths:
            out[name][str(n)] = result[name]
    return out


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
    """Steps per second of :class:`rl.env.MagneticCrawlerEnv` (pattern 1, 4 mT; 0.01 s each:
    100 substeps in training physics), random actions, episodes never ending during the run."""
    from rl.env import MagneticCrawlerEnv

    env = MagneticCrawlerEnv(1, 4e-3, physics=physics, duration=1e6)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    return _timed_rate(lambda: env.step(rng.uniform(-1.0, 1.0, 2).astype(np.float32)), steps, repeats)


def vector_env_steps_per_s(
    n_envs: int = 16, vector_steps: int = 20, repeats: int = 3, physics: str = "training"
) -> float:
    """Environment transitions per second of :class:`rl.vector_env.MagneticCrawlerVectorEnv` with
    ``n_envs`` crawlers in one simulator (``n_envs`` transitions per vector step)."""
    from rl.vector_env import MagneticCrawlerVectorEnv

    env = MagneticCrawlerVectorEnv(n_envs, 1, 4e-3, physics=physics, duration=1e6)
    env.reset(seed=0)
    rng = np.random.default_rng(0)

    def step() -> None:
        env.step(rng.uniform(-1.0, 1.0, (n_envs, 2)).astype(np.float32))

    return _timed_rate(step, vector_steps, repeats, per_call=n_envs)


def td3_updates_per_s(updates: int = 200, repeats: int = 3, threads: int = 1) -> float:
    """TD3 gradient updates per second with the crawler's settings (260 observations, 2 actions,
    256-256 networks, minibatch 256, target-noise clip 0.8) on ``threads`` torch threads, from a
    replay buffer of random transitions."""
    import torch

    from rl.pipeline import crawler_config
    from rl.td3 import ReplayBuffer, TD3Agent

    previous = torch.get_num_threads()
    torch.set_num_threads(threads)
    try:
        cfg = crawler_config(0)
        obs_dim, act_dim = 260, 2
        agent = TD3Agent(obs_dim, act_dim, -np.ones(act_dim), np.ones(act_dim), cfg)
        buffer = ReplayBuffer(10_000, obs_dim, act_dim)
        rng = np.random.default_rng(0)
        for _ in range(buffer.capacity):
            buffer.add(rng.normal(size=obs_dim), rng.uniform(-1, 1, act_dim), rng.normal(),
                       rng.normal(size=obs_dim), False)
        return _timed_rate(lambda: agent.update(buffer.sample(cfg.batch_size, agent.rng)),
                           updates, repeats)
    finally:
        torch.set_num_threads(previous)


def _linear_shapes(module: Any) -> list[tuple[int, int]]:
    """``(in_features, out_features)`` of the ``nn.Linear`` layers of ``module``, in order."""
    import torch.nn as nn

    return [(m.in_features, m.out_features) for m in module.modules() if isinstance(m, nn.Linear)]


def td3_update_flops(agent: Any, batch_size: int) -> float:
    """Floating-point operations of one :meth:`rl.td3.TD3Agent.update`, averaged over the policy
    delay, counting the matrix products only (``2 * batch * in * out`` per product; biases,
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


def sgemm_gflops(shapes: Sequence[tuple[int, int, int]], repeats: int = 3, threads: int = 1,
                 min_time: float = 0.2) -> float:
    """Single-precision matrix-product rate of torch on this machine (GFLOP/s, ``threads`` threads):
    the median over ``repeats`` of products ``(m, k) @ (k, n)`` cycled over ``shapes`` for at least
    ``min_time`` s. With the network's own shapes this is the ceiling of a TD3 update."""
    import torch

    previous = torch.get_num_threads()
    torch.set_num_threads(threads)
    try:
        gen = torch.Generator().manual_seed(0)
        pairs = [(torch.randn(m, k, generator=gen), torch.randn(k, n, generator=gen))
                 for m, k, n in shapes]
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
    ``sgemm_gflops`` (:func:`sgemm_gflops` over the update's forward shapes), ``achieved_gflops``
    (``gflop_per_update * updates_per_s``), ``fraction_of_sgemm`` and ``floor_1e5_updates_s``
    (1e5 updates at the sgemm rate: no implementation on this core does them faster)."""
    from rl.pipeline import crawler_config
    from rl.td3 import TD3Agent

    cfg = crawler_config(0)
    agent = TD3Agent(260, 2, -np.ones(2), np.ones(2), cfg)
    flop = td3_update_flops(agent, cfg.batch_size)
    shapes = [(cfg.batch_size, i, o) for net in (agent.actor, agent.critic.q1_net)
              for i, o in _linear_shapes(net)]
    rate = sgemm_gflops(shapes, repeats=1 if quick else repeats, min_time=0.02 if quick else 0.2)
    gflop = flop / 1e9
    achieved = gflop * updates_per_s
    return {
        "gflop_per_update": gflop,
        "sgemm_gflops": rate,
        "achieved_gflops": achieved,
        "fraction_of_sgemm": achieved / rate,
        "floor_1e5_updates_s": 1e5 * flop / (rate * 1e9),
    }


# --------------------------------------------------------------------------------------------------
# Memory of a multi-seed training run
# --------------------------------------------------------------------------------------------------
def _process_tree_rss(root: int) -> int:
    """Resident memory (bytes) of process ``root`` and all its descendants, from ``/proc`` (Linux)."""
    children: dict[int, list[int]] = {}
    rss: dict[int, int] = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/status") as f:
                fields = dict(line.split(":", 1) for line in f if ":" in line)
        except OSError:  # the process ended while we looked
            continue
        pid = int(entry)
        children.setdefault(int(fields["PPid"]), []).append(pid)
        rss[pid] = int(fields.get("VmRSS", "0 kB").split()[0]) * 1024
    total, stack = 0, [root]
    while stack:
        pid = stack.pop()
        total += rss.get(pid, 0)
        stack.extend(children.get(pid, []))
    return total


def replay_buffer_bytes(capacity: int, obs_dim: int = 260, act_dim: int = 2) -> int:
    """Bytes of a full :class:`rl.td3.ReplayBuffer`: float32 obs, next obs, action, reward and
    terminated per transition."""
    return int(capacity) * (2 * obs_dim + act_dim + 2) * 4


def training_peak_memory(
    seeds: int = 8,
    steps: int = 3000,
    full_steps: int = 100_000,
    case: str = "m1-4mT",
    out: str | os.PathLike | None = None,
    interval: float = 0.2,
) -> dict[str, Any]:
    """Peak resident memory of a real ``seeds``-seed training run, all seeds at once in worker
    processes (``msr train --seeds N --workers N``), sampled every ``interval`` s over the whole
    process tree (Linux ``/proc``).

    The run lasts ``steps`` environment steps per seed (past the 2500 warm-up steps, so networks,
    optimisers and TD3 updates are live). The only memory that grows with the run length is the
    replay buffer, sized to the run and filled as it goes: ``projected_full_run_peak_bytes`` adds
    ``seeds`` x the buffer bytes of ``full_steps`` minus those of ``steps``.
    """
    import tempfile
    import threading

    from rl.pipeline import train_case

    if not os.path.isdir("/proc"):
        raise RuntimeError("training_peak_memory reads /proc: Linux only")
    root = os.getpid()
    baseline = _process_tree_rss(root)
    peak = [baseline]
    done = threading.Event()

    def sample() -> None:
        while not done.wait(interval):
            peak[0] = max(peak[0], _process_tree_rss(root))

    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        monitor = threading.Thread(target=sample, daemon=True)
        monitor.start()
        try:
            summary = train_case(case, seeds=seeds, steps=steps, workers=seeds,
                                 out=out if out is not None else tmp, threads=1, progress=False)
        finally:
            done.set()
            monitor.join()
    if summary["failed"]:
        raise RuntimeError(f"seeds {summary['failed']} failed: "
                           + "; ".join(str(r.get("error")) for r in summary["seeds"] if "error" in r))
    growth = seeds * (replay_buffer_bytes(full_steps) - replay_buffer_bytes(steps))
    return {
        "seeds": seeds,
        "workers": seeds,
        "steps_per_seed": steps,
        "peak_bytes": peak[0],
        "parent_baseline_bytes": baseline,
        "replay_buffer_bytes_per_seed_at_full": replay_buffer_bytes(full_steps),
        "full_steps": full_steps,
        "projected_full_run_peak_bytes": peak[0] + growth,
        "wall_s": time.perf_counter() - start,
    }


def benchmark(
    steps: int = 1000,
    repeats: int = 3,
    quick: bool = False,
    vector_envs: int = 16,
) -> dict[str, Any]:
    """Everything ``msr bench`` reports, measured in one run (training physics unless noted).

    Keys: ``step_us``, ``naive_step_us``, ``speedup`` (one time step of the paper's robot, us, ours
    vs per-element Python loops, training physics; both physics in ``training`` / ``accurate``),
    ``per_robot_step_us`` ``{"1", "4", "16", "64"}`` (us per robot-step, batched simulator),
    ``env_steps_per_s`` (single environment, one 0.01 s action = 100 substeps),
    ``vector_env_steps_per_s`` (transitions/s, ``vector_envs`` crawlers in one simulator),
    ``td3_updates_per_s`` (one torch thread), ``train_1e5_steps_s`` (projected wall time of a
    1e5-step seed on one core: ``1e5 * (1 / env_steps_per_s + 1 / td3_updates_per_s)``, s),
    ``train_1e5_steps_vector_s`` (the same with the vector environment's simulation cost: also
    the per-seed cost of seeds sharing a simulator, ``msr train --seeds-per-simulator``), the
    target (900 s),
    ``td3_roofline`` (:func:`td3_roofline`: the update's FLOP count against this core's
    matrix-product rate, and the floor it sets on 1e5 updates), the load average and the CPU
    count. ``quick``: tiny measurements (for tests; numbers are rough).
    """
    if quick:
        steps, repeats = min(steps, 200), 1
    robot_steps = 100 if quick else 6400
    env_steps, vector_steps, updates = (10, 3, 10) if quick else (200, 20, 200)
    load_before = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    start = time.perf_counter()
    cost = benchmark_step_cost(steps, repeats)
    training = cost["training"]
    batched = per_robot_step_cost(BATCH_SIZES, robot_steps, repeats)["batched"]
    env_rate = env_steps_per_s(env_steps, repeats)
    vector_rate = vector_env_steps_per_s(vector_envs, vector_steps, repeats)
    td3_rate = td3_updates_per_s(updates, repeats)
    roofline = td3_roofline(td3_rate, repeats, quick)
    return {
        "step_us": training["step_us"],
        "naive_step_us": training["naive_step_us"],
        "speedup": training["speedup_vs_naive"],
        "per_robot_step_us": batched,
        "env_steps_per_s": env_rate,
        "vector_envs": vector_envs,
        "vector_env_steps_per_s": vector_rate,
        "td3_updates_per_s": td3_rate,
        "train_1e5_steps_s": 1e5 * (1.0 / env_rate + 1.0 / td3_rate),
        "train_1e5_steps_vector_s": 1e5 * (1.0 / vector_rate + 1.0 / td3_rate),
        "train_1e5_target_s": 900.0,
        "td3_roofline": roofline,
        "per_robot_step_target_us_at_16": 12.0,
        "training": cost["training"],
        "accurate": cost["accurate"],
        "steps": steps,
        "repeats": repeats,
        "quick": quick,
        "cpu_count": os.cpu_count(),
        "load_average_1min": load_before,
        "wall_s": time.perf_counter() - start,
        "note": "wall-clock medians on this machine under its current load; 1e5-step projections: "
                "environment steps and TD3 updates on one core, one after the other",
    }

