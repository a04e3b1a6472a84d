"""Step-cost benchmark of the paper's robot (``msr bench``, ``benchmarks/step_cost.py``).

Compares, in one run on one machine, the cost of one ``PositionVerlet`` step of the paper's robot:

- ``ours``: the numba forcing of this package;
- ``naive``: the same forcing written as per-element Python loops (the authors' style);
- ``bare``: the same robot with gravity and ground but no magnetic forcing and no damping.

Medians over repeated measurements; machines here are noisy, so compare ratios within one run.

:func:`per_robot_step_cost` measures the per-robot-step cost of N robots in one batched simulator
(:func:`measure_batched`, shared with ``benchmarks/batched_step_cost.py``). The learning benchmarks
(environment and TD3 rates, training time and memory) and ``msr bench`` itself are in
:mod:`elastica_magnetic_rl.reports.bench`, on top of this package.
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

import elastica as ea
import numpy as np
from elastica.external_forces import NoForces

from . import simulation as simulation_module
from .actuation import CoilCurrents, MagnetPose
from .batch import BatchedRobots
from .field_maps import FieldMap
from .fields import ControlledField, RotatingField
from .forcing import LegacyInternalDamping, MagneticTorques, RelativeVelocityDamping, evaluate_field
from .magnet_fields import CuboidMagnetField, magnet_map
from .presets import yao2023_robot
from .robot_spec import RobotSpec
from .simulation import (
    MagneticRodSimulator,
    build_simulation,
    ground_plane,
    register_robot_forcing,
    robot_rod,
)
from .spatial_fields import HelmholtzCoils, PointDipoleField, SpatialFieldError, Waypoints
from .uniform_simulation import UniformFieldSimulation

__all__ = [
    "BATCH_SIZES",
    "NaiveMagneticTorques",
    "NaiveRelativeVelocityDamping",
    "batched_fields",
    "batched_spatial_step_cost",
    "benchmark_step_cost",
    "ground_model_step_cost",
    "measure_batched",
    "per_robot_step_cost",
    "per_rod_simulator",
    "spatial_sources",
    "spatial_step_cost",
    "uniform_step_cost",
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


def uniform_step_cost(physics: str, steps: int, repeats: int) -> dict[str, float]:
    """Median wall time of one step (us) of the paper's robot on the per-rod simulator
    (:func:`build_simulation`, a field held over each call) and on the batched kernel
    (:class:`UniformFieldSimulation`) under a held field and under a rotating field evaluated at
    every time step, interleaved within each repeat. The same trajectories to the last bit."""
    spec = yao2023_robot(1, physics)
    held = ControlledField(4e-3, initial=(0.0, 4e-3, 0.0))
    sims = {"per_rod": build_simulation(spec, held), "held": UniformFieldSimulation(spec, held),
            "rotating": UniformFieldSimulation(spec, RotatingField(4e-3, -1.0, phase=0.5 * np.pi))}
    times: dict[str, list[float]] = {name: [] for name in sims}
    for sim in sims.values():
        sim.step(50)  # JIT and caches warm
    for _ in range(repeats):
        for name, sim in sims.items():
            start = time.perf_counter()
            sim.step(steps)
            times[name].append((time.perf_counter() - start) / steps * 1e6)
    cost = {f"{name}_step_us": statistics.median(values) for name, values in times.items()}
    return {**cost, "held_speedup": cost["per_rod_step_us"] / cost["held_step_us"],
            "rotating_speedup": cost["per_rod_step_us"] / cost["rotating_step_us"]}


def benchmark_step_cost(
    steps: int = 2000, repeats: int = 5, physics_settings: Sequence[str] = ("training", "accurate"),
    spatial: bool = True,
) -> dict[str, object]:
    """Median step cost (us) of the paper's robot in both physics settings, and the ratios.

    Targets (issue 2): ``naive / ours >= 20`` and ``ours / bare <= 1.5``. Each setting also reports
    :func:`uniform_step_cost` (``per_rod_step_us``, ``held_step_us``, ``rotating_step_us`` and the
    speed-ups). With ``spatial``, each
    setting also reports :func:`spatial_step_cost` (``spatial_step_us``, ``spatial_ratio_to_uniform``:
    a point dipole, a moving dipole and a Helmholtz pair next to the uniform field; target
    (issue 33) at most 2x).
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
            **uniform_step_cost(physics, steps, repeats),
        }
        if spatial:
            # Fields in space next to the uniform one (issue 33), interleaved in their own run.
            cost = spatial_step_cost(physics, steps, repeats)
            result[physics]["spatial_step_us"] = cost["step_us"]
            result[physics]["spatial_ratio_to_uniform"] = cost["ratio_to_uniform"]
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


#: The ground models of :func:`ground_model_step_cost`: ``(sideways, friction)`` of ``[robot.ground]``.
GROUND_MODELS = {"explicit_rolling": ("rolling", "explicit"), "explicit_sliding": ("sliding", "explicit"),
                 "implicit_sliding": ("sliding", "implicit")}


