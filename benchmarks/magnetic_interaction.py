"""MagneticInteraction: cost per step on the paper's robot, and convergence as elements are refined.

Run: ``python benchmarks/magnetic_interaction.py [--steps N] [--json]``.

- cost: one PositionVerlet step of the paper's robot (accurate physics, pattern 2, 10 mT field) with
  and without the interaction, and the interaction kernel alone, n = 64;
- convergence: the robot bent into an arc of 270 degrees, pattern 2; force of the first half on the
  second half and the interaction energy for n = 16 ... 512 elements (cutoff 4 radii, fixed in m).
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace

import numpy as np

from elastica_magnetic import (
    ConstantField,
    InteractionSpec,
    MagneticInteraction,
    build_simulation,
    rectangular_band_rod,
    yao2023_magnetization,
    yao2023_robot,
)

L, W, H = 20e-3, 8e-3, 0.8e-3


def _median_step_us(simulation, steps: int, repeats: int = 5) -> float:
    simulation.step(200)  # JIT and warm caches
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        simulation.step(steps)
        times.append((time.perf_counter() - start) / steps)
    return 1e6 * float(np.median(times))


def step_cost(steps: int = 2000) -> dict:
    field = ConstantField(np.array([0.0, 0.0, 10e-3]))
    base = yao2023_robot(2)
    bare = _median_step_us(build_simulation(base, field), steps)
    with_interaction = _median_step_us(
        build_simulation(replace(base, interaction=InteractionSpec()), field), steps
    )
    rod = rectangular_band_rod(64, L, W, H, 1860.0, 84.5e3, 84.5e3 / 1.48)
    forcing = MagneticInteraction(yao2023_magnetization(2, 64), source_area=W * H)
    forcing.apply_forces(rod, 0.0)
    start = time.perf_counter()
    for _ in range(steps):
        forcing.apply_forces(rod, 0.0)
    kernel = 1e6 * (time.perf_counter() - start) / steps
    return {
        "n_elements": 64,
        "pairs": int(sum(64 - forcing._first_partner)),
        "step_us_paper_model": bare,
        "step_us_with_interaction": with_interaction,
        "interaction_call_us": kernel,
    }


def bent_arc(n: int, sweep: float = 1.5 * np.pi):
    """The robot's rod bent into a circular arc of ``sweep`` radians in the x-y plane."""
    rod = rectangular_band_rod(n, L, W, H, 1860.0, 84.5e3, 84.5e3 / 1.48)
    radius = L / sweep
    phi = np.linspace(0.0, sweep, n + 1)
    rod.position_collection[0, :] = radius * np.sin(phi)
    rod.position_collection[1, :] = radius * (1.0 - np.cos(phi))
    mid = 0.5 * (phi[:-1] + phi[1:])
    # Straight rod: d1 = y, d2 = z, d3 = x; turned about z by the tangent angle.
    rod.director_collection[0, 0, :] = -np.sin(mid)
    rod.director_collection[0, 1, :] = np.cos(mid)
    rod.director_collection[2, 0, :] = np.cos(mid)
    rod.director_collection[2, 1, :] = np.sin(mid)
    return rod


def convergence(ns=(16, 32, 64, 128, 256, 512), cutoff: float = 4 * H / np.sqrt(3)) -> list[dict]:
    rows = []
    for n in ns:
        straight = rectangular_band_rod(n, L, W, H, 1860.0, 84.5e3, 84.5e3 / 1.48)
        forcing = MagneticInteraction(yao2023_magnetization(2, n), cutoff=cutoff, source_area=W * H)
        forcing.moment_in_material_frame(straight)  # magnetization fixed in the straight rod
        rod = bent_arc(n)
        rod.external_forces[:] = 0.0
        forcing.apply_forces(rod, 0.0)
        # Element forces back from the node halves: F_0 = 2 f_0, F_k = 2 f_k - F_{k-1}.
        element = np.empty((3, n))
        element[:, 0] = 2 * rod.external_forces[:, 0]
        for k in range(1, n):
            element[:, k] = 2 * rod.external_forces[:, k] - element[:, k - 1]
        half = element[:, n // 2 :].sum(axis=1)
        rows.append(
            {
                "n": n,
                "force_on_second_half_mN": (1e3 * half[:2]).tolist(),
                "energy_uJ": 1e6 * forcing.potential_energy(rod),
            }
        )
    return rows


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    result = {"cost": step_cost(args.steps), "convergence": convergence()}
    if args.json:
        print(json.dumps(result, indent=1))
    else:
        c = result["cost"]
        print(
            f"n = 64, {c['pairs']} pairs: paper model {c['step_us_paper_model']:.1f} us/step, with the "
            f"interaction {c['step_us_with_interaction']:.1f} us/step; one interaction call "
            f"{c['interaction_call_us']:.1f} us"
        )
        for row in result["convergence"]:
            fx, fy = row["force_on_second_half_mN"]
            print(
                f"n = {row['n']:4d}: force on 2nd half ({fx:+.5f}, {fy:+.5f}) mN, "
                f"U = {row['energy_uJ']:.5f} uJ"
            )
