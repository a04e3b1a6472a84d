"""The actuation of a case steered by a permanent magnet on a robot arm (``[actuation] kind =
"magnet-pose"``): its settings (:class:`MagnetArm`) and the checks of its table (SI: m, A m^2, m/s,
rad/s). The rod of such a case is clamped at its base (a catheter): the arm's magnet bends it.

Each key's value is refused where it cannot be meant: a position or box far beyond any arm's reach
(mm written as m), a speed beyond any arm's (mm/s written as m/s), a turn rate in degrees, a start
outside the workspace or within ``min_clearance`` of the straight rod. An optional
``[actuation.magnet]`` gives the magnet a body (:class:`FiniteMagnet`): its field then comes from a
map of that body in its own frame instead of a point dipole.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike

from elastica_magnetic import (
    CuboidMagnetField,
    CylinderMagnetField,
    MagnetMap,
    MagnetPose,
    PointDipoleField,
    magnet_map,
)
from elastica_magnetic.field_maps import MAX_RESAMPLED_NODES
from elastica_magnetic.robot_spec import ACTION_PERIOD
from elastica_magnetic.spatial_fields import SpatialField, SpatialFieldError
from elastica_magnetic.specfile import SpecTable

from .steered import (
    MAX_REACH,
    SteeringActuation,
    control_rate_from_table,
    insertion_from_table,
    insertion_speed_from_table,
    speed_from_table,
)

__all__ = ["MAGNET_ARM_OBSERVATION", "FiniteMagnet", "MagnetArm", "magnet_arm_from_table"]

#: The observation of a magnet-arm case beyond the rod's node positions (3 per node): the tip's
#: velocity, the magnet's position and direction (3 each; ``rl/envs/catheter_env.py``).
MAGNET_ARM_OBSERVATION = (("tip_velocity", 3), ("magnet_position", 3), ("magnet_direction", 3))


#: T: the polarization ``J = mu0 M`` at which a magnet's map is made (any moment scales it).
MAP_POLARIZATION = 1.0
#: T: the strongest polarization of a permanent magnet (NdFeB's remanence is 1.2-1.45 T); a body
#: whose moment asks more is refused, one asking more than :data:`WARN_POLARIZATION` warned about.
MAX_POLARIZATION = 2.0
WARN_POLARIZATION = 1.5
#: T: a body whose moment asks less than this is warned about (a body far too large: mm written as m?).
MIN_POLARIZATION = 0.05
#: m: the largest edge of a magnet an arm carries (mm written as m beyond it).
MAX_MAGNET_SIZE = 0.2
MU0 = 4e-7 * math.pi
#: m: a magnet map's default spacing, coarser where the map would hold more than
#: :data:`MAP_NODES_PER_AXIS` nodes a side (about 100 MB with its gradient table).
MAP_SPACING = 0.004
MAP_NODES_PER_AXIS = 101
#: A map's spacing beyond this fraction of ``min_clearance`` is warned about (the map's error near
#: the magnet then tens of percent), at or beyond ``min_clearance`` refused.
MAP_SPACING_WARN = 0.5
#: A map wider than this many times what the rod can reach is refused (mm written as m?).
MAP_WIDTH_SLACK = 10.0


@dataclass(frozen=True)
class FiniteMagnet:
    """The body of the arm's magnet (``[actuation.magnet]``): ``shape`` ``"cuboid"`` (``dimension``
    its three edges, m, its own z along the moment) or ``"cylinder"`` (``dimension`` ``[diameter,
    height]``, m, its axis along the moment), magnetized uniformly along its moment. Its field is a
    map in its own frame (:func:`~elastica_magnetic.magnet_map`) of ``map_half_width`` (m, enough
    to hold the rod wherever the arm takes the magnet) at ``map_spacing`` (m); the arm's ``moment``
    sets its strength (its polarization ``J = mu0 moment / volume``)."""

    shape: str
    dimension: tuple[float, ...]
    map_half_width: float
    map_spacing: float = MAP_SPACING

    @property
    def volume(self) -> float:
        """m^3."""
        if self.shape == "cuboid":
            return float(np.prod(self.dimension))
        diameter, height = self.dimension
        return math.pi * diameter**2 / 4.0 * height

    @property
    def circumradius(self) -> float:
        """m: half the body's diagonal (nothing nearer its centre than this is surely outside it)."""
        if self.shape == "cuboid":
            return 0.5 * float(np.linalg.norm(self.dimension))
        return 0.5 * math.hypot(*self.dimension)

    def polarization(self, moment: float) -> float:
        """T: ``J = mu0 moment / volume`` for a moment of ``moment`` A m^2."""
        return MU0 * moment / self.volume

    def field_map(self) -> MagnetMap:
        """The body's map at :data:`MAP_POLARIZATION` (made once per process and body)."""
        return _body_map(self)

    def field(self, moment: float, position: ArrayLike, direction: ArrayLike) -> SpatialField:
        """The body's exact field (Magpylib) for a moment of ``moment`` A m^2, its centre at
        ``position`` (m), its own z (the moment) turned onto ``direction``."""
        return self._field_at(self.polarization(moment), position, direction)

    def _field_at(self, polarization: float, position: ArrayLike, direction: ArrayLike) -> SpatialField:
        j = [0.0, 0.0, polarization]
        if self.shape == "cuboid":
            return CuboidMagnetField(list(self.dimension), j, position, direction)
        return CylinderMagnetField(self.dimension[0], self.dimension[1], j, position, direction)

    def describe(self) -> str:
        """The body in words (mm)."""
        size = " x ".join(f"{1e3 * v:g}" for v in self.dimension)
        return (f"{self.shape} {size} mm, its field mapped +-{1e3 * self.map_half_width:.4g} mm at "
                f"{1e3 * self.map_spacing:g} mm")

    def to_dict(self) -> dict[str, Any]:
        """The ``[actuation.magnet]`` table."""
        return {"shape": self.shape, "dimension": list(self.dimension), "map_half_width": self.map_half_width,
                "map_spacing": self.map_spacing}


