"""The actuation of a case steered by the currents of fixed coils (``[actuation] kind =
"coil-currents"``), as in open electromagnetic navigation systems: its settings
(:class:`CoilArray`) and the checks of its table (SI: m, A, A/s). The rod is clamped at its base
(a catheter); the policy sets each coil's current (an action of +-1 is +-``current_limit``),
reached no faster than ``max_slew``.

Each coil is one circular winding: ``[[actuation.coils]]`` tables with ``radius`` (m), ``centre``
(m), ``axis`` (a direction, the current counter-clockwise about it) and ``turns``. The field is the
sum of the coils' (superposition: no iron). Values refused where they cannot be meant: a radius or
centre in mm written as m, a coil whose winding the rod can reach (the field is infinite on a
wire), currents or slew rates beyond any driver.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from elastica_magnetic import CoilCurrents, CurrentLoopField
from elastica_magnetic.hardware.plausibility import MIN_PLAUSIBLE_SLEW_A_PER_S
from elastica_magnetic.plausibility import judge
from elastica_magnetic.robot_spec import ACTION_PERIOD
from elastica_magnetic.specfile import SpecTable

from .steered import (
    MAX_REACH,
    SteeringActuation,
    control_rate_from_table,
    insertion_from_table,
    insertion_speed_from_table,
)

__all__ = ["CoilArray", "CoilWinding", "coil_array_from_table"]

#: Largest current (A) of a coil driver in a lab; mA written as A is 1000x.
MAX_CURRENT = 1000.0
#: Most turns of one coil.
MAX_TURNS = 1e5
#: Most coils of a case (the action's size): the open systems have 3 to 8.
MAX_COILS = 16


@dataclass(frozen=True)
class CoilWinding:
    """One coil: a circular winding of ``turns`` turns, ``radius`` m, centred at ``centre`` m, the
    current counter-clockwise about ``axis``."""

    radius: float
    centre: tuple[float, float, float]
    axis: tuple[float, float, float]
    turns: float

    def source(self) -> CurrentLoopField:
        """The coil's field at 1 A."""
        return CurrentLoopField(self.radius, current=1.0, centre=self.centre, axis=self.axis,
                                turns=self.turns)

    def to_dict(self) -> dict[str, Any]:
        return {"radius": self.radius, "centre": list(self.centre), "axis": list(self.axis),
                "turns": self.turns}


@dataclass(frozen=True)
class CoilArray(SteeringActuation):
    """Fixed coils whose currents steer the rod (``[actuation] kind = "coil-currents"``):
    ``coils`` (:class:`CoilWinding`), ``current_limit`` (A, each coil's largest absolute current),
    ``max_slew`` (A/s, the fastest change of a current; ``None``: within a control step), the
    control rate (Hz), and optionally an insertion stage (``insertion``, ``insertion_speed``: as
    :class:`~elastica_magnetic_rl.cases.arm_actuation.MagnetArm`'s)."""

    kind: ClassVar[str] = "coil-currents"
    #: What :meth:`field_at_tip` is, in words.
    tip_field_words: ClassVar[str] = "the coils' strongest at the straight tip"
    #: What :meth:`reach_field` is, in words, and the key and slips of coils too weak to bend the rod.
    reach_field_words: ClassVar[str] = "the coils' strongest at the straight tip"
    weak_source_hint: ClassVar[tuple[str, str]] = (
        "current_limit", "a current in mA written as A, too few turns, or coils too far from the tip?")
    coils: tuple[CoilWinding, ...]
    current_limit: float
    max_slew: float | None = None
    control_rate: float = 1.0 / ACTION_PERIOD
    insertion: tuple[float, float] | None = None
    insertion_speed: float = 0.01

    @property
    def actuator_size(self) -> int:
        """One current per coil."""
        return len(self.coils)

    @property
    def observation_blocks(self) -> tuple[tuple[str, int], ...]:
        """The observation's blocks after the rod's node positions, as name and size pairs.

        The tip's velocity (3), the coils' currents over their limit (one per coil), the field
        they make at the tip (3), and the insertion (1) with a stage."""
        return (("tip_velocity", 3), ("coil_currents", len(self.coils)), ("tip_field", 3),
                *self.stage_blocks())

    def actuator(self) -> CoilCurrents:
        """New coils of this actuation, every current zero."""
        return CoilCurrents([coil.source() for coil in self.coils], self.current_limit, self.max_slew)

    def start_words(self) -> str:
        """How an episode starts, in words."""
        return "from zero currents"

    def actuator_action_words(self) -> str:
        """What the coils' action components (one per coil) command, in words."""
        return f"each of the {len(self.coils)} coils' current over its limit ({self.current_limit:g} A)"

    def field_at_tip(self, rod_length: float) -> float:
        """The strongest field (T) the coils can make at the tip of the straight rod (along +x from
        the origin, ``rod_length`` m), every current within its limit: the field scale of the case
        (the largest of a convex function over the box of currents is at a corner)."""
        matrix = self.actuator().field_matrix([rod_length, 0.0, 0.0]) * self.current_limit
        if len(self.coils) > 12:  # 2^N corners grow fast: the sum of the columns' norms bounds it
            return float(np.linalg.norm(matrix, axis=0).sum())
        return max(float(np.linalg.norm(matrix @ np.array(signs)))
                   for signs in itertools.product((-1.0, 1.0), repeat=len(self.coils)))

    def reach_field(self, rod_length: float) -> float:
        """T: the strongest field the coils make at the straight tip (:meth:`field_at_tip`)."""
        return self.field_at_tip(rod_length)

    def describe(self, rod_length: float) -> str:
        """The coils in words (mm, A, mT)."""
        slew = "" if self.max_slew is None else f", at most {self.max_slew:g} A/s"
        return (f"{len(self.coils)} fixed coils, each at most {self.current_limit:g} A{slew}; up to "
                f"{1e3 * self.field_at_tip(rod_length):.3g} mT at the straight tip")

    def to_dict(self) -> dict[str, Any]:
        """The ``[actuation]`` table."""
        out: dict[str, Any] = {"kind": self.kind, "current_limit": self.current_limit}
        if self.max_slew is not None:
            out["max_slew"] = self.max_slew
        return {**out, "control_rate": self.control_rate, **self.stage_dict(),
                "coils": [coil.to_dict() for coil in self.coils]}


