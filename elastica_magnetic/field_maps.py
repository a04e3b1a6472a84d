"""A magnetic field tabulated on a regular 3D grid: :class:`FieldMap`, and its readers.

A map comes from arrays (``x, y, z`` in m, ``B`` in T), an ``.npz`` archive, the project's field-map
CSV (``x_m,y_m,z_m,Bx_mT,By_mT,Bz_mT``), or a finite-element tool's grid export (COMSOL's
spreadsheet ``.txt``: a ``%`` header with the length unit and the column names, e.g.
``% x  y  z  mf.Bx (T)  mf.By (T)  mf.Bz (T)``). ``B`` and its gradient are interpolated
trilinearly (numba: :func:`elastica_magnetic._spatial_kernels.grid_field`). The map is a
:class:`~elastica_magnetic.spatial_fields.SpatialField`: it can be posed, moved and summed like the
closed-form sources of :mod:`elastica_magnetic.spatial_fields`.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import _spatial_kernels as kernels
from .clock_columns import other_spelling_hint
from .spatial_fields import (
    ScalarOrWaveform,
    SpatialField,
    SpatialFieldError,
    VectorOrPath,
    _Scalar,
    _Vector,
    rotation_to,
)

__all__ = [
    "FieldMap",
    "FieldMapDomainError",
    "EXPORT_LENGTH_UNITS",
    "EXPORT_FIELD_UNITS",
    "MAX_RESAMPLED_NODES",
]

#: Length and field units a grid export may state, with their factor to m and to T.
EXPORT_LENGTH_UNITS = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "µm": 1e-6}
EXPORT_FIELD_UNITS = {"T": 1.0, "mT": 1e-3, "uT": 1e-6, "µT": 1e-6, "G": 1e-4, "gauss": 1e-4}

#: The most nodes (all axes together) an uneven grid export is resampled onto: 2 million nodes hold
#: about 200 MB of samples and gradient tables. A mesh refined near one point would need far more
#: at its finest spacing; such a file is refused, to be resampled onto an even grid where it was made.
MAX_RESAMPLED_NODES = 2_000_000


class FieldMapDomainError(SpatialFieldError):
    """A point outside the grid of a :class:`FieldMap`."""


class FieldMap(SpatialField):
    """A field tabulated on a regular 3D grid (e.g. exported from a finite-element tool).

    ``B`` and its gradient are interpolated trilinearly; the gradient table is computed once from
    the samples by second-order central differences (one-sided at the faces). Both are continuous,
    and the gradient is accurate to ``O(h^2)`` for a smooth field (``h`` the spacing). A point
    outside the grid raises :class:`FieldMapDomainError`.

    Parameters
    ----------
    x, y, z : array_like
        Grid coordinates, m: evenly spaced, increasing, at least 3 each.
    samples : array_like
        ``(nx, ny, nz, 3)`` flux density, T.
    scale : float or callable
        Factor on the whole map (e.g. a coil current waveform), or ``scale(time) -> float``.
    position : array_like (3,) or callable
        Where the map's own origin is in the lab, m, or ``position(time)``: a map that moves
        with its magnet or coil (default: the map's frame is the lab's).
    axis : array_like (3,) or callable
        The lab direction of the map's own z, or ``axis(time)`` (turned the shortest way from
        +z; default +z). A point is looked up at ``R^T (x - position)``; the field is ``R B``
        and the gradient ``R G R^T`` (``R`` the map's rotation).
    """

    def __init__(self, x: ArrayLike, y: ArrayLike, z: ArrayLike, samples: ArrayLike,
                 scale: ScalarOrWaveform = 1.0, source: str = "field map", *,
                 position: VectorOrPath = (0.0, 0.0, 0.0), axis: VectorOrPath = (0.0, 0.0, 1.0)) -> None:
        axes = []
        for name, values in (("x", x), ("y", y), ("z", z)):
            values = np.asarray(values, dtype=np.float64)
            if values.ndim != 1 or values.shape[0] < 3:
                raise SpatialFieldError(f"{source}: {name} must list at least 3 grid coordinates (m), "
                                        f"got shape {values.shape}")
            steps = np.diff(values)
            if not np.all(np.isfinite(values)) or np.any(steps <= 0.0) or np.ptp(steps) > 1e-6 * steps.mean():
                raise SpatialFieldError(f"{source}: {name} must be evenly spaced and increasing (m)")
            axes.append(values)
        shape = tuple(a.shape[0] for a in axes)
        samples = np.asarray(samples, dtype=np.float64)
        if samples.shape != (*shape, 3):
            raise SpatialFieldError(f"{source}: samples must have shape {(*shape, 3)} (nx, ny, nz, 3) "
                                    f"in T, got {samples.shape}")
        if not np.all(np.isfinite(samples)):
            raise SpatialFieldError(f"{source}: samples contain NaN or infinite values")
        self.source = source
        self.axes = axes
        self.origin = np.array([a[0] for a in axes])
        self.spacing = np.array([(a[-1] - a[0]) / (a.shape[0] - 1) for a in axes])
        self.shape = np.array(shape, dtype=np.int64)
        self.samples = np.ascontiguousarray(np.moveaxis(samples, -1, 0))
        gradients = np.empty((3, 3, *shape))
        for i in range(3):
            for j in range(3):
                gradients[i, j] = np.gradient(self.samples[i], self.spacing[j], axis=j, edge_order=2)
        self.gradients = np.ascontiguousarray(gradients)
        self.scale = _Scalar(scale, "scale", "1")
        self.position = _Vector(position, "position", "m")
        self.axis = _Vector(axis, "axis", "a direction")
        self._posed = callable(position) or callable(axis) or bool(
            np.any(self.position(0.0) != 0.0) or np.any(rotation_to(self.axis(0.0)) != np.eye(3)))

    @classmethod
    def from_npz(cls, path: str | Path, scale: ScalarOrWaveform = 1.0) -> FieldMap:
        """Load ``x``, ``y``, ``z`` (m) and ``B`` (``(nx, ny, nz, 3)``, T) from an ``.npz`` file.
        A file that is not an ``.npz`` archive, a damaged (truncated) one, a missing array or one
        that does not hold plain numbers is a :class:`SpatialFieldError` naming the file."""
        path = Path(path)
        arrays = _npz_arrays(path, ("x", "y", "z", "B"))
        return cls(arrays["x"], arrays["y"], arrays["z"], arrays["B"], scale, source=str(path))

    @classmethod
    def from_csv(cls, path: str | Path, scale: ScalarOrWaveform = 1.0) -> FieldMap:
        """Load a CSV with header ``x_m,y_m,z_m,Bx_mT,By_mT,Bz_mT``: one row per grid point, in any
        order, every point of a regular grid present once (field in mT, as the field CSV files)."""
        path = Path(path)
        columns = ("x_m", "y_m", "z_m", "Bx_mT", "By_mT", "Bz_mT")
        try:
            with open(path, encoding="utf-8-sig") as handle:
                header = [h.strip() for h in handle.readline().split(",")]
                if tuple(header) == columns:
                    table = np.loadtxt(handle, delimiter=",", ndmin=2)
        except (OSError, UnicodeDecodeError) as exc:
            raise SpatialFieldError(f"{path}: cannot be read ({exc})") from None
        except ValueError as exc:
            raise SpatialFieldError(f"{path}: every row must hold 6 numbers ({exc})") from None
        if tuple(header) != columns:  # outside the try: its own message, not a row's
            missing = [c for c in columns if c not in header]
            spelled = other_spelling_hint(missing, header, "positions in m and the field in mT, under "
                                          "these names: convert and rename them")
            raise SpatialFieldError(f"{path}: header must be {','.join(columns)}, got {','.join(header)}"
                                    f"{spelled}")
        if table.shape[1] != 6:
            raise SpatialFieldError(f"{path}: expected 6 columns, got {table.shape[1]}")
        if not np.all(np.isfinite(table)):
            row = int(np.argwhere(~np.isfinite(table))[0, 0])
            raise SpatialFieldError(f"{path}: line {row + 2}: non-finite value")
        axes = [np.unique(table[:, d]) for d in range(3)]
        shape = tuple(a.shape[0] for a in axes)
        if table.shape[0] != shape[0] * shape[1] * shape[2]:
            raise SpatialFieldError(f"{path}: {table.shape[0]} rows do not fill a regular "
                                    f"{shape[0]} x {shape[1]} x {shape[2]} grid once")
        index = tuple(np.searchsorted(axes[d], table[:, d]) for d in range(3))
        samples = np.full((*shape, 3), np.nan)
        samples[index] = 1e-3 * table[:, 3:]
        if np.isnan(samples).any():
            raise SpatialFieldError(f"{path}: a grid point appears twice and another is missing")
        return cls(*axes, samples, scale, source=str(path))

    @classmethod
    def from_export(cls, path: str | Path, scale: ScalarOrWaveform = 1.0, *,
                    length_unit: str | None = None, field_unit: str | None = None) -> FieldMap:
        """Load a finite-element tool's grid export (COMSOL's spreadsheet format and the like):
        comment lines starting with ``%`` or ``#``, then one row per grid point, in any order,
        numbers separated by spaces, tabs or commas.

        The header's column names say which column is what: ``x y z`` (optionally with a unit,
        ``x (mm)``) and ``Bx By Bz`` (optionally with a prefix and a unit, ``mf.Bx (T)``), in any
        order; each column is read in its own unit. A header without a column-name line is read
        as ``x y z Bx By Bz``. A name line that does not name each of x, y, z, Bx, By, Bz exactly
        once is refused, naming the column.

        Units come from the header (``% Length unit: mm``, the units in the column names) or from
        ``length_unit`` (``"m"``, ``"cm"``, ``"mm"``, ``"um"``) and ``field_unit`` (``"T"``,
        ``"mT"``, ``"uT"``, ``"G"``), which must agree with the header where it states them; a
        file that states neither is refused (no unit is guessed). A rectilinear grid whose spacing
        is not even (a mesh refined near a magnet) is resampled by trilinear interpolation onto an
        even grid at its finest spacing along each axis (:attr:`resampled` says so): exact at the
        original nodes that fall on the new grid, and linear in between. A resampled grid of more
        than :data:`MAX_RESAMPLED_NODES` nodes is refused before it is made.

        The map's coordinates are in m and its samples in T, whatever the file's units."""
        path = Path(path)
        header, table = _read_export(path)
        width = _named_width(header)  # the columns the header names (6, or 7 with |B|)
        held = table.shape[1] if table.size else 0
        if width is not None and held != width:
            raise SpatialFieldError(
                f"{path}: the header's column names name {width} columns, the rows hold {held} (x y z "
                "Bx By Bz, and |B| if exported: e.g. '% x (mm)  y (mm)  z (mm)  mf.Bx (T)  mf.By (T)  "
                "mf.Bz (T)  mf.normB (T)')")
        if width is None and held != 6:
            raise SpatialFieldError(f"{path}: expected rows of 6 numbers (x y z Bx By Bz), got {held} "
                                    "columns")
        order, factors = _column_factors(path, header, length_unit, field_unit)
        table = table[:, order] * np.array(factors)
        if not np.all(np.isfinite(table)):
            row = int(np.argwhere(~np.isfinite(table))[0, 0])
            raise SpatialFieldError(f"{path}: data row {row + 1}: a value is not finite (COMSOL "
                                    "writes NaN outside the geometry: export a grid inside it)")
        axes = [np.unique(table[:, d]) for d in range(3)]
        shape = tuple(a.shape[0] for a in axes)
        if table.shape[0] != shape[0] * shape[1] * shape[2]:
            raise SpatialFieldError(f"{path}: {table.shape[0]} rows do not fill a rectilinear "
                                    f"{shape[0]} x {shape[1]} x {shape[2]} grid once (export a grid, "
                                    "not the mesh nodes)")
        counts = [_even_count(a) for a in axes]
        _check_resampled_size(path, axes, counts)
        index = tuple(np.searchsorted(axes[d], table[:, d]) for d in range(3))
        samples = np.full((*shape, 3), np.nan)
        samples[index] = table[:, 3:]
        if np.isnan(samples).any():
            raise SpatialFieldError(f"{path}: a grid point appears twice and another is missing")
        even = [axes[d] if counts[d] is None else np.linspace(axes[d][0], axes[d][-1], counts[d])
                for d in range(3)]
        for d in range(3):  # trilinear on a rectilinear grid: linear along each axis in turn
            if counts[d] is not None:
                samples = np.apply_along_axis(lambda v, d=d: np.interp(even[d], axes[d], v), d, samples)
        field_map = cls(*even, samples, scale, source=str(path))
        field_map.resampled = any(c is not None for c in counts)
        return field_map

    #: Whether the map was resampled onto an even grid (:meth:`from_export`).
    resampled = False

    def _add(self, points, time, b, g, with_gradient) -> None:
        if not self._posed:
            self._lookup(points, points, time, b, g, with_gradient)
            return
        n = points.shape[1]
        outside = kernels.posed_grid_field(
            self.position(time), rotation_to(self.axis(time)), self.scale(time), self.origin, self.spacing,
            self.shape, self.samples, self.gradients, points, b, g, with_gradient, np.empty((3, n)),
            np.empty((3, n)), np.empty((3, 3, n)))
        if outside >= 0:
            self._outside(points, outside, time)

    def _lookup(self, local, points, time, b, g, with_gradient) -> None:
        outside = kernels.grid_field(self.origin, self.spacing, self.shape, self.samples, self.gradients,
                                     self.scale(time), local, b, g, with_gradient)
        if outside >= 0:
            self._outside(points, outside, time)

    def _outside(self, points, column, time) -> None:
        lo = self.origin
        hi = self.origin + self.spacing * (self.shape - 1)
        raise FieldMapDomainError(
            f"{self.source}: point {points[:, column].tolist()} m (column {column}) at "
            f"t = {time:.6g} s is outside the map's grid [{lo.tolist()}, {hi.tolist()}] m")

    @property
    def fixed(self) -> bool:
        """Whether nothing of the map changes with time (its scale and pose constants): the batched
        simulator then drives its robots by one kernel call."""
        return (self.scale.constant is not None and self.position.constant is not None
                and self.axis.constant is not None)

    @property
    def posed(self) -> bool:
        """Whether the map's frame differs from the lab's (a position or an axis given)."""
        return self._posed


def _read_export(path: Path) -> tuple[list[str], NDArray[np.float64]]:
    """The comment lines (``%`` or ``#``, without the mark) and the numbers of a grid export."""
    header, rows = [], []
    try:
        with open(path, encoding="utf-8-sig") as handle:
            for number, line in enumerate(handle, 1):
                text = line.strip()
                if not text:
                    continue
                if text[0] in "%#":
                    header.append(text[1:].strip())
                    continue
                try:
                    rows.append([float(v) for v in text.replace(",", " ").split()])
                except ValueError:
                    raise SpatialFieldError(f"{path}: line {number}: expected numbers (x y z Bx By Bz), "
                                            f"got {text[:60]!r}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SpatialFieldError(f"{path}: cannot be read ({exc})") from None
    widths = {len(r) for r in rows}
    if len(widths) > 1:
        raise SpatialFieldError(f"{path}: rows of {sorted(widths)} numbers; every row must hold 6")
    return header, np.array(rows, dtype=np.float64).reshape(len(rows), -1)


#: A header line ``Key: value`` (COMSOL's ``% Length unit: mm``, ``% Model: ...``), not column names.
_METADATA = re.compile(r"^[A-Za-z][\w ]*:")
#: A column name with an optional unit in parentheses or brackets: ``mf.Bx (T)``, ``x [mm]``, ``y``.
_COLUMN = re.compile(r"([^\s,()\[\]]+)(?:\s*[(\[]\s*([^)\]]*?)\s*[)\]])?")
#: The components a column may name (after its prefix, ``mf.``, and lower-cased).
_COMPONENTS = {"x": 0, "y": 1, "z": 2, "bx": 3, "by": 4, "bz": 5}
_NAMES = ("x", "y", "z", "Bx", "By", "Bz")

#: Where a component's unit was stated: ``(what says it, the unit)``.
Statement = tuple[str, str]


def _component(name: str) -> int | None:
    return _COMPONENTS.get(name.rsplit(".", 1)[-1].replace("_", "").lower())


def _named_width(header: list[str]) -> int | None:
    """How many columns the header's column-name line names (``None``: no such line)."""
    for line in reversed(header):
        if _METADATA.match(line):
            continue
        tokens = _COLUMN.findall(line)
        if sum(_component(name) is not None for name, _ in tokens) >= 3:
            return len(tokens)
    return None


def _unit_name(unit: str | None) -> str | None:
    return None if unit is None else unit.replace("\u03bc", "\u00b5")  # Greek mu as the micro sign


#: Names of a field-norm column (``mf.normB``), which a grid export may hold beside the components.
_NORM_NAMES = frozenset({"normb", "bnorm", "norm", "absb", "|b|"})


def _is_norm(name: str) -> bool:
    return name.rsplit(".", 1)[-1].replace("_", "").lower() in _NORM_NAMES


def _export_columns(path: Path, header: list[str]) -> list[tuple[int, str, str | None]] | None:
    """For x, y, z, Bx, By, Bz in turn: the file's column (0-based), its name as written and its
    unit, read from the header's column-name line; ``None`` when the header has none (the
    columns are then x y z Bx By Bz). A line naming at least three of the components is the
    column-name line; one that does not name each exactly once is refused."""
    for line in reversed(header):  # the column names come last
        if _METADATA.match(line):
            continue
        tokens = _COLUMN.findall(line)
        if sum(_component(name) is not None for name, _ in tokens) < 3:
            continue  # a free-text comment
        found: dict[int, tuple[int, str, str | None]] = {}
        for column, (name, unit) in enumerate(tokens):
            if _is_norm(name):  # |B|, which COMSOL exports beside the components: not read
                continue
            component = _component(name)
            written = f"{name} ({unit})" if unit else name
            if component is None:
                raise SpatialFieldError(
                    f"{path}: column {column + 1} of the header, {written!r}, is none of x, y, z, Bx, "
                    "By, Bz (a prefix such as 'mf.' and a unit in parentheses may be added: 'mf.Bx (T)')")
            if component in found:
                raise SpatialFieldError(
                    f"{path}: columns {found[component][0] + 1} and {column + 1} of the header both name "
                    f"{_NAMES[component]} ({found[component][1]!r} and {written!r})")
            found[component] = (column, written, _unit_name(unit or None))
        missing = [_NAMES[c] for c in range(6) if c not in found]
        if missing:
            raise SpatialFieldError(
                f"{path}: the header's column names {line!r} name no {', '.join(missing)} column "
                "(expected x y z Bx By Bz, e.g. '% x (mm)  y (mm)  z (mm)  mf.Bx (T)  mf.By (T)  "
                "mf.Bz (T)')")
        return [found[c] for c in range(6)]
    return None


def _header_length_unit(header: list[str]) -> str | None:
    for line in header:
        key, _, value = line.partition(":")
        if key.strip().lower() == "length unit":
            return _unit_name(value.strip())
    return None


def _header_field_unit(path: Path, header: list[str]) -> str | None:
    """The field unit of a header without column names: the units of its last line that states
    three or more, which must be one unit (the columns cannot be told apart)."""
    for line in reversed(header):
        units = [u.strip() for u in re.findall(r"\(([^)]+)\)", line)]
        if len(units) >= 3:
            if len(set(units[-3:])) > 1:
                raise SpatialFieldError(
                    f"{path}: the header's units {', '.join(units[-3:])} differ, and it has no column "
                    "names (x y z Bx By Bz) saying which column is in which; name the columns, "
                    "e.g. '% x  y  z  mf.Bx (T)  mf.By (mT)  mf.Bz (mT)'")
            return _unit_name(units[-1])
    return None


def _export_unit(path: Path, what: str, stated: list[Statement], given: str | None,
                 known: dict[str, float], unstated: str | None = None) -> float:
    """The factor to SI of a column's ``what`` unit (``"length"`` or ``"field"``), from what the
    file ``stated`` (each ``(where, unit)``) and what the caller ``given`` (``{what}_unit``);
    ``unstated`` names the column when other columns state a unit and this one does not."""
    claims = [*stated, *([(f"{what}_unit", given)] if given is not None else [])]
    for where, unit in claims:
        if unit not in known:
            raise SpatialFieldError(f"{path}: {where} names the {what} unit {unit!r}; known: "
                                    f"{', '.join(known)}")
    if not claims:
        if unstated is not None:
            raise SpatialFieldError(f"{path}: {unstated} states no {what} unit while other columns "
                                    f"do; write it in the column name or give {what}_unit "
                                    f"({', '.join(known)})")
        raise SpatialFieldError(f"{path}: states no {what} unit (COMSOL: '% Length unit: mm', or units in "
                                f"the column names such as 'x (mm)' and 'mf.Bx (T)'); give {what}_unit "
                                f"({', '.join(known)})")
    (first, unit), rest = claims[0], claims[1:]
    for where, other in rest:
        if known[other] != known[unit]:
            fix = ("leave the option out or correct it" if where == f"{what}_unit" else
                   "correct the file")
            raise SpatialFieldError(f"{path}: {first} says the {what} unit is {unit}, {where} says "
                                    f"{other}: {fix}")
    return known[unit]


def _column_factors(path: Path, header: list[str], length_unit: str | None,
                    field_unit: str | None) -> tuple[list[int], list[float]]:
    """The file's column of x, y, z, Bx, By, Bz and each one's factor to m or T."""
    columns = _export_columns(path, header)
    length = _header_length_unit(header)
    line: list[Statement] = [] if length is None else [("the header's 'Length unit' line", length)]
    if columns is None:
        field = _header_field_unit(path, header)
        column_units: list[Statement] = [] if field is None else [("the header's column units", field)]
        statements = [line] * 3 + [column_units] * 3
        order, unstated = [0, 1, 2, 3, 4, 5], [None] * 6
    else:
        order = [column for column, _, _ in columns]
        own = [[] if unit is None else [(f"column {column + 1} {written!r}", unit)]
               for column, written, unit in columns]
        statements = [*(o + line for o in own[:3]), *own[3:]]
        named = [any(own[c] for c in kind) for kind in (range(3), range(3, 6))]
        unstated = [f"column {columns[c][0] + 1} {columns[c][1]!r}" if named[c // 3] else None
                    for c in range(6)]
    factors = [_export_unit(path, "length" if c < 3 else "field", statements[c],
                            length_unit if c < 3 else field_unit,
                            EXPORT_LENGTH_UNITS if c < 3 else EXPORT_FIELD_UNITS, unstated[c])
               for c in range(6)]
    return order, factors


def _even_count(values: NDArray[np.float64]) -> int | None:
    """``None`` when ``values`` are evenly spaced, else the node count of an even axis over the
    same span at their finest step."""
    steps = np.diff(values)
    if values.shape[0] < 2 or np.ptp(steps) <= 1e-6 * steps.mean():
        return None
    return int(math.ceil((values[-1] - values[0]) / steps.min() * (1.0 - 1e-9))) + 1  # 1e-9: round-off


def _check_resampled_size(path: Path, axes: list[NDArray[np.float64]], counts: list[int | None]) -> None:
    """Refuse an uneven grid whose even resampling would exceed :data:`MAX_RESAMPLED_NODES`,
    naming the axis, its finest spacing and the node count (before anything is allocated)."""
    sizes = [a.shape[0] if c is None else c for a, c in zip(axes, counts, strict=True)]
    total = math.prod(sizes)
    if total <= MAX_RESAMPLED_NODES:
        return
    d = max((k for k in range(3) if counts[k] is not None), key=lambda k: sizes[k])
    steps = np.diff(axes[d])
    k = int(np.argmin(steps))
    name = "xyz"[d]
    raise SpatialFieldError(
        f"{path}: the {name} axis is not evenly spaced, and its finest spacing, {steps[k]:.3g} m (between "
        f"{axes[d][k]:.12g} and {axes[d][k + 1]:.12g} m), would need {sizes[d]:,} {name} nodes on an even "
        f"grid, {sizes[0]:,} x {sizes[1]:,} x {sizes[2]:,} = {total:,} in all (at most "
        f"{MAX_RESAMPLED_NODES:,}): resample onto an even grid in the exporting tool (COMSOL: a Grid 3D "
        "dataset with evenly spaced x, y and z)")


def _npz_arrays(path: Path, names: tuple[str, ...]) -> dict[str, NDArray[np.float64]]:
    """The named arrays of an ``.npz`` file as float64, every problem a :class:`SpatialFieldError`
    naming the file and what is wrong (no traceback of numpy or zipfile)."""
    import zipfile

    expected = "x, y, z in m; B in T, shape (nx, ny, nz, 3)"
    arrays = {}
    try:
        with open(path, "rb") as handle:
            magic = handle.read(6)
        if magic.startswith(b"\x93NUMPY"):
            raise SpatialFieldError(f"{path}: is a single .npy array, not an .npz archive of arrays "
                                    f"({expected}); save it with numpy.savez")
        if not magic.startswith(b"PK"):
            raise SpatialFieldError(f"{path}: is not an .npz archive (a zip file of .npy arrays: "
                                    f"{expected}); save it with numpy.savez")
        with np.load(path, allow_pickle=False) as data:
            missing = [k for k in names if k not in data.files]
            if missing:
                raise SpatialFieldError(f"{path}: lacks array(s) {', '.join(missing)} ({expected})")
            for name in names:
                arrays[name] = data[name]  # read (and decompressed) here: a damaged member fails now
    except SpatialFieldError:
        raise
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise SpatialFieldError(f"{path}: cannot be read as an .npz field map: the file is damaged "
                                f"or not an .npz archive ({type(exc).__name__}: {exc})") from None
    for name, array in arrays.items():
        if array.dtype.kind not in "iuf":
            raise SpatialFieldError(f"{path}: array {name} holds {array.dtype} values, expected "
                                    f"numbers ({expected})")
    return {name: array.astype(np.float64) for name, array in arrays.items()}
