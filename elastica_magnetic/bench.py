"""Step-cost benchmark of the paper's robot (``msr bench``, ``benchmarks/step_cost.py``).

Compares, in one run on one machine, the cost of one ``PositionVerlet`` step of the paper's robot:

- ``ours``: the numba forcing of this package;
- ``naive``: the same forcing written as per-element Python loops (the authors' style);
- ``bare``: the same robot with gravity and ground but no magnetic forcing and no damping.

Medians over repeated measurements; machines here are noisy, so compare ratios within one run.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import replace

import numpy as np
from elastica.external_forces import NoForces

from . import simulation as simulation_module
from .fields import RotatingField
from .forcing import LegacyInternalDamping, MagneticTorques, RelativeVelocityDamping
from .presets import yao2023_robot
from .simulation import build_simulation

__all__ = ["NaiveMagneticTorques", "NaiveRelativeVelocityDamping", "benchmark_step_cost"]


class NaiveMagneticTorques(MagneticTorques):
    """:class:`MagneticTorques` with a per-element Python loop (for the benchmark only)."""

    def apply_torques(self, system, time=0.0) -> None:
        moment = self.moment_in_material_frame(system)
        field = np.asarray(self.field(time))
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


def benchmark_step_cost(steps: int = 2000, repeats: int = 5) -> dict[str, object]:
    """Median step cost (us) of the paper's robot in both physics settings, and the ratios.

    Targets (issue 2): ``naive / ours >= 20`` and ``ours / bare <= 1.5``.
    """
    result: dict[str, object] = {"steps": steps, "repeats": repeats}
    for physics in ("training", "accurate"):
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
