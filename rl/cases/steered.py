"""What the actuations that steer a clamped rod by a source share (``[actuation] kind =
"magnet-pose"``, :class:`~elastica_magnetic_rl.cases.arm_actuation.MagnetArm`, and ``kind =
"coil-currents"``, :class:`~elastica_magnetic_rl.cases.coil_actuation.CoilArray`): the rod is
clamped at its base (a catheter), an optional insertion stage pushes the base along +x (a last
action component), and a field-actuation value asked of them names the mismatch. SI units.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from elastica_magnetic import Advancer
from elastica_magnetic.robot_spec import ACTION_PERIOD
from elastica_magnetic.specfile import SpecError, SpecTable

__all__ = ["ACTUATION_KINDS", "MAX_REACH", "MAX_SPEED", "NotFieldActuatedError", "SteeringActuation",
           "check_steered_reach", "control_rate_from_table", "field_only_refusal", "insertion_from_table",
           "insertion_speed_from_table", "speed_from_table"]

#: ``[actuation] kind``: a uniform field from coils (the paper's, the default), a magnet on an arm,
#: or the currents of fixed coils.
ACTUATION_KINDS = ("field", "magnet-pose", "coil-currents")
#: Largest distance (m) of a magnet, coil or workspace corner from the rod's base: a robot arm's
#: reach or a coil system's size is about 1 m; a value in mm written as m is 1000x.
MAX_REACH = 2.0
#: Fastest motion (m/s) an arm or stage commands: ~1 m/s; mm/s written as m/s is far beyond.
MAX_SPEED = 5.0
#: Above this speed (m/s) a value is warned about: faster than a lab arm's tool or a catheter stage.
WARN_SPEED = 1.0
#: A stage that crosses its whole travel in less than this (s, ten control steps) is warned about.
MIN_STAGE_CROSSING = 0.1
#: What a field actuation has and a steering one has not (asked of the latter, they name the mismatch).
_FIELD_ACTUATION_NAMES = frozenset({"field_limit", "max_increment", "initial_field", "axes", "axis_limits",
                                    "axis_increments", "n_axes", "limits", "increments"})


class NotFieldActuatedError(ValueError):
    """A command or value that needs a field-actuated case was given a case steered by a source."""


def field_only_refusal(case: str, kind: str, needs: str = "") -> str:
    """The message of a command that plays a uniform field given ``case``, steered by a source of
    ``kind`` (``needs``: what it asked of the case, e.g. ``"a field_limit"``; ``case`` empty where
    the caller does not know the case's name)."""
    asked = f" (it asks the case for {needs})" if needs else ""
    where = f"{case}: " if case else "a case whose "
    return (f"{where}[actuation] kind = \"{kind}\" steers a rod clamped at its base by a source; this "
            f"command plays a uniform field (the paper's coils), so it does not apply{asked}: such a case "
            "trains with msr train --case and is judged on held-out targets (docs/steering_catheter.md)")


class SteeringActuation:
    """The shared behaviour of the steering actuations; a subclass (a frozen dataclass) has the
    fields ``insertion`` (``(low, high)`` m or ``None``), ``insertion_speed`` (m/s) and ``kind``,
    the property ``actuator_size`` (its own action components), ``reach_field(rod_length)`` (T:
    the strongest field it can make at the tip of the straight rod), ``reach_field_words`` (what
    that is, in words) and ``weak_source_hint`` (the key and the likely slips of a source too weak
    to bend the rod: :func:`check_steered_reach`)."""

    kind: str
    insertion: tuple[float, float] | None
    insertion_speed: float
    actuator_size: int
    reach_field_words: str
    weak_source_hint: tuple[str, str]

    @property
    def action_size(self) -> int:
        """The policy's action: the actuator's components, and the insertion stage's velocity."""
        return self.actuator_size + (self.insertion is not None)

    def action_words(self) -> str:
        """What each of the policy's action components (in [-1, 1]) commands, in words: the
        actuator's (:meth:`actuator_action_words`), then the insertion stage's velocity."""
        words = self.actuator_action_words()
        if self.insertion is not None:
            words += f"; then the insertion stage's velocity (x {self.insertion_speed:g} m/s)"
        return words

    def actuator_action_words(self) -> str:
        """What the actuator's own action components command, in words (a subclass's)."""
        raise NotImplementedError

    def advancer(self) -> Advancer | None:
        """A new insertion stage of this actuation (``None`` without one)."""
        return None if self.insertion is None else Advancer(self.insertion, self.insertion_speed)

    def stage_blocks(self) -> tuple[tuple[str, int], ...]:
        """The insertion's observation block (1) with a stage, else none."""
        return (("insertion", 1),) if self.insertion is not None else ()

    def stage_dict(self) -> dict[str, Any]:
        """The stage's keys of the ``[actuation]`` table (none without one)."""
        if self.insertion is None:
            return {}
        return {"insertion": list(self.insertion), "insertion_speed": self.insertion_speed}

    def __getattr__(self, name: str) -> Any:
        if name in _FIELD_ACTUATION_NAMES:
            raise NotFieldActuatedError(field_only_refusal("", self.kind, f"its {name}"))
        raise AttributeError(name)


def speed_from_table(t: SpecTable, key: str, default: float) -> float:
    """A speed (m/s) of an arm or a stage: above :data:`MAX_SPEED` refused, above
    :data:`WARN_SPEED` warned, both naming the mm/s slip."""
    value = t.number(key, "m/s", default, low=0.0, low_open=True)
    slip = f"mm/s written as m/s? ({value:g} mm/s is {value / 1e3:g} m/s)"
    if value > MAX_SPEED:
        raise t.error(key, f"{value:g} m/s is beyond any arm or stage ({MAX_SPEED:g} m/s): {slip}")
    if value > WARN_SPEED:
        t.warn(key, f"{value:g} m/s is faster than a lab arm or a catheter stage moves "
                    f"(~{WARN_SPEED:g} m/s): {slip}")
    return value


def insertion_speed_from_table(t: SpecTable, insertion: tuple[float, float] | None, default: float) -> float:
    """``insertion_speed`` (m/s): only with a stage; one that crosses the stage's travel within
    :data:`MIN_STAGE_CROSSING` is warned about (a stage that jumps, not one a policy steers)."""
    speed = speed_from_table(t, "insertion_speed", default)
    if t.has("insertion_speed") and insertion is None:
        raise t.error("insertion_speed", "is for an insertion stage: give its travel, insertion = "
                                         "[low, high] (m)")
    if insertion is not None:
        travel = insertion[1] - insertion[0]
        if travel / speed < MIN_STAGE_CROSSING and speed <= WARN_SPEED:
            t.warn("insertion_speed", f"{speed:g} m/s crosses the stage's {1e3 * travel:g} mm travel in "
                                      f"{1e3 * travel / speed:.3g} ms, within {MIN_STAGE_CROSSING:g} s (ten "
                                      f"control steps): mm/s written as m/s? ({speed:g} mm/s is "
                                      f"{speed / 1e3:g} m/s)")
    return speed


def control_rate_from_table(t: SpecTable, default: float) -> float:
    """``control_rate`` (Hz): only the environments' 0.01 s step is supported."""
    rate = t.number("control_rate", "Hz", default, low=0.0, low_open=True)
    if not math.isclose(rate, 1.0 / ACTION_PERIOD):
        raise t.error("control_rate", f"only {1.0 / ACTION_PERIOD:g} Hz is supported (the environments' "
                                      f"0.01 s step), got {rate:g}")
    return rate


def insertion_from_table(t: SpecTable, rod_length: float) -> tuple[float, float] | None:
    """``insertion = [low, high]`` (m): the stage's travel along +x from the base's start."""
    t.takes("insertion")
    if not t.has("insertion"):
        return None
    low, high = t.vector("insertion", "m", 2)
    if not (low <= 0.0 <= high and low < high):
        raise t.error("insertion", f"[{low:g}, {high:g}] m must hold 0 (the rod starts where it is built) "
                                   "with low < high")
    if max(-low, high) > MAX_REACH:
        raise t.error("insertion", f"[{low:g}, {high:g}] m: a travel beyond {MAX_REACH:g} m (mm written "
                                   "as m?)")
    if -low > rod_length:
        raise t.error("insertion", f"{low:g} m pulls the base back more than the rod's length "
                                   f"({rod_length:g} m)")
    return (low, high)


#: A current that takes longer than this fraction of an episode to go from zero to its limit is
#: warned about: the coils make only part of their field within an episode.
SLOW_SLEW_FRACTION = 0.5


def check_steered_reach(t: SpecTable, actuation: SteeringActuation, robot: Any, box: Any,
                        episode: float) -> None:
    """What a steering actuation (``t``: its ``[actuation]`` table) can do for a tip-reach task
    whose targets lie in ``box`` (m, ``[[xmin, ymin, zmin], [xmax, ymax, zmax]]``) within ``episode``
    s, for ``robot`` (:class:`~elastica_magnetic.robot_spec.RobotSpec`, the rod clamped at the origin
    along +x), warned when it cannot: the strongest field the source can make at the tip
    (``reach_field``) bending the tip by less (linear estimate, magnetic bending number / 3 of the
    length) than the box lies aside of the rod's axis; or a coil current that takes more than
    :data:`SLOW_SLEW_FRACTION` of the episode to reach its limit."""
    from elastica_magnetic.spec_check import magnetic_bending_number

    clearance = getattr(actuation, "min_clearance", None)
    if clearance is not None and clearance <= robot.radius:  # a magnet arm's magnet inside the rod
        raise SpecError(f"{t.source}: [robot] radius: the rod's radius, {1e3 * robot.radius:.3g} mm, reaches "
                        f"the [actuation] min_clearance of {1e3 * clearance:g} mm from its axis: the magnet "
                        "would come inside the rod; a catheter is a millimetre or two thick (mm or cm "
                        "written as m?), or give a larger min_clearance")
    if clearance is not None and clearance - actuation.magnet_reach <= robot.radius:
        reach = actuation.magnet_reach
        body = ("half its body's diagonal: a rim, edge or corner turned to the rod"
                if actuation.magnet is not None else
                f"half the side of the smallest NdFeB cube of {actuation.moment:g} A m^2, turned face-on")
        raise SpecError(f"{t.source}: [robot] radius: the rod's radius, {1e3 * robot.radius:.3g} mm, reaches "
                        f"the magnet: at the [actuation] min_clearance of {1e3 * clearance:g} mm from the "
                        f"rod's axis, the magnet's surface reaches {1e3 * reach:.3g} mm from its centre "
                        f"({body}) and comes within {1e3 * (clearance - reach):.3g} mm of the axis, inside "
                        "the rod; a catheter is a millimetre or two thick (mm or cm written as m?), or give "
                        "a min_clearance beyond the radius plus that reach")
    low, high = (np.asarray(row, dtype=np.float64) for row in box)
    aside = math.hypot(max(abs(low[1]), abs(high[1])), max(abs(low[2]), abs(high[2])))
    field = actuation.reach_field(robot.length)
    number = magnetic_bending_number(robot, field)
    bend = number * robot.length / 3.0
    if bend < aside:
        key, hint = actuation.weak_source_hint
        t.warn(key, f"the strongest field the source makes at the tip ({1e3 * field:.3g} mT, "
                    f"{actuation.reach_field_words}) bends it about {1e3 * bend:.3g} mm (magnetic bending "
                    f"number {number:.3g}; the linear estimate number x length / 3), less than the "
                    f"{1e3 * aside:.3g} mm the target box reaches aside of the rod's axis: targets out there "
                    f"cannot be reached; {hint}")
    slew = getattr(actuation, "max_slew", None)
    if slew is not None and actuation.current_limit / slew > SLOW_SLEW_FRACTION * episode:
        seconds = actuation.current_limit / slew
        part = "longer than" if seconds > episode else "more than half of"
        t.warn("max_slew", f"{slew:g} A/s takes {seconds:.3g} s to bring a current from zero to its limit "
                           f"({actuation.current_limit:g} A), {part} "
                           f"the {episode:g} s episode: the coils make only part of their field in an "
                           "episode (kA/s written as A/s?)")
