"""Checks of the shipped policies against what their files claim (``rl/policies/<name>/``).

Each shipped policy records, in ``policy.json``, the distance its actor makes the robot's middle
move in 10 s in the accurate physics from a zero field, and ships that run's waveform as
``fields.csv``. :func:`verify_shipped` runs the actor again and compares: the waveform row by row,
the distance to a relative tolerance, and the distance against the authors'.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from .pipeline import AUTHORS_DISTANCE_10S, POLICIES_DIR, POLICY_JSON, resolve_policy, run_policy

#: A re-run must reproduce the recorded distance to this relative difference (the accurate
#: physics is deterministic on one machine; this leaves room for other CPUs' round-off).
DISTANCE_RTOL = 1e-3
#: ... and the shipped waveform to this, mT (the CSV holds full double precision).
FIELD_ATOL_MT = 1e-6


def shipped_names(policies_dir: Path = POLICIES_DIR) -> list[str]:
    """Names of the shipped policies (folders with a ``policy.json``), sorted."""
    return sorted(p.name for p in Path(policies_dir).iterdir() if (p / POLICY_JSON).is_file())


def verify_shipped(name: str, duration: float = 10.0, progress: bool = False,
                   policies_dir: Path = POLICIES_DIR) -> dict[str, Any]:
    """Roll the shipped policy ``name`` out for ``duration`` s (accurate physics, zero field) and
    compare with its files. Returns the measured and recorded distances (m), their relative
    difference, the largest field difference from ``fields.csv`` over the rows run (mT), whether
    the authors' 10 s distance is reached (``None`` for a shorter run) and ``passed``."""
    from elastica_magnetic import read_field_csv

    folder = Path(policies_dir) / name
    info = json.loads((folder / POLICY_JSON).read_text())
    policy = resolve_policy(folder)
    rollout = run_policy(policy, duration, "accurate", "zero", progress)
    shipped = read_field_csv(folder / "fields.csv")
    rows = min(len(rollout.fields), len(shipped))
    field_diff_mt = float(np.max(np.abs(rollout.fields[:rows] - shipped[:rows])) * 1e3) if rows else 0.0
    result: dict[str, Any] = {
        "name": name, "case": info["case"], "duration_s": float(duration), "rows_compared": rows,
        "max_field_diff_mT": field_diff_mt, "field_atol_mT": FIELD_ATOL_MT,
        "mid_dx_m": rollout.mid_dx, "diverged": bool(rollout.meta["diverged"]),
    }
    passed = field_diff_mt <= FIELD_ATOL_MT and not result["diverged"]
    if abs(duration - float(info["evaluation"]["duration_s"])) < 1e-9:
        recorded = float(info["evaluation"]["mid_dx_m"])
        authors = AUTHORS_DISTANCE_10S[info["case"]]
        relative = abs(rollout.mid_dx - recorded) / abs(recorded)
        result.update(recorded_mid_dx_m=recorded, relative_diff=relative,
                      distance_rtol=DISTANCE_RTOL, authors_mid_dx_m=authors,
                      meets_authors=rollout.mid_dx >= authors)
        passed = passed and relative <= DISTANCE_RTOL and result["meets_authors"]
    result["passed"] = bool(passed)
    return result
