"""A spec's ``[task]`` table: its kind (:data:`~elastica_magnetic_rl.cases.tasks.TASK_KINDS`), each
kind's keys with their units, and the checks that name a key whose value cannot mean what it
says (a reward scale per mm, a target or ring in mm written for m, a tolerance that makes staying
put a success)."""

from __future__ import annotations

import math
from typing import Any

from elastica_magnetic.robot_spec import ACTION_PERIOD
from elastica_magnetic.specfile import SpecTable

from .tasks import TASK_KINDS, GotoTask, ReachTask, Task, TipReachTask

__all__ = ["MAX_YARDSTICK_BODY_LENGTHS", "REWARD_PER_LENGTH_RANGE", "task_from_table"]

#: Most body lengths a yardstick may cover in its 10 s: the paper's fastest gait rolls about 10
#: (198 mm for a 20 mm robot); 100 is no crawler's, and a distance in mm written as m gives 1000x.
MAX_YARDSTICK_BODY_LENGTHS = 100.0
#: Body lengths the paper's fastest gait covers in 10 s (its 10 mT rolling, about 198 mm for a 20 mm
#: robot): a task that needs more per episode is warned about.
FASTEST_GAIT_BODY_LENGTHS = 10.0


#: Usual reward for crawling one body length (``reward_scale`` per m times the length): the
#: paper's is 1e4 per m x 20 mm = 200. Far below, every step's reward is lost in the critic's
#: noise; far above, its values overflow the learning rates tuned for the paper's.
REWARD_PER_LENGTH_RANGE = (1.0, 1e6)


def task_from_table(t: SpecTable, length: float, reach: float | None = None) -> Task:
    """The ``[task]`` table of a spec (``t``); ``length`` (m, the robot's) judges the reward scale
    per body length and targets no crawler reaches; ``reach`` (m, default ``length``): how far from
    the base's start a clamped rod's tip can get (its length plus an insertion stage's travel)."""
    kind = t.string("kind", choices=tuple(TASK_KINDS))
    cls = TASK_KINDS[kind]
    d = cls()
    values: dict[str, Any] = {
        "reward_scale": t.number("reward_scale", "per m", d.reward_scale, low=0.0, low_open=True),
        "episode_duration": t.number("episode_duration", "s", d.episode_duration,
                                     low=ACTION_PERIOD, plausible="episode duration"),
    }
    if t.has("reward_scale"):
        _check_reward_scale(t, values["reward_scale"], length, d.reward_scale)
    if cls is ReachTask:
        values.update(
            target=t.number("target", "m ahead of the start", d.target),
            tolerance=t.number("tolerance", "m", d.tolerance, low=0.0, low_open=True),
            slow_zone=t.number("slow_zone", "m", d.slow_zone, low=0.0),
            speed_penalty=t.number("speed_penalty", "1", d.speed_penalty, low=0.0),
        )
        if values["tolerance"] >= abs(values["target"]):
            # a robot that stays put (or moves backwards) would end "within the tolerance"
            raise t.error("tolerance", f"{values['tolerance']:g} m must be smaller than the "
                          f"target distance |target| = {abs(values['target']):g} m, or staying "
                          "at the start counts as reaching the target")
        _check_target_reach(t, values["target"], length, values["episode_duration"])
        _check_slow_zone(t, values, abs(values["target"]))
    if cls is GotoTask:
        values.update(_goto_values(t, d, length, values["episode_duration"]))
    if cls is TipReachTask:
        values.update(_tip_reach_values(t, d, length, length if reach is None else reach))
        _check_tip_speed(t, values, length)
    t.finish()
    return cls(**values)


