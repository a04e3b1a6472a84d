"""A robot's values judged against what the models assume, when its spec is read: the moduli
(a shear modulus in the wrong unit), a thin band, Coulomb friction, the contact tolerances against
the rod's size, and each physics setting's time step against the robot's stability limits.

A value no robot has (a unit mistake) is a :class:`~elastica_magnetic.spec_format.SpecError` naming
the file, table and key; an unusual one is warned about (:meth:`SpecTable.warn
<elastica_magnetic.spec_format.SpecTable.warn>`). The tables themselves are read by
:mod:`elastica_magnetic.specfile`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from .robot_spec import ACTION_PERIOD, RobotSpec
from .section import equivalent_radius
from .spec_format import SpecError, SpecTable
from .stability import estimated_stable_time_step, suggested_time_step

__all__ = [
    "MECHANISM_KEYS",
    "MIN_TIME_STEP",
    "check_contact_tolerances",
    "check_friction",
    "check_moduli",
    "check_thin_band",
    "check_time_steps",
]


#: Beyond this ratio of the two moduli (either way) the shear modulus is a unit mistake, refused.
MODULI_RATIO_LIMIT = 100.0


def check_moduli(t: SpecTable, youngs_modulus: float, shear_modulus: float) -> None:
    """Judge the shear modulus G against Young's E through the Poisson ratio E / (2 G) - 1 it
    implies. Between E / 3 (0.5: incompressible) and E (-0.5; the authors' effective E / (1 + nu)
    lies below) it is usual; outside, warned (no isotropic solid has nu above 0.5, and an auxetic
    rubber below -0.5 is no soft robot's); a factor of :data:`MODULI_RATIO_LIMIT` or more away from
    E, refused: a unit mistake."""
    implied = youngs_modulus / (2.0 * shear_modulus) - 1.0
    stated = (f"{shear_modulus:g} Pa against youngs_modulus {youngs_modulus:g} Pa implies a Poisson "
              f"ratio E / (2 G) - 1 = {implied:.4g}")
    if shear_modulus * MODULI_RATIO_LIMIT <= youngs_modulus:
        raise t.error("shear_modulus", f"{stated}, impossible for a solid: kPa written where Pa is "
                      f"expected? ({shear_modulus:g} kPa is {shear_modulus * 1e3:g} Pa); or give "
                      "poisson_ratio instead")
    if shear_modulus >= youngs_modulus * MODULI_RATIO_LIMIT:
        raise t.error("shear_modulus", f"{stated}: G {shear_modulus / youngs_modulus:.3g} times E "
                      "is no solid's (G lies between about E / 3 and E / 2 for a rubber): a unit "
                      "mistake (Pa where kPa was meant, or the other modulus)? or give "
                      "poisson_ratio instead")
    if shear_modulus * 3.0 < youngs_modulus * (1.0 - 1e-9):
        t.warn("shear_modulus", f"{shear_modulus:g} Pa is below a third of youngs_modulus "
               f"({youngs_modulus:g} Pa): it implies a Poisson ratio E / (2 G) - 1 = {implied:.3g}, above "
               "the 0.5 of an incompressible solid (expected G between about E / 3 and E: a unit "
               "mistake or a typo? or give poisson_ratio instead)")
    elif shear_modulus > youngs_modulus * (1.0 + 1e-9):
        t.warn("shear_modulus", f"{shear_modulus:g} Pa is above youngs_modulus ({youngs_modulus:g} "
               f"Pa): it implies a Poisson ratio E / (2 G) - 1 = {implied:.3g}, below -0.5 (a "
               "strongly auxetic material; rubbers are near 0.5, and the effective E / (1 + nu) is "
               "below E): a typo, or the moduli swapped? or give poisson_ratio instead")


def check_thin_band(t: SpecTable, width: float, thickness: float) -> None:
    if width < thickness:
        raise t.error("width", f"{width!r} m is smaller than thickness = {thickness!r} m: the "
                               "equivalent-rod model bends the band about its width and assumes a "
                               "thin band (width >= thickness); swap the two if they are exchanged, "
                               "or give radius (m) for a round rod")


def check_friction(t: SpecTable, ground: Mapping[str, float]) -> None:
    if ground["kinetic_mu"] > ground["static_mu"]:
        raise t.error("kinetic_mu", f"{ground['kinetic_mu']!r} is above static_mu = "
                                    f"{ground['static_mu']!r}: Coulomb friction has kinetic <= static "
                                    "(a sliding element would hold harder than a sticking one)")


#: Largest contact band, in radii of the rod: a band of a tenth of a radius already gives friction
#: to an element lifted visibly off the floor; a whole radius, to an element clear of it.
CONTACT_BAND_WARN_RADII, CONTACT_BAND_REFUSE_RADII = 0.1, 1.0
#: Largest sticking speed, in body lengths per second: below it an element counts as sticking (static
#: friction holds it), so a robot crawling slower than it would be held in place. Crawlers move a
#: hundredth to a few body lengths per second.
STICKING_SPEED_WARN, STICKING_SPEED_REFUSE = 1e-3, 1e-1


def check_contact_tolerances(t: SpecTable, robot: Mapping[str, Any]) -> None:
    """Judge the contact band against the rod's radius and the sticking speed against its length:
    both are numbers whose unit cannot be guessed, only whether they make the contact a different
    model (friction on lifted elements, a crawling robot held as if stuck)."""
    ground = robot["ground"]
    radius = robot["radius"] if "radius" in robot else equivalent_radius(robot["thickness"])
    band = ground["surface_tolerance"] / radius
    what = (f"the contact band is {band:.3g} radii of the rod (r = {radius:.3g} m): an element "
            f"{ground['surface_tolerance']:g} m above the floor counts as touching and feels friction")
    if band >= CONTACT_BAND_REFUSE_RADII:
        raise t.error("surface_tolerance", f"{ground['surface_tolerance']!r} m is not below the rod's "
                      f"radius: {what}; give a band below {CONTACT_BAND_WARN_RADII:g} radii "
                      "(default 1e-7 m), in m")
    if band > CONTACT_BAND_WARN_RADII:
        t.warn("surface_tolerance", f"{what} (above {CONTACT_BAND_WARN_RADII:g} radii; default 1e-7 m)")
    length = robot["length"]
    sticking = ground["slip_velocity_tolerance"] / length
    what = (f"{ground['slip_velocity_tolerance']:g} m/s is {sticking:.3g} body lengths per second "
            f"(L = {length:g} m): an element sliding slower counts as sticking, so a robot crawling "
            "slower is held by static friction")
    if sticking >= STICKING_SPEED_REFUSE:
        raise t.error("slip_velocity_tolerance", f"{what}; crawlers move 0.01 to a few body lengths "
                      f"per second: give a speed below {STICKING_SPEED_WARN:g} body lengths per second "
                      "(default 1e-8 m/s), in m/s")
    if sticking > STICKING_SPEED_WARN:
        t.warn("slip_velocity_tolerance", f"{what} (above {STICKING_SPEED_WARN:g} body lengths per "
               "second; default 1e-8 m/s)")


#: s: a robot whose stable step is below this (1e6 steps per 0.01 s action; the time step's own
#: plausibility warns there: finer than any soft robot needs) has a value in the wrong unit: the
#: key that sets the limit is named, not a time step to run it with.
MIN_TIME_STEP = 1e-8
#: The spec keys that set each mechanism's stability limit
#: (:func:`~elastica_magnetic.stability.time_step_limits`).
MECHANISM_KEYS = {
    "axial and bending waves": "[robot] youngs_modulus, density and the elements' length",
    "shear and rotation": "[robot] shear_coefficient and shear modulus (or poisson_ratio)",
    "relative damping": "[robot.damping] relative", "legacy force damping": "[robot.damping] legacy_force",
    "legacy torque damping": "[robot.damping] legacy_torque",
    "Kelvin-Voigt viscosity": "[robot.damping] kelvin_voigt",
    "ground stiffness": "[robot.ground] stiffness", "ground damping": "[robot.ground] damping",
}


def check_time_steps(robots: Mapping[str, RobotSpec], spec: Mapping[str, Any], source: str) -> None:
    """Refuse a physics setting (``robots``: the robot in each, by setting name, as read from the
    parsed ``spec`` of file ``source``) whose ``dt`` is above the robot's smallest bare stability limit
    (:func:`~elastica_magnetic.stability.time_step_limits`: every blow-up measured came below it),
    naming the mechanism and a step that fits. Steps between the calibrated estimate and that
    limit are likely unstable: ``msr case check`` reports them."""
    physics = spec.get("physics")
    for setting, robot in robots.items():
        stable, limiting, limits = estimated_stable_time_step(robot)
        if robot.dt <= limits[limiting]:
            continue
        table = physics.get(setting) if isinstance(physics, Mapping) else None
        value = "given" if isinstance(table, Mapping) and "dt" in table else "the default"
        suggested = suggested_time_step(stable)
        if suggested < MIN_TIME_STEP:  # no step can run it: the value is off
            raise SpecError(
                f"{source}: {MECHANISM_KEYS[limiting]}: this robot's {limiting} alone needs a time step "
                f"below {limits[limiting]:.2e} s, {ACTION_PERIOD / suggested:.2g} steps per 0.01 s "
                "action: finer than any soft robot needs (runs of days), so no robot has such a value; "
                "is it in other units (msr case show m1-4mT --toml: the paper's robot)?")
        raise SpecError(
            f"{source}: [physics.{setting}] dt: {robot.dt:g} s ({value}) is above this robot's "
            f"stability limit {limits[limiting]:.2e} s (the {limiting} limit; robots measured blew up "
            f"at 0.72-0.89 of it, estimated stable step {stable:.2e} s); the simulation would blow "
            f"up or give a wrong result. Set dt = {suggested_time_step(stable):g} in "
            f"[physics.{setting}]")
