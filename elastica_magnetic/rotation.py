"""Rotating fields under a rate limit: the shortest period a rate limit allows at a given amplitude,
and the period a recorded waveform actually turns at.

The coil driver changes each field component by at most ``max_increment`` per 0.01 s step. A field
of amplitude ``B`` turning by ``delta`` per step changes a component by up to ``2 B sin(delta / 2)``,
so a uniform rotation at full amplitude takes at least
``T_min = 2 pi dt / (2 asin(max_increment / (2 B)))``: 1.257 s at 6 mT and 0.3 mT per 0.01 s.
Asked to turn faster, a rate-limited field lags, turns unevenly (faster near the diagonals, where
both components share the change) and shrinks a little; its real period is what
:func:`measure_rotation` reads from the waveform (e.g. ``fields.csv``): the baseline's rule asked
for 1 s at 6 mT turns once per 1.141 s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from .robot_spec import ACTION_PERIOD

__all__ = ["RotationMeasurement", "min_rotation_period", "measure_rotation"]


def min_rotation_period(amplitude: float, max_increment: float, step: float = ACTION_PERIOD) -> float:
    """Shortest period (s) of a field of ``amplitude`` (T) turning uniformly in a plane when each
    component changes by at most ``max_increment`` (T) per ``step`` (s); 0 when the limit allows
    any turn. An uneven turn can average slightly less (see the module docstring)."""
    for name, value in (("amplitude", amplitude), ("max_increment", max_increment), ("step", step)):
        if not (math.isfinite(value) and value > 0.0):
            raise ValueError(f"{name} must be a positive finite number, got {value}")
    ratio = max_increment / (2.0 * amplitude)
    if ratio >= 1.0:
        return 0.0
    return 2.0 * math.pi * step / (2.0 * math.asin(ratio))


@dataclass(frozen=True)
class RotationMeasurement:
    """How a recorded field turns in the x-y plane, measured from ``start_s`` (the first sample at
    ``settled`` x its largest amplitude) to the end.

    ``period_s``: time per turn, s (``inf`` when it does not turn); ``turns``: turns made (signed:
    positive counter-clockwise seen from +z); ``clockwise``; ``amplitude_T``: mean in-plane
    amplitude over the window, T."""

    period_s: float
    turns: float
    clockwise: bool
    amplitude_T: float
    start_s: float
    duration_s: float


def measure_rotation(field: ArrayLike, rate: float = 1.0 / ACTION_PERIOD,
                     settled: float = 0.9) -> RotationMeasurement:
    """The rotation of a sampled field ``(N, 3)`` in T (x, y, z; one row per ``1 / rate`` s, as
    in ``fields.csv`` read in T), in the x-y plane. The window starts once the in-plane amplitude
    first reaches ``settled`` x its largest value (after the ramp from zero)."""
    samples = np.asarray(field, dtype=np.float64)
    if samples.ndim != 2 or samples.shape[1] != 3 or samples.shape[0] < 2:
        raise ValueError(f"field must have shape (N >= 2, 3) in T, got {samples.shape}")
    if not np.all(np.isfinite(samples)):
        raise ValueError("field has NaN or infinite values")
    if not (math.isfinite(rate) and rate > 0.0):
        raise ValueError(f"rate must be a positive number of samples per s, got {rate}")
    if not 0.0 < settled <= 1.0:
        raise ValueError(f"settled must be in (0, 1], got {settled}")
    amplitude = np.hypot(samples[:, 0], samples[:, 1])
    peak = float(amplitude.max())
    if peak == 0.0:
        return RotationMeasurement(math.inf, 0.0, False, 0.0, 0.0, 0.0)
    start = int(np.argmax(amplitude >= settled * peak))
    window = samples[start:]
    angle = np.unwrap(np.arctan2(window[:, 1], window[:, 0]))
    duration = (window.shape[0] - 1) / rate
    turns = float(angle[-1] - angle[0]) / (2.0 * math.pi)
    period = duration / abs(turns) if turns != 0.0 and duration > 0.0 else math.inf
    return RotationMeasurement(period, turns, turns < 0.0, float(amplitude[start:].mean()),
                               start / rate, duration)
