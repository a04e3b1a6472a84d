"""Unit systems: SI and the authors' scaled mm-mg-s system.

PyElastica is unit-agnostic, so the same robot can be simulated in any consistent system. Yao et
al. used millimetre, milligram, second: force in nN, stress in mPa, torque in nN mm. They kept the
magnetization in A/m, which makes ``V M B`` a torque in nN mm when ``B`` is in mT: the field then
scales like a pressure (energy per volume per A/m). :class:`UnitSystem` converts a quantity by its
dimension; the unit-invariance test simulates the same robot in both systems.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["UnitSystem", "SI", "MM_MG_S", "DIMENSIONS"]

#: Dimensions as exponents of (length, mass, time), with magnetization kept in A/m so that the
#: field B (T) has the dimension of a pressure.
DIMENSIONS: dict[str, tuple[int, int, int]] = {
    "dimensionless": (0, 0, 0),
    "length": (1, 0, 0),
    "mass": (0, 1, 0),
    "time": (0, 0, 1),
    "velocity": (1, 0, -1),
    "acceleration": (1, 0, -2),
    "density": (-3, 1, 0),
    "pressure": (-1, 1, -2),
    "force": (1, 1, -2),
    "torque": (2, 1, -2),
    "field": (-1, 1, -2),
    "magnetization": (0, 0, 0),
    "stiffness": (0, 1, -2),  # N/m
    "damping": (0, 1, -1),  # N s/m
    "damping_per_length": (-1, 1, -1),  # N s/m^2
    "rotational_damping": (1, 1, -1),  # N s (torque per angular velocity per length)
    "viscosity": (-1, 1, -1),  # Pa s
}


@dataclass(frozen=True)
class UnitSystem:
    """A unit system given by how many of its units make one metre, kilogram and second."""

    name: str
    per_metre: float
    per_kilogram: float
    per_second: float

    def factor(self, dimension: str) -> float:
        """Multiply an SI value of this dimension by the factor to express it in this system."""
        try:
            length, mass, time = DIMENSIONS[dimension]
        except KeyError:
            raise ValueError(f"unknown dimension {dimension!r}; known: {sorted(DIMENSIONS)}") from None
        return self.per_metre**length * self.per_kilogram**mass * self.per_second**time

    def from_si(self, value, dimension: str):
        """Convert an SI value (scalar or array) to this system."""
        return value * self.factor(dimension)

    def to_si(self, value, dimension: str):
        """Convert a value (scalar or array) in this system to SI."""
        return value / self.factor(dimension)


SI = UnitSystem("SI (m, kg, s)", 1.0, 1.0, 1.0)
#: The authors' system: mm, mg, s (force nN, stress mPa, field mT with M in A/m).
MM_MG_S = UnitSystem("mm, mg, s", 1e3, 1e6, 1.0)