@functools.lru_cache(maxsize=4)
def _body_map(body: FiniteMagnet) -> MagnetMap:
    magnet = body._field_at(MAP_POLARIZATION, (0.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    return magnet_map(magnet, body.map_half_width, body.map_spacing)


@dataclass(frozen=True)
class MagnetArm(SteeringActuation):
    """A permanent magnet on a robot arm steers the rod (``[actuation] kind = "magnet-pose"``):
    the keywords of :class:`~elastica_magnetic.MagnetPose` (``moment`` A m^2; ``position`` m and
    ``direction`` at the start of each episode; ``workspace`` m; ``max_speed`` m/s;
    ``max_turn_rate`` rad/s), the nearest the magnet may come to the rod (``min_clearance``, m: an
    episode ends there), the control rate (Hz), and optionally an insertion stage that pushes the
    rod's clamped base along +x (``insertion``: its travel ``(low, high)``, m, ``low <= 0 <=
    high``; ``insertion_speed``, m/s): a sixth action component. ``magnet``: the magnet's body
    (:class:`FiniteMagnet`), default ``None``: a point dipole."""

    kind: ClassVar[str] = "magnet-pose"
    #: What :meth:`reach_field` is, in words, and the key and slips of a magnet too weak to bend the rod.
    reach_field_words: ClassVar[str] = "the magnet's on its axis at min_clearance"
    weak_source_hint: ClassVar[tuple[str, str]] = (
        "moment", "a moment in mA m^2 written as A m^2, or min_clearance too large?")
    moment: float
    position: tuple[float, float, float]
    direction: tuple[float, float, float]
    workspace: tuple[tuple[float, float, float], tuple[float, float, float]]
    max_speed: float = 0.05
    max_turn_rate: float = 1.0
    min_clearance: float = 0.01
    control_rate: float = 1.0 / ACTION_PERIOD
    insertion: tuple[float, float] | None = None
    insertion_speed: float = 0.01
    magnet: FiniteMagnet | None = None

    #: The arm's commands: velocity (3) and turn rate (2).
    actuator_size: ClassVar[int] = MagnetPose.action_size
    #: What :meth:`field_at_tip` is, in words.
    tip_field_words: ClassVar[str] = "the magnet's at the straight tip at its start pose"

    @property
    def observation_blocks(self) -> tuple[tuple[str, int], ...]:
        """The observation's blocks after the rod's node positions (name, size):
        :data:`MAGNET_ARM_OBSERVATION`, and the insertion (1) with a stage."""
        return (*MAGNET_ARM_OBSERVATION, *self.stage_blocks())

    def actuator(self) -> MagnetPose:
        """A new arm of this actuation, at its start pose (its magnet's map shared by all arms of a
        process)."""
        return MagnetPose(**self.arm_settings(),
                          field_map=None if self.magnet is None else self.magnet.field_map())

    @property
    def magnet_reach(self) -> float:
        """m: how far the magnet's surface may reach from its centre toward the rod as the arm turns
        it: its body's circumradius (a rim, an edge or a corner turned to the rod), or for a point
        dipole half the side of the smallest NdFeB cube of its moment (:data:`NDFEB_MAGNETIZATION`;
        its body is not given, so the least it can be). At ``min_clearance`` the magnet's surface is
        this much nearer the rod's axis."""
        if self.magnet is not None:
            return self.magnet.circumradius
        return 0.5 * (self.moment / NDFEB_MAGNETIZATION) ** (1.0 / 3.0)

    def start_words(self) -> str:
        """How an episode starts, in words."""
        return "from the magnet's start pose"

    def actuator_action_words(self) -> str:
        """What the arm's five action components command, in words."""
        return (f"the magnet's velocity (3, x {self.max_speed:g} m/s as a vector) and its moment's turn "
                f"rate about the two directions across it (2, x {self.max_turn_rate:g} rad/s)")

    def arm_settings(self) -> dict[str, Any]:
        """The keywords of :class:`~elastica_magnetic.MagnetPose` (SI)."""
        return {"moment": self.moment, "position": list(self.position), "direction": list(self.direction),
                "workspace": [list(row) for row in self.workspace], "max_speed": self.max_speed,
                "max_turn_rate": self.max_turn_rate}

    def source(self, position: ArrayLike, direction: ArrayLike) -> SpatialField:
        """The magnet's field at a pose (centre ``position``, m; moment along ``direction``): its
        body's (:meth:`FiniteMagnet.field`), or a point dipole's without one."""
        if self.magnet is not None:
            return self.magnet.field(self.moment, position, direction)
        unit = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
        return PointDipoleField(self.moment * unit, position)

    def field_at_tip(self, rod_length: float) -> float:
        """The field magnitude (T) the magnet makes at its start pose at the tip of the straight rod
        (along +x from the origin, ``rod_length`` m): the field scale of the case's start."""
        source = self.source(self.position, self.direction)
        return float(np.linalg.norm(source.at(np.array([[rod_length], [0.0], [0.0]]))))

    def reach_field(self, rod_length: float) -> float:
        """T: the strongest field the magnet can make at the tip: on its axis, as near as
        ``min_clearance`` (a point dipole's ``mu0 / 4 pi x 2 m / d^3``; a body's own field there;
        an upper bound, whatever the rod's shape)."""
        if self.magnet is None:
            return 1e-7 * 2.0 * self.moment / self.min_clearance**3
        source = self.source((0.0, 0.0, 0.0), (0.0, 0.0, 1.0))
        return float(np.linalg.norm(source.at(np.array([[0.0], [0.0], [self.min_clearance]]))))

    def describe(self, rod_length: float) -> str:
        """The arm in words (mm, mm/s, mT)."""
        mm = ", ".join(f"{1e3 * v:g}" for v in self.position)
        box = " .. ".join("(" + ", ".join(f"{1e3 * v:g}" for v in row) + ")" for row in self.workspace)
        body = "" if self.magnet is None else (f" ({self.magnet.describe()}, "
                                               f"J {self.magnet.polarization(self.moment):.3g} T)")
        pointing = ", ".join(f"{v:g}" for v in self.direction)
        return (f"a {self.moment:g} A m^2 magnet{body} on an arm, starting at ({mm}) mm pointing "
                f"({pointing}), its centre in {box} mm, at most {1e3 * self.max_speed:g} mm/s and "
                f"{self.max_turn_rate:g} rad/s, kept {1e3 * self.min_clearance:g} mm from the rod; "
                f"{1e3 * self.field_at_tip(rod_length):.3g} mT at the straight tip at the start")

    def to_dict(self) -> dict[str, Any]:
        """The ``[actuation]`` table."""
        return {"kind": self.kind, **self.arm_settings(), "min_clearance": self.min_clearance,
                "control_rate": self.control_rate, **self.stage_dict(),
                **({} if self.magnet is None else {"magnet": self.magnet.to_dict()})}


#: Fastest turn (rad/s) an arm commands: a few turns per second; degrees written as rad is far beyond.
MAX_TURN_RATE = 20.0
#: Above this turn rate (rad/s, a turn per second) a value is warned about (degrees per second?).
WARN_TURN_RATE = 2.0 * math.pi
#: A/m: the magnetization of a sintered NdFeB magnet (remanence ~1.3 T): a magnet of moment ``m``
#: is at least a cube of ``(m / M)^(1/3)`` on a side.
NDFEB_MAGNETIZATION = 1.0e6
#: T: a magnet whose field at the straight tip is above this is warned about (catheters are
#: steered by some mT; a uniform field_limit above 1 T is refused).
MAX_TIP_FIELD = 1.0
#: m: a min_clearance above this is no catheter's magnet distance (mm written as m).
MAX_CLEARANCE = 1.0


def _turn_rate(t: SpecTable, default: float) -> float:
    """``max_turn_rate`` (rad/s): above :data:`MAX_TURN_RATE` refused, above a turn per second
    warned, both naming degrees."""
    value = t.number("max_turn_rate", "rad/s", default, low=0.0, low_open=True)
    slip = f"degrees written as radians? ({value:g} deg/s is {math.radians(value):.3g} rad/s)"
    if value > MAX_TURN_RATE:
        raise t.error("max_turn_rate", f"{value:g} rad/s is beyond any arm ({MAX_TURN_RATE:g} rad/s): {slip}")
    if value > WARN_TURN_RATE:
        t.warn("max_turn_rate", f"{value:g} rad/s is more than a turn per second: {slip}")
    return value


def _min_clearance(t: SpecTable, default: float, moment: float, bodied: bool) -> float:
    """``min_clearance`` (m): a length in mm written as m refused; one that lets the magnet's centre
    come nearer than half the side of the smallest magnet of its moment (an NdFeB cube) refused:
    the rod would be inside the magnet (a magnet with a body is checked against its own size)."""
    value = t.number("min_clearance", "m", default, low=0.0, low_open=True)
    if value > MAX_CLEARANCE:
        raise t.error("min_clearance", f"{value:g} m is no magnet's distance from a catheter: mm written as "
                                       f"m? ({value:g} mm is {value / 1e3:g} m)")
    if bodied:
        return value
    side = (moment / NDFEB_MAGNETIZATION) ** (1.0 / 3.0)
    if value < 0.5 * side:
        raise t.error("min_clearance", f"{1e3 * value:g} mm is less than half the side of a {moment:g} A m^2 "
                                       f"magnet (an NdFeB cube of {1e3 * side:.3g} mm at ~1e6 A/m): the rod "
                                       "would pass inside the magnet; a smaller moment (mA m^2?) or a larger "
                                       "min_clearance")
    return value


def magnet_arm_from_table(t: SpecTable, rod_length: float) -> MagnetArm:
    """The ``[actuation]`` table of ``kind = "magnet-pose"`` (``rod_length``, m: the straight rod
    along +x from the origin, which the start must clear)."""
    moment = t.number("moment", "A m^2", low=0.0, low_open=True, high=1e4)
    position = t.vector("position", "m", 3)
    direction = t.vector("direction", "a direction", 3)
    box = t.raw("workspace")
    if (not isinstance(box, list) or len(box) != 2 or any(
            not isinstance(row, list) or len(row) != 3 or any(
                isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) for v in row)
            for row in box)):
        raise t.error("workspace", f"expected [[xmin, ymin, zmin], [xmax, ymax, zmax]] in m, got {box!r}")
    workspace = np.asarray(box, dtype=np.float64)
    if np.any(workspace[1] <= workspace[0]):
        raise t.error("workspace", f"each min must be below its max (m), got {box!r}")
    for key, value in (("position", np.asarray(position)), ("workspace", workspace)):
        if np.abs(value).max() > MAX_REACH:
            raise t.error(key, f"{value.tolist()} m reaches {np.abs(value).max():g} m from the base, "
                               f"beyond any arm ({MAX_REACH:g} m): lengths in mm written as m?")
    d = MagnetArm(moment=0.0, position=(0.0, 0.0, 0.0), direction=(1.0, 0.0, 0.0),
                  workspace=((0.0, 0.0, 0.0), (1.0, 1.0, 1.0)))
    insertion = insertion_from_table(t, rod_length)
    arm = MagnetArm(
        moment=moment, position=tuple(position), direction=tuple(direction),
        workspace=(tuple(workspace[0].tolist()), tuple(workspace[1].tolist())),
        max_speed=speed_from_table(t, "max_speed", d.max_speed),
        max_turn_rate=_turn_rate(t, d.max_turn_rate),
        min_clearance=_min_clearance(t, d.min_clearance, moment, t.has("magnet")),
        control_rate=control_rate_from_table(t, d.control_rate),
        insertion=insertion,
        insertion_speed=insertion_speed_from_table(t, insertion, d.insertion_speed),
        magnet=_finite_magnet(t, moment, workspace, rod_length, insertion))
    try:
        MagnetPose(**arm.arm_settings())
    except SpatialFieldError as exc:
        raise t.error("position" if "position" in str(exc) else "direction", str(exc)) from None
    clearance = _clearance_of_straight_rod(np.asarray(position), rod_length)
    if clearance < arm.min_clearance:
        raise t.error("position", f"{list(position)} m is {1e3 * clearance:.3g} mm from the straight rod "
                                  f"(along +x from the origin, {rod_length:g} m), nearer than min_clearance "
                                  f"= {1e3 * arm.min_clearance:g} mm: every episode would end at its start")
    tip_field = arm.field_at_tip(rod_length)
    if tip_field > MAX_TIP_FIELD:
        t.warn("moment", f"{moment:g} A m^2 makes {tip_field:.3g} T at the straight tip at the start, more "
                         f"than {MAX_TIP_FIELD:g} T (a catheter is steered by some mT): mA m^2 written as "
                         "A m^2?")
    t.finish()
    return arm


def _finite_magnet(t: SpecTable, moment: float, workspace: np.ndarray, rod_length: float,
                   insertion: tuple[float, float] | None) -> FiniteMagnet | None:
    """``[actuation.magnet]`` (optional): the magnet's body, checked against its moment (a
    polarization no permanent magnet has, or far below any), against ``min_clearance`` (the rod
    inside the body) and its map against where the rod can be (the rod's reach from its base over
    the stage's travel, from anywhere in ``workspace``)."""
    m = t.table("magnet", required=False)
    if m is None:
        return None
    shape = m.string("shape", choices=("cuboid", "cylinder"))
    size = 3 if shape == "cuboid" else 2
    dimension = m.vector("dimension", "m: " + ("three edges" if size == 3 else "[diameter, height]"), size)
    if min(dimension) <= 0.0:
        raise m.error("dimension", f"{dimension} m: each must be a positive length")
    if max(dimension) > MAX_MAGNET_SIZE:
        raise m.error("dimension", f"{dimension} m: an edge beyond {MAX_MAGNET_SIZE:g} m is no arm's magnet "
                                   "(mm written as m?)")
    base = [np.array([x, 0.0, 0.0]) for x in (insertion or (0.0, 0.0))]
    corners = np.array([[workspace[i][0], workspace[j][1], workspace[k][2]]
                        for i in (0, 1) for j in (0, 1) for k in (0, 1)])
    needed = max(float(np.linalg.norm(c - b)) for c in corners for b in base) + rod_length
    half_width = m.number("map_half_width", "m", needed, low=0.0, low_open=True)
    if half_width < needed * (1.0 - 1e-12):
        raise m.error("map_half_width", f"{half_width:g} m does not hold the rod wherever the arm takes the "
                                        f"magnet: {needed:.4g} m at least (the farthest corner of the "
                                        "workspace from the base, plus the rod's length)")
    if half_width > MAP_WIDTH_SLACK * needed:
        raise m.error("map_half_width", f"{half_width:g} m is more than {MAP_WIDTH_SLACK:g} times the "
                                        f"{needed:.4g} m the rod can reach (the farthest corner of the "
                                        "workspace from the base, plus the rod's length): mm written as m? "
                                        "Leave it out for that reach")
    clearance = t.number("min_clearance", "m", 0.01)
    spacing = m.number("map_spacing", "m", _default_spacing(half_width, clearance), low=0.0, low_open=True)
    _check_map_spacing(m, spacing, half_width, clearance)
    nodes = (int(round(2.0 * half_width / spacing)) + 1) ** 3
    if nodes > MAX_RESAMPLED_NODES:
        coarsest = 2.0 * half_width / (MAX_RESAMPLED_NODES ** (1.0 / 3.0) - 1.0)
        raise m.error("map_spacing", f"{spacing:g} m over +-{half_width:.4g} m is {nodes} nodes, more than "
                                     f"{MAX_RESAMPLED_NODES}: {coarsest:.3g} m or coarser (or a smaller "
                                     "workspace)")
    body = FiniteMagnet(shape, tuple(dimension), half_width, spacing)
    polarization = body.polarization(moment)
    words = f"{moment:g} A m^2 in this body asks a polarization J = mu0 m / V = {polarization:.3g} T"
    if polarization > MAX_POLARIZATION:
        raise t.error("moment", f"{words}, beyond any permanent magnet (NdFeB 1.2-1.45 T): a larger body or "
                                "a smaller moment")
    if polarization > WARN_POLARIZATION:
        t.warn("moment", f"{words}, more than NdFeB's 1.45 T")
    if polarization < MIN_POLARIZATION:
        m.warn("dimension", f"{words}: a body far larger than its moment (mm written as m?)")
    if clearance < body.circumradius:
        raise t.error("min_clearance", f"{1e3 * clearance:g} mm is less than half the magnet's diagonal "
                                       f"({1e3 * body.circumradius:.3g} mm): the rod could pass inside it")
    m.finish()
    return body


def _default_spacing(half_width: float, clearance: float) -> float:
    """m: :data:`MAP_SPACING`, coarser where the map would exceed :data:`MAP_NODES_PER_AXIS` nodes a
    side, finer down to :data:`MAP_SPACING_WARN` x ``clearance`` (the map's error near the magnet)
    as long as it holds at most ``MAX_RESAMPLED_NODES`` nodes."""
    finest = 2.0 * half_width / (MAX_RESAMPLED_NODES ** (1.0 / 3.0) - 2.0)
    usual = max(MAP_SPACING, 2.0 * half_width / (MAP_NODES_PER_AXIS - 1))
    return max(min(usual, MAP_SPACING_WARN * clearance), finest)


def _check_map_spacing(m: SpecTable, spacing: float, half_width: float, clearance: float) -> None:
    """The map's spacing (m) against the nearest the rod comes to the magnet (``clearance``, m):
    the field changes over distances of that order, and the map's error grows as ``(spacing /
    distance)^2`` (a few percent at a fifth: docs/spatial_fields.md). Refused at or beyond the
    clearance (the map would not resolve the field where it is strongest; mm written as m?),
    warned beyond :data:`MAP_SPACING_WARN` of it."""
    words = (f"{1e3 * spacing:g} mm against the {1e3 * clearance:g} mm (min_clearance) the rod may come "
             "to the magnet's centre")
    if spacing >= min(clearance, half_width):
        raise m.error("map_spacing", f"{words}: the map cannot resolve the field where it is strongest "
                                     f"(its error grows as the spacing squared); at most "
                                     f"{1e3 * MAP_SPACING_WARN * clearance:.3g} mm (mm written as m?)")
    if spacing > MAP_SPACING_WARN * clearance:
        m.warn("map_spacing", f"{words}: the map's error near the magnet is tens of percent (it grows as "
                              f"the spacing squared); {1e3 * MAP_SPACING_WARN * clearance:.3g} mm or finer")


def _clearance_of_straight_rod(point: np.ndarray, length: float) -> float:
    """Distance (m) from ``point`` to the segment from the origin to ``(length, 0, 0)``."""
    x = min(max(float(point[0]), 0.0), length)
    return float(np.linalg.norm(point - np.array([x, 0.0, 0.0])))