def _goto_values(t: SpecTable, d: GotoTask, length: float, duration: float) -> dict[str, float]:
    """The goto task's keys: the targets' ring (``distance``, m; bearings ``angle_low`` ..
    ``angle_high``, rad from ahead, counter-clockwise seen from above), ``tolerance`` (m), the
    reward's ``slow_zone`` (m), ``speed_penalty`` and ``time_penalty`` (m/s), and ``heading_share``
    (the fraction of drawn episodes that are heading episodes)."""
    values = {
        "distance": t.number("distance", "m from the start", d.distance, low=0.0, low_open=True),
        "angle_low": _bearing(t, "angle_low", d.angle_low),
        "angle_high": _bearing(t, "angle_high", d.angle_high),
        "tolerance": t.number("tolerance", "m", d.tolerance, low=0.0, low_open=True),
        "slow_zone": t.number("slow_zone", "m", d.slow_zone, low=0.0),
        "speed_penalty": t.number("speed_penalty", "1", d.speed_penalty, low=0.0),
        "heading_share": t.number("heading_share", "fraction of the training episodes", d.heading_share,
                                  low=0.0, high=1.0),
        "time_penalty": t.number("time_penalty", "m/s", d.time_penalty, low=0.0),
    }
    if values["angle_low"] > values["angle_high"]:
        raise t.error("angle_high", f"{values['angle_high']:g} rad is below angle_low = "
                      f"{values['angle_low']:g} rad: the targets' bearings run from angle_low up to "
                      "angle_high")
    if values["tolerance"] >= values["distance"]:
        raise t.error("tolerance", f"{values['tolerance']:g} m must be smaller than the target "
                      f"distance {values['distance']:g} m, or staying at the start counts as "
                      "reaching every target")
    _check_target_reach(t, values["distance"], length, duration, key="distance")
    _check_slow_zone(t, values, values["distance"])
    _check_time_penalty(t, values["time_penalty"], length)
    return values


#: Body lengths per second: a goto ``time_penalty`` (m/s) above this many of the robot's length is
#: warned about (crawlers cover a fraction of a body length a second; mm/s written for m/s).
WARN_TIME_PENALTY_LENGTHS = 10.0


def _check_time_penalty(t: SpecTable, penalty: float, length: float) -> None:
    """Warn about a ``time_penalty`` (m/s) above :data:`WARN_TIME_PENALTY_LENGTHS` body lengths
    (``length``, m) a second: every step then costs far more than any step toward the target earns."""
    if penalty > WARN_TIME_PENALTY_LENGTHS * length:
        t.warn("time_penalty", f"{penalty:g} m/s is more than {WARN_TIME_PENALTY_LENGTHS:g} body lengths "
               f"({length:g} m) a second: every step away from the target costs far more than a step "
               f"toward it earns; mm/s written for m/s? ({penalty:g} mm/s is {1e-3 * penalty:g} m/s)")


def _bearing(t: SpecTable, key: str, default: float) -> float:
    """A target bearing (rad, within one turn either way), degrees named as the likely mistake."""
    value = t.number(key, "rad", default)
    if abs(value) > 2 * math.pi:
        raise t.error(key, f"must be within [-6.28319, 6.28319] rad (one turn), got {value:g}: "
                      f"degrees? give rad ({value:g} degrees = {math.radians(value):.6g} rad)")
    return value


def _check_slow_zone(t: SpecTable, values: dict[str, float], distance: float) -> None:
    """Refuse a ``speed_penalty`` of 1 or more (a step toward the target inside the slow zone
    then earns nothing: the task cannot be learned; percent written for a fraction named); warn
    about a ``slow_zone`` (m) not smaller than the target's ``distance`` (m): the robot is near
    the target from its first step (mm written for m named)."""
    penalty, zone = values["speed_penalty"], values["slow_zone"]
    if penalty >= 1.0:
        hint = (f"; it looks like percent written for a fraction ({penalty:g} % is {penalty / 100:g})"
                if 1.0 < penalty <= 100.0 else "")
        raise t.error("speed_penalty", f"{penalty:g} >= 1: inside the slow zone a step toward the "
                      "target then costs at least what it earns, so reaching the target cannot be "
                      f"learned; give a fraction below 1 (default 0.5){hint}")
    if zone >= distance:
        hint = (f"; it looks like mm written where m is expected ({zone:g} mm is {1e-3 * zone:g} m)"
                if 1e-3 * zone < distance else "")
        t.warn("slow_zone", f"{zone:g} m is not smaller than the target's distance {distance:g} m: "
               f"the robot is in the slow zone from its first step, and every move costs{hint}")


#: m/s: the mean tip speed a tip-reach episode may ask (the farthest target from the straight tip
#: over the episode) before it is warned about (magnetic catheters are steered at some mm/s to a few
#: cm/s), and beyond which it is refused (no tip bent by a field crosses its box that fast).
WARN_TIP_SPEED, MAX_TIP_SPEED = 0.05, 0.5


