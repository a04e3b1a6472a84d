"""Assemble and run a finalized PyElastica simulation of one magnetic robot.

:func:`build_simulation` registers, in this order (the order matters, see the design notes):
magnetic torques, relative-velocity damping, legacy internal damping, gravity, then the ground
contact, and finalizes the simulator. :class:`RobotSimulation` steps it with ``PositionVerlet`` and
stops with :class:`SimulationDivergedError` (naming the time and the element) on NaN or a runaway speed.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import elastica as ea
import numpy as np
from numpy.typing import NDArray

from .forcing import LegacyInternalDamping, MagneticTorques, RelativeVelocityDamping
from .ground import FrictionalGroundContact
from .insertion import Advancer, InsertionClamp
from .interaction import DEFAULT_CUTOFF_RADII, MagneticInteraction
from .robot_spec import RobotSpec
from .section import rectangular_band_rod
from .spatial_fields import is_spatial
from .viscoelastic import KelvinVoigtDamping

__all__ = [
    "MagneticRodSimulator",
    "RobotSimulation",
    "SimulationDivergedError",
    "build_simulation",
    "PLANAR_TRAJECTORY_COLUMNS",
    "TRAJECTORY_COLUMNS",
    "trajectory_row",
]

FieldFunction = Callable[[float], NDArray[np.float64]]

#: The columns of the published reference trajectory (planar): time, middle (mean of the two
#: central elements), back (element 0), front (last element), largest element height, span.
PLANAR_TRAJECTORY_COLUMNS = (
    "t_s",
    "mid_x_m",
    "mid_y_m",
    "back_x_m",
    "back_y_m",
    "front_x_m",
    "front_y_m",
    "height_max_m",
    "span_m",
)
#: Columns of ``trajectory.csv``: the planar ones, then the same markers' sideways position z
#: (across the robot's start, in the floor plane: 0 for planar motion).
TRAJECTORY_COLUMNS = (*PLANAR_TRAJECTORY_COLUMNS, "mid_z_m", "back_z_m", "front_z_m")


class MagneticRodSimulator(
    ea.BaseSystemCollection, ea.Constraints, ea.Forcing, ea.Contact, ea.Damping, ea.CallBacks
):
    """A PyElastica simulator with every mixin a magnetic robot needs."""


class SimulationDivergedError(RuntimeError):
    """The simulation produced NaN or a runaway velocity; the message names the time and element."""

    def __init__(self, message: str, time: float, element: int) -> None:
        super().__init__(message)
        self.time = time
        self.element = element


#: The name of earlier releases (kept so that users' scripts run; it will go).
SimulationDiverged = SimulationDivergedError


@dataclass
class RobotSimulation:
    """A finalized simulator of one robot, ready to step.

    Attributes
    ----------
    spec : RobotSpec
        The robot and its physics (its ``units``; SI unless converted).
    simulator : MagneticRodSimulator
    rod : elastica.CosseratRod
    field : callable
        The field source driving the magnetic torques (``field(time) -> (3,)``).
    step_count : int
        Time steps taken; ``time == step_count * spec.dt``.
    max_speed : float
        A node faster than this (spec units, m/s in SI) counts as a numerical blow-up.
    """

    spec: RobotSpec
    simulator: MagneticRodSimulator
    rod: ea.CosseratRod
    field: FieldFunction
    stepper: ea.PositionVerlet = field(default_factory=ea.PositionVerlet)
    step_count: int = 0
    max_speed: float = 10.0

    @property
    def time(self) -> float:
        """Simulated time, s (spec units)."""
        return self.step_count * self.spec.dt

    def step(self, n_steps: int) -> None:
        """Take ``n_steps`` time steps, then check that the state is finite and not running away."""
        simulator, stepper, dt = self.simulator, self.stepper, self.spec.dt
        start = self.step_count
        for k in range(n_steps):
            # Time from the step counter, not accumulated: the field's zero-order hold stays exact.
            stepper.step(simulator, (start + k) * dt, dt)
        self.step_count = start + n_steps
        self.check_health()

    def advance(self, duration: float) -> None:
        """Step for ``duration`` seconds (rounded to whole time steps), checking every 0.01 s."""
        advance_in_actions(self, duration)

    def check_health(self) -> None:
        """Raise :class:`SimulationDivergedError` if any node has NaN or moves faster than ``max_speed``."""
        velocity = self.rod.velocity_collection
        position = self.rod.position_collection
        speed2 = np.einsum("ij,ij->j", velocity, velocity)
        limit2 = self.max_speed**2
        # Written so that NaN fails the test.
        if np.all(speed2 <= limit2) and np.all(np.isfinite(position)):
            return
        bad = np.flatnonzero(~(speed2 <= limit2) | ~np.all(np.isfinite(position), axis=0))
        node = int(bad[0])
        element = min(node, self.rod.n_elems - 1)
        what = "NaN" if not np.isfinite(speed2[node] + position[:, node].sum()) else (
            f"runaway speed {math.sqrt(speed2[node]):.3g} > {self.max_speed:.3g}"
        )
        raise SimulationDivergedError(
            f"simulation diverged at t = {self.time:.6f} s: {what} at node {node} "
            f"(element {element}){_cutoff_hint(self.spec)}; reduce dt (now {self.spec.dt:g}) or check "
            "the parameters",
            time=self.time,
            element=element,
        )

    def markers(self) -> dict[str, float]:
        """One trajectory row (see :data:`TRAJECTORY_COLUMNS`) of the current state."""
        return trajectory_row(self.rod, self.time)


def advance_in_actions(simulation: Any, duration: float) -> None:
    """Step ``simulation`` (a :class:`RobotSimulation` or one with its ``spec`` and ``step``) for
    ``duration`` seconds, rounded to whole time steps, in calls of at most 0.01 s (each call
    checks the state)."""
    n_total = int(round(duration / simulation.spec.dt))
    block = max(1, simulation.spec.steps_per_action)
    while n_total > 0:
        n = min(block, n_total)
        simulation.step(n)
        n_total -= n


def _cutoff_hint(spec: RobotSpec) -> str:
    """What a divergence may owe to the spec's interaction: a cutoff below the default (four
    radii) lets near pairs interact as point dipoles, far stiffer than the rod ("" otherwise)."""
    cutoff = None if spec.interaction is None else spec.interaction.cutoff
    default = DEFAULT_CUTOFF_RADII * spec.radius
    if cutoff is None or cutoff >= default:
        return ""
    return (f"; the spec's [robot.interaction] cutoff, {cutoff:g} m, is below the default four radii "
            f"({default:.3g} m): pairs that near interact as point dipoles, stiffer than the rod itself: "
            "raise it or leave it out")


def trajectory_row(rod: ea.CosseratRod, time: float) -> dict[str, float]:
    """Trajectory markers of a robot (:data:`TRAJECTORY_COLUMNS`), from its element centres (y from
    the start height; the span along x)."""
    position = rod.position_collection
    centres_x = 0.5 * (position[0, :-1] + position[0, 1:])
    centres_y = 0.5 * (position[1, :-1] + position[1, 1:])
    centres_z = 0.5 * (position[2, :-1] + position[2, 1:])
    n = centres_x.shape[0]
    mid = [n // 2 - 1, n // 2] if n % 2 == 0 else [n // 2]
    return {
        "t_s": time,
        "mid_x_m": float(centres_x[mid].mean()),
        "mid_y_m": float(centres_y[mid].mean()),
        "back_x_m": float(centres_x[0]),
        "back_y_m": float(centres_y[0]),
        "front_x_m": float(centres_x[-1]),
        "front_y_m": float(centres_y[-1]),
        "height_max_m": float(centres_y.max()),
        "span_m": float(centres_x[-1] - centres_x[0]),
        "mid_z_m": float(centres_z[mid].mean()),
        "back_z_m": float(centres_z[0]),
        "front_z_m": float(centres_z[-1]),
    }


def robot_rod(spec: RobotSpec) -> ea.CosseratRod:
    """The straight equivalent rod of ``spec`` (along +x from the origin), not yet in a simulator."""
    return rectangular_band_rod(
        spec.n_elements,
        spec.length,
        spec.width,
        spec.height,
        spec.effective_density,
        spec.youngs_modulus,
        spec.shear_modulus,
        alpha_c=spec.alpha_c,
        radius=spec.radius if spec.section == "round" else None,
    )


def ground_plane(spec: RobotSpec) -> ea.Plane | None:
    """The ground ``y = -radius`` of ``spec`` (``None`` when the spec has no ground)."""
    if spec.ground is None:
        return None
    return ea.Plane(plane_origin=np.array([0.0, -spec.radius, 0.0]), plane_normal=np.array([0.0, 1.0, 0.0]))


def register_robot_forcing(
    simulator: MagneticRodSimulator,
    rod: ea.CosseratRod,
    spec: RobotSpec,
    field_source: FieldFunction,
    plane: ea.Plane | None,
) -> None:
    """Register the per-rod forcing of ``spec`` on ``rod``: magnetic torques (and, opt-in, the
    magnetic interaction), the dampings, gravity, (opt-in) self-contact, then the ground contact with
    ``plane`` (already appended). Order matters: every load on the rod
    must be in place before the ground contact runs."""
    simulator.add_forcing_to(rod).using(
        MagneticTorques, field=field_source, magnetization=spec.magnetization, frame="lab"
    )
    interaction = spec.interaction
    if interaction is not None:
        simulator.add_forcing_to(rod).using(
            MagneticInteraction,
            magnetization=spec.magnetization,
            frame="lab",
            cutoff=interaction.cutoff,
            source_area=(spec.width * spec.height
                         if interaction.band_source and spec.section == "band" else None),
        )
    if spec.damping is not None and spec.damping.kelvin_voigt > 0.0:
        simulator.add_forcing_to(rod).using(KelvinVoigtDamping, viscosity=spec.damping.kelvin_voigt)
    if spec.damping is not None:
        simulator.add_forcing_to(rod).using(
            RelativeVelocityDamping, nu=spec.damping.relative_nu, node_offset=spec.damping.node_offset
        )
        simulator.add_forcing_to(rod).using(
            LegacyInternalDamping,
            force_coefficient=spec.damping.legacy_force,
            torque_coefficient=spec.damping.legacy_torque,
        )
    if spec.gravity > 0.0:
        simulator.add_forcing_to(rod).using(
            ea.GravityForces, acc_gravity=np.array([0.0, -spec.effective_gravity, 0.0])
        )
    if interaction is not None and interaction.self_contact_k > 0.0:
        simulator.detect_contact_between(rod, rod).using(
            ea.RodSelfContact, k=interaction.self_contact_k, nu=interaction.self_contact_nu
        )
    if spec.ground is not None and plane is not None:
        g = spec.ground
        simulator.detect_contact_between(rod, plane).using(
            FrictionalGroundContact,
            k=g.k,
            nu=g.nu,
            static_mu=g.static_mu,
            kinetic_mu=g.kinetic_mu,
            surface_tolerance=g.surface_tolerance,
            slip_velocity_tol=g.slip_velocity_tol,
            sideways=g.sideways,
            friction=g.friction,
            time_step=spec.dt,
        )


def constrain_base(simulator: Any, rod: Any, advancer: Advancer | None = None,
                   clock: Any = None) -> None:
    """Clamp ``rod``'s first node and element in ``simulator`` (before it is finalized): held where
    they are built, or, with an ``advancer``, moved along its axis by its insertion (``clock``: the
    advancer's time from the simulator's)."""
    if advancer is None:
        simulator.constrain(rod).using(
            ea.OneEndFixedBC, constrained_position_idx=(0,), constrained_director_idx=(0,))
        return
    simulator.constrain(rod).using(InsertionClamp, constrained_position_idx=(0,),
                                   constrained_director_idx=(0,), advancer=advancer, clock=clock)


def build_simulation(
    spec: RobotSpec, field_source: FieldFunction, *, max_speed: float | None = None,
    clamp: bool = False, advancer: Advancer | None = None,
) -> RobotSimulation:
    """Build and finalize the simulator of ``spec`` driven by ``field_source``.

    Parameters
    ----------
    spec : RobotSpec
        Robot and physics (e.g. :func:`~elastica_magnetic.yao2023_robot`).
    field_source : callable or spatial source
        ``field(time) -> (3,)`` in tesla (in the spec's unit system), or a source that varies in
        space (:mod:`elastica_magnetic.spatial_fields`; SI specs only), which adds the magnetic
        force.
    max_speed : float, optional
        Blow-up threshold for node speeds; default 10 m/s (in the spec's units).
    clamp : bool
        Clamp the rod's first node and element (position and directors), e.g. a catheter held at
        its base.
    advancer : Advancer, optional
        With ``clamp``: an insertion stage (:class:`~elastica_magnetic.insertion.Advancer`) that
        pushes the clamped base along its axis (:class:`~elastica_magnetic.insertion.InsertionClamp`).
    """
    spatial = is_spatial(field_source)
    if not (callable(field_source) or spatial):
        raise TypeError("field_source must be a callable field(time) -> (3,) or a spatial source "
                        "(at(points, time), gradient(points, time))")
    if spatial and spec.units.factor("length") != 1.0:
        raise ValueError(f"a spatial field source works in SI (m, T); the spec is in "
                         f"{spec.units.name}: build it in SI")
    simulator = MagneticRodSimulator()
    rod = robot_rod(spec)
    simulator.append(rod)
    if advancer is not None and not clamp:
        raise ValueError("an advancer pushes a clamped base: give clamp=True with it")
    if clamp:
        constrain_base(simulator, rod, advancer)
    plane = ground_plane(spec)
    if plane is not None:
        simulator.append(plane)
    register_robot_forcing(simulator, rod, spec, field_source, plane)
    simulator.finalize()
    if max_speed is None:
        max_speed = 10.0 * spec.units.factor("velocity")
    return RobotSimulation(spec, simulator, rod, field_source, max_speed=max_speed)

