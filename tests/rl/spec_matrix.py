"""The spec matrix (issue 49): ``hypothesis`` strategies of valid spec files covering every form
the format allows for what the features read (a named magnetization pattern, ``segments`` by
elements or by fractions with and without their own magnitudes, a per-element ``table``; an
explicit shear modulus or a Poisson ratio; a crawl or a reach task; a band or a round section;
the paper's two field axes or three, one limit or one per axis; a rolling or sliding ground; a
goto task's heading episodes, time penalty and steering yardstick turning in place or not, at
the default turn or its own ``steering_period``),
written as a user writes them (the shortest form: the parser completes them). Tests of any
feature draw from :func:`user_specs` rather than trusting the shipped cases alone.
"""

from __future__ import annotations

import copy
from typing import Any

from hypothesis import strategies as st

#: A user's robot, shortest form (every other key takes its default).
BASE: dict[str, Any] = {
    "name": "drawn",
    "robot": {
        "name": "drawn", "length": 0.02, "n_elements": 24, "width": 0.008, "thickness": 0.0008,
        "density": 1860.0, "youngs_modulus": 84500.0,
        "magnetization": {"kind": "yao2023-pattern1"},
        "ground": {"static_mu": 0.8, "kinetic_mu": 0.6},
    },
    "actuation": {"field_limit": 0.004},
    "task": {"kind": "crawl"},
}

_DIRECTIONS = st.sampled_from([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0],
                               [0.0, -1.0, 0.0], [0.6, 0.8, 0.0], [0.0, 0.0, 1.0]])
_MAGNITUDES = st.floats(20_000.0, 120_000.0)


#: Every magnetization kind a spec may name.
KINDS = ("yao2023-pattern1", "yao2023-pattern2", "uniform", "sinusoid", "two-segment", "segments",
         "table")


@st.composite
def magnetizations(draw, n_elements: int, kinds: tuple[str, ...] = KINDS) -> dict[str, Any]:
    """A ``[robot.magnetization]`` table of any of ``kinds``."""
    kind = draw(st.sampled_from(kinds))
    table: dict[str, Any] = {"kind": kind}
    if kind == "table":
        values = draw(st.lists(st.lists(st.floats(-80_000.0, 80_000.0), min_size=n_elements,
                                        max_size=n_elements), min_size=3, max_size=3))
        values[0][0] = 50_000.0  # never all zero
        table["values"] = values
        return table
    if kind == "segments":
        count = draw(st.integers(2, min(12, n_elements)))
        by_fraction = draw(st.booleans())
        cuts = sorted(draw(st.lists(st.integers(1, n_elements - 1), min_size=count - 1,
                                    max_size=count - 1, unique=True)))
        sizes = [b - a for a, b in zip([0, *cuts], [*cuts, n_elements], strict=True)]
        segments = []
        for size in sizes:
            segment: dict[str, Any] = {"direction": draw(_DIRECTIONS)}
            if by_fraction:
                segment["fraction"] = size / n_elements
            else:
                segment["elements"] = size
            if draw(st.booleans()):
                segment["magnitude"] = draw(_MAGNITUDES)
            segments.append(segment)
        if by_fraction:  # fractions that sum to 1 exactly, as a user would round them
            segments[-1]["fraction"] = 1.0 - sum(s["fraction"] for s in segments[:-1])
        table["segments"] = segments
    if draw(st.booleans()):
        table["magnitude"] = draw(_MAGNITUDES)
    if kind == "uniform":
        table["direction"] = draw(_DIRECTIONS)
    if kind == "two-segment":
        table["first"], table["second"] = draw(_DIRECTIONS), draw(_DIRECTIONS)
    return table


@st.composite
def user_specs(draw, kinds: tuple[str, ...] = KINDS, poisson: bool | None = None,
               round_section: bool | None = None, task: str | None = None,
               actuation: dict[str, Any] | None = None) -> dict[str, Any]:
    """A valid spec as a user writes it, in every form the format allows for the robot's
    magnetization (of ``kinds``), its moduli (``poisson``: a Poisson ratio, else a shear modulus),
    its section (``round_section``: a radius, else a band), its task (``"crawl"`` or
    ``"reach"``; ``"goto"`` only when asked: it needs the third coil pair, so its actuation is
    drawn from the three-axis forms, and a share of heading episodes or none), its actuation (one of
    :data:`ACTUATIONS`) and its ground's sideways model (rolling, sliding or left out); ``None``:
    drawn."""
    spec = copy.deepcopy(BASE)
    robot = spec["robot"]
    robot["n_elements"] = draw(st.sampled_from([16, 24, 32]))
    robot["magnetization"] = draw(magnetizations(robot["n_elements"], kinds))
    if draw(st.booleans()) if poisson is None else poisson:
        robot["poisson_ratio"] = draw(st.floats(0.3, 0.499))
    else:
        robot["shear_modulus"] = robot["youngs_modulus"] / draw(st.floats(2.6, 3.0))
    if draw(st.booleans()) if round_section is None else round_section:
        del robot["width"], robot["thickness"]
        robot["radius"] = 0.0005
    kind = draw(st.sampled_from(["crawl", "reach"])) if task is None else task
    if kind == "reach":
        spec["task"] = {"kind": "reach", "target": 0.01, "tolerance": 0.001}
    elif kind == "goto":
        spec["task"] = {"kind": "goto", "distance": draw(st.sampled_from([0.01, 0.015])), "tolerance": 0.002}
        share = draw(st.sampled_from([None, 0.5, 1.0]))  # heading episodes in its training
        if share is not None:
            spec["task"]["heading_share"] = share
        penalty = draw(st.sampled_from([None, 0.002]))  # m/s: arriving sooner pays
        if penalty is not None:
            spec["task"]["time_penalty"] = penalty
        turn = draw(st.sampled_from([None, True, False]))  # the steering yardstick's turn in place
        if turn is not None:
            spec["yardstick"] = {"turn_in_place": turn}
        steering = draw(st.sampled_from([None, 0.15]))  # s, the turn it asks of the field
        if steering is not None:
            spec.setdefault("yardstick", {})["steering_period"] = steering
    forms = [a for a in ACTUATIONS if a.get("axes") == "xyz"] if kind == "goto" else ACTUATIONS
    spec["actuation"] = draw(st.sampled_from(forms)) if actuation is None else actuation
    sideways = draw(st.sampled_from(["rolling", "sliding", None]))
    if sideways is not None:
        robot["ground"]["sideways"] = sideways
    if sideways == "sliding" and draw(st.booleans()):  # a band may integrate its friction implicitly
        robot["ground"]["friction"] = "implicit"
    return copy.deepcopy(spec)


#: Every form of ``[actuation]``: one limit (the paper's two axes), a limit per axis, the third
#: coil pair with one limit, and with a weaker z pair and its own increment.
ACTUATIONS: tuple[dict[str, Any], ...] = (
    {"field_limit": 0.004},
    {"field_limit": [0.004, 0.003]},
    {"axes": "xyz", "field_limit": 0.004},
    {"axes": "xyz", "field_limit": [0.004, 0.004, 0.002], "max_increment": [3e-4, 3e-4, 2e-4]},
)
