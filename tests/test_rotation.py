"""Rotating fields under a rate limit: the shortest period, and the period a waveform really has."""

from __future__ import annotations

import math

import numpy as np
import pytest

from elastica_magnetic.fields import RotatingField
from elastica_magnetic.rotation import measure_rotation, min_rotation_period


def _rate_limited(limit: float, increment: float, period: float, seconds: float) -> np.ndarray:
    """The baseline's rule (rl's RotatingFieldPolicy): each 0.01 s, aim at the limit rotated
    clockwise by 2 pi 0.01 / period from the present angle, each component moving at most
    ``increment``; the field starts at zero. Returns (N, 3) in T."""
    field, rows = np.zeros(2), []
    step = 2 * math.pi * 0.01 / period
    for _ in range(int(round(seconds / 0.01))):
        angle = math.atan2(field[1], field[0])
        target = limit * np.array([math.cos(angle - step), math.sin(angle - step)])
        field = field + np.clip(target - field, -increment, increment)
        rows.append([field[0], field[1], 0.0])
    return np.array(rows)


def test_the_shortest_period_under_the_rate_limit():
    assert min_rotation_period(6e-3, 3e-4) == pytest.approx(2 * math.pi * 0.01 / (2 * math.asin(0.025)))
    assert min_rotation_period(6e-3, 3e-4) == pytest.approx(1.2565, abs=1e-4)
    assert min_rotation_period(4e-3, 3e-4) == pytest.approx(0.8376, abs=1e-4)
    assert min_rotation_period(1e-4, 3e-4) == 0.0  # the limit allows any turn
    with pytest.raises(ValueError, match="amplitude must be a positive"):
        min_rotation_period(0.0, 3e-4)


def test_a_free_rotating_field_measures_its_period():
    field = RotatingField(6e-3, -0.5, phase=0.5 * math.pi, ramp_time=0.2)
    samples = np.array([field(k * 0.01).copy() for k in range(1001)])  # the source reuses its array
    m = measure_rotation(samples)
    assert m.period_s == pytest.approx(2.0, rel=1e-9) and m.clockwise and m.turns < -4.5
    assert m.amplitude_T == pytest.approx(6e-3, rel=0.01) and 0.17 <= m.start_s <= 0.2


def test_the_rate_limit_stretches_a_short_period():
    """At 6 mT and 0.3 mT per step a 1 s turn is not possible (T_min = 1.257 s): the field lags
    and shrinks and turns slower than asked; a 3 s turn is played as asked."""
    fast = measure_rotation(_rate_limited(6e-3, 3e-4, 1.0, 10.0))
    assert fast.clockwise and fast.period_s == pytest.approx(1.141, abs=0.002)
    assert fast.amplitude_T < 6e-3
    slow = measure_rotation(_rate_limited(6e-3, 3e-4, 3.0, 10.0))
    assert slow.period_s == pytest.approx(3.0, rel=0.01)
    print(f"asked 1 s: {fast.period_s:.3f} s at {1e3 * fast.amplitude_T:.2f} mT; "
          f"asked 3 s: {slow.period_s:.3f} s")


def test_no_rotation_and_bad_input():
    still = measure_rotation(np.tile([1e-3, 0.0, 0.0], (50, 1)))
    assert still.period_s == math.inf and still.turns == 0.0
    assert measure_rotation(np.zeros((5, 3))).period_s == math.inf
    with pytest.raises(ValueError, match=r"shape \(N >= 2, 3\)"):
        measure_rotation(np.zeros((5, 2)))
    with pytest.raises(ValueError, match="NaN"):
        measure_rotation(np.full((5, 3), np.nan))
