"""The published field waveform and trajectory of Yao et al. 2023, shipped with the package.

Copied from the paper's supplementary code (MIT licence, copyright 2023 Jianpeng Yao); see
``data/yao2023/README.md`` for provenance and the meaning of each column.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["REFERENCE_CASES", "reference_field_csv", "reference_trajectory_csv"]

_DATA = Path(__file__).resolve().parent / "data" / "yao2023"

#: Published cases shipped here, by folder name.
REFERENCE_CASES = ("magnetization1_4mT",)


def _case_dir(case: str) -> Path:
    if case not in REFERENCE_CASES:
        raise ValueError(f"unknown reference case {case!r}; shipped: {', '.join(REFERENCE_CASES)}")
    return _DATA / case


def reference_field_csv(case: str = "magnetization1_4mT") -> Path:
    """Path of the published field CSV (mT, 100 rows per second) of ``case``."""
    return _case_dir(case) / "magnetic_field.csv"


def reference_trajectory_csv(case: str = "magnetization1_4mT") -> Path:
    """Path of the published trajectory (SI, 60 frames per second) of ``case``."""
    return _case_dir(case) / "trajectory.csv"
