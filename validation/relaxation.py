"""Dynamic relaxation shared by the static cases: damp a finalized-to-be simulator to rest."""

from __future__ import annotations

import math

import elastica as ea

__all__ = ["relax"]


def relax(
    simulator, rod, youngs_modulus: float, density: float, damping: float, duration: float
) -> int:
    """Add a uniform analytical damper, finalize, and step ``duration`` seconds; return the steps.

    The time step is 0.3 of the element's wave-crossing time ``l / sqrt(E / rho)`` (axial, shear
    and bending waves have the same order of speed); ``damping`` (1/s) sets how fast it settles.
    """
    dt = 0.3 * float(rod.rest_lengths.min()) / math.sqrt(youngs_modulus / density)
    simulator.dampen(rod).using(ea.AnalyticalLinearDamper, uniform_damping_constant=damping, time_step=dt)
    simulator.finalize()
    stepper = ea.PositionVerlet()
    steps = int(round(duration / dt))
    for k in range(steps):
        stepper.step(simulator, k * dt, dt)
    return steps
