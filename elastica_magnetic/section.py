"""The equivalent circular section of a rectangular band (paper, Materials and Methods).

PyElastica models circular sections. A band of width ``w`` and height ``h`` bending about its width
has ``I = w h^3 / 12``; loads that scale with the section area (magnetic torques ``V M x B``,
gravity) produce the same strains in a circular rod if its rigidities also scale with the area:
``I / A`` must match, which gives ``r = h / sqrt(3)`` (paper Eq. 28), and the shear rigidity
``alpha_c G A`` needs ``alpha_c = 1``. PyElastica 1.0 hard-codes ``alpha_c = 27/28`` in its rod
factory (and silently ignores an ``alpha_c=`` keyword), so :func:`set_shear_coefficient` rescales
the two shear diagonals in place, leaving the twist stiffness (which uses the shear modulus) alone.
"""

from __future__ import annotations

import logging
import math
from contextlib import contextmanager

import numpy as np
from elastica.rod.cosserat_rod import CosseratRod
from numpy.typing import ArrayLike

__all__ = [
    "PYELASTICA_SHEAR_COEFFICIENT",
    "equivalent_radius",
    "set_shear_coefficient",
    "shear_coefficient",
    "rectangular_band_rod",
    "quiet_small_inertia_warning",
    "rigidity_scale",
]

#: The shear coefficient PyElastica 1.0 hard-codes in ``rod/factory_function.py``.
PYELASTICA_SHEAR_COEFFICIENT = 27.0 / 28.0
_ALPHA_ATTRIBUTE = "_msr_shear_coefficient"


def equivalent_radius(height: float) -> float:
    """Radius (m) of the circular rod equivalent to a band of thickness ``height`` (m): ``h/sqrt(3)``.

    The band and the rod then have the same ratio of bending rigidity to section area, so loads
    proportional to the area give the same bending strain.
    """
    if not (math.isfinite(height) and height > 0.0):
        raise ValueError(f"height must be a positive length in m, got {height}")
    return height / math.sqrt(3.0)


def shear_coefficient(rod: CosseratRod) -> float:
    """The shear coefficient ``alpha_c`` the rod's shear matrix currently uses."""
    return getattr(rod, _ALPHA_ATTRIBUTE, PYELASTICA_SHEAR_COEFFICIENT)


def set_shear_coefficient(rod: CosseratRod, alpha_c: float) -> None:
    """Make the rod's two shear rigidities ``alpha_c G A`` (in place, before or after finalize).

    Only ``shear_matrix[0, 0, :]`` and ``[1, 1, :]`` change; the stretch rigidity ``[2, 2]`` and
    the twist stiffness are untouched. Calling it again with another value rescales from the
    current coefficient, so repeated calls do not compound.
    """
    if not (math.isfinite(alpha_c) and alpha_c > 0.0):
        raise ValueError(f"alpha_c must be a positive number, got {alpha_c}")
    factor = alpha_c / shear_coefficient(rod)
    rod.shear_matrix[0, 0, :] *= factor
    rod.shear_matrix[1, 1, :] *= factor
    setattr(rod, _ALPHA_ATTRIBUTE, float(alpha_c))