def coil_array_from_table(t: SpecTable, rod_length: float) -> CoilArray:
    """The ``[actuation]`` table of ``kind = "coil-currents"`` (``rod_length``, m: the rod clamped
    at the origin along +x, whose reach the coils' windings must clear)."""
    insertion = insertion_from_table(t, rod_length)
    coils = _coils(t)
    d = CoilArray(coils=(), current_limit=1.0)
    array = CoilArray(
        coils=coils,
        current_limit=t.number("current_limit", "A", low=0.0, low_open=True, high=MAX_CURRENT,
                               plausible="coil current"),
        max_slew=t.number("max_slew", "A/s", None, low=0.0, low_open=True),
        control_rate=control_rate_from_table(t, d.control_rate),
        insertion=insertion,
        insertion_speed=insertion_speed_from_table(t, insertion, d.insertion_speed))
    if array.max_slew is not None and array.max_slew < MIN_PLAUSIBLE_SLEW_A_PER_S:
        seconds = array.current_limit / array.max_slew
        raise t.error("max_slew", f"{array.max_slew:g} A/s is below {MIN_PLAUSIBLE_SLEW_A_PER_S:g} A/s: it "
                                  f"would take {seconds:.4g} s to reach the current limit "
                                  f"({array.current_limit:g} A); A/ms written as A/s?")
    reach = rod_length + (insertion[1] if insertion else 0.0)
    low = insertion[0] if insertion else 0.0
    for k, coil in enumerate(coils):
        gap = _wire_clearance(coil, low, reach - rod_length, rod_length)
        if gap <= 0.0:
            where = f"radius {coil.radius:g} m at {list(coil.centre)} m"
            raise t.error(f"coils[{k}]", f"its winding ({where}) is within the rod's reach ({rod_length:g} "
                                         "m from its base, which the stage moves along x): an element on "
                                         "the wire would feel an infinite field; move the coil out (mm "
                                         "written as m?)")
    _check_coincident(t, coils)
    _check_tip_field(t, array, rod_length)
    t.finish()
    return array


#: Below this ratio of the smallest to the largest singular value of the coils' field matrix at the
#: straight tip, the coils cannot point the field there in every direction (a rank-deficient array:
#: one coil, coils on one axis).
MIN_FIELD_CONDITION = 1e-3


