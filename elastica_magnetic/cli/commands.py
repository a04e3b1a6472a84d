"""``msr field replay`` and ``msr field simulate``: thin wrappers over the library."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from ..clock_columns import other_spelling_hint
from ..field_csv import header_named_twice, limit_problem, separator_hint
from ..field_spec import load_field
from ..fields import RotatingField, TabulatedField
from ..io import missing_folder_hint
from ..openloop import run_open_loop, write_trajectory_csv
from ..presets import ROBOTS
from ..progress import progress_bar
from ..results import result_folder
from ..spatial_fields import FieldSum
from ..specfile import SpecError, actuation_kind_of, axis_limits_of, field_limit_of, load_robot
from .app import CommandError, print_notes, print_result
from .options import duration_option, heading_option, number, output_path

ROBOT_HELP = (f"a preset ({', '.join(ROBOTS)}) or a spec file (.toml, e.g. from "
              "`msr case show m1-4mT --toml`); default yao2023-m1")
#: Largest ``msr field simulate --amplitude``, T (the paper's fields are 4 and 10 mT).
MAX_AMPLITUDE_T = 0.1
#: ``msr field simulate`` amplitude for a robot whose spec has no ``[actuation] field_limit`` (a preset), T.
DEFAULT_AMPLITUDE_T = 4e-3
#: What ``msr field replay`` / ``msr field simulate`` write into ``--out`` (results written before the
#: result marker are recognised by these names).
REPLAY_FILES = ("trajectory.csv", "replay.png")
SIMULATE_FILES = ("trajectory.csv", "shapes.png", "tip_path.png")
FORCE_HELP = ("replace the result of an earlier run of this command for the same robot in --out "
              "(another command's result, another robot's or files msr did not write are never "
              "replaced)")
#: Half the 100 Hz rate of the trajectory and field records: faster rotations would alias.
NYQUIST_HZ = 50.0


def robot_option(value: str) -> str:
    """``--robot NAME_OR_PATH``, checked at parse time (a bad spec file names the file and key)."""
    try:
        load_robot(value)
        kind = actuation_kind_of(value)
    except SpecError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    if kind not in (None, "field"):
        raise argparse.ArgumentTypeError(
            f"{value}: [actuation] kind = \"{kind}\": a rod clamped at its base and steered by a source "
            "(docs/steering_catheter.md), which these commands do not model: they play a uniform field on a "
            "free robot; train the case with msr train --case, or give a source in space as a [field] table "
            "(docs/spatial_fields.md)")
    return value


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "replay",
        help="play a field CSV (mT, 100 Hz) open loop on a robot (the paper's by default)",
        description="Play a field CSV open loop on a robot (a preset or a spec file; the paper's "
        "pattern-1 robot by default) and write trajectory.csv (100 Hz, first row t = 0) and a "
        "figure.",
    )
    p.add_argument("field_csv", type=Path, help="field CSV: mag_x, mag_y, mag_z in mT, 100 rows/s")
    p.add_argument("--robot", type=robot_option, default="yao2023-m1", help=ROBOT_HELP)
    p.add_argument("--physics", choices=("accurate", "training"), default="accurate")
    p.add_argument("--duration", type=duration_option(), default=None,
                   help="s, at most the waveform's length (default: the waveform's length)")
    p.add_argument("--reference", type=Path, default=None,
                   help="a trajectory.csv to compare with (drawn dashed; differences reported)")
    p.add_argument("--out", type=output_path, default="out/replay", help="output folder")
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.add_argument("--no-progress", action="store_true", help="no progress bar or lines")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=replay_command)

    p = sub.add_parser(
        "simulate",
        help="simulate a robot under a rotating field (the paper's by default)",
        description="Simulate a robot (a preset or a spec file; the paper's pattern-1 robot by "
        "default) under a field rotating in the x-y plane; write trajectory.csv and a picture of "
        "the robot's shapes.",
    )
    p.add_argument("--robot", type=robot_option, default="yao2023-m1", help=ROBOT_HELP)
    p.add_argument("--physics", choices=("accurate", "training"), default="accurate")
    p.add_argument("--amplitude", type=number("T", 0.0, MAX_AMPLITUDE_T, low_open=True), default=None,
                   help=f"field amplitude, T (at most {MAX_AMPLITUDE_T:g}; default: the spec's "
                   f"[actuation] field_limit, {1e3 * DEFAULT_AMPLITUDE_T:g} mT for a preset)")
    p.add_argument("--frequency", default=None,
                   type=number("Hz", -NYQUIST_HZ, NYQUIST_HZ, low_open=True, high_open=True),
                   help="rotation frequency, Hz (negative: clockwise, rolls the robot "
                   f"towards +x; default -1); |f| < {NYQUIST_HZ:g} Hz, the Nyquist limit of the 100 "
                   "Hz output")
    p.add_argument("--ramp", type=number("s", 0.0), default=None,
                   help="amplitude ramp-up time, s (0: none; at most --duration; default 0.2 or "
                   "--duration if shorter)")
    p.add_argument("--heading", type=heading_option, default=None,
                   help="turn the rotation plane about the vertical (y) axis, rad, counter-"
                   "clockwise seen from above (default 0: the x-y plane; 1.5708, i.e. 90 degrees: "
                   "the y-z plane, which rolls the robot sideways toward -z); needs the third "
                   "coil pair")
    p.add_argument("--duration", type=duration_option(), default=3.0, help="s")
    p.add_argument("--out", type=output_path, default="out/simulate", help="output folder")
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.add_argument("--no-progress", action="store_true", help="no progress bar or lines")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=simulate_command)


def _progress(total: int, description: str, disable: bool = False):
    """``progress(done)`` for :func:`run_open_loop`: a bar on a terminal, sparse lines otherwise
    (nothing with ``disable``)."""
    bar = progress_bar(total, description, unit="x10ms", leave=False, disable=disable)

    def update(done: int) -> None:
        bar.n = done
        if done == total or done % 20 == 0:
            bar.refresh()
        if done == total:
            bar.close()

    return update


def _judge_amplitude(amplitude: float) -> None:
    """``--amplitude`` (T) against the coil fields of the plausibility table, as a field CSV is:
    refused where no coil makes it, warned about where unusual, the unit mistake named."""
    from ..plausibility import judge, warn_implausible

    finding = judge("coil field", amplitude)
    if finding is None:
        return
    if finding.refuse:
        raise CommandError(f"--amplitude {finding.text}")
    warn_implausible(f"--amplitude {finding.text}")


def simulate_amplitude(args: argparse.Namespace) -> tuple[float, str]:
    """The ``msr field simulate`` field amplitude (T) and where it comes from: ``--amplitude``, else the
    spec's ``[actuation] field_limit``, else :data:`DEFAULT_AMPLITUDE_T`."""
    if args.amplitude is not None:
        _judge_amplitude(args.amplitude)
        return args.amplitude, "--amplitude"
    limit = field_limit_of(args.robot)
    if limit is None:
        return DEFAULT_AMPLITUDE_T, "default (no [actuation] field_limit)"
    return limit, "[actuation] field_limit"


