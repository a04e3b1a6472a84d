"""The ``[field]`` and ``[boundary]`` tables of a spec file: a field source that varies in space
and a clamp, for ``msr field simulate`` and ``msr field replay``::

    [boundary]
    clamp = "first"            # clamp the first node and element (a catheter held at its base)

    [field]
    kind = "point-dipole"      # point-dipole, current-loop, helmholtz, maxwell, field-map,
                               # cuboid-magnet, cylinder-magnet, constant-gradient
    moment = [0.0, 0.0, 2.0]   # A m^2 (point-dipole)
    # position = [0.0, 0.05, 0.0]  # m: a fixed pose, or the [field.path] table below
    ramp = 0.2                 # s: the strength grows linearly from zero (default 0)
    frequency = 0.0            # Hz: strength x cos(2 pi f t + phase) (default 0: constant)
    phase = 0.0                # rad

    [field.path]               # the pose follows waypoints (linear between, held after)
    times = [0.0, 1.0, 2.0]    # s
    points = [[0.0, 0.05, 0.0], [0.02, 0.05, 0.0], [0.04, 0.05, 0.0]]  # m

Coils (``current-loop``, ``helmholtz``, ``maxwell``) take ``radius`` (m), ``current`` (A),
``turns`` (default 1), ``axis`` (default ``[0, 0, 1]``) and ``centre`` (m) or ``[field.path]``;
``field-map`` takes ``file`` (``.npz`` or ``.csv``, relative to the spec file; see
:class:`~elastica_magnetic.FieldMap`) and ``scale`` (default 1). Finite magnets (Magpylib, see
:mod:`elastica_magnetic.magnet_fields`): ``cuboid-magnet`` takes ``dimension`` (m, 3 edges),
``cylinder-magnet`` ``diameter`` and ``height`` (m); both take ``polarization`` (T, ``mu0 M`` in
the magnet's own frame), ``axis`` (lab direction of the magnet's own z) and ``position`` (m) or
``[field.path]``. ``constant-gradient`` (:class:`~elastica_magnetic.ConstantGradientField`) takes
``gradient`` (T/m, three rows ``[dB_i/dx, dB_i/dy, dB_i/dz]``, symmetric and traceless) and
``origin`` (m, where the field is zero) or ``[field.path]``. Every value is SI. Errors are
:class:`~elastica_magnetic.specfile.SpecError` naming the file, the table and the key. Values are
judged against physical ranges (:mod:`~elastica_magnetic.plausibility`: a unit mistake is refused
or warned about, naming it), and the source against the spec's robot
(:mod:`~elastica_magnetic.field_plausibility`: a magnet or a wire on the rod, a field the rod
cannot resolve).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from .spatial_fields import (
    ConstantGradientField,
    CurrentLoopField,
    FieldMap,
    HelmholtzCoils,
    MaxwellCoils,
    PointDipoleField,
    SpatialField,
    SpatialFieldError,
    Waypoints,
)
from .spec_format import SpecError, SpecTable, read_spec

__all__ = ["FIELD_KINDS", "CLAMPS", "FieldSetup", "describe_field", "field_source", "load_field"]

#: Field kinds and the keys each takes besides ``kind``, ``ramp``, ``frequency``, ``phase``.
FIELD_KINDS: dict[str, tuple[str, ...]] = {
    "point-dipole": ("moment", "position", "path"),
    "current-loop": ("radius", "current", "turns", "axis", "centre", "path"),
    "helmholtz": ("radius", "current", "turns", "axis", "centre", "path"),
    "maxwell": ("radius", "current", "turns", "axis", "centre", "path"),
    "field-map": ("file", "scale"),
    "cuboid-magnet": ("dimension", "polarization", "axis", "position", "path"),
    "cylinder-magnet": ("diameter", "height", "polarization", "axis", "position", "path"),
    "constant-gradient": ("gradient", "origin", "path"),
}
#: Values of ``[boundary] clamp``.
CLAMPS = ("none", "first")


class FieldSetup:
    """A checked ``[field]`` and ``[boundary]``: :attr:`table` (plain data, every default written
    out; ``None`` without ``[field]``), :attr:`clamp` and :meth:`source`."""

    def __init__(self, table: dict[str, Any] | None, clamp: bool, base: Path, source: str) -> None:
        self.table, self.clamp, self.base, self.origin = table, clamp, base, source

    def source(self) -> SpatialField | None:
        """The field source the table describes (``None`` without ``[field]``)."""
        return None if self.table is None else field_source(self.table, self.base, self.origin)


def describe_field(spec: Mapping[str, Any], source: str = "<spec>") -> FieldSetup | None:
    """Check the ``[field]`` and ``[boundary]`` tables of a parsed spec; ``None`` without either.
    Relative files are taken from ``source``'s folder."""
    top = SpecTable(spec, source)
    boundary = top.table("boundary", required=False)
    clamp = False
    if boundary is not None:
        clamp = boundary.string("clamp", "none", choices=CLAMPS) == "first"
        boundary.finish()
    t = top.table("field", required=False)
    base = Path(source).parent if source != "<spec>" else Path(".")
    if t is None:
        return None if boundary is None else FieldSetup(None, clamp, base, source)
    kind = t.string("kind", choices=tuple(FIELD_KINDS))
    out: dict[str, Any] = {"kind": kind}
    if kind == "point-dipole":
        out["moment"] = t.vector("moment", "A m^2", 3)
        t.check_plausible("moment", _norm(out["moment"]), "magnetic moment", "|moment|")
        _pose(t, out, "position")
    elif kind == "constant-gradient":
        out["gradient"] = _matrix3(t, "gradient", "T/m")
        t.check_plausible("gradient", max(abs(v) for row in out["gradient"] for v in row), "gradient",
                          "its largest |dB_i/dx_j|")
        _pose(t, out, "origin")
    elif kind == "field-map":
        out["file"] = t.string("file")
        out["scale"] = t.number("scale", "1", 1.0)
    elif kind in ("cuboid-magnet", "cylinder-magnet"):
        if kind == "cuboid-magnet":
            out["dimension"] = t.vector("dimension", "m", 3)
            if min(out["dimension"]) <= 0.0:
                raise t.error("dimension", f"must be positive lengths (m), got {out['dimension']!r}")
            for edge in out["dimension"]:
                t.check_plausible("dimension", edge, "magnet dimension", "an edge")
        else:
            out["diameter"] = t.number("diameter", "m", low=0.0, low_open=True,
                                       plausible="magnet dimension")
            out["height"] = t.number("height", "m", low=0.0, low_open=True, plausible="magnet dimension")
        out["polarization"] = t.vector("polarization", "T, J = mu0 M in the magnet's own frame", 3)
        t.check_plausible("polarization", _norm(out["polarization"]), "polarization", "|polarization|")
        out["axis"] = t.vector("axis", "a direction [x, y, z]", 3, [0.0, 0.0, 1.0])
        if not any(out["axis"]):
            raise t.error("axis", "must be a non-zero direction [x, y, z]")
        _pose(t, out, "position")
    else:
        out["radius"] = t.number("radius", "m", low=0.0, low_open=True, plausible="coil radius")
        out["current"] = t.number("current", "A", plausible="coil current")
        out["turns"] = t.number("turns", "turns", 1.0, low=0.0, low_open=True)
        out["axis"] = t.vector("axis", "a direction [x, y, z]", 3, [0.0, 0.0, 1.0])
        if not any(out["axis"]):
            raise t.error("axis", "must be a non-zero direction [x, y, z]")
        _pose(t, out, "centre")
    out["ramp"] = t.number("ramp", "s", 0.0, low=0.0, plausible="field time")
    out["frequency"] = t.number("frequency", "Hz", 0.0)
    out["phase"] = t.number("phase", "rad", 0.0, plausible="phase angle")
    t.finish()
    setup = FieldSetup(out, clamp, base, source)
    try:
        setup.source()  # a missing or bad map file is an error now, naming the key
        _check_source(t, out, spec, base, source)
    except SpatialFieldError as exc:
        raise SpecError(f"{source}: [field]: {exc}") from None
    return setup