def tip_speed_problem(box: Any, rod_length: float, duration: float) -> tuple[bool, str] | None:
    """What is wrong with a tip-reach episode of ``duration`` s for a rod of ``rod_length`` m
    (clamped at the origin along +x) and targets in ``box`` (m): the mean speed it asks of the
    straight tip to its farthest target above :data:`WARN_TIP_SPEED` (``(False, text)``: warn) or
    :data:`MAX_TIP_SPEED` (``(True, text)``: refuse); ``None`` when it is plausible."""
    low, high = box
    farthest = max(math.dist((rod_length, 0.0, 0.0), (x, y, z)) for x in (low[0], high[0])
                   for y in (low[1], high[1]) for z in (low[2], high[2]))
    speed = farthest / duration
    if speed <= WARN_TIP_SPEED:
        return None
    return speed > MAX_TIP_SPEED, (
        f"{duration:g} s asks the tip to cross up to {1e3 * farthest:.3g} mm to its farthest target at "
        f"{1e3 * speed:.3g} mm/s on average, faster than a catheter steered by a field moves (some mm/s "
        f"to {1e3 * WARN_TIP_SPEED:g} mm/s); ms written as s? give a longer episode (s)")


def _check_tip_speed(t: SpecTable, values: dict[str, Any], rod_length: float) -> None:
    """:func:`tip_speed_problem` of the spec's ``episode_duration``: refused or warned, naming it."""
    problem = tip_speed_problem(values["target_box"], rod_length, values["episode_duration"])
    if problem is None:
        return
    refuse, text = problem
    if refuse:
        raise t.error("episode_duration", text)
    t.warn("episode_duration", text)


def target_reach_problem(target: float, length: float, duration: float,
                         key: str = "target") -> tuple[str, str] | None:
    """What is wrong with a reach or goto episode of ``duration`` s whose ``key`` (the target, m)
    is that far for a robot ``length`` m long: more body lengths than
    :data:`MAX_YARDSTICK_BODY_LENGTHS` per 10 s (``("refuse", text)``, naming the key at fault:
    ``"episode_duration"`` or ``key``, as the returned pair's text says), or faster than the paper's
    fastest gait (``("warn", text)``); ``None`` when it is plausible."""
    lengths, most = abs(target) / length, MAX_YARDSTICK_BODY_LENGTHS * duration / 10.0
    if lengths <= most:
        if lengths > FASTEST_GAIT_BODY_LENGTHS * duration / 10.0:  # possible, but faster than any gait
            return "warn", (f"{duration:g} s for the {key} {target:g} m ({lengths:.2g} body lengths of this "
                            f"{length:g} m robot) asks {lengths / duration:.2g} body lengths per second, "
                            f"faster than the paper's fastest gait (about {FASTEST_GAIT_BODY_LENGTHS:g} "
                            "in 10 s): few or no episodes can end at the target (ms written as s?)")
        return None
    needed = 10.0 * lengths / MAX_YARDSTICK_BODY_LENGTHS  # s: the shortest episode that could
    if needed <= 10.0:  # the target is within a 10 s walk: the episode is what is short
        return "episode_duration", (f"{duration:g} s is too short for the {key} {target:g} m "
                                    f"({lengths:.2g} body lengths of this {length:g} m robot): no crawler "
                                    f"covers it in less than {needed:.2g} s; give a longer episode (s)")
    hint = (f"; it looks like mm written where m is expected ({target:g} mm is {1e-3 * target:g} m)"
            if lengths / 1e3 <= most else "")
    return key, (f"{target:g} m is {lengths:.3g} body lengths of this {length:g} m robot, more than the "
                 f"{most:g} that any crawler covers in the {duration:g} s episode{hint}")


def _check_target_reach(t: SpecTable, target: float, length: float, duration: float,
                        key: str = "target") -> None:
    """:func:`target_reach_problem` of the spec's values: refused or warned, naming the key."""
    problem = target_reach_problem(target, length, duration, key)
    if problem is None:
        return
    at, text = problem
    if at == "warn":
        t.warn("episode_duration", text)
        return
    raise t.error(at, text)


def episode_problem(case: Any, duration: float) -> tuple[bool, str] | None:
    """What is wrong with running ``case``'s task (a :class:`~elastica_magnetic_rl.cases.case.Case`)
    in episodes of ``duration`` s instead of its own (``msr train --episode-duration``), as its spec's
    ``episode_duration`` would be judged: ``(True, text)`` to refuse, ``(False, text)`` to warn, or
    ``None``. A crawl's episode has no target to judge it by."""
    task, length = case.task, float(case.robot.tables["robot"]["length"])
    if isinstance(task, TipReachTask):
        return tip_speed_problem(task.target_box, length, duration)
    if isinstance(task, GotoTask | ReachTask):
        target, key = (task.distance, "distance") if isinstance(task, GotoTask) else (task.target, "target")
        problem = target_reach_problem(target, length, duration, key)
        return None if problem is None else (problem[0] != "warn", problem[1])
    return None