def replay_command(args: argparse.Namespace) -> int:
    field = TabulatedField.from_csv(args.field_csv)
    waveform_z = np.asarray(field.samples)[:, 2]
    duration = field.duration if args.duration is None else args.duration
    if duration > field.duration + 1e-9:
        raise CommandError(
            f"--duration {duration:g} s is past the end of {args.field_csv} ({field.duration:g} s: "
            f"{field.samples.shape[0]} rows at 100 Hz); the coil driver zeroes the field after the "
            "last row, so give at most the file's length"
        )
    spec = load_robot(args.robot, args.physics)
    over = limit_problem(field.samples, axis_limits_of(args.robot), str(args.field_csv))
    if over is not None:
        raise CommandError(over)
    setup = load_field(args.robot)
    source = setup.source() if setup is not None else None
    if source is not None:  # the coils' uniform waveform plus the spec's field in space
        field = FieldSum(field, source)
    # Every input and the output folder are checked before the simulation starts.
    reference = (_read_reference(args.reference, duration, spec.length) if args.reference is not None
                 else None)
    _note_sideways_model(spec, bool(np.any(waveform_z != 0.0)))
    with result_folder(args.out, kind="replay", subject=f"robot {spec.name}", force=args.force,
                       known_files=REPLAY_FILES) as out:
        print_notes(out.notes)
        result = run_open_loop(
            spec, field, duration,
            progress=_progress(int(round(duration * 100)), "replay", args.no_progress),
            clamp=setup is not None and setup.clamp,
        )
        trajectory_csv = write_trajectory_csv(result.trajectory, out.path / "trajectory.csv")
        summary: dict[str, object] = {}
        if reference is not None:
            summary = compare_trajectories(result.trajectory, reference)
        from ..plotting import plot_open_loop

        figure = plot_open_loop(
            result, out.path / "replay.png", reference=reference,
            title=f"{args.robot}, {args.physics} physics: {args.field_csv.name}",
        )
    print_result({**_summary(args, result, out.final_path(trajectory_csv),
                             out.final_path(figure)), **summary}, args.json)
    return 0


