"""Case ``replay-yao2023``: the authors' published field, replayed open loop, against their trajectory.

The model is the authors' model, so the replay must reproduce their run: the middle's final
displacement within 1% of the published value and the middle's x within 0.5 mm at every published
frame (60 per second). ``--quick`` replays the first second with the same per-frame tolerance.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from elastica_magnetic import TabulatedField, run_open_loop, write_trajectory_csv, yao2023_robot
from elastica_magnetic.plotting import plot_open_loop
from elastica_magnetic.reference import reference_field_csv, reference_trajectory_csv

from .report import CaseResult, Comparison

FINAL_DISPLACEMENT_TOLERANCE = 0.01  # relative
MID_X_TOLERANCE = 0.5e-3  # m, at every frame


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
    interp = {c: np.interp(ref.t_s, sim.t_s, sim[c]) for c in sim.columns if c != "t_s"}
    ref_dx = float(ref.mid_x_m.iloc[-1] - ref.mid_x_m.iloc[0])
    sim_dx = float(interp["mid_x_m"][-1] - sim.mid_x_m.iloc[0])
    case.comparisons.append(Comparison(
        f"middle's displacement after {duration:g} s", sim_dx, ref_dx, (sim_dx - ref_dx) / ref_dx,
        FINAL_DISPLACEMENT_TOLERANCE, "m", relative=True,
    ))
    worst = int(np.argmax(np.abs(interp["mid_x_m"] - ref.mid_x_m.to_numpy())))
    case.comparisons.append(Comparison(
        f"middle's x, largest difference over all frames (t = {ref.t_s.iloc[worst]:.3f} s)",
        float(interp["mid_x_m"][worst]), float(ref.mid_x_m.iloc[worst]),
        float(interp["mid_x_m"][worst] - ref.mid_x_m.iloc[worst]), MID_X_TOLERANCE, "m",
    ))
    for column, label in (
        ("mid_y_m", "middle's y"), ("back_x_m", "back x"), ("front_x_m", "front x"),
        ("height_max_m", "height"), ("span_m", "span"),
    ):
        diff = interp[column] - ref[column].to_numpy()
        k = int(np.argmax(np.abs(diff)))
        case.comparisons.append(Comparison(
            f"{label}, largest difference (t = {ref.t_s.iloc[k]:.3f} s)",
            float(interp[column][k]), float(ref[column].iloc[k]), float(diff[k]), 0.0, "m",
            checked=False,
        ))
    case.comparisons.append(Comparison(
        "peak height", result.max_height, float(ref.height_max_m.max()),
        result.max_height - float(ref.height_max_m.max()), 0.0, "m", checked=False,
    ))
    out.mkdir(parents=True, exist_ok=True)
    write_trajectory_csv(sim, out / "replay-yao2023_trajectory.csv")
    case.figures.append(plot_open_loop(
        result, out / "replay-yao2023.png",
        title="replay of the published field (solid) vs published trajectory (dashed)",
        reference=ref,
    ))
    case.notes.append(
        f"simulation: {result.steps} steps in {result.wall_s:.1f} s ({result.step_us:.1f} us/step)"
    )
    case.wall_s = time.perf_counter() - start
    return case