def _check_reward_scale(t: SpecTable, scale: float, length: float, papers: float) -> None:
    """Warn about a reward scale (per m) whose reward for crawling one body length (``length``, m)
    is outside :data:`REWARD_PER_LENGTH_RANGE`, naming the per-mm or per-cm mistake it looks like."""
    per_length = scale * length
    low, high = REWARD_PER_LENGTH_RANGE
    if low <= per_length <= high:
        return
    mistakes = [(unit, size) for unit, size in (("mm", 1e3), ("cm", 1e2))
                if per_length < low and low <= scale * size * length <= high]
    hint = (f"; it looks like a reward per {' or per '.join(u for u, _ in mistakes)} written as per m ("
            + "; ".join(f"{scale:g} per {u} is {scale * size:g} per m" for u, size in mistakes)
            + ")") if mistakes else ""
    t.warn("reward_scale", f"{scale:g} per m gives a reward of {per_length:.3g} for crawling one "
           f"body length ({length:g} m), {'below' if per_length < low else 'above'} the usual "
           f"{low:g} to {high:g} (the paper's: {papers:g} per m, 200 for its 20 mm robot): "
           f"training learns from rewards this size poorly{hint}")


def _tip_reach_values(t: SpecTable, d: TipReachTask, rod_length: float, length: float) -> dict[str, Any]:
    """The tip-reach task's keys: ``target_box`` (m; the rod, ``rod_length`` m, is clamped at the
    origin along +x, so no target beyond ``length`` (its reach, a stage's travel included) from the
    base can be reached: a box wholly beyond is refused, one partly beyond warned, one behind the
    base warned), ``tolerance`` (m; one the straight tip already meets for every target refused),
    the reward's ``slow_zone`` (m) and ``speed_penalty``."""
    box = t.raw("target_box", [list(row) for row in d.target_box])
    if (not isinstance(box, list) or len(box) != 2 or any(
            not isinstance(row, list) or len(row) != 3 or any(
                isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) for v in row)
            for row in box)):
        raise t.error("target_box", f"expected [[xmin, ymin, zmin], [xmax, ymax, zmax]] in m, got {box!r}")
    low, high = ([float(v) for v in row] for row in box)
    if any(a > b for a, b in zip(low, high, strict=True)):
        raise t.error("target_box", f"each min must be at most its max (m), got {box!r}")
    nearest = math.dist((0.0, 0.0, 0.0), [min(max(0.0, a), b) for a, b in zip(low, high, strict=True)])
    farthest = max(math.dist((0.0, 0.0, 0.0), (x, y, z)) for x in (low[0], high[0])
                   for y in (low[1], high[1]) for z in (low[2], high[2]))
    if nearest > length:
        raise t.error("target_box", f"{box!r} m lies wholly beyond the rod's reach ({length:g} m from "
                      "its clamped base's start at the origin): no target in it can be reached (mm written "
                      "as m?)")
    if farthest > length:
        t.warn("target_box", f"part of {box!r} m lies beyond the rod's reach ({length:g} m from its "
               "clamped base's start): targets drawn there cannot be reached")
    if high[0] < 0.0:
        t.warn("target_box", f"{box!r} m lies behind the clamped base (x < 0): only a tip turned back "
               "on the rod reaches it")
    values = {
        "target_box": (tuple(low), tuple(high)),
        "tolerance": t.number("tolerance", "m", d.tolerance, low=0.0, low_open=True),
        "slow_zone": t.number("slow_zone", "m", d.slow_zone, low=0.0),
        "speed_penalty": t.number("speed_penalty", "1", d.speed_penalty, low=0.0),
    }
    if values["tolerance"] >= length:
        raise t.error("tolerance", f"{values['tolerance']:g} m is the rod's reach ({length:g} m from its "
                      "base, a stage's travel included) or more: every tip would count as on target "
                      "(mm written as m?)")
    # the farthest a target can be from the straight tip at the start, (rod_length, 0, 0)
    idle = max(math.dist((rod_length, 0.0, 0.0), (x, y, z)) for x in (low[0], high[0])
               for y in (low[1], high[1]) for z in (low[2], high[2]))
    if values["tolerance"] >= idle:
        raise t.error("tolerance", f"{values['tolerance']:g} m: the straight tip at the start is within "
                      f"{idle:.3g} m of every target in the box, so staying put would succeed (mm written "
                      "as m?)")
    _check_slow_zone(t, values, idle)
    return values
