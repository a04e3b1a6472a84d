"""What ``msr design`` may change: the ``[design]`` table of a spec, and the map from a search
vector to a robot (``msr design`` itself: :mod:`elastica_magnetic_rl.design`).

A design is a magnetization a lab can make: ``segments`` stretches of the body, back to front,
each magnetized uniformly along a direction in the bending plane (``directions = "plane"``) or in
space (``"3d"``, for a case whose actuation has the third coil pair), at the material's
``remanence`` or at any magnitude up to it (``magnitude = "free"``), the stretches of equal
length or free lengths no shorter than ``min_length``. The rest of the spec (geometry, material,
ground, actuation) is the user's and stays as written.

The search vector ``x`` (what CMA-ES moves, every coordinate of order 1):

====================  ==========================================================================
coordinates           meaning
====================  ==========================================================================
``segments``          each segment's direction angle in the x-y plane, in units of pi (rad / pi)
``segments`` (3d)     each segment's elevation toward +z, in units of pi
``segments`` (free)   each segment's magnitude, a fraction of the remanence in [0, 1] (one under
                      the plausible ~1 kA/m is made 0: an unmagnetized segment)
``segments`` (free)   each segment's length weight in [0.05, 1] (lengths: their shares above
                      ``min_length``)
one per size          ``length``, ``width``, ``thickness`` (or ``radius``) in [0, 1] of its
                      ``[low, high]`` range (m), when the table gives one
1                     the rotating field's period, 0 .. 1 from ``period_low`` to ``period_high``
                      on a log scale (the search's own variable, not part of the design)
====================  ==========================================================================

Units: m, A/m, s (SI, as the spec).
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic.magnetization import MagnetizationSegment, segment_element_counts
from elastica_magnetic.plausibility import QUANTITIES
from elastica_magnetic.robot_spec import ACTION_PERIOD
from elastica_magnetic.specfile import SpecTable

__all__ = ["DESIGN_TABLE", "MAX_SEGMENTS", "MIN_SEGMENTS", "DesignSpace", "design_space"]

#: The spec table ``msr design`` reads.
DESIGN_TABLE = "design"
#: Fewest and most segments a design may have.
MIN_SEGMENTS, MAX_SEGMENTS = 2, 12
#: Segments when neither the ``[design]`` table nor the spec's own magnetization says how many.
DEFAULT_SEGMENTS = 6
#: Length weights of free lengths live in ``[LENGTH_WEIGHT_LOW, 1]``.
LENGTH_WEIGHT_LOW = 0.05
#: Rotation periods the search tries by default, s (those of the baseline sweep's grid).
DEFAULT_PERIOD_RANGE = (0.5, 6.0)


@dataclass(frozen=True)
class DesignSpace:
    """The magnetizations a design search explores (see the module docstring).

    ``n_elements`` and ``length`` (m) are the robot's; ``remanence`` is in A/m, ``min_length`` in
    m, ``period_range`` in s."""

    segments: int
    lengths: str  # "equal" | "free"
    min_length: float
    directions: str  # "plane" | "3d"
    magnitude: str  # "fixed" | "free"
    remanence: float
    period_range: tuple[float, float]
    n_elements: int
    length: float
    #: Sizes the search may change: ``(key, low, high)`` of ``[robot]`` (m): ``length``,
    #: ``width``, ``thickness`` (a band) or ``radius`` (a round section).
    sizes: tuple[tuple[str, float, float], ...] = ()

    # -- the search vector ------------------------------------------------------------------------
    @property
    def dim(self) -> int:
        """Length of the search vector (the design's coordinates and the period)."""
        per_segment = 1 + (self.directions == "3d") + (self.magnitude == "free") + (
            self.lengths == "free")
        return self.segments * per_segment + len(self.sizes) + 1

    def _slices(self) -> dict[str, slice]:
        n, at, out = self.segments, 0, {}
        for name, present in (("azimuth", True), ("elevation", self.directions == "3d"),
                              ("magnitude", self.magnitude == "free"),
                              ("length", self.lengths == "free")):
            if present:
                out[name] = slice(at, at + n)
                at += n
        for key, _, _ in self.sizes:
            out[f"size:{key}"] = slice(at, at + 1)
            at += 1
        out["period"] = slice(at, at + 1)
        return out

    def bounds(self) -> tuple[list[float], list[float]]:
        """Lower and upper bound of each coordinate (``-inf``/``inf``: an angle, unbounded)."""
        low, high = [-math.inf] * self.dim, [math.inf] * self.dim
        for name, where in self._slices().items():
            if name in ("magnitude", "period", "length") or name.startswith("size:"):
                for k in range(where.start, where.stop):
                    low[k] = LENGTH_WEIGHT_LOW if name == "length" else 0.0
                    high[k] = 1.0
        return low, high

    def period(self, x: NDArray[np.float64]) -> float:
        """The rotating field's period a vector asks for, s."""
        low, high = self.period_range
        u = float(np.clip(x[self._slices()["period"]][0], 0.0, 1.0))
        return low * (high / low) ** u

    def period_coordinate(self, period: float) -> float:
        """The coordinate of a period (s), clipped to the range."""
        low, high = self.period_range
        return float(np.clip(math.log(period / low) / math.log(high / low), 0.0, 1.0))

    def size_values(self, x: NDArray[np.float64]) -> dict[str, float]:
        """The sizes (m) a vector asks for, by ``[robot]`` key (empty: the robot's own)."""
        s = self._slices()
        return {key: low + float(np.clip(x[s[f"size:{key}"]][0], 0.0, 1.0)) * (high - low)
                for key, low, high in self.sizes}

    # -- vector <-> magnetization -----------------------------------------------------------------
    def element_counts(self, x: NDArray[np.float64]) -> list[int]:
        """Elements of each segment, back to front (sum ``n_elements``)."""
        n = self.segments
        if self.lengths == "equal":
            return segment_element_counts(self.n_elements, [
                MagnetizationSegment((1.0, 0.0, 0.0), 0.0, fraction=1.0 / n) for _ in range(n)])
        weights = np.clip(np.asarray(x[self._slices()["length"]], dtype=float), LENGTH_WEIGHT_LOW, 1.0)
        floor = self.min_length / self.size_values(x).get("length", self.length)
        shares = floor + (1.0 - n * floor) * weights / weights.sum()
        least = max(1, math.ceil(floor * self.n_elements - 1e-9))
        edges = np.rint(np.cumsum(shares) * self.n_elements).astype(int)
        edges[-1] = self.n_elements
        counts = np.diff(np.concatenate([[0], edges]))
        return _at_least(counts, least)

    def segment_list(self, x: NDArray[np.float64]) -> list[dict[str, Any]]:
        """The ``[robot.magnetization] segments`` list of a vector (directions as unit vectors,
        magnitudes in A/m, sizes in elements)."""
        s = self._slices()
        azimuth = np.pi * np.asarray(x[s["azimuth"]], dtype=float)
        elevation = (np.pi * np.asarray(x[s["elevation"]], dtype=float) if "elevation" in s
                     else np.zeros(self.segments))
        fraction = (np.clip(x[s["magnitude"]], 0.0, 1.0) if "magnitude" in s
                    else np.ones(self.segments))
        out = []
        for k, count in enumerate(self.element_counts(x)):
            c = math.cos(elevation[k])
            direction = [_tidy(c * math.cos(azimuth[k])), _tidy(c * math.sin(azimuth[k])),
                         _tidy(math.sin(elevation[k]))]
            out.append({"elements": int(count), "direction": direction,
                        "magnitude": _made(float(self.remanence * fraction[k]))})
        return out

    def spec_of(self, base: Mapping[str, Any], x: NDArray[np.float64]) -> dict[str, Any]:
        """A copy of the spec ``base`` (without ``[design]``) with the magnetization of ``x``."""
        spec = copy.deepcopy(dict(base))
        spec["robot"] = dict(spec["robot"])
        spec["robot"]["magnetization"] = {"kind": "segments", "segments": self.segment_list(x)}
        spec["robot"].update(self.size_values(x))
        return spec

    def start_vector(self, magnetization: NDArray[np.float64], period: float,
                     sizes: Mapping[str, float] | None = None) -> NDArray[np.float64]:
        """The vector closest to a robot's own magnetization ``(3, n_elements)`` (A/m): each
        segment of equal length along the mean direction of its elements, at their mean magnitude
        (a fraction of the remanence, when magnitudes are free), its own ``sizes`` (m, by
        ``[robot]`` key; default the middle of each range) and the period (s)."""
        s = self._slices()
        x = np.zeros(self.dim)
        for key, low, high in self.sizes:
            own = (sizes or {}).get(key, 0.5 * (low + high))
            x[s[f"size:{key}"]] = (own - low) / (high - low)
        x[s["period"]] = self.period_coordinate(period)
        if "length" in s:
            x[s["length"]] = 1.0
        equal = self.element_counts(np.ones(self.dim)) if self.lengths == "free" else \
            self.element_counts(x)
        start = 0
        for k, count in enumerate(equal):
            m = magnetization[:, start:start + count]
            start += count
            mean = m.mean(axis=1)
            x[s["azimuth"].start + k] = math.atan2(mean[1], mean[0]) / math.pi
            if "elevation" in s:
                x[s["elevation"].start + k] = math.atan2(mean[2], math.hypot(mean[0], mean[1])) / math.pi
            if "magnitude" in s:
                x[s["magnitude"].start + k] = min(1.0, float(np.linalg.norm(m, axis=0).mean())
                                                  / self.remanence)
        return x

    def turning_vectors(self, x0: NDArray[np.float64]) -> list[NDArray[np.float64]]:
        """``x0`` with the direction turning once along the body, in each sense (in the bending
        plane, starting along +x): the family of the walking sheets of Hu et al. 2018, which the
        search's first generation tries beside its random draws."""
        azimuth = self._slices()["azimuth"]
        out = []
        for sense in (1.0, -1.0):
            x = np.array(x0, dtype=float)
            x[azimuth] = sense * 2.0 * np.arange(self.segments) / self.segments  # units of pi
            if "elevation" in self._slices():
                x[self._slices()["elevation"]] = 0.0
            out.append(x)
        return out

    def to_dict(self) -> dict[str, Any]:
        """The table as a spec writes it (every key that applies explicit)."""
        out = {"segments": self.segments, "lengths": self.lengths, "min_length": self.min_length,
               "directions": self.directions, "magnitude": self.magnitude,
               "remanence": self.remanence, "period_low": self.period_range[0],
               "period_high": self.period_range[1]}
        if self.lengths == "equal":
            del out["min_length"]  # equal segments have no minimum of their own
        out.update({key: [low, high] for key, low, high in self.sizes})
        return out


def _made(magnitude: float) -> float:
    """A free magnitude (A/m) as a lab makes it: one too weak for a magnetic soft robot (the
    plausibility table's "unusual": under about 1 kA/m, next to nothing against 60 kA/m) is an
    unmagnetized segment, 0 A/m; so the spec written is the design evaluated, without warnings."""
    weakest = QUANTITIES["magnetization"].warn[0]
    return 0.0 if weakest is not None and magnitude < weakest.value else magnitude


def _tidy(value: float) -> float:
    """A direction component with rounding noise (|v| < 1e-12) written as 0."""
    return 0.0 if abs(value) < 1e-12 else float(value)


def _at_least(counts: NDArray[np.int64], least: int) -> list[int]:
    """``counts`` (summing to n) with every entry raised to ``least``, the elements taken from
    the largest ones (rounding element edges may leave a segment one element short)."""
    counts = counts.astype(int).copy()
    for k in range(len(counts)):
        while counts[k] < least:
            donor = int(np.argmax(counts))
            counts[donor] -= 1
            counts[k] += 1
    return [int(c) for c in counts]


def design_space(table: Mapping[str, Any] | None, robot: Mapping[str, Any], axes: str,
                 source: str, magnetization: NDArray[np.float64],
                 accept: frozenset[str] = frozenset()) -> DesignSpace:
    """The checked :class:`DesignSpace` of a ``[design]`` table (``None``: the defaults) for a
    robot (its checked ``[robot]`` table: ``length`` m, ``n_elements``), the case's actuation
    ``axes`` and the robot's own magnetization ``(3, n_elements)`` (A/m; the default remanence is
    its largest magnitude, the default segment count its own segments' or
    :data:`DEFAULT_SEGMENTS`; ``accept``: the spec's ``[checks] accept`` keys). Raises
    :class:`SpecError` naming the file, the key and the problem."""
    t = SpecTable({} if table is None else table, source, DESIGN_TABLE, accept)
    length, n_elements = float(robot["length"]), int(robot["n_elements"])
    own = robot["magnetization"].get("segments")
    default_n = len(own) if isinstance(own, list) and MIN_SEGMENTS <= len(own) <= MAX_SEGMENTS \
        else DEFAULT_SEGMENTS
    segments = t.number("segments", "segments", default_n, low=MIN_SEGMENTS, high=MAX_SEGMENTS,
                        integer=True)
    if segments > n_elements:
        raise t.error("segments", f"{segments} segments need at least as many elements; the robot "
                      f"has n_elements = {n_elements}")
    lengths = t.string("lengths", "equal", choices=("equal", "free"))
    min_length = t.number("min_length", "m", length / n_elements if lengths == "free" else 0.0,
                          low=0.0)
    if lengths == "free":
        _check_min_length(t, min_length, segments, length, n_elements)
    elif t.has("min_length"):
        raise t.error("min_length", "applies to free lengths only (lengths = \"free\"); equal "
                      f"segments are {length / segments:g} m each")
    directions = t.string("directions", "3d" if axes == "xyz" else "plane", choices=("plane", "3d"))
    if directions == "3d" and axes != "xyz":
        raise t.error("directions", "\"3d\" needs the third coil pair ([actuation] axes = \"xyz\"): "
                      f"the field of axes = {axes!r} stays in the x-y plane and an out-of-plane "
                      "magnetization only twists the robot; use \"plane\"")
    magnitude = t.string("magnitude", "fixed", choices=("fixed", "free"))
    own_largest = float(np.linalg.norm(magnetization, axis=0).max())
    remanence = t.number("remanence", "A/m", own_largest, low=0.0, low_open=True,
                         plausible="magnetization")
    if remanence < own_largest * (1.0 - 1e-9):  # the search starts from the robot as written
        raise t.error("remanence", f"{remanence:g} A/m is below the robot's own largest "
                      f"magnetization, {own_largest:g} A/m: the search starts from the robot as "
                      "written, which that material could not make; raise remanence to at least "
                      f"{own_largest:g} A/m, or lower the robot's magnetization (kA/m for A/m?)")
    sizes = _sizes(t, robot, segments, min_length if lengths == "free" else 0.0)
    period_low, period_high = _period_range(t)
    t.finish()
    return DesignSpace(segments, lengths, min_length, directions, magnitude, remanence,
                       (period_low, period_high), n_elements, length, sizes)


def _period_range(t: SpecTable) -> tuple[float, float]:
    """``period_low`` and ``period_high`` (s): above the Nyquist limit of the 0.01 s control (a
    field turning in two control steps or less does not turn), judged as rotation periods (a
    value in ms is warned)."""
    out = []
    for key, default in (("period_low", DEFAULT_PERIOD_RANGE[0]), ("period_high", DEFAULT_PERIOD_RANGE[1])):
        value = t.number(key, "s", default, low=0.0, low_open=True, plausible="rotation period")
        if value <= 2.0 * ACTION_PERIOD:
            raise t.error(key, f"{value:g} s is at or under 2 x the {ACTION_PERIOD:g} s control "
                          f"period (the Nyquist limit of the {1 / ACTION_PERIOD:g} Hz control: the "
                          f"field cannot turn); give more than {2 * ACTION_PERIOD:g} s")
        out.append(value)
    if not out[0] < out[1]:
        raise t.error("period_high", f"must be larger than period_low ({out[0]:g} s), got {out[1]:g} s")
    return out[0], out[1]


#: The sizes a ``[design]`` table may vary, by the robot's section.
SIZE_KEYS = {"band": ("length", "width", "thickness"), "round": ("length", "radius")}


def _sizes(t: SpecTable, robot: Mapping[str, Any], segments: int, min_length: float
           ) -> tuple[tuple[str, float, float], ...]:
    """The ``[design]`` size ranges ``KEY = [low, high]`` (m), each holding the robot's own value
    (the search starts from the robot as written)."""
    section = "round" if "radius" in robot else "band"
    out = []
    for key in SIZE_KEYS["band"] + ("radius",):
        t.raw(key, None)  # a key this table takes (named when another one is misspelt)
        if not t.has(key):
            continue
        if key not in SIZE_KEYS[section]:
            raise t.error(key, f"the robot has a {section} section ({', '.join(SIZE_KEYS[section])} "
                          "may vary)")
        low, high = t.vector(key, "m, [low, high]", 2)
        own = float(robot[key])
        if not 0.0 < low < high:
            raise t.error(key, f"expected [low, high] with 0 < low < high (m), got [{low:g}, {high:g}]")
        t.check_plausible(key, high, "rod length" if key == "length" else "section", f"{key} high")
        if not low <= own <= high:
            raise t.error(key, f"[{low:g}, {high:g}] m does not hold the robot's own {key} = {own:g} m "
                          "(the search starts from the robot as written; mm for m?)")
        if key == "length" and min_length * segments > low * (1.0 + 1e-9):
            raise t.error(key, f"{segments} segments of at least min_length = {min_length:g} m do not "
                          f"fit in the shortest length, {low:g} m")
        out.append((key, float(low), float(high)))
    _check_band_sizes(t, robot, dict((key, (low, high)) for key, low, high in out))
    return tuple(out)


def _check_band_sizes(t: SpecTable, robot: Mapping[str, Any], ranges: dict[str, tuple[float, float]]
                      ) -> None:
    """A band is at least as wide as it is thick (the spec's own rule): every thickness the search
    may choose must fit under every width it may choose."""
    if "thickness" not in ranges and "width" not in ranges:
        return
    thickest = ranges.get("thickness", (0.0, float(robot["thickness"])))[1]
    narrowest = ranges.get("width", (float(robot["width"]), 0.0))[0]
    if thickest > narrowest:
        key = "thickness" if "thickness" in ranges else "width"
        raise t.error(key, f"the thickest band searched ({thickest:g} m) is thicker than the narrowest "
                      f"({narrowest:g} m wide); a band is at least as wide as it is thick: give a "
                      "thickness range under the width (mm for m?)")


def _check_min_length(t: SpecTable, min_length: float, segments: int, length: float,
                      n_elements: int) -> None:
    element = length / n_elements
    if min_length * segments > length * (1.0 + 1e-9):
        raise t.error("min_length", f"{segments} segments of at least {min_length:g} m need "
                      f"{segments * min_length:g} m, the robot is {length:g} m long (mm for m?)")
    if min_length < element * (1.0 - 1e-9):
        raise t.error("min_length", f"{min_length:g} m is shorter than one element "
                      f"({element:g} m = length / n_elements): a segment holds whole elements")
