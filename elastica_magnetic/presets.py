"""Robot presets: the crawling robot of Yao et al. 2023 and the sheet of Hu et al. 2018.

A :class:`RobotSpec` holds every physical parameter of one robot and its physics setting, in SI.
:func:`~elastica_magnetic.build_simulation` turns it into a finalized PyElastica simulator.

The two physics settings of the paper ("Miscellaneous training tips"):

- ``"accurate"``: true density and gravity, ``dt = 8e-6 s`` (1250 steps per 0.01 s action).
- ``"training"``: *mass scaling* by ``s = 1000/95 = 10.526``: density x s and gravity / s, with
  ``dt = 1e-4 s`` (100 steps per action), about ten times cheaper. The weight ``rho A g`` and every
  static equilibrium are unchanged; what changes is inertia: translational and rotational inertia
  grow by ``s``, so the natural frequencies drop by ``sqrt(s)`` (3.2x), the stable time step grows
  by ``sqrt(s)``, and every damping (relative, legacy, contact) is ``s`` times weaker relative to
  inertia. Motions are slower and less damped: a different physics on purpose, which is why
  policies trained in it are refined in the accurate one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from .magnetization import YAO2023_MAGNETIZATION, sinusoidal_magnetization, yao2023_magnetization
from .section import equivalent_radius
from .units import SI, UnitSystem

__all__ = [
    "GroundSpec",
    "DampingSpec",
    "InteractionSpec",
    "RobotSpec",
    "Physics",
    "YAO2023_MASS_SCALE",
    "ACTION_PERIOD",
    "yao2023_robot",
    "hu2018_robot",
    "ROBOTS",
    "robot_by_name",
]

Physics = Literal["accurate", "training"]

#: The authors' mass-scaling factor for training (density x 1000/95, gravity / 1000/95).
YAO2023_MASS_SCALE = 1000.0 / 95.0
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


def _physics(physics: Physics) -> tuple[float, float]:
    """(mass_scale, dt) of a physics setting."""
    if physics == "accurate":
        return 1.0, 8e-6
    if physics == "training":
        return YAO2023_MASS_SCALE, 1e-4
    raise ValueError(f"physics must be 'accurate' or 'training', got {physics!r}")


def yao2023_robot(pattern: int = 1, physics: Physics = "accurate") -> RobotSpec:
    """The crawling robot of Yao et al. 2023: 20 x 8 x 0.8 mm band, 64 elements.

    E = 84.5 kPa, Poisson 0.48, 1860 kg/m^3, M = 61.3 kA/m (pattern 1 or 2), friction 0.8 / 0.6.
    The shear modulus is the authors' *effective* value ``E / (1 + nu)``: their PyElastica (0.2.x)
    computed it so, twice the textbook ``E / (2 (1 + nu))``; we keep it to reproduce their results
    (the difference moves the crawling distance by about 1%).
    """
    mass_scale, dt = _physics(physics)
    youngs_modulus, poisson = 84.5e3, 0.48
    return RobotSpec(
        name=f"yao2023-m{pattern}",
        n_elements=64,
        length=20e-3,
        width=8e-3,
        height=0.8e-3,
        density=1860.0,
        youngs_modulus=youngs_modulus,
        shear_modulus=youngs_modulus / (1.0 + poisson),
        magnetization=yao2023_magnetization(pattern, 64, YAO2023_MAGNETIZATION),
        alpha_c=1.0,
        gravity=STANDARD_GRAVITY,
        mass_scale=mass_scale,
        dt=dt,
        ground=GroundSpec(),
        damping=DampingSpec(),
    )


def hu2018_robot(
    n_elements: int = 64, phase: float = 0.0, dt: float = 2e-6, damping: DampingSpec | None = None
) -> RobotSpec:
    """The sheet of Hu et al. 2018: 3.7 mm x 1.5 mm x 185 um, single-wavelength magnetization.

    Free-free, no gravity, no ground. E = 84.5 kPa, 1860 kg/m^3, M = 61.3 kA/m, shear modulus
    ``E / (2 (1 + 0.5))`` (incompressible), ``alpha_c = 1``. The default damping is the paper's
    dissipation scaled to this smaller robot; it only sets how fast a static relaxation settles.
    """
    youngs_modulus = 84.5e3
    if damping is None:
        damping = DampingSpec(relative_nu=2.0, node_offset=4, legacy_force=0.05, legacy_torque=1e-9)
    return RobotSpec(
        name="hu2018",
        n_elements=n_elements,
        length=3.7e-3,
        width=1.5e-3,
        height=185e-6,
        density=1860.0,
        youngs_modulus=youngs_modulus,
        shear_modulus=youngs_modulus / 3.0,
        magnetization=sinusoidal_magnetization(n_elements, YAO2023_MAGNETIZATION, phase),
        alpha_c=1.0,
        gravity=0.0,
        dt=dt,
        ground=None,
        damping=damping,
    )


#: Robot names accepted by the command line.
ROBOTS = ("yao2023-m1", "yao2023-m2", "hu2018")


def robot_by_name(name: str, physics: Physics = "accurate") -> RobotSpec:
    """A preset by its command-line name (``yao2023-m1``, ``yao2023-m2``, ``hu2018``)."""
    if name == "yao2023-m1":
        return yao2023_robot(1, physics)
    if name == "yao2023-m2":
        return yao2023_robot(2, physics)
    if name == "hu2018":
        return hu2018_robot()
    raise ValueError(f"unknown robot {name!r}; choose one of {', '.join(ROBOTS)}")
