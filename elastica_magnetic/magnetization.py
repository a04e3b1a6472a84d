"""Magnetization patterns: ``(3, n_elements)`` arrays in A/m.

Patterns are given in the lab frame of the reference configuration, a straight rod along +x with
the bending plane x-y, which is how :class:`~elastica_magnetic.MagneticTorques` takes them by default
(``frame="lab"``). Element ``i`` has its centre at arc length ``s_i = (i + 1/2) L / n``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "YAO2023_MAGNETIZATION",
    "uniform_magnetization",
    "two_segment_magnetization",
    "MagnetizationSegment",
    "segment_element_counts",
    "segments_magnetization",
    "yao2023_magnetization",
    "sinusoidal_magnetization",
    "magnetization_from_function",
    "element_centres",
]

#: Magnetization magnitude of the paper's robots (and of Hu et al. 2018), A/m.
YAO2023_MAGNETIZATION = 61.3e3


def _check_count(n_elements: int) -> int:
    if int(n_elements) != n_elements or n_elements < 1:
        raise ValueError(f"n_elements must be a positive integer, got {n_elements!r}")
    return int(n_elements)


def _check_magnitude(magnitude: float) -> float:
    if not math.isfinite(magnitude) or magnitude < 0.0:
        raise ValueError(f"magnitude must be finite and >= 0 in A/m, got {magnitude}")
    return float(magnitude)


def _unit(direction: ArrayLike, name: str) -> NDArray[np.float64]:
    direction = np.asarray(direction, dtype=np.float64)
    if direction.shape != (3,):
        raise ValueError(f"{name} must be a 3-vector, got shape {direction.shape}")
    norm = float(np.linalg.norm(direction))
    if not math.isfinite(norm) or norm == 0.0:
        raise ValueError(f"{name} must be a finite non-zero vector, got {direction}")
    return direction / norm


def element_centres(n_elements: int, length: float) -> NDArray[np.float64]:
    """Arc length of the element centres, ``(n_elements,)`` in m."""
    n_elements = _check_count(n_elements)
    return (np.arange(n_elements) + 0.5) * (length / n_elements)


def uniform_magnetization(
    n_elements: int, magnitude: float, direction: ArrayLike = (1.0, 0.0, 0.0)
) -> NDArray[np.float64]:
    """The same magnetization ``magnitude`` (A/m) along ``direction`` in every element."""
    n_elements = _check_count(n_elements)
    m = _check_magnitude(magnitude) * _unit(direction, "direction")
    return np.repeat(m[:, None], n_elements, axis=1)


def two_segment_magnetization(
    n_elements: int,
    magnitude: float,
    first: ArrayLike,
    second: ArrayLike,
    split: int | None = None,
) -> NDArray[np.float64]:
    """Elements ``0 .. split-1`` along ``first``, the rest along ``second`` (A/m).

    ``split`` defaults to half the elements (the paper's folded-and-magnetized robots).
    """
    n_elements = _check_count(n_elements)
    split = n_elements // 2 if split is None else int(split)
    if not 0 <= split <= n_elements:
        raise ValueError(f"split must be in [0, {n_elements}], got {split}")
    magnitude = _check_magnitude(magnitude)
    result = np.empty((3, n_elements))
    result[:, :split] = magnitude * _unit(first, "first")[:, None]
    result[:, split:] = magnitude * _unit(second, "second")[:, None]
    return result


@dataclass(frozen=True)
class MagnetizationSegment:
    """One stretch of a piecewise-uniform magnetization, from the back (``s = 0``) forward.

    Give its size as either ``elements`` (a number of elements) or ``fraction`` (a fraction of the
    rod's length, in ``(0, 1]``): every segment of one list uses the same kind. ``direction`` is any
    non-zero 3-vector (normalised), ``magnitude`` in A/m.
    """

    direction: tuple[float, float, float]
    magnitude: float
    elements: int | None = None
    fraction: float | None = None


#: Largest tolerated ``|sum(fractions) - 1|`` of a segment list.
FRACTION_TOLERANCE = 1e-9


def segment_element_counts(n_elements: int, segments: Sequence[MagnetizationSegment]) -> list[int]:
    """Elements in each segment (one list, back to front), ``len(segments)`` integers summing to
    ``n_elements``.

    With ``elements`` the counts are given and must sum to ``n_elements``. With ``fraction`` they
    must sum to 1 (within :data:`FRACTION_TOLERANCE`), and element ``i`` belongs to the segment
    whose stretch ``[c_k, c_k+1)`` of the length holds its centre ``(i + 1/2) / n_elements``
    (``c_k``: the sum of the fractions before segment ``k``); so ``[0.5, 0.5]`` splits like the
    paper's halves, ``n_elements // 2`` elements first. A segment that holds no element centre is
    an error. Errors are :class:`ValueError` naming the segment (counted from 0).
    """
    n_elements = _check_count(n_elements)
    if len(segments) == 0:
        raise ValueError("segments: need at least one segment")
    by_count = [seg.elements is not None for seg in segments]
    by_fraction = [seg.fraction is not None for seg in segments]
    for k in range(len(segments)):
        if by_count[k] == by_fraction[k]:
            raise ValueError(f"segment {k}: give either elements (a number of elements) or "
                             "fraction (of the length), not both or neither")
    if any(by_count) and any(by_fraction):
        raise ValueError("segments: give every segment's size the same way, all as elements or all "
                         "as fraction")
    if all(by_count):
        counts = []
        for k, seg in enumerate(segments):
            count = seg.elements
            if isinstance(count, bool) or int(count) != count or count < 1:
                raise ValueError(f"segment {k}: elements must be a positive integer, got {count!r}")
            counts.append(int(count))
        if sum(counts) != n_elements:
            raise ValueError(f"segments: elements sum to {sum(counts)} ({' + '.join(map(str, counts))})"
                             f", the rod has n_elements = {n_elements}")
        return counts
    fractions = [float(seg.fraction) for seg in segments]
    for k, fraction in enumerate(fractions):
        if not (math.isfinite(fraction) and 0.0 < fraction <= 1.0):
            raise ValueError(f"segment {k}: fraction must be in (0, 1] (of the length), got {fraction!r}")
    total = math.fsum(fractions)
    if abs(total - 1.0) > FRACTION_TOLERANCE:
        raise ValueError(f"segments: fractions sum to {total:.12g}, must sum to 1 (the whole length)")
    centres = (np.arange(n_elements) + 0.5) / n_elements
    starts = np.concatenate([[0.0], np.cumsum(fractions)[:-1]])
    owner = np.searchsorted(starts, centres, side="right") - 1
    counts = np.bincount(owner, minlength=len(segments)).tolist()
    for k, count in enumerate(counts):
        if count == 0:
            raise ValueError(f"segment {k}: fraction {fractions[k]:g} holds no element centre (an "
                             f"element is 1/{n_elements} = {1.0 / n_elements:.4g} of the length)")
    return [int(c) for c in counts]


def segments_magnetization(
    n_elements: int, segments: Sequence[MagnetizationSegment]
) -> NDArray[np.float64]:
    """Piecewise-uniform magnetization, ``(3, n_elements)`` in A/m: segment ``k`` along its unit
    ``direction`` with its ``magnitude``, over the elements :func:`segment_element_counts` gives it
    (back to front). The paper's patterns are two segments of ``fraction`` 0.5 (or ``elements``
    ``n // 2`` and the rest) and give exactly the arrays of :func:`yao2023_magnetization`."""
    counts = segment_element_counts(n_elements, segments)
    result = np.empty((3, sum(counts)))
    start = 0
    for k, (seg, count) in enumerate(zip(segments, counts, strict=True)):
        try:
            m = _check_magnitude(seg.magnitude) * _unit(seg.direction, "direction")
        except ValueError as exc:
            raise ValueError(f"segment {k}: {exc}") from None
        result[:, start:start + count] = m[:, None]
        start += count
    return result


def yao2023_magnetization(
    pattern: int, n_elements: int = 64, magnitude: float = YAO2023_MAGNETIZATION
) -> NDArray[np.float64]:
    """The paper's two patterns (Fig. 2I; authors' code), lab frame of the straight robot along +x.

    - pattern 1: first half along -x, second half along +x;
    - pattern 2: first half along -y, second half along +y.
    """
    if pattern == 1:
        return two_segment_magnetization(n_elements, magnitude, (-1, 0, 0), (1, 0, 0))
    if pattern == 2:
        return two_segment_magnetization(n_elements, magnitude, (0, -1, 0), (0, 1, 0))
    raise ValueError(f"pattern must be 1 or 2, got {pattern!r}")


def sinusoidal_magnetization(
    n_elements: int, magnitude: float = YAO2023_MAGNETIZATION, phase: float = 0.0
) -> NDArray[np.float64]:
    """Single-wavelength harmonic magnetization of Hu et al. 2018 (A/m).

    The direction angle turns one full turn along the rod, ``alpha_m(s) = 2 pi s / L + phase``
    (rad, counter-clockwise from the +x tangent, in the x-y bending plane), sampled at the element
    centres.
    """
    n_elements = _check_count(n_elements)
    magnitude = _check_magnitude(magnitude)
    alpha = 2.0 * np.pi * (np.arange(n_elements) + 0.5) / n_elements + phase
    return magnitude * np.stack([np.cos(alpha), np.sin(alpha), np.zeros(n_elements)])


def magnetization_from_function(
    function: Callable[[NDArray[np.float64]], ArrayLike], n_elements: int, length: float
) -> NDArray[np.float64]:
    """Magnetization from any function of arc length.

    Parameters
    ----------
    function : callable
        ``function(s) -> (3, n)`` magnetization in A/m for the ``(n,)`` arc lengths ``s`` in m.
    n_elements : int
        Number of elements; the function is sampled at the element centres.
    length : float
        Rod length, m.
    """
    s = element_centres(n_elements, length)
    result = np.asarray(function(s), dtype=np.float64)
    if result.shape != (3, s.shape[0]):
        raise ValueError(
            f"magnetization function must return shape (3, {s.shape[0]}) in A/m for "
            f"{s.shape[0]} arc lengths, got {result.shape}"
        )
    if not np.all(np.isfinite(result)):
        raise ValueError("magnetization function returned NaN or infinite values")
    return result
