"""Plausibility of a spec's ``[field]`` against its robot: what no single key shows.

Checked on the rod as it starts (straight along +x from the origin, radius ``r``), with the source
at its pose at ``t = 0`` and its waveform at full strength:

- a permanent magnet whose body overlaps the rod (a point dipole inside it, a cuboid or cylinder
  within ``r`` of its centreline) and a current loop whose wire passes within ``r`` of it are
  refused: the field there is singular or meaningless (the rod is flung, or a division by zero);
- a field map whose grid does not hold every element centre is refused (the first step would fail);
- the largest field on the rod is judged as ``"field in space"`` (a point dipole far too close, a
  current in mA written as A); a field that changes along the rod by more than
  :data:`~elastica_magnetic.plausibility.MAX_RELATIVE_CHANGE_PER_ELEMENT` of the strongest field on
  it within one element is warned about (``[checks] accept = ["field.resolution"]``);
- a field that oscillates (``frequency``) with fewer than
  :data:`~elastica_magnetic.plausibility.MIN_STEPS_PER_PERIOD` time steps per period in a physics
  setting is warned about (``"field.frequency"``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .field_maps import FieldMap, FieldMapDomainError
from .plausibility import MAX_RELATIVE_CHANGE_PER_ELEMENT, judge, too_few_steps
from .robot_spec import RobotSpec
from .spatial_fields import CurrentLoopsField, SpatialField
from .spec_format import SpecError, SpecTable

__all__ = ["check_field_on_rod", "rod_centreline"]

#: Points per element where the rod's centreline is sampled for overlaps.
SAMPLES_PER_ELEMENT = 8


def rod_centreline(robot: RobotSpec, per_element: int = SAMPLES_PER_ELEMENT) -> NDArray[np.float64]:
    """``(3, n)`` points (m) along the straight rod's initial centreline, nodes included."""
    x = np.linspace(0.0, robot.length, robot.n_elements * per_element + 1)
    return np.vstack([x, np.zeros_like(x), np.zeros_like(x)])


def _element(robot: RobotSpec, x: float) -> int:
    return min(int(x / (robot.length / robot.n_elements)), robot.n_elements - 1)


def check_field_on_rod(t: SpecTable, table: Mapping[str, Any], source: SpatialField,
                       robot: RobotSpec, time_steps: Mapping[str, float]) -> None:
    """Run the checks of this module on a checked ``[field]`` ``table`` (``t``: its
    :class:`SpecTable`), its ``source`` built without waveform, the ``robot`` and the time step of
    each physics setting (s). Refusals are :class:`SpecError`; warnings go through ``t``."""
    kind = table["kind"]
    if kind in ("point-dipole", "cuboid-magnet", "cylinder-magnet"):
        _magnet_overlap(t, table, source, robot)
    elif isinstance(source, CurrentLoopsField):
        _wire_through_rod(t, source, robot)
    _field_on_rod(t, kind, source, robot)
    setting = max(time_steps, key=time_steps.__getitem__)  # the coarsest step: one warning
    problem = too_few_steps(table["frequency"], time_steps[setting])
    if problem is not None:
        t.warn("frequency", f"{table['frequency']:g} Hz with [physics.{setting}] dt = "
                            f"{time_steps[setting]:g} s is {problem}")


def _magnet_overlap(t: SpecTable, table: Mapping[str, Any], source: Any, robot: RobotSpec) -> None:
    """Refuse a magnet whose body overlaps the rod (within its radius of the centreline)."""
    points = rod_centreline(robot)
    centre = np.asarray(source.position(0.0), dtype=np.float64)
    radius = robot.radius
    kind = table["kind"]
    if kind == "point-dipole":  # a point: inside the rod when within its radius
        depth = np.linalg.norm(points - centre[:, None], axis=0)
        what = "the point dipole"
    else:  # distance from the body, in the magnet's own frame
        local = source.magnet.orientation.inv().apply((points - centre[:, None]).T).T
        if kind == "cuboid-magnet":
            half = 0.5 * np.asarray(table["dimension"])[:, None]
            outside = np.maximum(np.abs(local) - half, 0.0)
            depth = np.linalg.norm(outside, axis=0)
        else:
            radial = np.maximum(np.hypot(local[0], local[1]) - 0.5 * table["diameter"], 0.0)
            axial = np.maximum(np.abs(local[2]) - 0.5 * table["height"], 0.0)
            depth = np.hypot(radial, axial)
        what = f"the {kind.replace('-', ' ')}'s body"
    k = int(np.argmin(depth))
    if depth[k] <= radius:
        key = "position" if "path" not in table else "path"
        x = points[0, k]
        raise t.error(key, f"{what} at {centre.tolist()} m (t = 0) is {depth[k]:.3g} m from the rod's "
                           f"centreline at x = {x:.4g} m (element {_element(robot, x)}), within its "
                           f"radius {radius:.3g} m: the magnet overlaps the rod, where its field is "
                           "singular; move it off the rod (positions in m, not mm?)")