def simulate_command(args: argparse.Namespace) -> int:
    setup = load_field(args.robot)
    if setup is not None and setup.table is not None:
        return _simulate_spatial(args, setup)
    args.frequency = -1.0 if args.frequency is None else args.frequency
    if args.ramp is None:
        args.ramp = min(0.2, args.duration)
    if args.ramp > args.duration:
        fix = f"give a --ramp of at most {args.duration:g} s, or a longer --duration"
        if 10.0 * args.duration <= args.ramp and 1e-3 * args.ramp <= args.duration:  # --ramp 200 for 0.2 s
            fix = (f"ms written where s is expected? {args.ramp:g} ms is {1e-3 * args.ramp:g} s: "
                   f"give --ramp {1e-3 * args.ramp:g}")
        raise CommandError(
            f"--ramp {args.ramp:g} s is longer than --duration {args.duration:g} s: the field would "
            f"never reach its amplitude ({fix})"
        )
    spec = load_robot(args.robot, args.physics)
    args.amplitude, amplitude_from = simulate_amplitude(args)
    heading = 0.0 if args.heading is None else args.heading
    _check_axis_limits(args.robot, args.amplitude, heading)
    _note_sideways_model(spec, heading % math.pi != 0.0)
    field = RotatingField(args.amplitude, args.frequency, phase=0.5 * np.pi, ramp_time=args.ramp,
                          heading=heading)
    with result_folder(args.out, kind="simulate", subject=f"robot {spec.name}", force=args.force,
                       known_files=SIMULATE_FILES) as out:
        print_notes(out.notes)
        result = run_open_loop(
            spec, field, args.duration,
            progress=_progress(int(round(args.duration * 100)), "simulate", args.no_progress),
            clamp=setup is not None and setup.clamp,
        )
        trajectory_csv = write_trajectory_csv(result.trajectory, out.path / "trajectory.csv")
        from ..plotting import plot_open_loop

        figure = plot_open_loop(
            result, out.path / "shapes.png",
            title=f"{args.robot} under a {1e3 * args.amplitude:g} mT field rotating at "
            f"{args.frequency:g} Hz{f', plane turned {heading:g} rad' if heading else ''} "
            f"({args.physics} physics)",
        )
    print_result({**_summary(args, result, out.final_path(trajectory_csv), out.final_path(figure)),
                  "amplitude_T": args.amplitude, "amplitude_from": amplitude_from,
                  "heading_rad": heading}, args.json)
    return 0


def _simulate_spatial(args: argparse.Namespace, setup) -> int:
    """``msr field simulate`` with a spec whose ``[field]`` names a source in space (no rotating field)."""
    given = [f"--{name}" for name in ("amplitude", "frequency", "ramp", "heading")
             if getattr(args, name) is not None]
    if given:
        raise CommandError(f"{' and '.join(given)} set the rotating field, but {args.robot} names its "
                           f"own field ([field] kind = {setup.table['kind']!r}); drop them or the [field] "
                           "table")
    spec = load_robot(args.robot, args.physics)
    source = setup.source()
    with result_folder(args.out, kind="simulate", subject=f"robot {spec.name}", force=args.force,
                       known_files=SIMULATE_FILES) as out:
        print_notes(out.notes)
        result = run_open_loop(
            spec, source, args.duration,
            progress=_progress(int(round(args.duration * 100)), "simulate", args.no_progress),
            clamp=setup.clamp,
        )
        trajectory_csv = write_trajectory_csv(result.trajectory, out.path / "trajectory.csv")
        from ..plotting import plot_open_loop, plot_tip_path

        kind = setup.table["kind"]
        title = f"{Path(args.robot).name} in a {kind} field ({args.physics} physics)"
        figure = plot_open_loop(result, out.path / "shapes.png", title=title)
        tip = plot_tip_path(result, source, out.path / "tip_path.png", title=title)
    summary = _summary(args, result, out.final_path(trajectory_csv), out.final_path(figure))
    summary.update(field=kind, clamp=setup.clamp, tip_path_figure=str(out.final_path(tip)),
                   tip_final_m=[float(result.trajectory.front_x_m.iloc[-1]),
                                float(result.trajectory.front_y_m.iloc[-1])])
    print_result(summary, args.json)
    return 0


