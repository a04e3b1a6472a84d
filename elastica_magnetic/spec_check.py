"""What a researcher checks in a robot's spec before training on it: derived quantities, the
stability of each physics' time step, how far the robot sinks into the ground, and where the spec
leaves the model's validity.

:func:`check_spec` takes a parsed spec file (its ``[robot]``, ``[physics]`` and, when present,
``[field]``, ``[boundary]``, ``[actuation] field_limit``, ``[task] kind`` and ``[yardstick]
distance_10s``);
:func:`check_robot` takes the checked robot tables and those values directly (what the learning
package's ``Case`` holds). Both return a :class:`SpecCheck` (SI units); :func:`format_check` gives
a compact text summary and :meth:`SpecCheck.to_dict` plain JSON-able data.

**Time step.** Each physics' step against the robot's estimated stable step
(:mod:`~elastica_magnetic.stability`, the formulas and their calibration).

**Sag.** The ground (PyElastica's rod-plane contact, see :mod:`~elastica_magnetic.ground`) first
cancels, element by element, the part of the loads on the rod that pushes into it (each element
gets the mean of its two nodes' loads, the end elements their end node's in full), then adds a
spring ``k`` per unit penetration and a damper. A node therefore gets back its own load less
``(2 F_i - F_(i-1) - F_(i+1)) / 4``: a load uniform along the rod (the weight of a rod lying flat)
is carried with **no penetration at all**, and only what varies from node to node (the shear the
field's couples make where the magnetization changes, the rod's own bending) is left to the
spring, resisted by the rod's stiffness as much as by ``k``. That residual has no closed form, so
the check measures it: the robot lying on the ground, the field ramped to its limit in 0.1 s along
+x, -x, +y and -y and held, 0.5 s in all; the sag is the deepest element centre below its resting
height. ``element weight / k`` is reported beside it: the depth at which the spring alone would
hold an element's weight (an element landing on the ground has only the spring and the damper to
stop it).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from .field_spec import describe_field
from .robot_spec import ACTION_PERIOD, RobotSpec
from .specfile import RobotDescription, SpecTable, describe_robot, spec_field_limit
from .stability import SAFETY_FACTOR, estimated_stable_time_step, suggested_time_step

__all__ = [
    "Issue",
    "TimeStepCheck",
    "SagCheck",
    "SpecCheck",
    "simulate_sag",
    "check_robot",
    "magnetic_bending_number",
    "check_spec",
    "format_check",
    "SAG_DIRECTIONS",
]

#: Field directions of the sag check (unit vectors, lab frame).
SAG_DIRECTIONS: dict[str, tuple[float, float, float]] = {
    "+x": (1.0, 0.0, 0.0), "-x": (-1.0, 0.0, 0.0), "+y": (0.0, 1.0, 0.0), "-y": (0.0, -1.0, 0.0)}
#: Ramp and total time of each sag simulation, s.
SAG_RAMP_S, SAG_DURATION_S = 0.1, 0.5
#: Longest sag simulation, time steps per field direction (beyond it the sag is not simulated).
SAG_MAX_STEPS = 100_000


@dataclass(frozen=True)
class Issue:
    """One finding: ``level`` ``"error"`` (the spec will not simulate what it means to) or
    ``"warning"`` (outside the model's validity, or a result that misleads); ``key`` is the spec
    key it concerns (``"[physics.accurate] dt"``), ``message`` says what and what to do."""

    level: str
    key: str
    message: str


@dataclass(frozen=True)
class TimeStepCheck:
    """The time step of one physics setting against its estimated stability limit (s)."""

    physics: str
    dt_s: float
    mass_scale: float
    stable_dt_s: float  # CALIBRATION x the smallest of limits_s
    limiting: str  # the name of that limit
    margin: float  # stable_dt_s / dt_s: below 1 the step is estimated unstable
    suggested_dt_s: float
    limits_s: dict[str, float] = field(default_factory=dict)  # every bare limit, s (inf: none)


@dataclass(frozen=True)
class SagCheck:
    """Deepest penetration (m) of an element centre below its resting height: under the weight
    alone and under the field limit along each of :data:`SAG_DIRECTIONS`, simulated in
    ``physics`` for ``duration_s`` (``field_m`` empty without a field limit)."""

    physics: str
    duration_s: float
    weight_m: float
    field_limit_T: float | None
    field_m: dict[str, float] = field(default_factory=dict)

    @property
    def deepest_m(self) -> float:
        return max([self.weight_m, *self.field_m.values()])


@dataclass(frozen=True)
class SpecCheck:
    """Derived quantities of a robot (SI) and what is wrong with its spec.

    The rod is the equivalent circular rod of the band (radius ``thickness / sqrt(3)``, the same
    ratio of bending stiffness to area): its mass, area and bending stiffness are the simulated
    ones; the ``band_`` values are those of the rectangular band itself, for comparison.
    """

    name: str
    source: str
    section: str  # "band" or "round"
    n_elements: int
    length_m: float
    width_m: float
    thickness_m: float
    element_length_m: float
    density_kg_m3: float
    youngs_modulus_Pa: float
    shear_modulus_Pa: float
    shear_modulus_from: str  # "shear_modulus" or "poisson_ratio"
    equivalent_radius_m: float
    area_m2: float
    second_moment_m4: float
    mass_kg: float
    band_mass_kg: float
    weight_N: float
    bending_stiffness_Nm2: float
    band_bending_stiffness_Nm2: float
    magnetization: list[str]  # runs of equal magnetization, summarized
    max_magnetization_A_m: float
    field_limit_T: float | None
    magnetic_bending_number: float | None  # M B L^2 A / (E I) at the field limit
    spring_only_sag_m: float | None  # element weight / ground stiffness
    time_steps: list[TimeStepCheck]
    sag: SagCheck | None
    yardstick_m: float | None
    issues: list[Issue]
    #: what ``field_limit_T`` is: the coils' limit, or e.g. a magnet's field at the tip
    field_name: str = "field limit"

    @property
    def has_errors(self) -> bool:
        """True when an issue is an error (``msr case check`` then exits non-zero)."""
        return any(i.level == "error" for i in self.issues)

    @property
    def warnings(self) -> list[Issue]:
        return [i for i in self.issues if i.level == "warning"]

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able data (``inf`` limits as ``None``)."""
        data = asdict(self)
        data["has_errors"] = self.has_errors
        return _finite(data)


def _finite(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_finite(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


# -- time step -------------------------------------------------------------------------------------


def _time_step_check(robot: RobotSpec, physics: str) -> TimeStepCheck:
    stable, limiting, limits = estimated_stable_time_step(robot)
    return TimeStepCheck(physics, robot.dt, robot.mass_scale, stable, limiting, stable / robot.dt,
                         suggested_time_step(stable), limits)


# -- sag -------------------------------------------------------------------------------------------


def simulate_sag(robot: RobotSpec, field_limit: float | None,
                 duration: float = SAG_DURATION_S, ramp: float = SAG_RAMP_S,
                 directions: Mapping[str, tuple[float, float, float]] = SAG_DIRECTIONS,
                 physics: str | None = None) -> SagCheck:
    """Simulate the robot lying on its ground, first under its weight alone, then under the field
    ramped to ``field_limit`` (T) in ``ramp`` s along each of ``directions`` (label -> unit
    vector) and held, for ``duration`` s each; the deepest element centre below its resting height
    (m). ``physics`` labels the result (default: from the robot's mass scale). Raises
    :class:`~elastica_magnetic.SimulationDivergedError` if a run blows up."""
    from .fields import ConstantField, RampedField
    from .simulation import build_simulation

    if robot.ground is None:
        raise ValueError("the robot has no ground: nothing to sink into")

    def deepest(source: Any) -> float:
        sim = build_simulation(robot, source)
        depth = 0.0
        for _ in range(max(1, int(round(duration / ACTION_PERIOD)))):
            sim.step(robot.steps_per_action)
            position = sim.rod.position_collection
            centre_y = 0.5 * (position[1, :-1] + position[1, 1:])
            depth = max(depth, float(-centre_y.min()))
        return depth

    weight = deepest(ConstantField((0.0, 0.0, 0.0)))
    field_m = {}
    if field_limit is not None:
        for label, direction in directions.items():
            field_m[label] = deepest(RampedField(field_limit * np.array(direction), ramp))
    label = physics if physics is not None else _physics_name(robot)
    return SagCheck(label, duration, weight, field_limit, field_m)


def _physics_name(robot: RobotSpec) -> str:
    return "accurate" if robot.mass_scale == 1.0 else f"mass scale {robot.mass_scale:.4g}"


# -- the check -------------------------------------------------------------------------------------


def check_spec(spec: Mapping[str, Any], source: str = "<spec>", *, sag: bool = True) -> SpecCheck:
    """Check a parsed spec file (e.g. :func:`~elastica_magnetic.specfile.read_spec`'s result).

    Its ``[robot]`` and ``[physics]`` are checked as :func:`describe_robot` does (a bad key is a
    :class:`~elastica_magnetic.specfile.SpecError`), its ``[field]`` and ``[boundary]`` as
    :func:`~elastica_magnetic.field_spec.describe_field` does for ``msr field simulate`` (a unit mistake
    or a source on the rod is a ``SpecError``, an unusual value a warning); ``[actuation]
    field_limit`` (T), ``[task] kind`` and ``[yardstick] distance_10s`` (m) are read when present
    (the learning package checks the rest of those tables). ``sag=False`` skips the sag simulations (seconds;
    the first run in a process also compiles the kernels)."""
    description = describe_robot(spec, source)
    field_limit = spec_field_limit(spec, source)
    # The [field] in space and [boundary], as msr field simulate builds them (same errors and warnings,
    # the source against the rod), before the sag simulations.
    describe_field(spec, source)
    task = spec.get("task")
    task_kind = task.get("kind") if isinstance(task, Mapping) else None
    yardstick: Any = None
    # distance_10s judges a crawl; other tasks are judged otherwise (a ring of targets, a box...)
    if isinstance(spec.get("yardstick"), Mapping) and task_kind in (None, "crawl"):
        table = SpecTable(spec["yardstick"], source, "yardstick")
        yardstick = table.number("distance_10s", "m", None)
    name = spec.get("name") if isinstance(spec.get("name"), str) else description.name
    return check_robot(description, field_limit=field_limit, task_kind=task_kind,
                       yardstick_m=yardstick, name=name, source=source, sag=sag)


def magnetic_bending_number(robot: RobotSpec, field: float) -> float:
    """The magnetic bending number ``M B L^2 A / (E I)`` of ``robot`` (its strongest
    magnetization M, A/m; length L, m; the equivalent round section's area A and second moment I;
    modulus E, Pa) in a field of ``field`` T: the magnetic couple over the bending stiffness. A
    cantilever under a uniform couple bends its tip by about ``number / 3`` of its length while
    that is small (``q L^3 / 3 E I`` with ``q = M A B`` per length)."""
    area, inertia = math.pi * robot.radius**2, math.pi * robot.radius**4 / 4.0
    strongest = float(np.linalg.norm(robot.magnetization, axis=0).max())
    return strongest * field * robot.length**2 * area / (robot.youngs_modulus * inertia)


def check_robot(description: RobotDescription, *, field_limit: float | None = None,
                task_kind: str | None = None, yardstick_m: float | None = None,
                name: str | None = None, source: str = "<spec>", sag: bool = True,
                field_name: str = "field limit") -> SpecCheck:
    """Check a robot (checked ``[robot]``/``[physics]`` tables) with, optionally, its field limit
    (T; ``field_name`` says what the field is where it is not the coils' limit), its task's kind
    (``"crawl"``/``"reach"``; ``None``: not a case) and its yardstick (m in 10 s; ``None``: none).
    See :func:`check_spec`."""
    r = description.tables["robot"]
    accurate = description.robot("accurate")
    radius, n = accurate.radius, accurate.n_elements
    dl = accurate.length / n
    area, inertia = math.pi * radius**2, math.pi * radius**4 / 4.0
    band_area = accurate.width * accurate.height if accurate.section == "band" else area
    band_inertia = (accurate.width * accurate.height**3 / 12.0 if accurate.section == "band"
                    else inertia)
    mass = accurate.density * area * accurate.length
    weight = mass * accurate.gravity
    m_norm = np.linalg.norm(accurate.magnetization, axis=0)
    magnetic_number = None if field_limit is None else magnetic_bending_number(accurate, field_limit)
    spring_sag = None
    if accurate.ground is not None:
        spring_sag = weight / n / accurate.ground.k
    steps = [_time_step_check(description.robot(p), p) for p in ("training", "accurate")]
    issues = _time_step_issues(steps)
    sag_check = None
    if sag and accurate.ground is not None:
        sag_check, sag_issues = _sag(description, steps, field_limit, radius)
        issues += sag_issues
    issues += _validity_issues(accurate, field_limit, task_kind, yardstick_m, spring_sag)
    if magnetic_number is not None and 0.0 < magnetic_number < WEAK_MAGNETIC_NUMBER:
        coils = field_name == "field limit"
        where = field_name if field_name.startswith("the ") else f"the {field_name}"
        issues.append(Issue(
            "warning", "[robot.magnetization] magnitude" if coils else "[actuation]",
            f"the magnetic bending number M B L^2 A / EI at {where} is {magnetic_number:.3g} "
            "(the paper's robots at 4 mT: about 22): no field within the limit bends this robot "
            "noticeably. A remanence B_r in T written where the magnetization M in A/m is expected "
            "(M = B_r / mu0: 0.077 T is 61 kA/m)? or " + (
                "a field limit too small?" if coils else
                f"a source too weak ({1e3 * field_limit:.3g} mT: a magnet's moment in mA m^2 written "
                "as A m^2, a current in mA written as A?)")))
    return SpecCheck(
        name=name or description.name, source=source, section=accurate.section, n_elements=n,
        length_m=accurate.length, width_m=accurate.width, thickness_m=accurate.height,
        element_length_m=dl, density_kg_m3=accurate.density,
        youngs_modulus_Pa=accurate.youngs_modulus, shear_modulus_Pa=accurate.shear_modulus,
        shear_modulus_from="shear_modulus" if "shear_modulus" in r else "poisson_ratio",
        equivalent_radius_m=radius, area_m2=area, second_moment_m4=inertia, mass_kg=mass,
        band_mass_kg=accurate.density * band_area * accurate.length, weight_N=weight,
        bending_stiffness_Nm2=accurate.youngs_modulus * inertia,
        band_bending_stiffness_Nm2=accurate.youngs_modulus * band_inertia,
        magnetization=_runs(accurate.magnetization), max_magnetization_A_m=float(m_norm.max()),
        field_limit_T=field_limit, magnetic_bending_number=magnetic_number, field_name=field_name,
        spring_only_sag_m=spring_sag, time_steps=steps, sag=sag_check, yardstick_m=yardstick_m,
        issues=issues)


def unstable_time_step(robot: RobotSpec, physics: str) -> str | None:
    """What ``msr case check`` reports as an error about ``robot``'s time step in ``physics``
    (a step above the calibrated stable estimate: likely to blow up), ``None`` when it holds."""
    issues = [i for i in _time_step_issues([_time_step_check(robot, physics)]) if i.level == "error"]
    return f"{issues[0].key}: {issues[0].message}" if issues else None


def _time_step_issues(steps: list[TimeStepCheck]) -> list[Issue]:
    issues = []
    for s in steps:
        key = f"[physics.{s.physics}] dt"
        text = (f"dt = {s.dt_s:.3g} s against an estimated stable {s.stable_dt_s:.3g} s "
                f"({s.limiting}); margin {s.margin:.3g}")
        if s.margin < 1.0:
            issues.append(Issue("error", key, f"{text}: likely unstable, use dt = "
                                              f"{s.suggested_dt_s:.3g} s or smaller"))
        elif s.margin < SAFETY_FACTOR:
            issues.append(Issue("warning", key, f"{text} < {SAFETY_FACTOR:g}: a stiffer, lighter "
                                                "or finer robot may blow up; dt = "
                                                f"{s.suggested_dt_s:.3g} s keeps a margin of "
                                                f"{SAFETY_FACTOR:g}"))
    return issues


def _sag(description: RobotDescription, steps: list[TimeStepCheck], field_limit: float | None,
         radius: float) -> tuple[SagCheck | None, list[Issue]]:
    """The sag simulated in the training physics (the statics are the same in both; it is ~10x
    cheaper), or the accurate one if the training step is estimated unstable."""
    from .simulation import SimulationDivergedError

    usable = [s for s in steps if s.margin >= 1.0]
    if not usable:
        return None, [Issue("warning", "[robot.ground]", "sag not simulated: no physics setting "
                                                         "has a stable time step")]
    chosen = usable[0]
    robot = description.robot(chosen.physics)  # type: ignore[arg-type]
    n_steps = int(round(SAG_DURATION_S / robot.dt))
    if n_steps > SAG_MAX_STEPS:
        return None, [Issue("warning", f"[physics.{chosen.physics}] dt", f"sag not simulated: "
                            f"{n_steps} time steps per run (at most {SAG_MAX_STEPS})")]
    try:
        check = simulate_sag(robot, field_limit, physics=chosen.physics)
    except SimulationDivergedError as exc:
        return None, [Issue("error", f"[physics.{chosen.physics}] dt",
                            f"the robot resting on the ground under the field diverged: {exc}")]
    issues = []
    deepest = check.deepest_m
    if deepest > radius:
        where = max(check.field_m, key=check.field_m.__getitem__) if check.field_m else None
        cause = f"the field limit along {where}" if where and check.field_m[where] == deepest else (
            "its weight")
        issues.append(Issue("warning", "[robot.ground] stiffness",
                            f"under {cause} the robot sinks {1e3 * deepest:.3g} mm into the ground, "
                            f"deeper than its equivalent radius {1e3 * radius:.3g} mm: the contact "
                            "model no longer describes a robot on a surface; stiffen the ground "
                            "(stiffness, N/m) or check the field limit and magnetization"))
    return check, issues


#: Below this magnetic bending number at the field limit no field bends the robot noticeably.
WEAK_MAGNETIC_NUMBER = 1e-2


def _validity_issues(robot: RobotSpec, field_limit: float | None,
                     task_kind: str | None, yardstick: float | None,
                     spring_sag: float | None) -> list[Issue]:
    issues = []
    if robot.section == "band" and robot.width < robot.height:
        issues.append(Issue("warning", "[robot] width",
                            f"width {1e3 * robot.width:.3g} mm < thickness {1e3 * robot.height:.3g} "
                            "mm: the equivalent-rod model assumes a thin band bending about its "
                            "width (width >= thickness)"))
    if spring_sag is not None and spring_sag > robot.radius:
        issues.append(Issue("warning", "[robot.ground] stiffness",
                            f"an element's weight on the ground spring alone is "
                            f"{1e3 * spring_sag:.3g} mm of penetration, more than the equivalent "
                            f"radius {1e3 * robot.radius:.3g} mm: a landing element sinks deep"))
    if task_kind == "crawl":
        if yardstick is None:
            issues.append(Issue("warning", "[yardstick] distance_10s",
                                "missing: the case has no yardstick, so no policy of it is judged "
                                "(no meets_target, no success count); search one with msr "
                                "baseline --case"))
        elif yardstick == 0.0:
            issues.append(Issue("warning", "[yardstick] distance_10s",
                                "0 m: the case has no yardstick, so no policy of it is judged (no "
                                "meets_target, no success count); search one with msr field baseline "
                                "--case and set it"))
    if field_limit is None and task_kind is not None:
        issues.append(Issue("warning", "[actuation] field_limit", "missing"))
    if robot.gravity == 0.0 and robot.ground is not None:
        issues.append(Issue("warning", "[robot] gravity", "0 with a ground: nothing holds the "
                                                         "robot on it"))
    return issues


def _runs(magnetization: np.ndarray, most: int = 6) -> list[str]:
    """Runs of equal magnetization, back to front: ``"elements 0-31: (-61300, 0, 0) A/m"``; more
    than ``most`` runs are summarized in one line."""
    n = magnetization.shape[1]
    change = np.flatnonzero(np.any(np.diff(magnetization, axis=1) != 0.0, axis=0)) + 1
    starts = [0, *change.tolist()]
    ends = [*(change - 1).tolist(), n - 1]
    if len(starts) > most:
        norm = np.linalg.norm(magnetization, axis=0)
        return [f"{len(starts)} runs over {n} elements (varies along the rod), |M| "
                f"{norm.min():.4g} to {norm.max():.4g} A/m"]
    return [f"elements {a}-{b}: ({', '.join(f'{v:.6g}' for v in magnetization[:, a])}) A/m"
            for a, b in zip(starts, ends, strict=True)]


def _mm(metres: float) -> str:
    """A length in mm to the micrometre."""
    return f"{1e3 * metres:.3f}"


def format_check(check: SpecCheck) -> str:
    """A compact, readable summary of a :class:`SpecCheck` (mm, mg, kPa for reading; the JSON of
    :meth:`SpecCheck.to_dict` keeps SI)."""
    c = check
    lines = [f"{c.name} ({c.source})"]
    shape = (f"{1e3 * c.length_m:g} x {1e3 * c.width_m:g} x {1e3 * c.thickness_m:g} mm band"
             if c.section == "band" else f"{1e3 * c.length_m:g} mm round rod")
    lines.append(f"  robot        {shape}, {c.n_elements} elements of {1e3 * c.element_length_m:.3g} mm")
    lines.append(f"  material     {c.density_kg_m3:g} kg/m^3, E {1e-3 * c.youngs_modulus_Pa:.4g} kPa, "
                 f"G {1e-3 * c.shear_modulus_Pa:.4g} kPa (from {c.shear_modulus_from})")
    band = c.section == "band"  # a round rod is its own equivalent: no band to compare with
    lines.append(f"  rod          equivalent radius {1e3 * c.equivalent_radius_m:.4g} mm, mass "
                 f"{1e6 * c.mass_kg:.4g} mg" + (f" (band {1e6 * c.band_mass_kg:.4g} mg)" if band else "")
                 + f", weight {1e6 * c.weight_N:.4g} uN")
    lines.append(f"  bending      EI {c.bending_stiffness_Nm2:.4g} N m^2"
                 + (f" (band {c.band_bending_stiffness_Nm2:.4g} N m^2)" if band else ""))
    lines.append(f"  magnetized   {c.magnetization[0]}")
    lines += [f"               {run}" for run in c.magnetization[1:]]
    if c.field_limit_T is not None:
        coils = c.field_name == "field limit"
        label, what = ("field limit", "") if coils else ("field", f" ({c.field_name})")
        lines.append(f"  {label:<12} {1e3 * c.field_limit_T:.3g} mT{what}: magnetic bending number M B L^2 A"
                     f" / EI = {c.magnetic_bending_number:.3g}")
    for s in c.time_steps:
        lines.append(f"  dt {s.physics:<9} {s.dt_s:.3g} s, stable ~{s.stable_dt_s:.3g} s "
                     f"({s.limiting}), margin {s.margin:.3g}, suggested {s.suggested_dt_s:.3g} s")
    if c.spring_only_sag_m is not None:
        lines.append(f"  ground       an element's weight on the spring alone: "
                     f"{1e3 * c.spring_only_sag_m:.3g} mm")
    if c.sag is not None:
        parts = [f"weight {_mm(c.sag.weight_m)} mm"]
        parts += [f"{k} {_mm(v)} mm" for k, v in c.sag.field_m.items()]
        lines.append(f"  sag          {', '.join(parts)} (radius {1e3 * c.equivalent_radius_m:.3g} "
                     f"mm; {c.sag.physics} physics, {c.sag.duration_s:g} s)")
    if c.yardstick_m is not None:
        lines.append(f"  yardstick    {1e3 * c.yardstick_m:g} mm in 10 s")
    if not c.issues:
        lines.append("  no errors, no warnings")
    for issue in c.issues:
        lines.append(f"  {issue.level}: {issue.key}: {issue.message}")
    return "\n".join(lines)