def _check_coincident(t: SpecTable, coils: tuple[CoilWinding, ...]) -> None:
    """Two windings in one place (the same centre, radius and axis line, within 1 % of the
    radius) cannot both be built: refused, naming both."""
    for (i, a), (j, b) in itertools.combinations(enumerate(coils), 2):
        scale = 0.01 * min(a.radius, b.radius)
        axis_a, axis_b = (np.asarray(c.axis, dtype=np.float64) / np.linalg.norm(c.axis) for c in (a, b))
        if (math.dist(a.centre, b.centre) <= scale and abs(a.radius - b.radius) <= scale
                and np.linalg.norm(np.cross(axis_a, axis_b)) <= 0.01):
            raise t.error(f"coils[{j}]", f"its winding is coils[{i}]'s (the same centre {list(b.centre)} m, "
                                         f"radius {b.radius:g} m and axis): two windings cannot occupy one "
                                         "place; give it its own position, or add the turns to one coil")


def _check_tip_field(t: SpecTable, array: CoilArray, rod_length: float) -> None:
    """The coils' strongest field at the straight tip judged as a coil field (refused beyond any
    coil system, warned when unusually strong; a weak one is the case's reach check's), and the
    directions they can make it in: coils that make it along fewer than three independent
    directions (one coil, coils on one axis) steer the tip in a line or a plane only (warned)."""
    finding = judge("coil field", array.field_at_tip(rod_length), hint=False)
    if finding is not None and finding.high:  # too weak a field: the reach check of the case says so
        turns = sorted({f"{coil.turns:g}" for coil in array.coils})
        text = (f"the coils' strongest field at the straight tip: {finding.text} (current_limit "
                f"{array.current_limit:g} A, turns {', '.join(turns)}: a current in mA written as A, or too "
                "many turns?)")
        if finding.refuse:
            raise t.error("current_limit", text)
        t.warn("current_limit", text)
    singular = np.linalg.svd(array.actuator().field_matrix([rod_length, 0.0, 0.0]), compute_uv=False)
    if singular.size < 3 or singular[-1] < MIN_FIELD_CONDITION * singular[0]:
        rank = int(np.sum(singular >= MIN_FIELD_CONDITION * singular[0]))
        t.warn("coils", f"the {len(array.coils)} coil(s) make the field at the straight tip along only "
                        f"{rank} independent direction(s) (a field steering a tip in 3D needs 3): the tip "
                        "bends toward a line or a plane of targets only; add coils off the others' axes")


def _coils(t: SpecTable) -> tuple[CoilWinding, ...]:
    """``coils = [{radius, centre, axis, turns}, ...]``, checked."""
    raw = t.raw("coils")
    if not isinstance(raw, list) or not raw or not all(isinstance(item, dict) for item in raw):
        raise t.error("coils", "expected a non-empty list of tables [[actuation.coils]] with radius (m), "
                               "centre (m), axis and turns")
    if len(raw) > MAX_COILS:
        raise t.error("coils", f"{len(raw)} coils: at most {MAX_COILS} (one action component each)")
    out = []
    for k, item in enumerate(raw):
        sub = SpecTable(item, t.source, f"{t.path}.coils[{k}]", t.accept)
        radius = sub.number("radius", "m", low=0.0, low_open=True, high=MAX_REACH, plausible="coil radius")
        centre = sub.vector("centre", "m", 3)
        if max(abs(v) for v in centre) > MAX_REACH:
            raise sub.error("centre", f"{centre} m is beyond any coil system ({MAX_REACH:g} m from the "
                                      "base): mm written as m?")
        axis = sub.vector("axis", "a direction", 3)
        if not any(axis):
            raise sub.error("axis", "must be a non-zero direction")
        turns = sub.number("turns", "turns", low=1.0, high=MAX_TURNS)
        if not float(turns).is_integer():
            sub.warn("turns", f"{turns:g}: a winding has a whole number of turns (its field is current x "
                              "turns)")
        sub.finish()
        out.append(CoilWinding(radius, tuple(centre), tuple(axis), turns))
    return tuple(out)


def _wire_clearance(coil: CoilWinding, low: float, high: float, length: float) -> float:
    """m: the distance from the coil's winding to the nearest point the rod can reach (within
    ``length`` of its base, the base anywhere on the x axis from ``low`` to ``high``), negative
    where the winding is within reach."""
    source = coil.source()
    frame = source.frame
    angles = np.linspace(0.0, 2.0 * math.pi, 721)
    ring = (np.asarray(coil.centre)[:, None] + coil.radius * (np.outer(frame[:, 0], np.cos(angles))
                                                             + np.outer(frame[:, 1], np.sin(angles))))
    along = np.clip(ring[0], low, high)
    distance = np.sqrt((ring[0] - along) ** 2 + ring[1] ** 2 + ring[2] ** 2)
    return float(distance.min() - length)