def _norm(vector: list[float]) -> float:
    return math.sqrt(sum(v * v for v in vector))


def _check_source(t: SpecTable, table: dict[str, Any], spec: Mapping[str, Any], base: Path,
                  source: str) -> None:
    """The plausibility of the source as a whole (:mod:`~elastica_magnetic.field_plausibility`):
    a field map's grid and samples, and, when the spec has a ``[robot]``, the source against the
    rod (the source at full strength, without its waveform)."""
    from .field_plausibility import check_field_map, check_field_on_rod
    from .specfile import describe_robot

    bare = field_source({**table, "ramp": 0.0, "frequency": 0.0, "phase": 0.0}, base, source)
    if isinstance(bare, FieldMap):
        check_field_map(t, bare, table["scale"])
    if "robot" not in spec:
        return
    description = describe_robot(spec, source)
    time_steps = {name: setting["dt"] for name, setting in description.tables["physics"].items()}
    check_field_on_rod(t, table, bare, description.robot("accurate"), time_steps)


def _matrix3(t: SpecTable, key: str, unit: str) -> list[list[float]]:
    rows = t.raw(key)
    if (not isinstance(rows, list) or len(rows) != 3 or any(
            not isinstance(row, list) or len(row) != 3 or any(
                isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) for v in row)
            for row in rows)):
        raise t.error(key, f"expected 3 rows of 3 finite numbers ({unit}), got {rows!r}")
    return [[float(v) for v in row] for row in rows]