def _wire_through_rod(t: SpecTable, source: CurrentLoopsField, robot: RobotSpec) -> None:
    """Refuse a loop whose wire passes within the rod's radius of its centreline."""
    points = rod_centreline(robot)
    centre = source.centre(0.0)
    for radius, offset in zip(source.radii, source.offsets, strict=True):
        q = points - (centre + offset * source.axis)[:, None]
        axial = source.axis @ q
        radial = np.linalg.norm(q - np.outer(source.axis, axial), axis=0)
        distance = np.hypot(radial - radius, axial)
        k = int(np.argmin(distance))
        if distance[k] <= robot.radius:
            raise t.error("centre" if "centre" in t.data else "radius",
                          f"the wire of the loop of radius {radius:g} m at "
                          f"{(centre + offset * source.axis).tolist()} m passes {distance[k]:.3g} m from "
                          f"the rod's centreline at x = {points[0, k]:.4g} m (element "
                          f"{_element(robot, points[0, k])}), within its radius {robot.radius:.3g} m: "
                          "the field is infinite on the wire; move the coil off the rod")


#: T: a source whose field on the rod at t = 0 is below this is warned about (a moving one may
#: come closer later, so it is not refused).
NEGLIGIBLE_FIELD = 1e-9


def _field_on_rod(t: SpecTable, kind: str, source: SpatialField, robot: RobotSpec) -> None:
    """The field at the element centres at t = 0: inside a map's grid, not too strong, resolved."""
    dl = robot.length / robot.n_elements
    centres = np.zeros((3, robot.n_elements))
    centres[0] = dl * (np.arange(robot.n_elements) + 0.5)
    try:
        b, g = source.evaluate(centres, 0.0)
    except FieldMapDomainError as exc:
        raise t.error("file", f"the robot's element centres (x = {centres[0, 0]:.4g} to "
                              f"{centres[0, -1]:.4g} m, y = z = 0) are not all inside the map's grid: "
                              f"{exc}; the map must cover the robot (grid coordinates in m)") from None
    strength = np.linalg.norm(b, axis=0)
    strongest = float(strength.max())
    if not math.isfinite(strongest):
        raise t.error("kind", "the field on the rod is not finite at t = 0")
    finding = judge("field in space", strongest, hint=False)
    if finding is not None and finding.high:  # a weak field at t = 0 may come closer later
        shown = f"the largest |B| on the rod at t = 0 ({kind})"
        if finding.refuse:
            raise SpecError(f"{t.where('kind')}: {shown} = {finding.text}")
        t.warn("strength", f"{shown} = {finding.text}")
    if strongest < NEGLIGIBLE_FIELD:
        t.warn("strength", f"the largest |B| on the rod at t = 0 ({kind}) is {strongest:.3g} T, below "
                           f"{NEGLIGIBLE_FIELD:g} T (the Earth's field is 5e-5 T): the rod feels next to "
                           "nothing; a moment, current or scale in the wrong unit?")
    if strongest == 0.0:
        return
    change = float(np.linalg.norm(g[:, 0, :], axis=0).max()) * dl / strongest
    if change > MAX_RELATIVE_CHANGE_PER_ELEMENT:
        e = int(np.argmax(np.linalg.norm(g[:, 0, :], axis=0)))
        t.warn("resolution", f"the field along the rod changes by {change:.2g} x the strongest field on "
                             f"it ({strongest:.3g} T) within one element ({dl:.3g} m, near element {e}), "
                             f"more than {MAX_RELATIVE_CHANGE_PER_ELEMENT:g} x: the rod samples the field "
                             "once per element and cannot resolve it; use more elements or move the "
                             "source away")


def check_field_map(t: SpecTable, source: FieldMap, scale: float) -> None:
    """Refuse a field map whose grid or samples betray a unit mistake: grid coordinates judged as
    ``"position"`` (mm written as m), the largest ``|B| x |scale|`` as ``"field in space"`` (in the
    file's unit: T in an ``.npz``, mT in a ``.csv``); warn about an unusual one (``field.file``)."""
    coordinate = max(float(np.abs(a).max()) for a in source.axes)
    finding = judge("position", coordinate)
    if finding is not None and finding.refuse:
        raise t.error("file", f"the grid of {source.source}: largest |coordinate| = {finding.text}")
    unit, size = ("mT", 1e-3) if source.source.endswith(".csv") else ("T", 1.0)
    peak = float(np.linalg.norm(source.samples, axis=0).max()) * abs(scale) / size
    finding = judge("field in space", peak, unit, size)
    if finding is not None:
        text = f"the largest |B| of {source.source} (x scale {scale:g}) = {finding.text}"
        if finding.refuse:
            raise t.error("file", text)
        t.warn("file", text)
