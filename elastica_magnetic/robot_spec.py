"""The robot spec: every physical parameter of one robot and its physics setting, in SI
(:class:`RobotSpec`, with its ground, damping and interaction parts).
:func:`~elastica_magnetic.build_simulation` turns a spec into a finalized PyElastica simulator; the
paper's robots are :mod:`elastica_magnetic.presets`, spec files are read by
:mod:`elastica_magnetic.specfile`.

The two physics settings of the paper (``physics``: :data:`Physics`) differ by mass scaling and time
step (see :mod:`elastica_magnetic.presets`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from .section import equivalent_radius
from .units import SI, UnitSystem

__all__ = [
    "ACTION_PERIOD",
    "DampingSpec",
    "GroundSpec",
    "InteractionSpec",
    "Physics",
    "RobotSpec",
    "STANDARD_GRAVITY",
]

Physics = Literal["accurate", "training"]

#: Period of one field update (the paper's 100 Hz), s.
ACTION_PERIOD = 0.01
STANDARD_GRAVITY = 9.80665


@dataclass(frozen=True)
class GroundSpec:
    """A flat ground ``y = -radius`` (the rod's centreline starts at ``y = 0`` on it).

    Defaults are the authors' values converted to SI (their mm-mg-s constants in brackets):
    ``k`` 0.08 N/m [8e4], ``nu`` 6e-3 N s/m [6000], ``surface_tolerance`` 1e-7 m [1e-4].
    """

    k: float = 0.08
    nu: float = 6e-3
    static_mu: float = 0.8
    kinetic_mu: float = 0.6
    surface_tolerance: float = 1e-7
    slip_velocity_tol: float = 1e-8
    #: Friction across the rod: ``"rolling"`` (PyElastica's model of a round rod, which rolls
    #: sideways: the paper's, default) or ``"sliding"`` (a flat band, which cannot roll: Coulomb
    #: friction sideways, static up to ``static_mu`` N, kinetic ``kinetic_mu`` N, no torque).
    sideways: str = "rolling"
    #: How the friction is integrated: ``"explicit"`` (PyElastica's, the paper's, default: kinetic
    #: friction whenever a contact moves faster than ``slip_velocity_tol``, which overshoots once a
    #: slide is slower than ``kinetic_mu g dt``, so a slide never quite stops) or ``"implicit"``
    #: (Coulomb friction solved for each node's velocity at the end of the step: a slide ends at rest,
    #: a contact at rest needs ``static_mu`` N to start, friction never gains energy; needs
    #: ``sideways = "sliding"``).
    friction: str = "explicit"

    def __post_init__(self) -> None:
        if self.sideways not in SIDEWAYS_FRICTION:
            raise ValueError(f"ground sideways must be one of {', '.join(SIDEWAYS_FRICTION)}, got "
                             f"{self.sideways!r}")
        if self.friction not in FRICTION_INTEGRATION:
            raise ValueError(f"ground friction must be one of {', '.join(FRICTION_INTEGRATION)}, got "
                             f"{self.friction!r}")
        if self.friction == "implicit" and self.sideways != "sliding":
            raise ValueError(IMPLICIT_NEEDS_SLIDING)


#: The choices of :attr:`GroundSpec.sideways`.
SIDEWAYS_FRICTION = ("rolling", "sliding")
#: The choices of :attr:`GroundSpec.friction`.
FRICTION_INTEGRATION = ("explicit", "implicit")
#: Why ``friction = "implicit"`` refuses a rolling rod.
IMPLICIT_NEEDS_SLIDING = ('friction = "implicit" needs sideways = "sliding": the implicit friction is that '
                          "of a band, which slides the same way along and across itself; a round rod's "
                          "rolling is PyElastica's explicit model")


@dataclass(frozen=True)
class DampingSpec:
    """The paper's dissipation: relative-velocity damping plus the legacy internal damping.

    Defaults are the authors' values in SI: relative ``nu`` 20 N s/m^2 [2e4] between nodes ``j`` and
    ``j + 4``; legacy ``nu = 150`` [their units] is 0.15 N s/m^2 on forces and 1.5e-7 N s on torques.
    """

    relative_nu: float = 20.0
    node_offset: int = 4
    legacy_force: float = 0.15
    legacy_torque: float = 1.5e-7
    #: Kelvin-Voigt internal viscosity, Pa s (:class:`~elastica_magnetic.KelvinVoigtDamping`); 0: off.
    #: Not part of the paper's model: set the other three to 0 to use it instead of the paper's dampings.
    kelvin_voigt: float = 0.0


@dataclass(frozen=True)
class InteractionSpec:
    """Opt-in physics the paper left out: the magnetic interaction between the robot's own elements
    (:class:`~elastica_magnetic.MagneticInteraction`) and the rod's contact with itself.

    ``cutoff`` (m): pairs closer than this rest arclength do not interact (``None``: four radii).
    ``band_source``: the field is made by the band's moment (area ``width x height``), the response
    uses the equivalent rod's moment as the magnetic torque does (see the class). ``self_contact_k``
    (N/m) and ``self_contact_nu`` (N s/m): PyElastica's ``RodSelfContact``; ``k = 0`` leaves it out.
    """

    cutoff: float | None = None
    band_source: bool = True
    self_contact_k: float = 0.0
    self_contact_nu: float = 0.0


@dataclass(frozen=True)
class RobotSpec:
    """Every parameter of one robot and its physics, SI units.

    The rod is the equivalent circular rod of a ``length x width x height`` band (radius
    ``height / sqrt(3)``, shear coefficient ``alpha_c``), straight along +x from the origin at
    ``t = 0``, bending in the x-y plane; gravity acts along -y. ``section="round"``: a round rod
    whose diameter is ``width`` = ``height`` (radius ``height / 2``).
    """

    name: str
    n_elements: int
    length: float  # m
    width: float  # m
    height: float  # m
    density: float  # kg/m^3, true density (before mass scaling)
    youngs_modulus: float  # Pa
    shear_modulus: float  # Pa
    magnetization: NDArray[np.float64] = field(repr=False, compare=False)  # (3, n) A/m, lab frame
    alpha_c: float = 1.0
    gravity: float = STANDARD_GRAVITY  # m/s^2 along -y (true value, before mass scaling)
    mass_scale: float = 1.0  # density x s, gravity / s
    dt: float = 8e-6  # s
    ground: GroundSpec | None = GroundSpec()
    damping: DampingSpec | None = DampingSpec()
    units: UnitSystem = SI
    interaction: InteractionSpec | None = None
    section: Literal["band", "round"] = "band"

    def __post_init__(self) -> None:
        if self.section not in ("band", "round"):
            raise ValueError(f"RobotSpec.section must be 'band' or 'round', got {self.section!r}")
        if self.section == "round" and self.width != self.height:
            raise ValueError("a round RobotSpec has width == height == its diameter, got "
                             f"{self.width} and {self.height}")
        for name in ("length", "width", "height", "density", "youngs_modulus", "shear_modulus"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"RobotSpec.{name} must be positive and finite, got {value}")
        for name in ("alpha_c", "mass_scale", "dt"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"RobotSpec.{name} must be positive and finite, got {value}")
        if not (math.isfinite(self.gravity) and self.gravity >= 0.0):
            raise ValueError(f"RobotSpec.gravity must be >= 0, got {self.gravity}")
        shape = np.shape(self.magnetization)
        if shape != (3, self.n_elements):
            raise ValueError(
                f"RobotSpec.magnetization must have shape (3, {self.n_elements}) in A/m, got {shape}"
            )

    @property
    def radius(self) -> float:
        """Radius of the rod, m: ``height / sqrt(3)`` for a band (the equivalent circular rod),
        ``height / 2`` for a round section."""
        if self.section == "round":
            return 0.5 * self.height
        return equivalent_radius(self.height)

    @property
    def effective_density(self) -> float:
        """Density used in the simulation: ``density * mass_scale``."""
        return self.density * self.mass_scale

    @property
    def effective_gravity(self) -> float:
        """Gravity used in the simulation: ``gravity / mass_scale``."""
        return self.gravity / self.mass_scale

    @property
    def steps_per_action(self) -> int:
        """Time steps per 0.01 s field update."""
        return int(round(ACTION_PERIOD * self.units.factor("time") / self.dt))

    def to_units(self, units: UnitSystem) -> RobotSpec:
        """The same robot expressed in another unit system (from SI)."""
        if self.units != SI:
            raise ValueError("to_units converts from SI only")
        f = units.factor
        ground = None
        if self.ground is not None:
            ground = replace(
                self.ground,
                k=self.ground.k * f("stiffness"),
                nu=self.ground.nu * f("damping"),
                surface_tolerance=self.ground.surface_tolerance * f("length"),
                slip_velocity_tol=self.ground.slip_velocity_tol * f("velocity"),
            )
        damping = None
        if self.damping is not None:
            damping = replace(
                self.damping,
                relative_nu=self.damping.relative_nu * f("damping_per_length"),
                legacy_force=self.damping.legacy_force * f("damping_per_length"),
                legacy_torque=self.damping.legacy_torque * f("rotational_damping"),
                kelvin_voigt=self.damping.kelvin_voigt * f("viscosity"),
            )
        interaction = None
        if self.interaction is not None:
            cutoff = self.interaction.cutoff
            interaction = replace(
                self.interaction,
                cutoff=None if cutoff is None else cutoff * f("length"),
                self_contact_k=self.interaction.self_contact_k * f("stiffness"),
                self_contact_nu=self.interaction.self_contact_nu * f("damping"),
            )
        return replace(
            self,
            length=self.length * f("length"),
            width=self.width * f("length"),
            height=self.height * f("length"),
            density=self.density * f("density"),
            youngs_modulus=self.youngs_modulus * f("pressure"),
            shear_modulus=self.shear_modulus * f("pressure"),
            magnetization=self.magnetization * f("magnetization"),
            gravity=self.gravity * f("acceleration"),
            dt=self.dt * f("time"),
            ground=ground,
            damping=damping,
            units=units,
            interaction=interaction,
        )
