"""The stable time step of the explicit integrator for a robot: one home for it. The spec parser
refuses a step above the estimate (:mod:`~elastica_magnetic.specfile`); ``msr case check`` reports
each physics' margin (:mod:`~elastica_magnetic.spec_check`).

**Time step.** The integrator (position Verlet) is stable for a mode of angular frequency
``omega`` while ``omega dt < 2``; a velocity damping of rate ``c / m`` needs ``dt < 2 m / c``. The
estimate is the smallest of these limits, for elements of length ``dl``, mass per length
``rho_s A`` (``rho_s``: the physics' density, ``rho x mass_scale``), rod radius ``r``:

- axial and bending waves: ``dl / sqrt(E / rho_s)``;
- shear with the rotation it couples to: ``1 / (c_s sqrt(1/dl^2 + 1/r^2))``,
  ``c_s = sqrt(alpha_c G / rho_s)``;
- relative-velocity damping (each node in two pairs, pairs moving apart): ``rho_s A / (2 nu)``;
- legacy damping on forces and torques: ``2 rho_s A / c_f`` and ``2 rho_s I / c_t``;
- Kelvin-Voigt viscosity ``eta``: ``rho_s dl^2 / (2 eta)``;
- ground contact: ``2 sqrt(m_e / k)`` (spring) and ``2 m_e / nu_g`` (damping), ``m_e = rho_s A dl``.

These bare limits ignore how the modes combine (and the rod's free ends), so the estimate is the
smallest of them times :data:`CALIBRATION` = 0.7, measured: the paper's robot becomes unstable at
0.80-0.89 of the bare axial limit without damping (3.7e-5 s stable, 4.1e-5 s not, accurate
physics), 0.75-0.82 in the training physics (1.12e-4 s stable, 1.23e-4 s not) and 0.72-0.80 of
the relative damping's limit with every damping on (2.25e-5 s stable, 2.49e-5 s not). The paper's
steps have margins 1.05 (training, 1e-4 s) and 2.7 (accurate, 8e-6 s). A 30 x 6 x 1 mm band
(48 elements, 150 kPa, 2000 kg/m^3) becomes unstable at 0.79-0.87 (training) and 0.71-0.79
(accurate) of its smallest bare limit. The suggested step is
the largest of 1, 2, 4, 5 or 8 x 10^k s that is at most half the estimate (each divides the
0.01 s control period into whole steps).
"""

from __future__ import annotations

import math

from .robot_spec import ACTION_PERIOD, RobotSpec

__all__ = ["CALIBRATION", "SAFETY_FACTOR", "estimated_stable_time_step", "suggested_time_step",
           "time_step_limits"]

#: The stable step, as a fraction of the smallest bare limit (measured, see the module docstring).
CALIBRATION = 0.7
#: A time step at most this fraction of the estimated stable one is what :func:`suggested_time_step`
#: proposes; a margin (stable / chosen) below 1 is refused, below this factor a warning.
SAFETY_FACTOR = 2.0


def time_step_limits(robot: RobotSpec) -> dict[str, float]:
    """The bare stability limit of each mechanism of ``robot`` in its physics (s; ``inf`` where a
    mechanism is absent); see the module docstring for the formulas. The estimated stable step
    is the smallest of them times :data:`CALIBRATION`."""
    rho = robot.effective_density
    n, r = robot.n_elements, robot.radius
    dl = robot.length / n
    area, inertia = math.pi * r**2, math.pi * r**4 / 4.0
    c_axial = math.sqrt(robot.youngs_modulus / rho)
    c_shear = math.sqrt(robot.alpha_c * robot.shear_modulus / rho)
    limits = {
        "axial and bending waves": dl / c_axial,
        "shear and rotation": 1.0 / (c_shear * math.sqrt(1.0 / dl**2 + 1.0 / r**2)),
    }
    inf = math.inf
    d = robot.damping
    if d is not None:
        limits["relative damping"] = rho * area / (2.0 * d.relative_nu) if d.relative_nu > 0 else inf
        limits["legacy force damping"] = (2.0 * rho * area / d.legacy_force
                                          if d.legacy_force > 0 else inf)
        limits["legacy torque damping"] = (2.0 * rho * inertia / d.legacy_torque
                                           if d.legacy_torque > 0 else inf)
        limits["Kelvin-Voigt viscosity"] = (rho * dl**2 / (2.0 * d.kelvin_voigt)
                                            if d.kelvin_voigt > 0 else inf)
    g = robot.ground
    if g is not None:
        m_e = rho * area * dl
        limits["ground stiffness"] = 2.0 * math.sqrt(m_e / g.k)
        limits["ground damping"] = 2.0 * m_e / g.nu if g.nu > 0 else inf
    return limits


def suggested_time_step(stable_dt: float) -> float:
    """The largest step of 1, 2, 4, 5 or 8 x 10^k s (each divides the 0.01 s control period into
    whole steps for k <= -2) at most ``stable_dt / SAFETY_FACTOR``, s; at most 0.01 s."""
    target = min(stable_dt / SAFETY_FACTOR, ACTION_PERIOD)
    exponent = math.floor(math.log10(target))
    for k in (exponent, exponent - 1):
        for digit in (8, 5, 4, 2, 1):
            dt = float(f"{digit}e{k}")
            if dt <= target * (1 + 1e-12):
                return dt
    raise AssertionError("unreachable")


def estimated_stable_time_step(robot: RobotSpec) -> tuple[float, str, dict[str, float]]:
    """The estimated stable step of ``robot`` in its physics (s: :data:`CALIBRATION` x the smallest
    bare limit), the mechanism that sets it, and every bare limit (:func:`time_step_limits`)."""
    limits = time_step_limits(robot)
    limiting = min(limits, key=limits.__getitem__)
    return CALIBRATION * limits[limiting], limiting, limits
