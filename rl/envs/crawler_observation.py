"""The observation of a crawler (the paper's, in the order of the authors' code), shared by
:class:`~elastica_magnetic_rl.envs.env.MagneticCrawlerEnv` and the vector environment: its blocks
and scales, its ``Box`` and its values for one rod. SI inputs; the network sees the authors' numbers
(their mm units).

Observation (float32, shape ``(4 n + 4,)`` = ``(260,)`` for ``n = 64`` elements)
--------------------------------------------------------------------------------
In the order of the authors' code (angular velocity first; see :data:`OBSERVATION_LAYOUT` for the
index slices and :data:`OBSERVATION_SCALES` for the factors, :func:`observation_spec` for a JSON
description):

========================  ======  ============================================================
block                     size    value
========================  ======  ============================================================
``angular_velocity``      n       ``0.25 * omega_z`` per element, omega_z in rad/s: the bending
                                  angular velocity about lab +z (= ``omega_collection[1]``,
                                  the material ``d2`` axis, for planar motion), CCW positive
``orientation``           n       ``atan2(t_y, t_x)`` per element, rad, ``t = d3`` the tangent
                                  director (equal to the unit tangent up to shear)
``height``                n + 1   ``100 * y`` per node where ``y > 0`` else 0, ``y`` in m
                                  (the authors' ``0.1 * y[mm]``)
``contact``               n + 1   per node, ``1 + 1e4 * max(-y, 0)`` if the node touches the ground
                                  (``y <= surface_tolerance``, 1e-7 m) else 0, ``y`` in m (the
                                  authors' ``1 + 10 * penetration[mm]``)
``field_amplitude``       1       ``200 * |B|``, ``|B|`` in T (the authors' ``0.2 * |B|[mT]``)
``field_angle``           1       ``atan2(B_y, B_x)``, rad (0 for a zero field)
========================  ======  ============================================================

Three-axis actuation adds ``field_z`` (``200 * B_z``, T) after ``field_angle``; a task adds its
blocks after those (:mod:`elastica_magnetic_rl.cases.tasks`).
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from ..cases.field_actuation import ACTUATION_OBSERVATION
from ..cases.tasks import GOTO_CLOCK_PERIOD, Task

__all__ = ["OBSERVATION_LAYOUT", "OBSERVATION_SCALES", "crawler_observation", "crawler_observation_space",
           "observation_layout", "observation_spec"]

#: Scale factors of the observation, SI input units (see the module docstring).
OBSERVATION_SCALES: dict[str, float] = {
    "angular_velocity": 0.25,  # per rad/s
    "orientation": 1.0,  # per rad
    "height": 100.0,  # per m (y > 0 only)
    "contact_base": 1.0,  # value of a touching node with no penetration
    "contact_penetration": 1e4,  # per m of penetration
    "field_amplitude": 200.0,  # per T
    "field_angle": 1.0,  # per rad
    "field_z": 200.0,  # per T (3-axis actuation only), as the amplitude
}


def observation_layout(
    n_elements: int = 64, extra: tuple[tuple[str, int], ...] = ()
) -> dict[str, slice]:
    """Index slices of each observation block for a rod of ``n_elements`` elements, then the
    task's ``extra`` blocks (name, size), e.g. the reach task's ``target_offset``."""
    n, m = int(n_elements), int(n_elements) + 1
    sizes = (("angular_velocity", n), ("orientation", n), ("height", m), ("contact", m),
             ("field_amplitude", 1), ("field_angle", 1), *extra)
    out, start = {}, 0
    for name, size in sizes:
        out[name] = slice(start, start + size)
        start += size
    return out


#: Index slices of the observation of the paper's 64-element robot (260 entries).
OBSERVATION_LAYOUT: dict[str, slice] = observation_layout(64)


def observation_spec(n_elements: int = 64, surface_tolerance: float = 1e-7,
                     task: Task | None = None, axes: str = "xy") -> dict[str, Any]:
    """JSON-ready description of the observation (layout, scales, formulas), for exported policies
    (``axes``: the controlled field components, ``"xy"`` or ``"xyz"``)."""
    extra = (*ACTUATION_OBSERVATION[axes], *(() if task is None else task.extra_observation))
    layout = observation_layout(n_elements, extra)
    goto = task is not None and task.kind == "goto"
    formulas = {"target_offset": ("100 * (forward, left) [m]: the target in the robot's own frame "
                                  "(ahead along its heading; left, -z at the start)") if goto else
                "100 * (target_x - x_mid) [m]: the reach task's distance to go",
                "heading": "(cos h, sin h): the back-to-front direction (cos h, 0, -sin h), h "
                           "counter-clockwise seen from above, 0 along +x",
                "field_z": "200 * B_z [T] (3-axis actuation: the third coil pair's field)",
                "clock": f"(cos, sin)(2 pi t / {GOTO_CLOCK_PERIOD:g} s), t [s] into the episode: the "
                         "controller's clock (the steering yardstick reverses its turn by it)"}
    return {
        "size": next(reversed(layout.values())).stop,
        "dtype": "float32",
        "blocks": [
            {"name": name, "start": s.start, "stop": s.stop} for name, s in layout.items()
        ],
        "scales": {k: v for k, v in OBSERVATION_SCALES.items() if k != "field_z" or axes == "xyz"},
        "formulas": {
            "angular_velocity": "0.25 * omega_z [rad/s] per element (bending angular velocity about "
                                "lab +z, counter-clockwise positive)",
            "orientation": "atan2(t_y, t_x) per element [rad], t = tangent director d3",
            "height": "100 * y [m] per node where y > 0, else 0 (y: node centreline height above "
                      "its resting value; ground plane at y = -r)",
            "contact": f"1 + 1e4 * max(-y, 0) [m] per node where y <= {surface_tolerance:g} m "
                       "(touching the ground), else 0",
            "field_amplitude": "200 * |B| [T]",
            "field_angle": "atan2(B_y, B_x) [rad]",
            **{name: formulas[name] for name, _ in extra},
        },
        "units": "SI (m, s, rad, T)",
    }


def crawler_observation_space(
    n_elements: int, field_limit: float, extra: tuple[tuple[str, int], ...] = (),
    z_limit: float | None = None,
) -> gym.spaces.Box:
    """The float32 ``Box`` of one observation, shape ``(4 n + 4 + extra,)`` (bounds per block:
    angles in ``[-pi, pi]``, heights, contacts and the amplitude non-negative, the amplitude at most
    ``200 * field_limit`` (T) plus round-off, ``field_z`` within ``+-200 * z_limit`` (T; default
    ``field_limit``); the task's extra blocks unbounded)."""
    n = int(n_elements)
    layout = observation_layout(n, extra)
    size = next(reversed(layout.values())).stop
    low = np.full(size, -np.inf, dtype=np.float32)
    high = np.full(size, np.inf, dtype=np.float32)
    for name in ("orientation", "field_angle"):
        low[layout[name]], high[layout[name]] = -np.pi, np.pi
    for name in ("height", "contact", "field_amplitude"):
        low[layout[name]] = 0.0
    high[layout["field_amplitude"]] = np.float32(
        OBSERVATION_SCALES["field_amplitude"] * float(field_limit) * (1.0 + 1e-5)
    )
    if "field_z" in layout:  # the third coil pair's component, signed
        bound = OBSERVATION_SCALES["field_z"] * float(z_limit or field_limit) * (1.0 + 1e-5)
        low[layout["field_z"]], high[layout["field_z"]] = -bound, bound
    return gym.spaces.Box(low, high, dtype=np.float32)


def crawler_observation(
    rod: Any, field: NDArray[np.float64], layout: dict[str, slice], surface_tolerance: float,
    extra: NDArray[np.float64] | None = None,
) -> NDArray[np.float32]:
    """Observation of one rod (see the module docstring), float32 ``(4 n + 4 + k,)``.

    Args:
        rod: a :class:`elastica.CosseratRod` (or a view of one robot of a memory block).
        field: the field now applied, ``(3,)`` in T (lab frame).
        layout: :func:`observation_layout` of the rod's element count and the task's blocks.
        surface_tolerance: largest height of a node counted as touching the ground, m.
        extra: the task's extra observation values ``(k,)`` (see :mod:`elastica_magnetic_rl.cases.tasks`).
    """
    sc = OBSERVATION_SCALES
    stop = layout["field_z" if "field_z" in layout else "field_angle"].stop
    obs = np.empty(stop if extra is None else stop + len(extra), dtype=np.float64)
    if extra is not None:
        obs[stop:] = extra
    # omega is in the material frame; lab components are Q^T omega. Bending about lab z is
    # sum_k Q[k, 2] omega[k] (= omega[1] when d2 = +z, as for this planar robot).
    directors = rod.director_collection
    omega_z = np.einsum("ki,ki->i", directors[:, 2, :], rod.omega_collection)
    obs[layout["angular_velocity"]] = sc["angular_velocity"] * omega_z
    obs[layout["orientation"]] = np.arctan2(directors[2, 1, :], directors[2, 0, :])
    y = rod.position_collection[1]
    obs[layout["height"]] = sc["height"] * np.maximum(y, 0.0)
    touching = y <= surface_tolerance
    penetration = np.maximum(-y, 0.0)
    obs[layout["contact"]] = np.where(
        touching, sc["contact_base"] + sc["contact_penetration"] * penetration, 0.0
    )
    obs[layout["field_amplitude"]] = sc["field_amplitude"] * math.hypot(field[0], field[1])
    obs[layout["field_angle"]] = math.atan2(field[1], field[0])
    if "field_z" in layout:
        obs[layout["field_z"]] = sc["field_z"] * field[2]
    return obs.astype(np.float32)
