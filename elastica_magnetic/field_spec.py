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
``field-map`` takes ``file`` (``.npz``, ``.csv``, or a grid export of a finite-element tool,
COMSOL's spreadsheet ``.txt``, relative to the spec file; see :class:`~elastica_magnetic.FieldMap`
and :meth:`~elastica_magnetic.FieldMap.from_export`), ``scale`` (default 1), and for a grid export
``length_unit`` / ``field_unit`` where its header does not state them. Finite magnets (Magpylib, see
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
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .field_maps import EXPORT_FIELD_UNITS, EXPORT_LENGTH_UNITS, FieldMap
from .io import missing_folder_hint
from .spatial_fields import (
    ConstantGradientField,
    CurrentLoopField,
    HelmholtzCoils,
    MaxwellCoils,
    PointDipoleField,
    SpatialField,
    SpatialFieldError,
    Waypoints,
)
from .spec_format import SpecError, SpecTable, read_spec

__all__ = ["FIELD_KINDS", "CLAMPS", "FieldKind", "FieldSetup", "describe_field", "field_source",
           "load_field"]

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
    kind = FIELD_KIND_TABLE[t.string("kind", choices=tuple(FIELD_KINDS))]
    out: dict[str, Any] = {"kind": kind.name}
    kind.read(t, out)
    if kind.pose_key is not None:
        _pose(t, out, kind.pose_key)
    out["ramp"] = t.number("ramp", "s", 0.0, low=0.0, plausible="field time")
    out["frequency"] = t.number("frequency", "Hz", 0.0)
    out["phase"] = t.number("phase", "rad", 0.0, plausible="phase angle")
    if out["frequency"] == 0.0 and abs(math.cos(out["phase"])) < 1e-9:
        # a constant strength cos(phase) of zero: the source's shape times 0 at every time
        _refuse_no_field(t, "phase", f"{out['phase']:g} rad with frequency 0 (a constant strength "
                                     f"cos(phase) = {math.cos(out['phase']):.2g})")
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
    kind = FIELD_KIND_TABLE[table["kind"]]
    pose: Any = table.get(kind.pose_key) if kind.pose_key is not None else None
    if "path" in table:
        pose = Waypoints(table["path"]["times"], table["path"]["points"])
    return kind.build(table, pose, _waveform(table), base)


# -- the kinds: what each reads from its table and the source it builds --------------------------
Strength = Callable[[float], float] | None


def _refuse_no_field(t: SpecTable, key: str, value: str) -> None:
    """A source that makes no field anywhere: the rod would feel nothing, and the run would report
    the unloaded rod as if it were the source's result."""
    what = "strength (a phase whose cosine is not 0, or a frequency)" if key == "phase" else key
    raise t.error(key, f"{value}: this source makes no field anywhere, so the rod would feel nothing; "
                       f"give its {what} (docs/spatial_fields.md)")


def _read_dipole(t: SpecTable, out: dict[str, Any]) -> None:
    out["moment"] = t.vector("moment", "A m^2", 3)
    if not any(out["moment"]):
        _refuse_no_field(t, "moment", "[0, 0, 0] A m^2")
    t.check_plausible("moment", _norm(out["moment"]), "magnetic moment", "|moment|")


def _build_dipole(table: Mapping[str, Any], pose: Any, strength: Strength, base: Path) -> SpatialField:
    moment = table["moment"]
    if strength is not None:
        import numpy as np

        vector = np.asarray(moment, dtype=float)
        return PointDipoleField(lambda t: vector * strength(t), pose)
    return PointDipoleField(moment, pose)


def _read_gradient(t: SpecTable, out: dict[str, Any]) -> None:
    out["gradient"] = _matrix3(t, "gradient", "T/m")
    if not any(v for row in out["gradient"] for v in row):
        _refuse_no_field(t, "gradient", "every entry 0 T/m")
    t.check_plausible("gradient", max(abs(v) for row in out["gradient"] for v in row), "gradient",
                      "its largest |dB_i/dx_j|")


def _build_gradient(table: Mapping[str, Any], pose: Any, strength: Strength, base: Path) -> SpatialField:
    return ConstantGradientField(table["gradient"], 1.0 if strength is None else strength, pose)


def _read_map(t: SpecTable, out: dict[str, Any]) -> None:
    out["file"] = t.string("file")
    out["scale"] = t.number("scale", "1", 1.0)
    if out["scale"] == 0.0:
        _refuse_no_field(t, "scale", "0 (every sample of the map times 0)")
    for key, known in (("length_unit", EXPORT_LENGTH_UNITS), ("field_unit", EXPORT_FIELD_UNITS)):
        unit = t.string(key, None, choices=tuple(known))
        if unit is not None:
            out[key] = unit


def _build_map(table: Mapping[str, Any], pose: Any, strength: Strength, base: Path) -> SpatialField:
    path = Path(table["file"])
    if not path.is_absolute():
        path = base / path
    scale = table["scale"]
    factor = scale if strength is None else (lambda t: scale * strength(t))
    if not path.is_file():
        raise SpatialFieldError(f"file {path}: no such field map (.npz, .csv or a grid export .txt)"
                                f"{missing_folder_hint(path)}")
    units = {k: table[k] for k in ("length_unit", "field_unit") if k in table}
    if path.suffix == ".npz" and not units:
        return FieldMap.from_npz(path, factor)
    if path.suffix == ".csv" and not units and not _is_export(path):
        return FieldMap.from_csv(path, factor)
    if path.suffix in (".csv", ".txt"):
        return FieldMap.from_export(path, factor, **units)
    raise SpatialFieldError(f"file {path}: expected an .npz or .csv field map, or a grid export "
                            "(.txt or .csv, COMSOL's spreadsheet format); length_unit and field_unit "
                            "are for a grid export")


def _is_export(path: Path) -> bool:
    """Whether a ``.csv`` file starts like a grid export (a ``%`` or ``#`` comment line)."""
    try:
        with open(path, encoding="utf-8-sig") as handle:
            return handle.readline().lstrip()[:1] in ("%", "#")
    except (OSError, UnicodeDecodeError):
        return False


def _read_axis(t: SpecTable, out: dict[str, Any]) -> None:
    out["axis"] = t.vector("axis", "a direction [x, y, z]", 3, [0.0, 0.0, 1.0])
    if not any(out["axis"]):
        raise t.error("axis", "must be a non-zero direction [x, y, z]")


def _read_cuboid(t: SpecTable, out: dict[str, Any]) -> None:
    out["dimension"] = t.vector("dimension", "m", 3)
    if min(out["dimension"]) <= 0.0:
        raise t.error("dimension", f"must be positive lengths (m), got {out['dimension']!r}")
    for edge in out["dimension"]:
        t.check_plausible("dimension", edge, "magnet dimension", "an edge")
    _read_polarization(t, out)


def _read_cylinder(t: SpecTable, out: dict[str, Any]) -> None:
    out["diameter"] = t.number("diameter", "m", low=0.0, low_open=True, plausible="magnet dimension")
    out["height"] = t.number("height", "m", low=0.0, low_open=True, plausible="magnet dimension")
    _read_polarization(t, out)


def _read_polarization(t: SpecTable, out: dict[str, Any]) -> None:
    out["polarization"] = t.vector("polarization", "T, J = mu0 M in the magnet's own frame", 3)
    t.check_plausible("polarization", _norm(out["polarization"]), "polarization", "|polarization|")
    _read_axis(t, out)


def _build_cuboid(table: Mapping[str, Any], pose: Any, strength: Strength, base: Path) -> SpatialField:
    from .magnet_fields import CuboidMagnetField

    return CuboidMagnetField(table["dimension"], table["polarization"], pose, table["axis"],
                             scale=1.0 if strength is None else strength)


def _build_cylinder(table: Mapping[str, Any], pose: Any, strength: Strength, base: Path) -> SpatialField:
    from .magnet_fields import CylinderMagnetField

    return CylinderMagnetField(table["diameter"], table["height"], table["polarization"], pose,
                               table["axis"], scale=1.0 if strength is None else strength)


def _read_coil(t: SpecTable, out: dict[str, Any]) -> None:
    out["radius"] = t.number("radius", "m", low=0.0, low_open=True, plausible="coil radius")
    out["current"] = t.number("current", "A", plausible="coil current")
    if out["current"] == 0.0:
        _refuse_no_field(t, "current", "0 A")
    out["turns"] = t.number("turns", "turns", 1.0, low=0.0, low_open=True)
    _read_axis(t, out)


def _coil_builder(cls: type) -> Callable[..., SpatialField]:
    def build(table: Mapping[str, Any], pose: Any, strength: Strength, base: Path) -> SpatialField:
        current = table["current"]
        waveform = current if strength is None else (lambda t: current * strength(t))
        return cls(table["radius"], current=waveform, centre=pose, axis=table["axis"],
                   turns=table["turns"])

    return build


@dataclass(frozen=True)
class FieldKind:
    """One ``[field] kind``: its ``name``, the ``keys`` it takes besides ``kind``, ``ramp``,
    ``frequency``, ``phase``, the key of its pose (``None``: none; else the pose may also be a
    ``[field.path]``), ``read(table, out)`` (checks and copies its own keys) and
    ``build(table, pose, strength, base)`` (its source; ``strength(t)`` the waveform or ``None``,
    ``base`` the folder relative files are taken from). Adding a kind is one entry in
    :data:`FIELD_KIND_TABLE`."""

    name: str
    keys: tuple[str, ...]
    pose_key: str | None
    read: Callable[[SpecTable, dict[str, Any]], None]
    build: Callable[[Mapping[str, Any], Any, Strength, Path], SpatialField]


_COIL_KEYS = ("radius", "current", "turns", "axis", "centre", "path")
#: Every field kind, by name.
FIELD_KIND_TABLE: dict[str, FieldKind] = {k.name: k for k in (
    FieldKind("point-dipole", ("moment", "position", "path"), "position", _read_dipole, _build_dipole),
    FieldKind("current-loop", _COIL_KEYS, "centre", _read_coil, _coil_builder(CurrentLoopField)),
    FieldKind("helmholtz", _COIL_KEYS, "centre", _read_coil, _coil_builder(HelmholtzCoils)),
    FieldKind("maxwell", _COIL_KEYS, "centre", _read_coil, _coil_builder(MaxwellCoils)),
    FieldKind("field-map", ("file", "scale", "length_unit", "field_unit"), None, _read_map, _build_map),
    FieldKind("cuboid-magnet", ("dimension", "polarization", "axis", "position", "path"), "position",
              _read_cuboid, _build_cuboid),
    FieldKind("cylinder-magnet", ("diameter", "height", "polarization", "axis", "position", "path"),
              "position", _read_cylinder, _build_cylinder),
    FieldKind("constant-gradient", ("gradient", "origin", "path"), "origin", _read_gradient,
              _build_gradient),
)}
#: Field kinds and the keys each takes besides ``kind``, ``ramp``, ``frequency``, ``phase``.
FIELD_KINDS: dict[str, tuple[str, ...]] = {name: kind.keys for name, kind in FIELD_KIND_TABLE.items()}


def load_field(path: str | Path) -> FieldSetup | None:
    """The checked ``[field]``/``[boundary]`` of a spec file; ``None`` for a robot preset name or a
    spec with neither table."""
    from .presets import ROBOTS

    if str(path) in ROBOTS:
        return None
    return describe_field(read_spec(path), str(path))