def _check_axis_limits(robot: str, amplitude: float, heading: float) -> None:
    """The rotating field's largest component on each axis (``amplitude`` T; x ``|cos h|``, y 1, z
    ``|sin h|`` of it) within the spec's limit of that axis: a three-axis spec's weaker z pair is
    not driven past its limit, and a spec whose coils are in x-y only plays no z field (a preset
    names no coils: a what-if, not checked)."""
    largest = {"x": amplitude * abs(math.cos(heading)), "y": amplitude,
               "z": amplitude * abs(math.sin(heading))}
    limits = axis_limits_of(robot)
    if limits and "z" not in limits and largest["z"] > 1e-9 * amplitude:  # a spec with coils in x-y only
        raise CommandError(
            f"--heading {heading:g} rad turns the field out of the x-y plane ({1e3 * largest['z']:.4g} mT "
            f"on z), and {robot}'s [actuation] drives the axes {''.join(limits)} only (no coil pair along "
            "z): the coils the spec describes cannot play it; give the spec axes = \"xyz\" with its limit "
            "(or simulate a preset robot, which names no coils, as a what-if)")
    for axis, limit in limits.items():
        if largest[axis] > limit * (1.0 + 1e-9):
            raise CommandError(
                f"the field rotating at {1e3 * amplitude:g} mT with --heading {heading:g} rad reaches "
                f"{1e3 * largest[axis]:.4g} mT on {axis}, above {robot}'s [actuation] field_limit of "
                f"{1e3 * limit:g} mT on {axis}; give --amplitude of at most "
                f"{1e3 * amplitude * limit / largest[axis]:.4g} mT")


def _note_sideways_model(spec, field_leaves_plane: bool) -> None:
    """A field out of the x-y plane on a band whose ground rolls it like a round rod (the default
    model): say so, and which model a flat band has, before the run."""
    ground = spec.ground
    if (field_leaves_plane and ground is not None and ground.sideways == "rolling"
            and spec.section == "band"):
        print("msr: note: the field leaves the x-y plane and [robot.ground] sideways is "
              "\"rolling\" (the default): the band rolls sideways like a round rod; set sideways = "
              "\"sliding\" to model a flat band that cannot roll (see the spec format's "
              "[robot.ground])", file=sys.stderr)


def _summary(args, result, trajectory_csv: Path, figure: Path) -> dict[str, object]:
    return {
        "robot": args.robot,
        "physics": args.physics,
        "mid_dx_m": result.mid_dx,
        "mid_dz_m": float(result.trajectory.mid_z_m.iloc[-1] - result.trajectory.mid_z_m.iloc[0]),
        "max_height_m": result.max_height,
        "duration_s": float(result.trajectory.t_s.iloc[-1]),
        "trajectory_csv": str(trajectory_csv),
        "figure": str(figure),
        "wall_s": result.wall_s,
        "step_us": result.step_us,
    }


#: Most a reference's first-frame span may exceed the robot's length (a lying robot spans about
#: its length; more is another unit or another robot).
REFERENCE_SPAN_LENGTHS = 1.5


#: What a reference with columns in other units or spellings is told.
_SI_NAMES = ("a reference is read in SI units, s and m, under trajectory.csv's column names: convert and "
             "rename them")