def ground_model_step_cost(n: int = 16, steps: int = 1000, repeats: int = 5,
                           physics: str = "training") -> dict[str, Any]:
    """Per-robot-step cost (us) of ``n`` paper robots in one :class:`~elastica_magnetic.BatchedRobots`
    under 4-10 mT fields (:func:`batched_fields`) on each ground model of :data:`GROUND_MODELS`
    (PyElastica's explicit friction rolling or sliding sideways, the implicit friction of a band),
    the models interleaved within each repeat, and the ratios to PyElastica's (``explicit_rolling``,
    the paper's). ``steps`` time steps per repeat, in 0.01 s blocks."""
    base = yao2023_robot(1, physics)
    runners = {}
    for name, (sideways, friction) in GROUND_MODELS.items():
        spec = replace(base, ground=replace(base.ground, sideways=sideways, friction=friction))
        runners[name] = _batched_runner(spec, n)
    taken = max(100, steps // 100 * 100)
    samples: dict[str, list[float]] = {name: [] for name in runners}
    for _ in range(repeats):
        for name, run in runners.items():
            samples[name].append(_us_per_robot_step(run, taken, n))
    medians = {name: statistics.median(values) for name, values in samples.items()}
    return {"physics": physics, "robots": n, "steps": taken, "repeats": repeats,
            "per_robot_step_us": medians,
            "ratio_to_explicit_rolling": {name: value / medians["explicit_rolling"]
                                          for name, value in medians.items()}}


def spatial_sources() -> dict[str, Any]:
    """The field sources of :func:`spatial_step_cost`, each about 4 mT at the paper's robot (a band
    20 mm long along +x from the origin): the uniform rotating field of ``msr bench``, a point
    dipole 50 mm above the robot (2.5 A m^2), the same dipole moving along a path, and a Helmholtz
    pair of radius 100 mm around it."""
    above = np.array([0.01, 0.05, 0.0])
    path = Waypoints([0.0, 1.0], [above, above + np.array([0.02, 0.0, 0.0])])
    current = 4e-3 * 0.1 / (0.8**1.5 * 4e-7 * np.pi)  # A turns for 4 mT at the centre
    return {
        "uniform": RotatingField(4e-3, -1.0, phase=0.5 * np.pi),
        "point_dipole": PointDipoleField([0.0, 2.5, 0.0], above),
        "moving_dipole": PointDipoleField([0.0, 2.5, 0.0], path),
        "helmholtz_pair": HelmholtzCoils(0.1, current=current, centre=[0.01, 0.0, 0.0], axis=[0, 1, 0]),
    }


def spatial_step_cost(physics: str = "accurate", steps: int = 2000, repeats: int = 5) -> dict[str, Any]:
    """Median step cost (us) of the paper's robot (:func:`~elastica_magnetic.yao2023_robot`, 64
    elements, ground and dampings) under each source of :func:`spatial_sources`, and its ratio to
    the uniform field's. The variants are measured in turn within each repeat, so drifts of a
    shared machine touch all of them alike. Target (issue 33): point dipole and coil pair at most
    2x the uniform field."""
    spec = yao2023_robot(1, physics)
    sims = {name: build_simulation(spec, source) for name, source in spatial_sources().items()}
    for sim in sims.values():
        sim.step(50)  # JIT and caches warm
    times: dict[str, list[float]] = {name: [] for name in sims}
    for _ in range(repeats):
        for name, sim in sims.items():
            start = time.perf_counter()
            sim.step(steps)
            times[name].append((time.perf_counter() - start) / steps * 1e6)
    medians = {name: statistics.median(values) for name, values in times.items()}
    return {
        "physics": physics, "steps": steps, "repeats": repeats, "step_us": medians,
        "ratio_to_uniform": {name: medians[name] / medians["uniform"] for name in medians},
    }


def _arm_above_the_robot() -> MagnetPose:
    """An arm holding the point dipole of :func:`spatial_sources` 50 mm above the paper's robot,
    moving along x at 20 mm/s and turning at 1 rad/s (commanded again every 0.01 s)."""
    return MagnetPose(2.5, [0.01, 0.05, 0.0], [0.0, 1.0, 0.0], [[-0.1, 0.02, -0.1], [0.1, 0.1, 0.1]],
                      max_speed=0.02, max_turn_rate=1.0)


def _finite_magnet_arms(n: int) -> list[MagnetPose]:
    """``n`` arms as :func:`_arm_above_the_robot`, each holding a finite magnet: a 10 mm cube's
    field map in its own frame (:func:`~elastica_magnetic.magnet_map`, +-160 mm at 4 mm) scaled to
    the arm's 2.5 A m^2, one map shared by all. None without Magpylib."""
    try:
        field_map = magnet_map(CuboidMagnetField([0.01] * 3, [0.0, 0.0, 1.3]), half_width=0.16, spacing=0.004)
    except SpatialFieldError:  # Magpylib not installed: no finite magnet to measure
        return []
    arm = _arm_above_the_robot()
    return [MagnetPose(arm.moment, arm.position_at(0.0), arm.direction_at(0.0), arm.workspace,
                       arm.max_speed, arm.max_turn_rate, field_map=field_map) for _ in range(n)]


def _helmholtz_map() -> FieldMap:
    """The Helmholtz pair of :func:`spatial_sources` tabulated at 2 mm on a box around the paper's
    robot (x -20..40 mm, y and z +-20 mm): a field map fixed in the lab."""
    pair = spatial_sources()["helmholtz_pair"]
    x, yz = np.linspace(-0.02, 0.04, 31), np.linspace(-0.02, 0.02, 21)
    grid = np.stack(np.meshgrid(x, yz, yz, indexing="ij"), axis=0).reshape(3, -1)
    samples = pair.at(grid, 0.0).reshape(3, x.size, yz.size, yz.size)
    return FieldMap(x, yz, yz, np.moveaxis(samples, 0, -1), source="Helmholtz pair's map")


def _three_axis_helmholtz() -> list[HelmholtzCoils]:
    """Three Helmholtz pairs of radius 100 mm on x, y and z around the paper's robot, each 4 mT at
    1 A (the turns folded into the current): the paper's coil system as fixed coils."""
    turns = 4e-3 * 0.1 / (0.8**1.5 * 4e-7 * np.pi)
    return [HelmholtzCoils(0.1, centre=[0.01, 0.0, 0.0], axis=axis, turns=turns)
            for axis in ([1, 0, 0], [0, 1, 0], [0, 0, 1])]


def batched_spatial_step_cost(n: int = 16, steps: int = 1000, repeats: int = 5,
                              physics: str = "training") -> dict[str, Any]:
    """Per-robot-step cost (us) of ``n`` paper robots in one :class:`~elastica_magnetic.BatchedRobots`,
    each robot under its own source of :func:`spatial_sources` (point dipoles, fixed or moving
    along waypoints, by one kernel for all robots; fixed coils such as the Helmholtz pair by one
    kernel per coil set; the pair's field map fixed in the lab, ``field_map``, by one kernel per
    map; other sources a Python call per robot and time step), its own arm-moved
    magnet (:class:`~elastica_magnetic.MagnetPose`, one kernel for all robots: a point dipole, or a
    finite magnet through its field map, ``arm_finite_magnet``) or its own currents in
    three Helmholtz pairs (:class:`~elastica_magnetic.CoilCurrents`, a field turning in the y-z plane),
    next to the uniform field (each robot's row), and the ratios to it. ``steps`` per
    repeat, in 0.01 s blocks as an environment steps (the arms commanded between blocks); the
    variants interleaved within each repeat. Target (issue 53): at most 2x the uniform field."""
    spec = yao2023_robot(1, physics)
    per_action = spec.steps_per_action
    arms = [_arm_above_the_robot() for _ in range(n)]
    kinds: dict[str, BatchedRobots] = {"uniform": BatchedRobots(spec, n, fields=batched_fields(n))}
    for name, source in spatial_sources().items():
        if name != "uniform":
            kinds[name] = BatchedRobots(spec, n, sources=[source] * n)
    kinds["field_map"] = BatchedRobots(spec, n, sources=[_helmholtz_map()] * n)
    kinds["arm_magnet"] = BatchedRobots(spec, n, sources=[arm.source for arm in arms])
    mapped_arms = _finite_magnet_arms(n)
    if mapped_arms:
        kinds["arm_finite_magnet"] = BatchedRobots(spec, n, sources=[arm.source for arm in mapped_arms])
    coils = _three_axis_helmholtz()
    drives = [CoilCurrents(coils, current_limit=1.0) for _ in range(n)]
    kinds["coil_currents"] = BatchedRobots(spec, n, sources=[drive.source for drive in drives])
    command = np.array([1.0, 0.0, 0.0, 1.0, 0.0])

    def run(name: str, robots: BatchedRobots, n_steps: int) -> None:
        for _ in range(max(1, n_steps // per_action)):
            if name in ("arm_magnet", "arm_finite_magnet"):
                for i, arm in enumerate(arms if name == "arm_magnet" else mapped_arms):
                    arm.apply(command, robots.robot_time(i), per_action * spec.dt)
            if name == "coil_currents":  # a field turning at 1 turn/s, currents ramped per 0.01 s
                for i, drive in enumerate(drives):
                    t = robots.robot_time(i)
                    drive.apply([0.0, math.cos(2 * math.pi * t), -math.sin(2 * math.pi * t)], t,
                                per_action * spec.dt)
            robots.step(per_action)

    for name, robots in kinds.items():
        run(name, robots, per_action)  # JIT and caches warm
    samples: dict[str, list[float]] = {name: [] for name in kinds}
    for _ in range(repeats):
        for name, robots in kinds.items():
            start = time.perf_counter()
            run(name, robots, steps)
            taken = max(1, steps // per_action) * per_action
            samples[name].append((time.perf_counter() - start) / (taken * n) * 1e6)
    medians = {name: statistics.median(values) for name, values in samples.items()}
    return {"physics": physics, "robots": n, "steps": steps, "repeats": repeats,
            "per_robot_step_us": medians,
            "ratio_to_uniform": {name: medians[name] / medians["uniform"] for name in medians}}
