"""What the learning package's ``msr`` sub-commands share: the help of ``--case`` and of the checkpoint
choice, ``--case`` parsed and checked at parse time, and a rollout's result printed."""

from __future__ import annotations

import argparse

from elastica_magnetic.cli import print_result

__all__ = ["CASE_HELP", "CHECKPOINT_HELP", "FORCE_HELP", "TARGET_HELP", "case_option", "checked_spec_option",
           "field_case_option", "print_rollout_result", "ring_option", "target_option",
           "trainable_case_option"]

CHECKPOINT_HELP = ("which actor of a run: auto (default: the final actor and best.pt evaluated in "
                   "the accurate physics from a zero field, the farther used), final, best, or a "
                   "checkpoint file")

CASE_HELP = "a shipped case (`msr case list`: m1-4mT, m2-4mT, m1-10mT, m2-10mT, ...) or a spec file (.toml)"

FORCE_HELP = ("replace an earlier result of this command for the same case in --out (without it "
              "an existing result is refused; another command's or case's result always is)")

TARGET_HELP = ("a goto case's target: FORWARD,LEFT in m from the start, in the robot's start frame "
               "(+x ahead; LEFT positive to its left, which is -z; default the task's distance "
               "straight ahead); a tip-reach case's: X,Y,Z in m in the spec's frame (default: the "
               "case's 20 held-out targets)")

#: The largest target distance ``--target`` takes, m: beyond it, mm were written for m.
MAX_TARGET_M = 10.0


def target_option(value: str) -> tuple[float, ...]:
    """``--target FORWARD,LEFT`` (a goto case) or ``X,Y,Z`` (a tip-reach case), m: two or three
    finite numbers; a distance of metres is refused as mm written for m. Which of the two the
    case takes is checked once the case is known."""
    import math

    try:
        numbers = tuple(float(v) for v in value.split(","))
    except ValueError:
        numbers = ()
    if len(numbers) not in (2, 3):
        raise argparse.ArgumentTypeError(
            f"expected FORWARD,LEFT (a goto case) or X,Y,Z (a tip-reach case) in m, e.g. 0.015,0 or "
            f"0.05,0.01,0; got {value!r}{_target_units_hint(value)}")
    if not all(math.isfinite(v) for v in numbers):
        raise argparse.ArgumentTypeError(f"the target must be finite numbers in m, got {value!r}")
    distance = math.sqrt(sum(v * v for v in numbers))
    if distance > MAX_TARGET_M:
        largest = max(numbers, key=abs)
        raise argparse.ArgumentTypeError(
            f"{value} is {distance:g} m from the start: metres, not mm ({largest:g} mm is {largest / 1e3:g})")
    return numbers


def waypoints_option(value: str) -> list[tuple[float, float]]:
    """``--waypoints F1,L1:F2,L2:...``: a goto case's path, two or more FORWARD,LEFT pairs in m
    from the start (each read as ``--target`` reads one), in the order they are visited."""
    pairs = [part for part in value.split(":")]
    if len(pairs) < 2:
        raise argparse.ArgumentTypeError(
            f"expected two or more FORWARD,LEFT pairs in m joined by ':', e.g. 0.01,0:0.01,0.01 (one "
            f"point is --target's); got {value!r}")
    points = []
    for k, pair in enumerate(pairs, start=1):
        try:
            point = target_option(pair)
        except argparse.ArgumentTypeError as exc:
            raise argparse.ArgumentTypeError(f"waypoint {k} of {value!r}: {exc}") from None
        if len(point) != 2:
            raise argparse.ArgumentTypeError(f"waypoint {k} of {value!r} is {pair!r}: a waypoint is "
                                             "FORWARD,LEFT in m (two numbers)")
        points.append(point)
    return points


#: Units a target may be written with, in m.
_TARGET_UNITS = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "µm": 1e-6}


def _target_units_hint(value: str) -> str:
    """``": numbers alone, in m (15mm is 0.015)"`` for a target whose numbers carry a unit, else
    ``""``."""
    import re

    for part in value.split(","):
        found = re.fullmatch(r"\s*([-+]?[\d.]+(?:[eE][-+]?\d+)?)\s*([a-zµ]+)\s*", part)
        if found and found.group(2) in _TARGET_UNITS:
            metres = float(found.group(1)) * _TARGET_UNITS[found.group(2)]
            return f": numbers alone, in m ({part.strip()} is {metres:g})"
    return ""


def ring_option(value: str) -> int:
    """``--ring N``: the number of targets on the ring, 1 to 72."""
    try:
        n = int(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of targets (1 to 72), got {value!r}") \
            from None
    if not 1 <= n <= 72:
        raise argparse.ArgumentTypeError(f"expected 1 to 72 targets, got {n}")
    return n


def case_option(value: str):
    """``--case NAME_OR_PATH``: the case, loaded and checked at parse time (a bad spec file is an
    argparse error naming the file and the key, before any work starts)."""
    from elastica_magnetic.specfile import SpecError

    from ..cases.case import load_case

    try:
        return load_case(value)
    except SpecError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def trainable_case_option(value: str):
    """``msr train --case``: :func:`case_option`, and a case whose ``yardstick_warmup`` has no
    controller to play it refused (:func:`~elastica_magnetic_rl.cases.case.warmup_refusal`)."""
    from ..cases.case import warmup_refusal

    case = case_option(value)
    refusal = warmup_refusal(case)
    if refusal:
        raise argparse.ArgumentTypeError(refusal)
    return case


def field_case_option(value: str):
    """``--case`` of a command that plays a uniform field: :func:`case_option`, a case steered by a
    source (a magnet arm, coil currents) refused by name at parse time."""
    from ..cases.steered import field_only_refusal

    case = case_option(value)
    if not case.field_actuated:
        raise argparse.ArgumentTypeError(field_only_refusal(case.name, case.actuation.kind))
    return case


def checked_spec_option(value: str):
    """``msr case check NAME_OR_PATH``: a case (:func:`case_option`), or a spec file without a
    ``[task]`` table, a robot to simulate rather than a case to train
    (:class:`~elastica_magnetic_rl.cases.check.RobotOnlySpec`); checked at parse time alike."""
    from elastica_magnetic.specfile import SpecError

    from ..cases.check import robot_only_spec

    try:
        spec = robot_only_spec(value)
    except SpecError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return spec if spec is not None else case_option(value)


def print_rollout_result(result: dict, as_json: bool) -> None:
    """A rollout's result; in text, the actor a run's choice used comes first, in one line."""
    if as_json or "actor_choice" not in result:
        print_result(result, as_json)
        return
    print(f"actor: {result['actor_choice']['summary']}")
    print_result({k: v for k, v in result.items() if k != "actor_choice"}, False)
