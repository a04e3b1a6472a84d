"""Shared fixtures of the hardware (host side + firmware) tests."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
# The published waveform ships with the package (elastica_magnetic/data/yao2023).
PUBLISHED_CSV = REPO / "elastica_magnetic" / "data" / "yao2023" / "magnetization1_4mT" / "magnetic_field.csv"
DEFAULT_CALIBRATION = REPO / "stm32" / "calibration" / "default.json"


@pytest.fixture
def default_calibration_path() -> Path:
    return DEFAULT_CALIBRATION
