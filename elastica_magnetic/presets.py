"""Robot presets, data only: the crawling robot of Yao et al. 2023 and the sheet of Hu et al. 2018,
each a :class:`~elastica_magnetic.robot_spec.RobotSpec` (the spec itself, every physical parameter
of a robot and its physics setting in SI, is :mod:`elastica_magnetic.robot_spec`).

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

from .magnetization import YAO2023_MAGNETIZATION, sinusoidal_magnetization, yao2023_magnetization

# the spec's home is .robot_spec
from .robot_spec import (
    STANDARD_GRAVITY,
    DampingSpec,
    GroundSpec,
    Physics,
    RobotSpec,
)

__all__ = [
    "YAO2023_MASS_SCALE",
    "yao2023_robot",
    "hu2018_robot",
    "ROBOTS",
    "robot_by_name",
]

#: The authors' mass-scaling factor for training (density x 1000/95, gravity / 1000/95).
YAO2023_MASS_SCALE = 1000.0 / 95.0


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