def _pose(t: SpecTable, out: dict[str, Any], key: str) -> None:
    path = t.table("path", required=False)
    if path is None:
        out[key] = t.vector(key, "m", 3, [0.0, 0.0, 0.0])
        t.check_plausible(key, _norm(out[key]), "position", f"|{key}|")
        return
    if t.has(key):
        raise t.error(key, f"give either {key} (m) or a [field.path] table, not both")
    times = path.raw("times")
    points = path.raw("points")
    if (not isinstance(times, list) or not times or any(
            isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) for v in times)):
        raise path.error("times", f"expected a list of finite times (s), got {times!r}")
    if any(b <= a for a, b in zip(times, times[1:], strict=False)):
        raise path.error("times", f"must increase strictly (s), got {times!r}")
    if (not isinstance(points, list) or len(points) != len(times) or any(
            not isinstance(p, list) or len(p) != 3 or any(
                isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) for v in p)
            for p in points)):
        raise path.error("points", f"expected {len(times)} points [x, y, z] (m), one per time")
    path.finish()
    out["path"] = {"times": [float(v) for v in times], "points": [[float(v) for v in p] for p in points]}
    path.check_plausible("points", max(_norm(p) for p in out["path"]["points"]), "position",
                         "the farthest point's distance from the origin")
    path.check_plausible("times", out["path"]["times"][-1], "field time", "the last time")


def _waveform(table: Mapping[str, Any]):
    """``strength(t)``: the ramp times the cosine (or ``None`` when constant, one)."""
    ramp, frequency, phase = table["ramp"], table["frequency"], table["phase"]
    if ramp == 0.0 and frequency == 0.0 and phase == 0.0:
        return None

    def strength(time: float) -> float:
        value = math.cos(2.0 * math.pi * frequency * time + phase)
        if ramp > 0.0:
            value *= min(max(time / ramp, 0.0), 1.0)
        return value

    return strength


def field_source(table: Mapping[str, Any], base: Path = Path("."), source: str = "<spec>") -> SpatialField:
    """The spatial source of a checked ``[field]`` table (see :func:`describe_field`)."""
    kind = table["kind"]
    strength = _waveform(table)
    pose_key = ("position" if kind in ("point-dipole", "cuboid-magnet", "cylinder-magnet") else
                "origin" if kind == "constant-gradient" else "centre")
    pose: Any = table.get(pose_key)
    if "path" in table:
        pose = Waypoints(table["path"]["times"], table["path"]["points"])
    if kind == "point-dipole":
        moment = table["moment"]
        if strength is not None:
            import numpy as np

            vector = np.asarray(moment, dtype=float)
            return PointDipoleField(lambda t: vector * strength(t), pose)
        return PointDipoleField(moment, pose)
    if kind in ("cuboid-magnet", "cylinder-magnet"):
        from .magnet_fields import CuboidMagnetField, CylinderMagnetField

        factor = 1.0 if strength is None else strength
        if kind == "cuboid-magnet":
            return CuboidMagnetField(table["dimension"], table["polarization"], pose, table["axis"],
                                     scale=factor)
        return CylinderMagnetField(table["diameter"], table["height"], table["polarization"], pose,
                                   table["axis"], scale=factor)
    if kind == "constant-gradient":
        return ConstantGradientField(table["gradient"], 1.0 if strength is None else strength, pose)
    if kind == "field-map":
        path = Path(table["file"])
        if not path.is_absolute():
            path = base / path
        scale = table["scale"]
        factor = scale if strength is None else (lambda t: scale * strength(t))
        if not path.is_file():
            raise SpatialFieldError(f"file {path}: no such field map (.npz or .csv)")
        if path.suffix == ".npz":
            return FieldMap.from_npz(path, factor)
        if path.suffix == ".csv":
            return FieldMap.from_csv(path, factor)
        raise SpatialFieldError(f"file {path}: expected an .npz or .csv field map")
    cls = {"current-loop": CurrentLoopField, "helmholtz": HelmholtzCoils, "maxwell": MaxwellCoils}[kind]
    current = table["current"]
    waveform = current if strength is None else (lambda t: current * strength(t))
    return cls(table["radius"], current=waveform, centre=pose, axis=table["axis"], turns=table["turns"])


def load_field(path: str | Path) -> FieldSetup | None:
    """The checked ``[field]``/``[boundary]`` of a spec file; ``None`` for a robot preset name or a
    spec with neither table."""
    from .presets import ROBOTS

    if str(path) in ROBOTS:
        return None
    return describe_field(read_spec(path), str(path))
