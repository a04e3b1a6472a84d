"""Spec files: a robot and its physics as plain TOML data, checked key by key.

A *spec* is a TOML file (read with :mod:`tomllib`) that describes a case completely. The file
format (reading, writing, a table read key by key, :class:`SpecError`) is
:mod:`elastica_magnetic.spec_format`, its names importable from here too; this module owns the two
tables that describe the physical robot:

- ``[robot]`` (geometry, material, gravity) with ``[robot.magnetization]`` (required),
  ``[robot.ground]``, ``[robot.damping]`` and ``[robot.interaction]`` (optional);
- ``[physics.training]`` and ``[physics.accurate]``: mass scaling and time step of the two physics
  settings (see :mod:`elastica_magnetic.presets`).

The learning package reads the other tables (``[actuation]``, ``[task]``, ``[training]``,
``[yardstick]``). Every value is SI; the keys, units and defaults are listed in
:data:`ROBOT_KEYS` and written next to each value by :func:`dumps`. Unknown keys, missing required
keys, wrong types and non-physical values raise :class:`SpecError`, which names the file, the
table and the key and states the expected unit or range.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .interaction import DEFAULT_CUTOFF_RADII
from .magnetization import (
    YAO2023_MAGNETIZATION,
    MagnetizationSegment,
    segment_element_counts,
    segments_magnetization,
    sinusoidal_magnetization,
    two_segment_magnetization,
    uniform_magnetization,
    yao2023_magnetization,
)
from .presets import ROBOTS, YAO2023_MASS_SCALE, robot_by_name
from .result_file import FileKind
from .robot_plausibility import (
    check_contact_tolerances,
    check_friction,
    check_moduli,
    check_thin_band,
    check_time_steps,
)
from .robot_spec import (
    ACTION_PERIOD,
    FRICTION_INTEGRATION,
    IMPLICIT_NEEDS_SLIDING,
    SIDEWAYS_FRICTION,
    STANDARD_GRAVITY,
    DampingSpec,
    GroundSpec,
    InteractionSpec,
    Physics,
    RobotSpec,
)
from .section import equivalent_radius

# the file format's home is .spec_format
from .spec_format import (
    REQUIRED,
    SpecError,
    SpecTable,
    accepted_keys,
    read_spec,
    toml_with_units,
)

__all__ = [
    "SPEC_TABLES",
    "MAGNETIZATION_KINDS",
    "RobotDescription",
    "dumps",
    "describe_robot",
    "robot_tables_spec",
    "load_robot",
    "axis_limits_of",
    "field_limit_of",
    "spec_field_limit",
    "check_plain_name",
]

#: Top-level keys of a spec file (the learning package reads ``actuation`` to ``yardstick`` and
#: ``design``; :mod:`elastica_magnetic.field_spec` reads ``field`` and ``boundary``).
SPEC_TABLES = ("name", "description", "robot", "physics", "actuation", "task", "training", "yardstick",
               "design", "field", "boundary", "checks")

#: Named magnetization patterns and their parameters (besides ``kind``); ``table`` gives the
#: per-element values directly.
MAGNETIZATION_KINDS: dict[str, tuple[str, ...]] = {
    "uniform": ("magnitude", "direction"),
    "two-segment": ("magnitude", "first", "second", "split"),
    "yao2023-pattern1": ("magnitude",),
    "yao2023-pattern2": ("magnitude",),
    "sinusoid": ("magnitude", "phase"),
    "segments": ("segments", "magnitude"),
    "table": ("values",),
}

#: The two physics settings and their defaults (the paper's): mass scale, time step (s).
PHYSICS_DEFAULTS: dict[str, dict[str, float]] = {
    "training": {"mass_scale": YAO2023_MASS_SCALE, "dt": 1e-4},
    "accurate": {"mass_scale": 1.0, "dt": 8e-6},
}

#: Units written next to values by :func:`dumps` (table path, key) -> unit.
UNITS: dict[tuple[str, str], str] = {
    ("robot", "length"): "m", ("robot", "width"): "m", ("robot", "thickness"): "m",
    ("robot", "radius"): "m", ("robot", "density"): "kg/m^3", ("robot", "youngs_modulus"): "Pa",
    ("robot", "shear_modulus"): "Pa", ("robot", "gravity"): "m/s^2 along -y",
    ("robot", "shear_coefficient"): "alpha_c", ("robot", "poisson_ratio"): "Poisson ratio",
    ("robot.magnetization", "magnitude"): "A/m", ("robot.magnetization", "phase"): "rad",
    ("robot.magnetization", "split"): "elements in the first segment",
    ("robot.magnetization", "values"): "A/m, [[m_x...], [m_y...], [m_z...]], lab frame, rod along +x",
    ("robot.ground", "stiffness"): "N/m", ("robot.ground", "damping"): "N s/m",
    ("robot.ground", "surface_tolerance"): "m", ("robot.ground", "slip_velocity_tolerance"): "m/s",
    ("robot.ground", "static_mu"): "friction coefficient",
    ("robot.ground", "kinetic_mu"): "friction coefficient",
    ("robot.ground", "sideways"): "rolling (a round rod) or sliding (a flat band)",
    ("robot.ground", "friction"): "explicit (PyElastica's) or implicit (a slide ends at rest)",
    ("robot.damping", "relative"): "N s/m^2", ("robot.damping", "node_offset"): "nodes",
    ("robot.damping", "legacy_force"): "N s/m^2", ("robot.damping", "legacy_torque"): "N s",
    ("robot.damping", "kelvin_voigt"): "Pa s",
    ("robot.interaction", "cutoff"): "m", ("robot.interaction", "self_contact_stiffness"): "N/m",
    ("robot.interaction", "self_contact_damping"): "N s/m",
    ("physics.training", "dt"): "s", ("physics.accurate", "dt"): "s",
    ("physics.training", "mass_scale"): "density x s, gravity / s",
    ("physics.accurate", "mass_scale"): "density x s, gravity / s",
}

def dumps(data: Mapping[str, Any], units: Mapping[tuple[str, str], str] | None = None) -> str:
    """TOML text of a spec, with the unit of each value in a comment (written with ``tomli_w``):
    :data:`UNITS` and ``units`` ((table, key) -> unit) for the tables of other packages."""
    return toml_with_units(data, {**UNITS, **(units or {})})


# -- the robot and its physics --------------------------------------------------------------------


@dataclass(frozen=True)
class RobotDescription:
    """The ``[robot]`` and ``[physics]`` tables of a spec, checked and complete (every default
    written out, SI): :attr:`tables` is plain data (``{"robot": ..., "physics": ...}``, and
    ``"checks"`` when the spec accepts unusual values, see
    :func:`~elastica_magnetic.spec_format.accepted_keys`) that round-trips through TOML and JSON;
    :meth:`robot` builds the :class:`RobotSpec`."""

    tables: dict[str, Any]

    @property
    def n_elements(self) -> int:
        return int(self.tables["robot"]["n_elements"])

    @property
    def name(self) -> str:
        return str(self.tables["robot"]["name"])

    def robot(self, physics: Physics = "accurate") -> RobotSpec:
        """The robot in one physics setting (``"accurate"`` or ``"training"``)."""
        if physics not in PHYSICS_DEFAULTS:
            raise ValueError(f"physics must be 'accurate' or 'training', got {physics!r}")
        r = self.tables["robot"]
        setting = self.tables["physics"][physics]
        n = int(r["n_elements"])
        if "radius" in r:
            section, width, height = "round", 2.0 * r["radius"], 2.0 * r["radius"]
        else:
            section, width, height = "band", r["width"], r["thickness"]
        if "shear_modulus" in r:
            shear_modulus = r["shear_modulus"]
        else:
            shear_modulus = r["youngs_modulus"] / (2.0 * (1.0 + r["poisson_ratio"]))
        ground = r.get("ground")
        damping = r.get("damping")
        interaction = r.get("interaction")
        return RobotSpec(
            name=r["name"],
            n_elements=n,
            length=r["length"],
            width=width,
            height=height,
            section=section,
            density=r["density"],
            youngs_modulus=r["youngs_modulus"],
            shear_modulus=shear_modulus,
            magnetization=magnetization_array(r["magnetization"], n),
            alpha_c=r["shear_coefficient"],
            gravity=r["gravity"],
            mass_scale=setting["mass_scale"],
            dt=setting["dt"],
            ground=None if ground is None else GroundSpec(
                k=ground["stiffness"], nu=ground["damping"], static_mu=ground["static_mu"],
                kinetic_mu=ground["kinetic_mu"], surface_tolerance=ground["surface_tolerance"],
                slip_velocity_tol=ground["slip_velocity_tolerance"],
                sideways=ground.get("sideways", GroundSpec.sideways),
                friction=ground.get("friction", GroundSpec.friction)),
            damping=None if damping is None else DampingSpec(
                relative_nu=damping["relative"], node_offset=damping["node_offset"],
                legacy_force=damping["legacy_force"], legacy_torque=damping["legacy_torque"],
                kelvin_voigt=damping["kelvin_voigt"]),
            interaction=None if interaction is None else InteractionSpec(
                cutoff=interaction.get("cutoff"), band_source=interaction["band_source"],
                self_contact_k=interaction["self_contact_stiffness"],
                self_contact_nu=interaction["self_contact_damping"]),
        )


def robot_tables_spec(tables: Mapping[str, Any]) -> dict[str, Any]:
    """The tables of a :class:`RobotDescription` (``[robot]``, ``[physics]``, ``[checks]``) as a spec
    that :func:`describe_robot` reads again (a varied robot's): its ``[checks] accept`` keeps the
    keys of those tables and the named checks, and drops the keys of the case's other tables (a
    crawl's ``yardstick.period``), which were checked where the case was read and name nothing here."""
    from .plausibility import NAMED_CHECKS

    out = dict(tables)
    accept = (tables.get("checks") or {}).get("accept")
    if isinstance(accept, list):
        kept = [k for k in accept if k in NAMED_CHECKS or k.split(".", 1)[0].split("[", 1)[0] in tables]
        if kept:
            out["checks"] = {**tables["checks"], "accept": kept}
        else:
            out.pop("checks", None)
    return out


def describe_robot(spec: Mapping[str, Any], source: str = "<spec>") -> RobotDescription:
    """Check the ``[robot]`` and ``[physics]`` tables of ``spec`` (a parsed spec file) and return
    them complete. Other top-level keys must be among :data:`SPEC_TABLES` (they are checked by
    their owners); anything else is an error naming ``source`` and the key."""
    top = SpecTable(spec, source)
    for key in spec:
        if key not in SPEC_TABLES:
            raise top.error(key, f"unknown top-level key (a spec has: {', '.join(SPEC_TABLES)})")
    if "name" in spec:  # the case's name (read by the learning package) names folders too
        check_plain_name(top, "name", spec["name"])
    robot = _robot_table(top.table("robot"))
    physics = _physics_table(top.table("physics", required=False), source, robot)
    tables = {"robot": robot, "physics": physics}
    if top.accept:  # kept with the robot, so that a run's stored spec accepts the same values
        tables["checks"] = {"accept": list(spec["checks"]["accept"])}
    description = RobotDescription(tables)
    check_time_steps({setting: description.robot(setting) for setting in description.tables["physics"]},
                     spec, source)
    return description


def _robot_table(t: SpecTable) -> dict[str, Any]:
    """The ``[robot]`` table and its sub-tables, every value checked, in the file's layout."""
    out: dict[str, Any] = {"name": t.string("name", "custom")}
    check_plain_name(t, "name", out["name"])
    out["length"] = t.number("length", "m", low=0.0, low_open=True, plausible="rod length")
    out["n_elements"] = t.number("n_elements", "elements", low=2, integer=True)
    if out["n_elements"] > MAX_ELEMENTS:
        raise t.error("n_elements", f"{out['n_elements']} elements is more than {MAX_ELEMENTS}: the stable "
                      "time step falls with the square of an element's length, so a rod that fine takes "
                      "days per simulated second (the paper's robots have 64); a count written with extra "
                      "digits?")
    out.update(_section_values(t))
    out.update(_material_values(t))
    out["magnetization"] = _magnetization_table(t.table("magnetization"), out["n_elements"])
    ground = t.table("ground", required=False)
    if ground is not None:
        out["ground"] = _ground_table(ground)
        check_contact_tolerances(ground, out)
        ground.finish()
    damping = t.table("damping", required=False)
    if damping is not None:
        out["damping"] = _damping_table(damping, out["n_elements"])
    interaction = t.table("interaction", required=False)
    if interaction is not None:
        radius = out["radius"] if "radius" in out else equivalent_radius(out["thickness"])
        out["interaction"] = _interaction_table(interaction, out["length"], out["n_elements"], radius)
    t.finish()
    return out


def _section_values(t: SpecTable) -> dict[str, float]:
    """``radius`` (a round rod) or ``width`` and ``thickness`` (a band), m."""
    t.takes("radius", "width", "thickness")
    if t.has("radius"):
        for other in ("width", "thickness"):
            if t.has(other):
                raise t.error(other, "give either radius (round rod) or width and thickness (band)")
        return {"radius": t.number("radius", "m", low=0.0, low_open=True, plausible="section")}
    if not (t.has("width") or t.has("thickness")):
        raise t.error("thickness", "missing: give width and thickness (m, a band) or radius (m)")
    out = {"width": t.number("width", "m", low=0.0, low_open=True, plausible="section"),
           "thickness": t.number("thickness", "m", low=0.0, low_open=True, plausible="section")}
    check_thin_band(t, out["width"], out["thickness"])
    return out


def _material_values(t: SpecTable) -> dict[str, float]:
    """Density, Young's modulus, the shear modulus or Poisson ratio, the shear coefficient and
    gravity (SI)."""
    out = {"density": t.number("density", "kg/m^3", low=0.0, low_open=True, plausible="density"),
           "youngs_modulus": t.number("youngs_modulus", "Pa", low=0.0, low_open=True,
                                      plausible="youngs modulus")}
    t.takes("shear_modulus", "poisson_ratio")
    if t.has("shear_modulus") and t.has("poisson_ratio"):
        raise t.error("poisson_ratio", "give either shear_modulus (Pa) or poisson_ratio, not both")
    if t.has("poisson_ratio"):
        nu = t.number("poisson_ratio", "1", high=0.5, plausible="poisson ratio")
        if nu <= -1.0:
            raise t.error("poisson_ratio", f"must be in (-1, 0.5], got {nu!r}")
        t.check_plausible("poisson_ratio", nu, "poisson ratio")
        out["poisson_ratio"] = nu
    else:
        out["shear_modulus"] = t.number("shear_modulus", "Pa, or give poisson_ratio", low=0.0,
                                        low_open=True, plausible="shear modulus")
        check_moduli(t, out["youngs_modulus"], out["shear_modulus"])
    out["shear_coefficient"] = t.number("shear_coefficient", "alpha_c, 1", 1.0, low=0.0, low_open=True,
                                        plausible="shear coefficient")
    out["gravity"] = t.number("gravity", "m/s^2", STANDARD_GRAVITY, low=0.0)
    if out["gravity"] != 0.0:  # 0: no gravity, on purpose
        t.check_plausible("gravity", out["gravity"], "gravity")
    return out


def _ground_table(ground: SpecTable) -> dict[str, Any]:
    """``[robot.ground]``: friction, contact spring and damper, tolerances, the sideways model."""
    d = GroundSpec()
    out = {
        "static_mu": ground.number("static_mu", "1", d.static_mu, low=0.0,
                                   plausible="friction coefficient"),
        "kinetic_mu": ground.number("kinetic_mu", "1", d.kinetic_mu, low=0.0,
                                    plausible="friction coefficient"),
        "stiffness": ground.number("stiffness", "N/m", d.k, low=0.0, low_open=True),
        "damping": ground.number("damping", "N s/m", d.nu, low=0.0),
        "surface_tolerance": ground.number("surface_tolerance", "m", d.surface_tolerance, low=0.0),
        "slip_velocity_tolerance": ground.number("slip_velocity_tolerance", "m/s",
                                                 d.slip_velocity_tol, low=0.0, low_open=True),
    }
    sideways = ground.string("sideways", d.sideways, choices=SIDEWAYS_FRICTION)
    if sideways != d.sideways:  # written only when chosen: earlier records stay the same
        out["sideways"] = sideways
    friction = ground.string("friction", d.friction, choices=FRICTION_INTEGRATION)
    if friction == "implicit" and sideways != "sliding":
        raise ground.error("friction", IMPLICIT_NEEDS_SLIDING.removeprefix('friction = "implicit" '))
    if friction != d.friction:
        out["friction"] = friction
    check_friction(ground, out)
    return out


def _damping_table(damping: SpecTable, n_elements: int) -> dict[str, Any]:
    """``[robot.damping]``: the relative, legacy and Kelvin-Voigt damping."""
    d = DampingSpec()
    out = {
        "relative": damping.number("relative", "N s/m^2", d.relative_nu, low=0.0),
        "node_offset": damping.number("node_offset", "nodes", d.node_offset, low=1, integer=True),
        "legacy_force": damping.number("legacy_force", "N s/m^2", d.legacy_force, low=0.0),
        "legacy_torque": damping.number("legacy_torque", "N s", d.legacy_torque, low=0.0),
        "kelvin_voigt": damping.number("kelvin_voigt", "Pa s", d.kelvin_voigt, low=0.0),
    }
    if out["node_offset"] > n_elements:
        raise damping.error("node_offset", f"must be at most n_elements = {n_elements}, "
                            f"got {out['node_offset']}")
    damping.finish()
    return out


#: The most elements a robot may have: beyond, every simulated second takes days (and the rod's
#: arrays, allocated before any check of the time step, may not fit in memory).
MAX_ELEMENTS = 10_000
#: The cutoff advised where four radii is no longer than an element (in elements): measured on the
#: paper's robot, cutoffs of 2 and 3 elements turned to NaN within 0.01 s and 3.2 ran.
SAFE_CUTOFF_ELEMENTS = 4.0
_NEIGHBOURS_AS_DIPOLES = ("neighbouring elements would interact as point dipoles one element apart, which "
                          "the continuum is not (the sum grows without bound as the rod is refined) and "
                          "which no time step follows (the run turns to NaN at once)")


def _interaction_table(interaction: SpecTable, length: float, n_elements: int,
                       radius: float) -> dict[str, Any]:
    """``[robot.interaction]``: the magnetic interaction's cutoff and source, self-contact
    (``length``: the rod's, m; a cutoff at or beyond it leaves no pair to interact, one at or below
    an element's length lets neighbours interact as point dipoles; one below the default of
    :data:`~elastica_magnetic.interaction.DEFAULT_CUTOFF_RADII` times the (equivalent) ``radius``, m,
    is warned about: near pairs as point dipoles are stiffer than the rod)."""
    out: dict[str, Any] = {}
    interaction.takes("cutoff")
    element = length / n_elements
    default = DEFAULT_CUTOFF_RADII * radius
    # where four radii is no longer than an element, that default would let neighbours interact too
    safe = SAFE_CUTOFF_ELEMENTS * element
    advice = ("leave cutoff out for four radii" if default > element * (1.0 + 1e-9) else
              f"give cutoff = {safe:g} ({SAFE_CUTOFF_ELEMENTS:g} elements; the default four radii, "
              f"{default:g} m, is no longer than one element of this rod)" if safe < length else
              f"this rod of {n_elements} elements is too coarse for the interaction: no cutoff of "
              f"{SAFE_CUTOFF_ELEMENTS:g} elements or more lies within its length; give n_elements of at "
              f"least {int(SAFE_CUTOFF_ELEMENTS) * 2}, or remove [robot.interaction]")
    if interaction.has("cutoff"):  # absent: four radii (see InteractionSpec)
        out["cutoff"] = interaction.number("cutoff", "m", low=0.0)
        if out["cutoff"] >= length:
            # millimetres only where the value in mm would be a cutoff (beyond an element, within the rod)
            mm = (f"; {out['cutoff']:g} mm is {1e-3 * out['cutoff']:g} m"
                  if element < 1e-3 * out["cutoff"] < length else "")
            raise interaction.error("cutoff", f"{out['cutoff']:g} m is at or beyond the rod's length "
                                    f"({length:g} m): pairs closer than the cutoff along the rod do not "
                                    "interact, so no pair would and the interaction the table asks for "
                                    f"would be off{f' (millimetres written as metres?{mm})' if mm else ''}; "
                                    f"{advice}")
        if out["cutoff"] <= element * (1.0 + 1e-9):
            raise interaction.error("cutoff", f"{out['cutoff']:g} m is at or below one element's length "
                                    f"({element:g} m): {_NEIGHBOURS_AS_DIPOLES}; {advice}")
        if out["cutoff"] < default:
            elements = out["cutoff"] / element
            interaction.warn("cutoff", f"{out['cutoff']:g} m ({elements:.3g} elements) is below the "
                             f"default of {DEFAULT_CUTOFF_RADII:g} radii ({default:g} m): pairs that near "
                             "interact as point dipoles, stiffer than the rod they are part of, and a "
                             "cutoff of a few elements diverges at once (measured on the paper's robot: 2 "
                             f"and 3 elements turn to NaN within 0.01 s, 3.2 run); {advice}")
    elif default <= element * (1.0 + 1e-9):
        raise interaction.error("cutoff", f"absent: the default of {DEFAULT_CUTOFF_RADII:g} radii "
                                f"({default:g} m) is at or below one element's length ({element:g} m): "
                                f"{_NEIGHBOURS_AS_DIPOLES}; {advice}")
    out.update(
        band_source=interaction.boolean("band_source", True),
        self_contact_stiffness=interaction.number("self_contact_stiffness", "N/m", 0.0, low=0.0),
        self_contact_damping=interaction.number("self_contact_damping", "N s/m", 0.0, low=0.0),
    )
    if out["self_contact_damping"] > 0.0 and out["self_contact_stiffness"] == 0.0:
        # the contact is left out without a stiffness: its damping would be dropped without a word
        raise interaction.error("self_contact_damping", f"{out['self_contact_damping']:g} N s/m with "
                                "self-contact off (self_contact_stiffness = 0, the default): the damping "
                                "acts only on a contact; give self_contact_stiffness (N/m) or remove "
                                "self_contact_damping")
    interaction.finish()
    return out


def _magnetization_table(t: SpecTable, n_elements: int) -> dict[str, Any]:
    kind = t.string("kind", choices=tuple(MAGNETIZATION_KINDS))
    out: dict[str, Any] = {"kind": kind}
    if kind == "table":
        values = t.raw("values")
        try:
            array = np.asarray(values, dtype=np.float64)
        except (TypeError, ValueError):
            raise t.error("values", "expected three lists of numbers (A/m): "
                                    "[[m_x...], [m_y...], [m_z...]]") from None
        if array.shape != (3, n_elements):
            raise t.error("values", f"expected shape (3, {n_elements}) (three lists of n_elements "
                                    f"values, A/m), got {array.shape}")
        if not np.all(np.isfinite(array)):
            raise t.error("values", "must be finite (A/m)")
        t.check_plausible("values", float(np.linalg.norm(array, axis=0).max()), "magnetization",
                          "the largest |M|")
        out["values"] = array.tolist()
    elif kind == "segments":
        out["segments"] = _segments(t, n_elements)
    else:
        out["magnitude"] = t.number("magnitude", "A/m", YAO2023_MAGNETIZATION, low=0.0,
                                    plausible="magnetization")
        if kind == "uniform":
            out["direction"] = _direction(t, "direction", [1.0, 0.0, 0.0])
        elif kind == "two-segment":
            out["first"] = _direction(t, "first")
            out["second"] = _direction(t, "second")
            out["split"] = t.number("split", "elements", n_elements // 2, low=0, high=n_elements,
                                    integer=True)
        elif kind == "sinusoid":
            out["phase"] = t.number("phase", "rad", 0.0, plausible="phase angle")
    t.finish()
    if not np.any(magnetization_array(out, n_elements)):
        key = {"table": "values", "segments": "segments"}.get(kind, "magnitude")
        t.warn(key, "no magnetization: every element is at 0 A/m, so no field can move this robot")
    return out


def _segments(t: SpecTable, n_elements: int) -> list[dict[str, Any]]:
    """``segments = [{elements = N | fraction = F, direction = [x, y, z], magnitude = M}, ...]``
    (``magnitude`` defaults to the table's ``magnitude``), checked and complete."""
    default_magnitude = t.number("magnitude", "A/m, the segments' default", YAO2023_MAGNETIZATION,
                                 low=0.0, plausible="magnetization")
    raw = t.raw("segments")
    if not isinstance(raw, list) or not raw:
        raise t.error("segments", "expected a non-empty list of tables {elements = N or fraction = "
                                  "F, direction = [x, y, z], magnitude = A/m}, back to front")
    out = []
    for k, item in enumerate(raw):
        sub = SpecTable(item, t.source, f"{t.path}.segments[{k}]", t.accept)
        if sub.has("elements") == sub.has("fraction"):
            others = sorted(k for k in item if k not in ("elements", "fraction", "direction", "magnitude")) \
                if isinstance(item, dict) else []
            unknown = (f" ({', '.join(others)}: not a key of a segment, whose keys are elements or "
                       "fraction, direction and magnitude)" if others else "")
            raise sub.error("elements", "give either elements (a number of elements) or fraction "
                                        f"(of the length), not both or neither{unknown}")
        segment: dict[str, Any] = {}
        if sub.has("elements"):
            segment["elements"] = sub.number("elements", "elements", low=1, high=n_elements,
                                             integer=True)
        else:
            raw = sub.raw("fraction")
            if isinstance(raw, (int, float)) and not isinstance(raw, bool) and 1.0 < raw <= 100.0:
                raise sub.error("fraction", f"must be <= 1 (of the length), got {raw!r}; it looks like "
                                f"percent written for a fraction ({raw:g} % is {raw / 100:g})")
            segment["fraction"] = sub.number("fraction", "of the length", low=0.0, low_open=True,
                                             high=1.0)
        segment["direction"] = _direction(sub, "direction")
        segment["magnitude"] = sub.number("magnitude", "A/m", default_magnitude, low=0.0,
                                          plausible="magnetization")
        sub.finish()
        out.append(segment)
    try:
        segment_element_counts(n_elements, _segment_list(out))
    except ValueError as exc:
        raise t.error("segments", str(exc).removeprefix("segments: ")) from None
    return out


def _segment_list(segments: list[Mapping[str, Any]]) -> list[MagnetizationSegment]:
    return [MagnetizationSegment(tuple(s["direction"]), s["magnitude"], s.get("elements"),
                                 s.get("fraction")) for s in segments]


def _direction(t: SpecTable, key: str, default: Any = REQUIRED) -> list[float]:
    value = t.vector(key, "a direction [x, y, z]", 3, default)
    if not any(value):
        raise t.error(key, f"must be a non-zero direction [x, y, z], got {value!r}")
    return value


def magnetization_array(table: Mapping[str, Any], n_elements: int) -> NDArray[np.float64]:
    """The ``(3, n_elements)`` magnetization (A/m, lab frame of the straight rod along +x) of a
    checked ``[robot.magnetization]`` table."""
    kind, magnitude = table["kind"], table.get("magnitude")
    if kind == "table":
        return np.array(table["values"], dtype=np.float64)
    if kind == "uniform":
        return uniform_magnetization(n_elements, magnitude, table["direction"])
    if kind == "two-segment":
        return two_segment_magnetization(n_elements, magnitude, table["first"], table["second"],
                                         table["split"])
    if kind in ("yao2023-pattern1", "yao2023-pattern2"):
        return yao2023_magnetization(int(kind[-1]), n_elements, magnitude)
    if kind == "sinusoid":
        return sinusoidal_magnetization(n_elements, magnitude, table["phase"])
    if kind == "segments":
        return segments_magnetization(n_elements, _segment_list(table["segments"]))
    raise ValueError(f"unknown magnetization kind {kind!r}")


def _physics_table(t: SpecTable | None, source: str, robot: Mapping[str, Any]) -> dict[str, Any]:
    out = {}
    for setting, defaults in PHYSICS_DEFAULTS.items():
        sub = t.table(setting, required=False) if t is not None else None
        if sub is None:
            out[setting] = dict(defaults)
            continue
        dt = sub.number("dt", "s", defaults["dt"], low=0.0, low_open=True, plausible="time step")
        steps = ACTION_PERIOD / dt
        if abs(steps - round(steps)) > 1e-6 * steps:
            raise sub.error("dt", f"must divide the {ACTION_PERIOD:g} s control period into whole "
                                  f"steps (e.g. 1e-4, 8e-6), got {dt!r}")
        out[setting] = {"mass_scale": sub.number("mass_scale", "1", defaults["mass_scale"], low=0.0,
                                                 low_open=True, plausible="mass scale"),
                        "dt": dt}
        sub.finish()
    if t is not None:
        t.finish()
    return out


# -- names that become folder or file names ------------------------------------------------------


def check_plain_name(t: SpecTable, key: str, value: Any) -> str:
    """``value`` as a name that becomes a folder or file name: a non-empty string without path
    separators, not starting with a dot (``..``, hidden), without control characters, at most
    100 characters; else a :class:`SpecError` naming the key."""
    if not isinstance(value, str):
        raise t.error(key, f"expected a string, got {value!r}")
    bad = ("is empty" if not value else
           "is longer than 100 characters" if len(value) > 100 else
           "contains a path separator" if "/" in value or "\\" in value else
           "starts with a dot" if value.startswith(".") else
           "contains a control character" if any(ord(c) < 32 or ord(c) == 127 for c in value) else
           "")
    if bad:
        raise t.error(key, f"{value!r} {bad}: a name becomes a folder or file name, so it must be a "
                           "plain name (letters, digits, '-', '_', '.'), not a path")
    return value


def _is_spec_file(path: Path) -> bool:
    import tomllib

    return isinstance(tomllib.loads(path.read_text(encoding="utf-8-sig")).get("robot"), dict)


#: What a command that writes a spec file (``msr field baseline --set-yardstick FILE --force``)
#: may replace: a spec.
SPEC_FILE = FileKind("a spec file (TOML with a [robot] table)", _is_spec_file)


def load_robot(robot: str | Path, physics: Physics = "accurate") -> RobotSpec:
    """A robot by preset name (``yao2023-m1``, ``yao2023-m2``, ``hu2018``) or from a spec file's
    ``[robot]`` and ``[physics]`` tables (e.g. ``msr case show m1-4mT --toml > my.toml``), in one
    physics setting. A bad file is a :class:`SpecError` naming the file and the key."""
    if str(robot) in ROBOTS:
        return robot_by_name(str(robot), physics)
    path = Path(robot)
    if path.suffix != ".toml" and not path.exists():
        raise SpecError(f"unknown robot {str(robot)!r}: not a preset ({', '.join(ROBOTS)}) and not a "
                        "spec file (.toml); for a case's robot, write the case as a spec file (msr "
                        "case show CASE --toml > my.toml) and give my.toml")
    return describe_robot(read_spec(path), str(path)).robot(physics)


def actuation_kind_of(robot: str | Path) -> str | None:
    """The ``[actuation] kind`` of a spec file (``"field"`` when the table has no kind), or ``None``
    for a preset name or a spec without the table."""
    if str(robot) in ROBOTS:
        return None
    actuation = read_spec(robot).get("actuation")
    if not isinstance(actuation, Mapping):
        return None
    return str(actuation.get("kind", "field"))


def field_limit_of(robot: str | Path) -> float | None:
    """The ``[actuation] field_limit`` (T) of a spec file, or ``None`` for a preset name or a spec
    without an ``[actuation]`` table. The value is checked as the learning package checks it (a
    number in ``(0, 1]`` T); a bad one is a :class:`SpecError` naming the file and key."""
    if str(robot) in ROBOTS:
        return None
    return spec_field_limit(read_spec(robot), str(robot))


def axis_limits_of(robot: str | Path) -> dict[str, float]:
    """The limit (T) of each axis a spec file's ``[actuation]`` controls, by axis name (``"x"``,
    ``"y"``, and ``"z"`` for ``axes = "xyz"``); empty for a preset or a spec without the table.
    Checked as :func:`field_limit_of` checks the largest."""
    if str(robot) in ROBOTS:
        return {}
    spec = read_spec(robot)
    largest = spec_field_limit(spec, str(robot))
    actuation = spec.get("actuation")
    if largest is None or not isinstance(actuation, Mapping):
        return {}
    axes = str(actuation.get("axes", "xy"))
    value = actuation.get("field_limit")
    limits = value if isinstance(value, list) and len(value) == len(axes) else [largest] * len(axes)
    return {axis: float(limit) for axis, limit in zip(axes, limits, strict=True)}


def spec_field_limit(spec: Mapping[str, Any], source: str = "<spec>") -> float | None:
    """The ``[actuation] field_limit`` (T) of a parsed spec, ``None`` without an ``[actuation]``
    table or with a magnet on an arm (``kind = "magnet-pose"``); checked as the learning package
    checks it (a number in ``(0, 1]`` T; a list of one per controlled axis gives the largest, the
    amplitude limit)."""
    actuation = spec.get("actuation")
    if actuation is None or (isinstance(actuation, Mapping) and actuation.get("kind") == "magnet-pose"):
        return None  # a magnet on an arm: no coils, no field limit
    accepted = accepted_keys(spec, source)
    value = actuation.get("field_limit") if isinstance(actuation, Mapping) else None
    items = value if isinstance(value, list) and value else [value]
    limits = []
    for item in items:
        data = dict(actuation) if isinstance(actuation, Mapping) else actuation
        if isinstance(value, list):
            data["field_limit"] = item
        table = SpecTable(data, source, "actuation", accepted)
        limits.append(table.number("field_limit", "T", low=0.0, low_open=True, high=1.0,
                                   plausible="coil field"))
    return max(limits)