def rectangular_band_rod(
    n_elements: int,
    length: float,
    width: float,
    height: float,
    density: float,
    youngs_modulus: float,
    shear_modulus: float,
    *,
    start: ArrayLike = (0.0, 0.0, 0.0),
    direction: ArrayLike = (1.0, 0.0, 0.0),
    normal: ArrayLike = (0.0, 1.0, 0.0),
    alpha_c: float = 1.0,
    radius: float | None = None,
) -> CosseratRod:
    """A straight PyElastica rod equivalent to a rectangular band (radius ``h/sqrt(3)``, ``alpha_c``).

    The band bends in the plane spanned by ``direction`` and ``normal`` (about its width). The rod
    is circular: its mass, volume and magnetic volume are those of the circle of radius
    ``h/sqrt(3)``, not of the band, which keeps every area-proportional load consistent (paper
    Eq. 20-28). ``width`` is checked but enters nothing else: the planar statics do not depend on it.

    Parameters
    ----------
    n_elements : int
    length, width, height : float
        Band dimensions, m.
    density : float
        kg/m^3.
    youngs_modulus, shear_modulus : float
        Pa. Give the shear modulus explicitly (PyElastica 1.0's ``poisson_ratio=`` keyword raises).
    start, direction, normal : array_like
        Position of the first node (m), rod axis, and the normal ``d1`` of the reference directors.
    alpha_c : float
        Shear coefficient (1 for the paper's equivalent band).
    radius : float, optional
        A round rod of this radius (m) instead of the band's equivalent one (``width`` and
        ``height`` are then only checked).
    """
    _check_positive(
        length=length,
        width=width,
        height=height,
        density=density,
        youngs_modulus=youngs_modulus,
        shear_modulus=shear_modulus,
    )
    if int(n_elements) != n_elements or n_elements < 2:
        raise ValueError(f"n_elements must be an integer >= 2, got {n_elements!r}")
    rod_radius = equivalent_radius(height) if radius is None else float(radius)
    scale = rigidity_scale(rod_radius, float(youngs_modulus), float(shear_modulus))
    with quiet_small_inertia_warning():
        rod = CosseratRod.straight_rod(
            int(n_elements),
            np.asarray(start, dtype=np.float64),
            np.asarray(direction, dtype=np.float64),
            np.asarray(normal, dtype=np.float64),
            float(length),
            rod_radius,
            float(density),
            youngs_modulus=float(youngs_modulus) * scale,
            shear_modulus=float(shear_modulus) * scale,
        )
    if scale != 1.0:  # the moduli only enter these two arrays; a power of two divides exactly
        rod.shear_matrix /= scale
        rod.bend_matrix /= scale
    set_shear_coefficient(rod, alpha_c)
    return rod


def rigidity_scale(radius: float, youngs_modulus: float, shear_modulus: float) -> float:
    """The power of two by which the rod is built stiffer, then made softer again.

    PyElastica 1.0's rod factory asserts that every bending and twisting rigidity (``E I`` and
    ``G J``, N m^2) exceeds ``Tolerance.atol()`` (about 2.2e-12): an absolute threshold, meant as
    "positive", that in SI units refuses millimetre robots ("Bend matrix has to be greater than
    0"; a 2 mm x 0.8 mm x 80 um band of 84.5 kPa has ``E I`` = 3.0e-13 N m^2). Nothing in the
    simulation uses that threshold afterwards, and the moduli enter only the shear and bend
    matrices, which are linear in them: :func:`rectangular_band_rod` builds the rod with both
    moduli times this factor and divides the two matrices by it (exact, being a power of two).
    Returns 1 when the rigidities are 16 times above the threshold or more.
    """
    from elastica.utils import Tolerance

    second_moment = math.pi * radius**4 / 4.0  # m^4, about a diameter; J = 2 I
    smallest = min(youngs_modulus * second_moment, shear_modulus * 2.0 * second_moment)
    limit = 16.0 * Tolerance.atol()
    if smallest >= limit:
        return 1.0
    if not smallest > limit * 2.0**-900:
        raise ValueError(f"bending rigidity {smallest:.3g} N m^2 (radius {radius:.3g} m) is too small "
                         "to represent; give a thicker band or a stiffer material")
    return 2.0 ** math.ceil(math.log2(limit / smallest))


def _check_positive(**values: float) -> None:
    units = {
        "length": "m",
        "width": "m",
        "height": "m",
        "density": "kg/m^3",
        "youngs_modulus": "Pa",
        "shear_modulus": "Pa",
    }
    for name, value in values.items():
        if not (isinstance(value, int | float | np.floating) and math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive finite value in {units[name]}, got {value}")


class _DropMessage(logging.Filter):
    def __init__(self, text: str) -> None:
        super().__init__()
        self.text = text

    def filter(self, record: logging.LogRecord) -> bool:
        return self.text not in record.getMessage()


@contextmanager
def quiet_small_inertia_warning():
    """Silence PyElastica's 'mass moment of inertia smaller than tolerance' warning.

    Its tolerance is absolute (about 1e-12 in whatever units), so every millimetre-scale robot in
    SI triggers it although nothing is wrong; other warnings still pass.
    """
    root = logging.getLogger()
    quiet = _DropMessage("Mass moment of inertia matrix smaller than tolerance")
    root.addFilter(quiet)
    try:
        yield
    finally:
        root.removeFilter(quiet)
