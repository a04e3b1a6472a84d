"""``msr real robustness`` and ``msr real identify``: thin wrappers over
:mod:`elastica_magnetic_rl.sim2real.robustness` and :mod:`elastica_magnetic_rl.sim2real.identify`
(heavy imports happen inside the commands)."""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import warnings
from collections.abc import Iterator
from pathlib import Path

from elastica_magnetic.cli import CommandError, command_name, duration_option, number, output_path
from elastica_magnetic.progress import progress_bar

from ..cases.variations import (
    DEFAULT_RANGES,
    GROUPS,
    SOURCE_RANGES,
    VariationError,
    magnitude_of,
    parse_variation,
)
from .identify import MAX_EVALUATIONS, STARTS

#: Largest ``--noise-m`` (m) anywhere, and the largest as a fraction of the body length: a noise
#: past it is a unit mistake (millimetres given for metres), not a tracker.
MAX_NOISE_M = 0.01
MAX_NOISE_LENGTHS = 0.1

_DEFAULT_SET = ", ".join(f"{name} ({'+'.join(GROUPS[name])}) x{low:g}:{high:g}"
                         for name, (low, high) in DEFAULT_RANGES.items()) + "; a magnet arm's " + ", ".join(
    f"{name} ({'+'.join(GROUPS[name])}) x{low:g}:{high:g}" for name, (low, high) in SOURCE_RANGES.items())


def _field_case_name(value: str) -> str:
    """``--case`` of ``msr real robustness``: checked at parse time (a case steered by a source
    refused by name: the robustness of a field waveform), passed on as given."""
    from elastica_magnetic.specfile import SpecError

    from ..cases.case import load_case
    from ..cases.steered import field_only_refusal

    try:
        case = load_case(value)
    except SpecError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    if not case.field_actuated:
        raise argparse.ArgumentTypeError(field_only_refusal(case.name, case.actuation.kind))
    return value


