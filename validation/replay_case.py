"""Case ``replay-yao2023``: the authors' published field, replayed open loop, against their trajectory.

The model is the authors' model, so the replay must reproduce their run: the middle's final
displacement, and the middle, back, front, height and span at every published frame (60 per
second), each within MARGIN x the worst difference achieved. ``--quick`` replays the first second,
with tolerances set from that second's own differences (they are ten times smaller than after
10 s, so the full run's tolerances would hide a regression there).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from elastica_magnetic import TabulatedField, run_open_loop, write_trajectory_csv, yao2023_robot
from elastica_magnetic.plotting import plot_open_loop
from elastica_magnetic.reference import reference_field_csv, reference_trajectory_csv

from .report import CaseResult, Comparison, Gate

# Worst differences achieved, rounded up to two digits (m; the displacement relative): full run
# from docs/validation (10 s), quick run from the first second. Tolerances are MARGIN x these.
ACHIEVED = {
    "full": {"displacement": 1.5e-3, "mid_x_m": 4.1e-5, "mid_y_m": 4.2e-5, "back_x_m": 4.6e-5,
             "front_x_m": 4.1e-5, "height_max_m": 4.2e-5, "span_m": 3.1e-5, "peak_height": 2.9e-6},
    "quick": {"displacement": 3.3e-4, "mid_x_m": 3.2e-6, "mid_y_m": 7.9e-6, "back_x_m": 3.3e-6,
              "front_x_m": 6.7e-6, "height_max_m": 8.1e-6, "span_m": 9.0e-6, "peak_height": 3.1e-6},
}
LABELS = {"mid_x_m": "middle's x", "mid_y_m": "middle's y", "back_x_m": "back x",
          "front_x_m": "front x", "height_max_m": "height", "span_m": "span"}


def gates(quick: bool) -> dict[str, Gate]:
    a = ACHIEVED["quick" if quick else "full"]
    out = {"displacement": Gate.from_achieved("middle's displacement", a["displacement"],
                                              relative=True, unit="m")}
    for column, label in LABELS.items():
        out[column] = Gate.from_achieved(f"{label}, every frame", a[column], unit="m")
    out["peak_height"] = Gate.from_achieved("peak height", a["peak_height"], unit="m")
    return out


def run(out: Path, quick: bool = False) -> CaseResult:
    start = time.perf_counter()
    field = TabulatedField.from_csv(reference_field_csv())
    reference = pd.read_csv(reference_trajectory_csv())
    duration = 1.0 if quick else field.duration
    result = run_open_loop(yao2023_robot(1, "accurate"), field, duration)
    ref = reference[reference.t_s <= duration + 1e-9]
    sim = result.trajectory
    case = CaseResult(
        name="replay-yao2023",
        title="Replay of the published field (Yao et al. 2023, pattern 1, 4 mT)",
        description=(
            "The authors' final pattern-1 policy at 4 mT generated `magnetic_field.csv` in their "
            "accurate physics; `trajectory.csv` is the robot's motion they published with it. We "
            f"replay the field open loop on `yao2023_robot(1, 'accurate')` for {duration:g} s "
            "(dt = 8e-6 s, PositionVerlet) and compare the trajectories at the published frames."
        ),
        quick=quick,
    )
    gate = gates(quick)
    case.gates = list(gate.values())
    interp = {c: np.interp(ref.t_s, sim.t_s, sim[c]) for c in sim.columns if c != "t_s"}
    ref_dx = float(ref.mid_x_m.iloc[-1] - ref.mid_x_m.iloc[0])
    sim_dx = float(interp["mid_x_m"][-1] - sim.mid_x_m.iloc[0])
    case.comparisons.append(Comparison.gated(
        f"middle's displacement after {duration:g} s", sim_dx, ref_dx, (sim_dx - ref_dx) / ref_dx,
        gate["displacement"],
    ))
    for column, label in LABELS.items():
        diff = interp[column] - ref[column].to_numpy()
        k = int(np.argmax(np.abs(diff)))
        case.comparisons.append(Comparison.gated(
            f"{label}, largest difference over all frames (t = {ref.t_s.iloc[k]:.3f} s)",
            float(interp[column][k]), float(ref[column].iloc[k]), float(diff[k]), gate[column],
        ))
    case.comparisons.append(Comparison.gated(
        "peak height", result.max_height, float(ref.height_max_m.max()),
        result.max_height - float(ref.height_max_m.max()), gate["peak_height"],
    ))
    out.mkdir(parents=True, exist_ok=True)
    write_trajectory_csv(sim, out / "replay-yao2023_trajectory.csv")
    case.figures.append(plot_open_loop(
        result, out / "replay-yao2023.png",
        title="replay of the published field (solid) vs published trajectory (dashed)",
        reference=ref,
    ))
    case.notes.append(
        f"simulation: {result.steps} steps in {result.wall_s:.1f} s ({result.step_us:.1f} us/step; "
        "informational: machine-dependent)"
    )
    case.wall_s = time.perf_counter() - start
    return case
