"""``msr replay`` and ``msr simulate``: thin wrappers over the library."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

from .cli import CommandError, print_result
from .fields import RotatingField, TabulatedField
from .openloop import run_open_loop, write_trajectory_csv
from .presets import ROBOTS, robot_by_name

YAO_ROBOTS = tuple(r for r in ROBOTS if r.startswith("yao2023"))


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "replay",
        help="play a field CSV (mT, 100 Hz) open loop on the paper's robot",
        description="Play a field CSV open loop on the paper's robot and write trajectory.csv "
        "(100 Hz, first row t = 0) and a figure.",
    )
    p.add_argument("field_csv", type=Path, help="field CSV: mag_x, mag_y, mag_z in mT, 100 rows/s")
    p.add_argument("--robot", choices=YAO_ROBOTS, default="yao2023-m1")
    p.add_argument("--physics", choices=("accurate", "training"), default="accurate")
    p.add_argument("--duration", type=float, default=None, help="s (default: the waveform's length)")
    p.add_argument("--reference", type=Path, default=None,
                   help="a trajectory.csv to compare with (drawn dashed; differences reported)")
    p.add_argument("--out", type=Path, default=Path("out/replay"), help="output folder")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=replay_command)

    p = sub.add_parser(
        "simulate",
        help="simulate the paper's robot under a rotating field",
        description="Simulate the paper's robot under a field rotating in the x-y plane; write "
        "trajectory.csv and a picture of the robot's shapes.",
    )
    p.add_argument("--robot", choices=YAO_ROBOTS, default="yao2023-m1")
    p.add_argument("--physics", choices=("accurate", "training"), default="accurate")
    p.add_argument("--amplitude", type=float, default=4e-3, help="field amplitude, T")
    p.add_argument("--frequency", type=float, default=-1.0,
                   help="rotation frequency, Hz (negative: clockwise, rolls the robot towards +x)")
    p.add_argument("--ramp", type=float, default=0.2, help="amplitude ramp-up time, s")
    p.add_argument("--duration", type=float, default=3.0, help="s")
    p.add_argument("--out", type=Path, default=Path("out/simulate"), help="output folder")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=simulate_command)


def _progress(total: int, description: str):
    from tqdm import tqdm

    bar = tqdm(total=total, desc=description, unit="x10ms", leave=False, disable=None)

    def update(done: int) -> None:
        bar.n = done
        bar.refresh() if done == total or done % 20 == 0 else None
        if done == total:
            bar.close()

    return update


def replay_command(args: argparse.Namespace) -> int:
    field = TabulatedField.from_csv(args.field_csv)
    duration = field.duration if args.duration is None else args.duration
    spec = robot_by_name(args.robot, args.physics)
    result = run_open_loop(
        spec, field, duration, progress=_progress(int(round(duration * 100)), "replay")
    )
    args.out.mkdir(parents=True, exist_ok=True)
    trajectory_csv = write_trajectory_csv(result.trajectory, args.out / "trajectory.csv")
    reference = None
    summary: dict[str, object] = {}
    if args.reference is not None:
        reference = _read_reference(args.reference)
        summary = compare_trajectories(result.trajectory, reference)
    from .plotting import plot_open_loop

    figure = plot_open_loop(
        result, args.out / "replay.png",
        title=f"{args.robot}, {args.physics} physics: {args.field_csv.name}", reference=reference,
    )
    print_result({**_summary(args, result, trajectory_csv, figure), **summary}, args.json)
    return 0


def simulate_command(args: argparse.Namespace) -> int:
    spec = robot_by_name(args.robot, args.physics)
    field = RotatingField(args.amplitude, args.frequency, phase=0.5 * np.pi, ramp_time=args.ramp)
    result = run_open_loop(
        spec, field, args.duration, progress=_progress(int(round(args.duration * 100)), "simulate")
    )
    args.out.mkdir(parents=True, exist_ok=True)
    trajectory_csv = write_trajectory_csv(result.trajectory, args.out / "trajectory.csv")
    from .plotting import plot_open_loop

    figure = plot_open_loop(
        result, args.out / "shapes.png",
        title=f"{args.robot} under a {1e3 * args.amplitude:g} mT field rotating at "
        f"{args.frequency:g} Hz ({args.physics} physics)",
    )
    print_result(_summary(args, result, trajectory_csv, figure), args.json)
    return 0


def _summary(args, result, trajectory_csv: Path, figure: Path) -> dict[str, object]:
    return {
        "robot": args.robot,
        "physics": args.physics,
        "mid_dx_m": result.mid_dx,
        "max_height_m": result.max_height,
        "duration_s": float(result.trajectory.t_s.iloc[-1]),
        "trajectory_csv": str(trajectory_csv),
        "figure": str(figure),
        "wall_s": result.wall_s,
        "step_us": result.step_us,
    }


def _read_reference(path: Path) -> pd.DataFrame:
    from .simulation import TRAJECTORY_COLUMNS

    if not path.is_file():
        raise CommandError(f"{path}: no such reference trajectory")
    reference = pd.read_csv(path)
    missing = [c for c in TRAJECTORY_COLUMNS if c not in reference.columns]
    if missing:
        raise CommandError(f"{path}: reference trajectory lacks column(s) {', '.join(missing)}")
    return reference


def compare_trajectories(trajectory: pd.DataFrame, reference: pd.DataFrame) -> dict[str, float]:
    """Differences between a simulated trajectory and a reference, on the reference's frames
    within the simulated time span (linear interpolation of the simulation). Lengths in m."""
    ref = reference[reference.t_s <= trajectory.t_s.iloc[-1] + 1e-9]
    out: dict[str, float] = {}
    for column in ("mid_x_m", "mid_y_m", "back_x_m", "front_x_m", "height_max_m", "span_m"):
        sim = np.interp(ref.t_s, trajectory.t_s, trajectory[column])
        out[f"max_abs_diff_{column}"] = float(np.max(np.abs(sim - ref[column])))
    ref_dx = float(ref.mid_x_m.iloc[-1] - ref.mid_x_m.iloc[0])
    sim_dx = float(np.interp(ref.t_s.iloc[-1], trajectory.t_s, trajectory.mid_x_m)
                   - trajectory.mid_x_m.iloc[0])
    out["reference_mid_dx_m"] = ref_dx
    out["mid_dx_relative_error"] = (sim_dx - ref_dx) / ref_dx if ref_dx != 0 else float("nan")
    return out