def variation_option(text: str):
    """``--vary KEY[+KEY...]=LOW:HIGH``, parsed at parse time (keys are checked against the spec
    once it is loaded)."""
    try:
        return parse_variation(text)
    except VariationError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``robustness`` and ``identify`` to ``msr``."""
    _add_robustness_command(sub)
    _add_identify_command(sub)


def _add_robustness_command(sub: argparse._SubParsersAction) -> None:
    """``msr real robustness``."""
    p = sub.add_parser(
        "robustness",
        help="how far a waveform (and its policy) carries robots whose spec values differ",
        description="Replay a waveform open loop (as the coils play it) and, for a policy, also "
        "run the policy closed loop, on robots whose spec values are varied; report each "
        "variant's distance, the nominal, worst and 10th-percentile distance and their fraction "
        "of the case's yardstick; write OUT/robustness.json, OUT/robustness.png and "
        "OUT/fields.csv (the waveform played). A tip-reach policy (a catheter steered by a magnet "
        "on an arm or by coils): the policy and the case's steering yardstick each steer every "
        "varied catheter to the case's 20 held-out targets; report the targets each reaches "
        "(OUT/targets.csv in place of the waveform).",
    )
    p.add_argument("source", metavar="POLICY_OR_FIELD_CSV",
                   help="a shipped policy name (m1-10mT, ...), a run folder, a checkpoint, or a "
                   "field CSV (mT, 100 Hz; give --case)")
    p.add_argument("--case", default=None, type=_field_case_name,
                   help="for a field CSV: the case it is played on (a shipped case or a spec file)")
    p.add_argument("--fields", type=Path, default=None,
                   help="for a policy: its waveform (default: the shipped fields.csv, else generated "
                   "as msr policy generate does: accurate physics, field from zero, --duration s)")
    p.add_argument("--checkpoint", default="auto",
                   help="for a training run: auto (default: the farther of its final and best actors, "
                   "as msr policy generate chooses), final, best, or a checkpoint file of the run")
    p.add_argument("--vary", type=variation_option, action="append", default=None,
                   metavar="KEY=LOW:HIGH",
                   help="vary dotted spec keys (KEY or KEY+KEY or a group: "
                   f"{', '.join(GROUPS)}) by factors LOW:HIGH of the nominal value, or to "
                   f"absolute values abs:LOW:HIGH (SI; one key); repeatable. Default: {_DEFAULT_SET}")
    p.add_argument("--samples", type=number("", 0, 10_000, integer=True), default=0,
                   help="Latin-hypercube draws besides one-at-a-time and corners (default 0)")
    p.add_argument("--seed", type=number("", 0, 2**32 - 1, integer=True), default=None,
                   help="seed of the Latin-hypercube draws of --samples (default 0)")
    p.add_argument("--no-corners", action="store_true",
                   help="leave out the corners (every combination of range ends)")
    p.add_argument("--open-loop-only", action="store_true", help="for a policy: skip the closed loop")
    p.add_argument("--physics", choices=("training", "accurate"), default="training")
    p.add_argument("--duration", type=duration_option(), default=None,
                   help="s (default 10; a tip-reach policy: its task's episode)")
    p.add_argument("--workers", type=number("processes", 1, 1024, integer=True), default=None,
                   help=f"worker processes (default: every core, {os.cpu_count()} here)")
    p.add_argument("--out", type=output_path, default="out/robustness",
                   help="output folder, written whole (must not exist unless --force)")
    p.add_argument("--force", action="store_true", help="replace an existing output folder")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.set_defaults(func=_on_signals(robustness_command))


def _add_identify_command(sub: argparse._SubParsersAction) -> None:
    """``msr real identify``."""
    p = sub.add_parser(
        "identify",
        help="fit spec values so that the simulated robot moves as a measured trajectory",
        description="Fit spec values (dotted keys) so that the robot of a spec, under the waveform "
        "that was played (or, for a catheter steered by a magnet on an arm, along the arm's recorded "
        "path: fit its magnet's moment, actuation.moment or the group magnet, from the tip's path; "
        "for one steered by fixed coils, along their recorded currents: fit their gains, the group "
        "coils or actuation.coils.K.turns), "
        "moves its tracked points as measured: least squares in the training "
        "physics from several starts, confirmed in the accurate physics; each value gets an "
        "interval or is reported not identifiable, and the residual is judged against --noise-m. "
        "Writes DIR/identified.toml (the whole spec with the fitted values), DIR/identify.json "
        "(values, intervals, residuals in m, warnings, every start) and "
        "DIR/identify.png (measured against fitted motion).",
    )
    p.add_argument("field_csv", type=Path, metavar="FIELD_CSV",
                   help="the waveform played (mT, 100 rows/s; row 0 starts at t = 0); for a case steered "
                   "by a magnet on an arm, the arm's recorded path: t_s, magnet_x_m, magnet_y_m, "
                   "magnet_z_m, direction_x, direction_y, direction_z[, insertion_m], 100 rows/s; for "
                   "one steered by fixed coils, their recorded currents: t_s, current_0_A, ..., "
                   "current_{N-1}_A[, insertion_m] (A, one per coil in the spec's order), 100 rows/s")
    p.add_argument("trajectory_csv", type=Path, metavar="TRAJECTORY_CSV",
                   help="the measured motion: msr's trajectory.csv, or a tracker's CSV: t_s (s), then "
                   "x_<s>_m, y_<s>_m (m) per tracked point, <s> its place along the body from 0 "
                   "(back end) to 1 (front end); for a catheter its tip path: t_s, tip_x_m, tip_y_m, "
                   "tip_z_m (m); any frame rate")
    p.add_argument("--robot", required=True, metavar="SPEC",
                   help="the nominal robot: a spec file (.toml) or a shipped case name")
    p.add_argument("--fit", required=True, metavar="KEY[,KEY...]",
                   help="the values to fit: dotted spec keys (robot.magnetization.magnitude, ...), "
                   f"keys joined by + fitted as one factor, or groups ({', '.join(GROUPS)})")
    p.add_argument("--out", type=output_path, required=True, metavar="DIR",
                   help="output folder, written whole (must not exist unless --force)")
    p.add_argument("--physics", choices=("training", "accurate"), default="training",
                   help="physics of the fit (the other one confirms it)")
    p.add_argument("--no-confirm", action="store_true", help="skip the confirmation run")
    p.add_argument("--max-evaluations", type=number("simulations", 10, 100_000, integer=True),
                   default=MAX_EVALUATIONS, help="most simulations the fit may run, every start "
                   f"together (default {MAX_EVALUATIONS})")
    p.add_argument("--starts", type=number("", 1, 64, integer=True), default=STARTS,
                   help=f"fits from the nominal values and from perturbed ones (default {STARTS}); "
                   "the best is kept, their spread shows a value the trajectory does not fix")
    p.add_argument("--seed", type=number("", 0, 2**32 - 1, integer=True), default=None,
                   help="seed of the perturbed starts (default 0; with --starts 2 or more)")
    p.add_argument("--noise-m", type=number("m", 0, MAX_NOISE_M, low_open=True), default=None,
                   metavar="M", help="the tracker's noise per coordinate (m; 0.05 mm is 5e-5), to "
                   "judge the residual by (default: none, the residual is not judged)")
    p.add_argument("--force", action="store_true", help="replace an existing output folder")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--json", action="store_true", help="print identify.json")
    p.set_defaults(func=_on_signals(identify_command))


def _on_signals(command):
    """``command`` with SIGTERM and SIGHUP stopping it as Ctrl-C does (its message, its output folder's
    claim released), not by the default death that leaves a lock beside the folder."""
    import functools

    from elastica_magnetic.interrupts import signals_as_exceptions

    @functools.wraps(command)
    def run(args: argparse.Namespace) -> int:
        with signals_as_exceptions():
            return command(args)

    return run


def robustness_command(args: argparse.Namespace) -> int:
    from elastica_magnetic_rl.shipping.policy_files import PolicyNotFoundError

    from .output import prepare_output_folder
    from .report import robustness_table
    from .robustness import plan_robustness, run_robustness, write_robustness
    from .tip_robustness import TipRobustnessPlan

    if args.seed is not None and not args.samples:  # it would be recorded but change nothing
        raise CommandError(f"--seed {args.seed}: seeds the Latin-hypercube draws of --samples, and "
                           "none are drawn (--samples 0); give --samples N, or leave --seed out")
    prepare_output_folder(args.out, args.force, kind="robustness")
    try:
        plan = plan_robustness(
            args.source, case=args.case, fields_csv=args.fields, variations=args.vary,
            corners=not args.no_corners, samples=args.samples, seed=args.seed or 0,
            physics=args.physics, duration=args.duration, progress=not args.no_progress,
            checkpoint=args.checkpoint,
        )
    except (PolicyNotFoundError, FileNotFoundError) as exc:
        raise CommandError(str(exc)) from None
    if args.open_loop_only and plan.policy is None:
        raise CommandError(f"--open-loop-only: {args.source} is a field CSV, played open loop only "
                           "(no policy to close the loop with); leave the option out")
    tip = isinstance(plan, TipRobustnessPlan)
    if args.open_loop_only and tip:
        raise CommandError(f"--open-loop-only: {args.source} is a policy of the tip-reach case "
                           f"{plan.case.name!r}, which steers from the tip it sees: its study is closed "
                           "loop only (the policy and the yardstick); leave the option out")
    report = run_robustness(plan, closed_loop=not args.open_loop_only, workers=args.workers,
                            progress=not args.no_progress)
    out = write_robustness(report, plan, args.out, force=args.force)
    if args.json:
        print(json.dumps({**report, "out": str(out)}, indent=2, default=str))
    else:
        print(robustness_table(report))
        played = out / ("targets.csv" if tip else "fields.csv")
        print(f"\nwritten: {out / 'robustness.json'}, {out / 'robustness.png'}, {played}")
    return 0



@contextlib.contextmanager
def _kept_warnings() -> Iterator[list[str]]:
    """The implausible-value warnings of the block's inputs (a path beyond the case's limits, ...),
    in the list it yields; each is shown as it would have been, when the block ends (also on a
    refusal), so a result can record what was printed."""
    from elastica_magnetic.plausibility import ImplausibleValueWarning

    kept: list[str] = []
    shown: list[warnings.WarningMessage] = []
    try:
        with warnings.catch_warnings(record=True) as caught:
            try:
                yield kept
            finally:
                shown = list(caught)
    finally:
        for w in shown:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
            if issubclass(w.category, ImplausibleValueWarning):
                kept.append(str(w.message))


def identify_command(args: argparse.Namespace) -> int:
    import sys

    from .identify import identify, load_spec, parse_fit, write_identified
    from .output import prepare_output_folder
    from .tracking import check_against_robot

    if args.seed is not None and args.starts == 1:  # it would be recorded but change nothing
        raise CommandError(f"--seed {args.seed}: seeds the perturbed starts, and --starts 1 fits "
                           "from the nominal values only; give --starts 2 or more, or leave --seed "
                           "out")
    prepare_output_folder(args.out, args.force, kind="identify")
    with _kept_warnings() as input_warnings:  # printed now, and recorded in identify.json
        drive, measured, steered_by = _drive_and_measured(args.field_csv, args.trajectory_csv, args.robot)
        spec = load_spec(args.robot, steered_by=steered_by)
        try:
            fits = parse_fit(args.fit, spec)
        except VariationError as exc:
            raise CommandError(str(exc)) from None
        drive.check_spec(spec)
        check_against_robot(measured, float(spec["robot"]["length"]), drive.duration)
        _check_noise(args.noise_m, float(spec["robot"]["length"]))

    # a bar on a terminal, plain lines in a log (a "\r"-redrawn line fills a log file)
    with progress_bar(args.max_evaluations, f"msr {command_name(args)}", "simulation",
                      disable=args.no_progress) as bar:

        def progress(evaluations: int, rms: float) -> None:
            bar.update(evaluations - bar.n)
            bar.set_postfix_str(f"residual RMS {1e3 * rms:.4f} mm")

        report = identify(drive, measured, spec, fits, physics=args.physics,
                          confirm=not args.no_confirm, max_evaluations=args.max_evaluations,
                          starts=args.starts, seed=args.seed or 0, noise_m=args.noise_m,
                          progress=progress)
    for warning in report["warnings"]:
        print(f"msr {command_name(args)}: warning: {warning}", file=sys.stderr)
    report["warnings"] = [*input_warnings, *report["warnings"]]  # what the result folder keeps
    played = {"magnet-pose": "magnet_path", "coil-currents": "coil_path"}.get(steered_by, "field_csv")
    report = {played: str(args.field_csv), "robot": str(args.robot), "fit": args.fit, **report}
    header = (f"Identified by msr real identify from {args.field_csv} and {args.trajectory_csv} "
              f"({args.physics} physics), nominal spec {args.robot}.")
    out = write_identified(report, spec, measured, args.out, args.force, header)
    public = {k: v for k, v in report.items() if k != "predicted"}
    if args.json:
        print(json.dumps({**public, "out": str(out)}, indent=2, default=str))
        return 0
    print_identified(report)
    if "confirm" in report:
        c = report["confirm"]
        print(f"{c['physics']} physics, fitted values: residual RMS {1e3 * c['rms_m']:.4f} mm, "
              f"largest {1e3 * c['max_abs_m']:.4f} mm (the spec's own values: "
              f"{1e3 * c['nominal_rms_m']:.4f} mm RMS)")
    print(f"written: {out / 'identified.toml'}, {out / 'identify.json'}, {out / 'identify.png'}")
    return 0


def _check_files_in_order(drive_csv: Path, trajectory_csv: Path) -> None:
    """The two files given the wrong way round refused by name (:class:`CommandError`), before the
    first is read as a field CSV: a field CSV second (a crawler's), or a catheter's tip path first or
    its recorded drive second."""
    from elastica_magnetic.field_csv import FIELD_COLUMNS

    from .identify import STEERED_BY
    from .recorded_paths import file_kind, header_names
    from .tracking import TIP_COLUMNS

    first, second = file_kind(drive_csv), file_kind(trajectory_csv)
    if second == "field" and first != "field":
        raise CommandError(f"{drive_csv}, {trajectory_csv}: the two files are the wrong way round "
                           f"({trajectory_csv} is a field CSV, {', '.join(FIELD_COLUMNS)} in mT, what played "
                           f"the motion; {drive_csv} has {', '.join(header_names(drive_csv)[:3])}...): first "
                           "the field CSV, then the measured trajectory; swap them")
    drive = second if second in STEERED_BY else None
    if drive is None and first != "tip":
        return
    drives = (f"{STEERED_BY['magnet-pose'][2]} or {STEERED_BY['coil-currents'][2]}" if drive is None
              else STEERED_BY[drive][2])
    raise CommandError(f"{drive_csv}, {trajectory_csv}: the two files are the wrong way round"
                       + (f" ({drive_csv} is a catheter's tip path, {', '.join(TIP_COLUMNS)}, the motion "
                          "measured)" if first == "tip" else "")
                       + f": first what played the motion, {drives}, then the tip path "
                       f"(t_s, {', '.join(TIP_COLUMNS)}); swap them")


def _check_tip_path_given(drive_csv: Path, trajectory_csv: Path, steered_by: str) -> None:
    """With a catheter's recorded drive first, the second file must be its tip path: a magnet path,
    the coils' currents or a field CSV there is named as such (:class:`CommandError`)."""
    from .identify import STEERED_BY
    from .recorded_paths import FILE_KINDS, file_kind
    from .tracking import TIP_COLUMNS

    kind = file_kind(trajectory_csv)
    if kind in (None, "tip"):
        return  # a tip path, or a file whose reader names what it lacks
    raise CommandError(f"{trajectory_csv}: is {FILE_KINDS[kind]}, not a motion measured: {drive_csv} is "
                       f"{STEERED_BY[steered_by][2].split(' (')[0]}, which steers a catheter, so the second "
                       f"file is the tip's path (t_s, {', '.join(TIP_COLUMNS)})")


def _drive_and_measured(drive_csv: Path, trajectory_csv: Path, robot: str):
    """What played the motion (a waveform, with the ``robot`` spec file's field in space and clamp;
    a magnet arm's path; or the coils' currents: told by the file's header), the measured motion,
    read and checked, and the actuation kind a recorded path drives (``None`` for a waveform); a tip
    path goes with a recorded path only."""
    from elastica_magnetic.drive_columns import is_coil_currents, is_magnet_path
    from elastica_magnetic.field_csv import read_field_csv
    from elastica_magnetic.field_spec import load_field

    from .coil_path import CoilDrive, read_coil_path
    from .fit_model import FieldDrive
    from .identify import STEERED_BY
    from .magnet_path import MagnetDrive, read_magnet_path
    from .tracking import read_trajectory

    if drive_csv.resolve() == trajectory_csv.resolve():
        raise CommandError(f"{drive_csv}, {trajectory_csv}: the same file twice: give first what played the "
                           "motion (a field CSV, a magnet path or the coils' currents), then the measured "
                           "motion (a trajectory or a tip path)")
    if is_magnet_path(drive_csv):
        drive, steered_by = MagnetDrive(read_magnet_path(drive_csv)), "magnet-pose"
    elif is_coil_currents(drive_csv):
        drive, steered_by = CoilDrive(read_coil_path(drive_csv)), "coil-currents"
    else:  # a coil's field, as msr field replay
        _check_files_in_order(drive_csv, trajectory_csv)
        drive = FieldDrive(read_field_csv(drive_csv, plausible=True),
                           load_field(robot) if Path(robot).suffix == ".toml" else None)
        steered_by = None
    if steered_by is not None:  # a catheter's motion is its tip path: another file named before it is read
        from elastica_magnetic.specfile import SpecError

        from .identify import load_spec

        try:  # the drive against the robot first: a crawler given an arm's path needs its field CSV
            load_spec(robot, steered_by=steered_by)
        except SpecError as exc:
            raise CommandError(str(exc)) from None
        _check_tip_path_given(drive_csv, trajectory_csv, steered_by)
    measured = read_trajectory(trajectory_csv)
    if steered_by is not None and measured.kind != "tip path":
        raise CommandError(f"{trajectory_csv}: {drive_csv} is {STEERED_BY[steered_by][2].split(' (')[0]}, "
                           "which steers a catheter: give the tip's path (t_s, tip_x_m, tip_y_m, tip_z_m), "
                           "not a crawler's points")
    if steered_by is None and measured.kind == "tip path":
        raise CommandError(f"{trajectory_csv}: a catheter's tip path goes with the magnet arm's recorded "
                           f"path (t_s, magnet_x_m, ...) or the coils' recorded currents (t_s, current_0_A, "
                           f"...); {drive_csv} is a field waveform")
    return drive, measured, steered_by


def _check_noise(noise_m: float | None, length: float) -> None:
    """``--noise-m`` against the body (``length``, m): a noise past MAX_NOISE_LENGTHS of it is
    millimetres given for metres."""
    if noise_m is not None and noise_m > MAX_NOISE_LENGTHS * length:
        raise CommandError(f"--noise-m {noise_m:g}: {noise_m / length:.2g} x the {1e3 * length:g} mm "
                           "body; the tracker's noise is in metres (0.05 mm is 5e-5): a value in "
                           "millimetres given for metres?")


def print_identified(report: dict) -> None:
    """The text report of ``msr real identify``: each fitted value with its standard error, its
    interval (and where it comes from) or why it is not identifiable, the residual and its ratio
    to the noise, and the starts."""
    for fit in report["fitted"].values():
        interval = fit["interval"]
        span = (f"factor in [{interval[0]:.4f}, {interval[1]:.4f}] (from the {fit['interval_from']})"
                if interval is not None else "no interval (not judged)" if fit["identifiable"] is None
                else f"factor unbounded (from the {fit['interval_from']})")
        for key, value in fit["values"].items():
            sigma = fit["sigma"][key]
            # a table (a per-element magnetization) is shown by its largest vector
            error = ("(no standard error)" if "stopped_short" in fit or fit["identifiable"] is None else
                     f"+- {'inf' if sigma is None else format(magnitude_of(sigma), '.2g')}")
            print(f"{key}: {magnitude_of(value):.6g} {error} "
                  f"(nominal {magnitude_of(fit['nominal_values'][key]):.6g}, "
                  f"x{fit['factor']:.4f}), {span}"
                  + ("  AT THE BOUND of the fit" if fit["at_bound"] else ""))
        if "stopped_short" in fit:
            note = fit["stopped_short"]["note"]
            print(f"  STOPPED SHORT: {note.removeprefix('the fit stopped short of its minimum: ')}")
        if fit["identifiable"] is None:
            print(f"  NOT JUDGED: {fit['reason'].removeprefix('not judged: ')}")
        elif not fit["identifiable"]:
            print(f"  NOT IDENTIFIABLE: {fit['reason']}")
    r = report["residual_m"]
    ratio = report["residual_vs_noise"]
    judged = (f"{ratio:.2f} x the noise" if ratio is not None else report["residual_judged"])
    print(f"residual RMS {1e3 * r['rms']:.4f} mm ({judged}), largest {1e3 * r['max_abs']:.4f} mm "
          f"(nominal robot: {1e3 * r['nominal_rms']:.4f} mm)")
    if report["identifiability"].get("variance_from") == "noise":
        print(f"intervals measured in the stated noise ({1e3 * report['noise_m']:.4g} mm), above the "
              "residual: the data cannot fix the values better than that noise allows")
    o = report["optimizer"]
    print(f"{len(o['starts'])} start(s), {o['simulations']} simulations: best start {o['best_start']} "
          f"{'converged' if o['converged'] else 'did NOT converge'}; "
          + {True: "the starts agree", False: "the starts do NOT agree",
             None: "one start: their agreement not tested (--starts 2 or more)"}[o["starts_agree"]])