def _read_reference(path: Path, duration: float, length: float | None = None) -> pd.DataFrame:
    """The reference trajectory of ``msr field replay --reference``, checked: the columns of
    ``trajectory.csv``, numbers only, a first frame's span that fits the robot's ``length`` (m),
    and at least two frames within ``[0, duration]`` s."""
    from ..simulation import PLANAR_TRAJECTORY_COLUMNS, TRAJECTORY_COLUMNS

    if not path.is_file():
        raise CommandError(f"--reference {path}: no such reference trajectory{missing_folder_hint(path)}")
    try:
        reference = pd.read_csv(path, encoding="utf-8-sig")
    except pd.errors.EmptyDataError:
        raise CommandError(
            f"--reference {path}: empty file, expected the columns of trajectory.csv"
        ) from None
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise CommandError(f"--reference {path}: not a readable UTF-8 CSV: {exc}") from None
    if twice := header_named_twice(path):
        raise CommandError(f"--reference {path}: its header {twice}; give each column once (which copy "
                           "is meant cannot be guessed)")
    missing = [c for c in PLANAR_TRAJECTORY_COLUMNS if c not in reference.columns]
    if missing:
        raise CommandError(f"--reference {path}: lacks column(s) {', '.join(missing)}"
                           f"{other_spelling_hint(missing, [str(c) for c in reference.columns], _SI_NAMES)}"
                           f"{separator_hint([str(c) for c in reference.columns])}")
    if reference.empty:
        raise CommandError(f"--reference {path}: header but no data rows")
    # the sideways columns where the reference has them all (a planar reference lacks them)
    columns = list(TRAJECTORY_COLUMNS if set(TRAJECTORY_COLUMNS) <= set(reference.columns)
                   else PLANAR_TRAJECTORY_COLUMNS)
    reference = reference[columns]
    values = reference.apply(pd.to_numeric, errors="coerce").to_numpy(dtype=np.float64)
    bad = ~np.isfinite(values)
    if bad.any():
        row, col = (int(i) for i in np.argwhere(bad)[0])
        raise CommandError(
            f"--reference {path}: line {row + 2}, column {columns[col]}: "
            f"{reference.iloc[row, col]!r} is not a finite number (SI units: s, m)"
        )
    reference = pd.DataFrame(values, columns=columns)
    steps = np.diff(reference.t_s.to_numpy())
    if np.any(steps <= 0.0):  # its window and distance are read from its first and last frame
        row = int(np.flatnonzero(steps <= 0.0)[0]) + 1
        raise CommandError(
            f"--reference {path}: line {row + 2}: t_s {reference.t_s.iloc[row]:g} s does not come after "
            f"the line before's {reference.t_s.iloc[row - 1]:g} s; give the frames once each, in time order")
    _judge_reference_positions(path, reference)
    span = float(reference.span_m.iloc[0])
    if length is not None and span > REFERENCE_SPAN_LENGTHS * length:  # the robot's extent along x
        unit = ("millimetres (divide by 1000)" if span > 160 * length else "centimetres (divide by 100)"
                if span > 10 * length else "another unit, or another robot's recording")
        raise CommandError(f"--reference {path}: its first frame's span_m is {span:g} m, {span / length:.3g} "
                           f"x the {1e3 * length:g} mm robot being replayed: the lengths look like {unit}; "
                           "give metres")
    within = int(np.count_nonzero((reference.t_s >= -1e-9) & (reference.t_s <= duration + 1e-9)))
    if within < 2:
        ms = ("; the times look like milliseconds: give seconds (divide t_s by 1000)"
              if reference.t_s.max() > 100.0 * duration else "")
        raise CommandError(
            f"--reference {path}: {within} frame(s) within the replayed 0 to {duration:g} s "
            f"(its t_s spans {reference.t_s.min():g} to {reference.t_s.max():g} s); need at least 2{ms}"
        )
    return reference


def _judge_reference_positions(path: Path, reference: pd.DataFrame) -> None:
    """Positions of a reference trajectory (m) against the plausibility table: a file in mm read as
    m puts the robot metres away (it was compared as such, an error of 10 m reported as a result)."""
    from ..plausibility import judge, warn_implausible

    columns = [c for c in reference.columns if c.endswith("_m")]
    magnitudes = reference[columns].abs().max()
    column = str(magnitudes.idxmax())
    finding = judge("position", float(magnitudes[column]))
    if finding is None:
        return
    text = f"--reference {path}: the largest |{column}| = {finding.text}"
    if finding.refuse:
        raise CommandError(text)
    warn_implausible(text)


def compare_trajectories(trajectory: pd.DataFrame, reference: pd.DataFrame) -> dict[str, float]:
    """Differences between a simulated trajectory and a reference, on the reference's frames
    within the simulated time span (linear interpolation of the simulation), and the middle's
    distance of each over that window (``compared_from_s`` to ``compared_to_s``). Lengths in m."""
    ref = reference[(reference.t_s >= -1e-9) & (reference.t_s <= trajectory.t_s.iloc[-1] + 1e-9)]
    out: dict[str, float] = {}
    for column in ("mid_x_m", "mid_y_m", "back_x_m", "front_x_m", "height_max_m", "span_m"):
        sim = np.interp(ref.t_s, trajectory.t_s, trajectory[column])
        out[f"max_abs_diff_{column}"] = float(np.max(np.abs(sim - ref[column])))
    if "mid_z_m" in ref.columns:  # a reference with the sideways markers
        sim = np.interp(ref.t_s, trajectory.t_s, trajectory["mid_z_m"])
        out["max_abs_diff_mid_z_m"] = float(np.max(np.abs(sim - ref["mid_z_m"])))
    # both distances over the reference's own window (a tracker may start late or stop early)
    first, last = float(ref.t_s.iloc[0]), float(ref.t_s.iloc[-1])
    ref_dx = float(ref.mid_x_m.iloc[-1] - ref.mid_x_m.iloc[0])
    sim_dx = float(np.interp(last, trajectory.t_s, trajectory.mid_x_m)
                   - np.interp(first, trajectory.t_s, trajectory.mid_x_m))
    out["compared_from_s"], out["compared_to_s"] = first, last
    out["reference_mid_dx_m"] = ref_dx
    out["mid_dx_relative_error"] = (sim_dx - ref_dx) / ref_dx if ref_dx != 0 else float("nan")
    return out
