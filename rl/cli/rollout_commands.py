"""``msr policy generate``, ``msr field baseline`` and ``msr policy demo``: a policy, the
hand-designed yardstick or the shipped demo rolled out and written (fields.csv, trajectory, figures;
a goto case's ring, a tip-reach case's targets). Thin wrappers over
:mod:`elastica_magnetic_rl.shipping.generate`, :mod:`elastica_magnetic_rl.shipping.baseline_sweep`,
:mod:`elastica_magnetic_rl.shipping.goto`, :mod:`elastica_magnetic_rl.shipping.tip_reach` and
:mod:`elastica_magnetic_rl.envs.yardsticks` (heavy imports happen inside the commands)."""

from __future__ import annotations

import argparse
import math
import os
import sys

from elastica_magnetic.cli import (
    CommandError,
    command_name,
    duration_option,
    heading_option,
    number,
    output_path,
    print_notes,
    print_result,
)

from ..cases.tasks import RING_TARGETS
from .options import (
    CASE_HELP,
    CHECKPOINT_HELP,
    FORCE_HELP,
    TARGET_HELP,
    case_option,
    print_rollout_result,
    ring_option,
    target_option,
    waypoints_option,
)

#: ``--duration`` of a rollout when not given, s.
DEFAULT_ROLLOUT_S = 10.0


def register(sub: argparse._SubParsersAction) -> None:
    """Add this module's sub-commands to ``msr``."""
    for add in (_add_generate_command, _add_baseline_command, _add_demo_command):
        add(sub)


def _add_rollout_options(p: argparse.ArgumentParser, out: str) -> None:
    """The options of the commands that roll a policy out and write what ``generate`` writes."""
    p.add_argument("--duration", type=duration_option(), default=None,
                   help="s (default 10; with --ring, the goto task's episode)")
    p.add_argument("--out", type=output_path, default=out)
    p.add_argument("--physics", choices=("accurate", "training"), default="accurate")
    p.add_argument("--no-figures", action="store_true", help="skip the figures and the GIF")
    p.add_argument("--no-gif", action="store_true", help="skip the GIF")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--json", action="store_true")
    p.add_argument("--force", action="store_true", help=FORCE_HELP)


def _pictures(args: argparse.Namespace):
    """The pictures ``--no-figures`` and ``--no-gif`` leave a rollout result."""
    from ..shipping.generate import Pictures

    return Pictures(figures=not args.no_figures, gif=not args.no_gif)


def _print_rollout_result(result: dict, as_json: bool) -> int:
    """Print a generate-like result (its notes first, on stderr); 1 if the rollout diverged."""
    print_notes(result.pop("notes", ()))
    print_rollout_result(result, as_json)
    return 0 if not result["diverged"] else 1


def _add_generate_command(sub: argparse._SubParsersAction) -> None:
    """``msr policy generate``."""
    p = sub.add_parser(
        "generate",
        help="generate a field waveform with a policy (accurate physics, field from zero)",
        description="Run a policy deterministically in the accurate physics with the field starting "
        "at zero; write fields.csv (index, mag_x, mag_y, mag_z in mT, 100 rows/s), trajectory.csv, "
        "rollout.npz, generate.json, the figures and gait.gif.",
    )
    p.add_argument("policy", help="run directory, checkpoint, shipped-policy folder or shipped name "
                                  "(e.g. m1-4mT)")
    p.add_argument("--checkpoint", default="auto", metavar="auto|final|best|PATH",
                   help=CHECKPOINT_HELP + " (evaluated for --duration s)")
    _add_goto_options(p)
    p.add_argument("--workers", type=number("", 1, integer=True), default=None,
                   help="--ring: targets run at a time (processes; default one per core)")
    _add_rollout_options(p, "out/generate")
    p.set_defaults(func=generate_command)


def _add_goto_options(p: argparse.ArgumentParser) -> None:
    """``--target`` and ``--ring``: where a goto case's robot is sent."""
    where = p.add_mutually_exclusive_group()
    where.add_argument("--target", type=target_option, default=None, metavar="FORWARD,LEFT|X,Y,Z",
                       help=TARGET_HELP)
    where.add_argument("--ring", type=ring_option, nargs="?", const=RING_TARGETS, default=None,
                       metavar="N", help=f"a goto case: send the robot to N targets (default "
                       f"{RING_TARGETS}) evenly spaced on the task's ring, each from the start, "
                       "for --duration s (default the task's episode); write ring.csv, ring.json "
                       "and ring.png (top view) instead of one rollout's files")
    where.add_argument("--waypoints", type=waypoints_option, default=None, metavar="F1,L1:F2,L2:...",
                       help="a goto case: a path, two or more FORWARD,LEFT points in m from the start "
                       "(as --target), each the target until the robot is within the task's tolerance "
                       "of it, the last held to the end; --duration defaults to the task's episode; "
                       "the result's goto block is of the last point, 'waypoints' gives when each was "
                       "reached, top_view.png draws the path")
    where.add_argument("--heading", type=heading_option, default=None, metavar="RAD",
                       help="a goto case: crawl along the line from the start at this heading (rad, "
                       "counter-clockwise seen from above, 0 ahead: 1.5708 is to the left) and keep "
                       "going, the target kept the task's distance ahead along the line; --duration "
                       "defaults to the task's episode; the result's 'heading' block gives the distance "
                       "along it and off it, top_view.png draws the line")
    where.add_argument("--validation", action="store_true",
                       help="a tip-reach case: steer to its 20 validation targets instead of the 20 "
                       "held-out ones (another seed; choose among seeds and checkpoints on these, so "
                       "that the held-out targets judge the chosen policy without having chosen it)")


def _refuse_validation(args: argparse.Namespace, case) -> None:
    """``--validation`` names a tip-reach case's target set: refused by name for any other case."""
    if args.validation:
        raise CommandError(f"--validation is a tip-reach case's set of validation targets; case "
                           f"{case.name!r} has the {case.task.kind} task")


def _where(args: argparse.Namespace) -> object:
    """Where a goto rollout goes: ``--target``'s point, ``--waypoints``' path or ``--heading``'s line."""
    from ..envs.waypoints import Heading, Waypoints

    if args.heading is not None:
        return Heading(args.heading)
    return args.target if args.waypoints is None else Waypoints(tuple(args.waypoints))


def _goto_args(args: argparse.Namespace, case) -> None:
    """Refuse ``--target``/``--ring`` for a case that is not goto (a tip-reach case's own
    checks: :func:`_tip_reach_args`), and a ``--target`` of three numbers (X,Y,Z, a tip-reach
    case's)."""
    from ..cases.tasks import GotoTask

    given = ("--target" if args.target is not None else "--ring" if args.ring is not None
             else "--waypoints" if args.waypoints is not None
             else "--heading" if args.heading is not None else None)
    if given and not isinstance(case.task, GotoTask):
        raise CommandError(f"{given} is for a goto case; case {case.name!r} has the "
                           f"{case.task.kind} task (it goes where its task says)")
    if args.target is not None and len(args.target) != 2:
        raise CommandError(f"--target of a goto case is FORWARD,LEFT in m from the start (two numbers); "
                           f"got {len(args.target)} (X,Y,Z is a tip-reach case's)")
    if args.target is not None or args.waypoints is not None:
        from ..shipping.goto import goto_target_notes

        if args.target is not None:
            print_notes(goto_target_notes(case, args.target))
        for k, point in enumerate(args.waypoints or (), start=1):
            print_notes(goto_target_notes(case, point, f"waypoint {k}"))


def _tip_reach_args(args: argparse.Namespace, case, command: str, refused: dict) -> None:
    """The options of ``command`` on a tip-reach case (a catheter steered by a source): those in
    ``refused`` (option: value) that cannot act are refused by name; ``--target`` is X,Y,Z; the
    duration defaults to the task's episode."""
    for option, value in refused.items():
        if value:
            raise CommandError(f"{option} does not apply to case {case.name!r}, steered by a source "
                               f"([actuation] kind = \"{case.actuation.kind}\"): {command} steers the tip to "
                               "each of the case's 20 held-out targets at once (or its 20 validation "
                               "targets: --validation), or to --target X,Y,Z (m)")
    if args.target is not None and len(args.target) != 3:
        raise CommandError(f"--target of a tip-reach case is X,Y,Z in m, in the spec's frame (three "
                           f"numbers); got {len(args.target)} (FORWARD,LEFT is a goto case's)")


def _ring_result(policy, args: argparse.Namespace, actor: dict | None = None) -> int:
    """``--ring``: the ring written into ``--out``, printed (``actor``: a run's actor choice)."""
    from ..shipping.goto import write_ring

    result = write_ring(policy, args.out, args.duration, args.physics, args.ring, force=args.force,
                        progress=not args.no_progress, workers=args.workers or os.cpu_count() or 1,
                        actor=actor, figures=not args.no_figures)
    print_notes(result.pop("notes", ()))
    if actor is not None:
        result = {**result, "actor_choice": actor}
    print_rollout_result(result, args.json)
    return 0


def _ring_of_run(loaded, args: argparse.Namespace) -> int:
    """``msr policy generate POLICY --ring``: of a run, the actor ``--checkpoint`` names (``auto``:
    the one a single rollout to the task's target straight ahead would play, compared as for
    ``--target``), said on an ``actor:`` line and in ``ring.json``."""
    from ..shipping.goto import check_ring_out, goto_target
    from ..shipping.policy_files import resolve_policy
    from ..shipping.policy_runs import choose_actor

    check_ring_out(loaded.case, args.out, "generate", args.force)  # before the actors' evaluations
    try:
        duration = args.duration if args.duration is not None else loaded.case.task.episode_duration
        choice = choose_actor(args.policy, args.checkpoint, duration, not args.no_progress,
                              goto_target(loaded.case, None))
    except FileNotFoundError as exc:
        raise CommandError(str(exc)) from None
    if choice is None:
        return _ring_result(loaded, args)
    return _ring_result(resolve_policy(choice.path), args,
                        {**choice.to_dict(), "summary": choice.describe()})


def _add_baseline_command(sub: argparse._SubParsersAction) -> None:
    """``msr field baseline``."""
    p = sub.add_parser(
        "baseline",
        help="generate with a hand-designed rotating field (the yardstick for learned policies)",
        description="Turn the field at the case's limit at a constant rate, through the agent's "
        "own action channel (0.3 mT per axis per 0.01 s, field from zero), and write the same "
        "files as `msr policy generate`: a rotating field rolls the robot, the gait to beat. Without "
        "--period, sweep the periods in both directions (worker processes; sweep.csv, sweep.png) "
        "and keep the farthest; the period the field really turned at under the rate limit is "
        "reported. Each 10 s run in the accurate physics takes about a minute; --physics training "
        "--duration 2 gives a quick look. A tip-reach case (a catheter steered by a magnet arm or "
        "coils): the steering yardstick on its 20 held-out targets (targets.csv, targets.json, "
        "targets.png), --duration the task's episode by default.",
    )
    p.add_argument("--case", type=case_option, required=True, help=CASE_HELP)
    p.add_argument("--period", type=number("s", 0.0, low_open=True), default=None,
                   help="s per turn of the field; without it, a sweep of --periods in both "
                        "directions, the farthest one's files written (a goto case: the steering "
                        "yardstick's, default the case's [yardstick] steering_period, 1 s where "
                        "not given)")
    p.add_argument("--counterclockwise", action="store_true",
                   help="turn the field counter-clockwise in the x-y plane, seen from +z (with "
                   "--period; default clockwise). Which way the robot then moves depends on its "
                   "magnetization: the paper's robots roll towards -x; the sweep tries both")
    p.add_argument("--periods", type=str, default=None, metavar="P1,P2,...",
                   help="the sweep's periods, s (default 0.5,0.75,1,1.5,2,2.5,3,4,5,6)")
    p.add_argument("--workers", type=number("", 1, integer=True), default=None,
                   help="sweep runs (or --ring targets) at a time (processes; default one per "
                        "core)")
    p.add_argument("--set-yardstick", type=output_path, default=None, metavar="OUT.toml",
                   help="write a copy of the case's spec with the sweep's best distance as "
                        "[yardstick] distance_10s (needs the accurate physics and 10 s)")
    p.add_argument("--turn-in-place", choices=("yes", "no"), default=None,
                   help="a goto case's steering yardstick: turn the robot in place until the target is "
                        "abeam before walking (yes), or walk toward every target, the field's plane "
                        "always toward it (no); default the case's [yardstick] turn_in_place (yes "
                        "where not given)")
    _add_goto_options(p)
    _add_rollout_options(p, "out/baseline")
    p.set_defaults(func=baseline_command)


def _add_demo_command(sub: argparse._SubParsersAction) -> None:
    """``msr policy demo``."""
    p = sub.add_parser(
        "demo",
        help="generate with the shipped pattern-1 4 mT policy (fields, figures, animation)",
    )
    p.add_argument("--out", type=output_path, default="out/demo")
    p.add_argument("--duration", type=duration_option(), default=DEFAULT_ROLLOUT_S,
                   help=f"s (default {DEFAULT_ROLLOUT_S:g})")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=demo_command)


def generate_command(args: argparse.Namespace) -> int:
    from ..shipping.generate import generate
    from ..shipping.policy_files import resolve_policy

    try:
        loaded = resolve_policy(args.policy)
    except FileNotFoundError as exc:
        raise CommandError(str(exc)) from None
    if not loaded.case.field_actuated:
        return _tip_reach_generate(args, loaded)
    _refuse_validation(args, loaded.case)
    if args.workers is not None and args.ring is None:
        raise CommandError("--workers is the number of --ring targets run at a time; a single "
                           "rollout runs in one process: leave it out, or give --ring")
    if args.waypoints is not None or args.heading is not None:
        _goto_args(args, loaded.case)  # before the duration: a crawl case's is refused by name
        args.duration = loaded.case.task.episode_duration if args.duration is None else args.duration
    if args.ring is None and args.duration is None:
        args.duration = DEFAULT_ROLLOUT_S
    if args.target is not None or args.ring is not None:
        _goto_args(args, loaded.case)
        if args.ring is not None:
            return _ring_of_run(loaded, args)
    try:
        result = generate(args.policy, duration=args.duration, out=args.out, physics=args.physics,
                          progress=not args.no_progress, pictures=_pictures(args),
                          checkpoint=args.checkpoint, force=args.force, target=_where(args))
    except FileNotFoundError as exc:
        raise CommandError(str(exc)) from None
    return _print_rollout_result(result, args.json)


def _tip_targets(args: argparse.Namespace) -> object:
    """The targets a tip-reach command steers to: ``--target``'s point, ``"validation"`` (the
    validation targets) with ``--validation``, else ``None`` (the held-out targets)."""
    return "validation" if args.validation else args.target


def _drive_of(case, target) -> object | None:
    """The recorder of the drive a single ``--target``'s steering writes (its magnet path or coil
    currents, and the tip's path: what ``msr real identify`` reads); None for the held-out targets."""
    from ..sim2real.identify import drive_recorder

    return drive_recorder(case) if target is not None else None


def _tip_reach_generate(args: argparse.Namespace, loaded) -> int:
    """``msr policy generate`` of a tip-reach policy: its actor steering the tip to the case's
    held-out targets, or to ``--target X,Y,Z``, written as the yardstick's are (targets.csv/json/png)."""
    from ..shipping.policy_files import resolve_policy
    from ..shipping.policy_runs import choose_tip_reach_actor
    from ..shipping.tip_reach import Steering, actor_controller, target_notes, write_targets

    _tip_reach_args(args, loaded.case, "msr policy generate",
                    {"--ring": args.ring is not None, "--workers": args.workers, "--no-gif": args.no_gif,
                     "--waypoints": args.waypoints, "--heading": args.heading is not None})
    try:
        choice = choose_tip_reach_actor(args.policy, args.checkpoint)
    except FileNotFoundError as exc:
        raise CommandError(str(exc)) from None
    if choice is not None:
        loaded = resolve_policy(choice.path)
    print_notes(target_notes(loaded.case, args.target) if args.target is not None else ())
    steering = Steering(actor_controller(loaded), f"policy {loaded.source}")
    result = write_targets(loaded.case, args.out, steering, physics=args.physics, duration=args.duration,
                           force=args.force, kind="generate", figures=not args.no_figures,
                           targets=_tip_targets(args), drive=_drive_of(loaded.case, args.target))
    if choice is not None:
        result["actor_choice"] = {**choice.to_dict(), "summary": choice.describe()}
    print_notes(result.pop("notes", ()))
    print_result(result, args.json)
    return 0


def baseline_command(args: argparse.Namespace) -> int:
    from elastica_magnetic import read_field_csv

    from ..cases.tasks import GotoTask
    from ..envs.yardsticks import RotatingFieldPolicy
    from ..shipping.baseline_sweep import achieved_period
    from ..shipping.generate import generate

    if not args.case.field_actuated:
        return _tip_reach_baseline(args)
    _refuse_validation(args, args.case)
    _goto_args(args, args.case)
    if isinstance(args.case.task, GotoTask):
        return _steering_baseline(args)
    if args.turn_in_place is not None:
        raise CommandError(f"--turn-in-place is a goto case's steering yardstick's; case {args.case.name!r} "
                           f"has the {args.case.task.kind} task, whose yardstick is a rotating field: "
                           "leave it out")
    if args.duration is None:
        args.duration = DEFAULT_ROLLOUT_S
    if args.set_yardstick is not None and (args.physics != "accurate" or args.duration != 10.0):
        raise CommandError("--set-yardstick: a yardstick is the distance in 10 s of the accurate "
                           f"physics; got --physics {args.physics} --duration {args.duration:g}")
    if args.period is None:
        return _baseline_sweep(args)
    if args.periods is not None or args.set_yardstick is not None:
        raise CommandError("--periods and --set-yardstick belong to the sweep: leave out --period")
    if args.workers is not None:
        raise CommandError("--workers is the number of sweep runs run at a time; --period runs one "
                           "rollout, in one process: leave it out, or drop --period to sweep")
    if args.period > args.duration:  # the field would not turn once: nothing to measure
        raise CommandError(_period_past_duration(args.period, args.duration, "the field"))
    try:
        policy = RotatingFieldPolicy(args.case, args.period, clockwise=not args.counterclockwise)
    except ValueError as exc:
        raise CommandError(f"--period: {exc}") from None
    result = generate(policy, duration=args.duration, out=args.out, physics=args.physics,
                      progress=not args.no_progress, pictures=_pictures(args),
                      force=args.force, kind="baseline")
    if result["fields_csv"]:
        result |= achieved_period(read_field_csv(result["fields_csv"]), args.period, args.case)
        if result["warning"]:
            print(f"warning: {result['warning']}", file=sys.stderr)
    return _print_rollout_result(result, args.json)


#: s: a rotation period this long is more likely ms written for s (the yardsticks turn in 0.5-6 s).
_PERIOD_LIKELY_MS = 100.0


def _period_past_duration(period: float, duration: float, field: str) -> str:
    """The refusal of a ``--period`` (s) longer than the run's ``duration`` (s), with the ms slip
    named where the period reads as one."""
    slip = (f" (ms written for s? {period:g} ms is {period / 1e3:g} s)"
            if period >= _PERIOD_LIKELY_MS else "")
    return (f"--period {period:g} s is longer than --duration {duration:g} s: {field} would not turn "
            f"once in the run{slip}; give a longer --duration or a shorter --period")


def _tip_reach_baseline(args: argparse.Namespace) -> int:
    """``msr field baseline`` of a case steered by a source: the steering yardstick on the
    case's held-out targets (or ``--target X,Y,Z``), written into ``--out``."""
    from ..shipping.tip_reach import Steering, steering_controller, target_notes, write_targets

    _tip_reach_args(args, args.case, "its yardstick", {
        "--period": args.period, "--counterclockwise": args.counterclockwise, "--periods": args.periods,
        "--set-yardstick": args.set_yardstick, "--workers": args.workers, "--ring": args.ring is not None,
        "--no-gif": args.no_gif, "--waypoints": args.waypoints, "--heading": args.heading is not None,
        "--turn-in-place": args.turn_in_place})
    print_notes(target_notes(args.case, args.target) if args.target is not None else ())
    result = write_targets(args.case, args.out, Steering(steering_controller), physics=args.physics,
                           duration=args.duration, force=args.force, figures=not args.no_figures,
                           targets=_tip_targets(args), drive=_drive_of(args.case, args.target))
    print_notes(result.pop("notes", ()))
    print_result(result, args.json)
    return 0


def _steering_baseline(args: argparse.Namespace) -> int:
    """``msr field baseline`` of a goto case: the steering yardstick to one target or a ring."""
    from ..envs.yardsticks import SteeringFieldPolicy
    from ..shipping.generate import generate

    for option, value in (("--counterclockwise", args.counterclockwise), ("--periods", args.periods),
                          ("--set-yardstick", args.set_yardstick)):
        if value:
            raise CommandError(f"{option} belongs to the rotating-field sweep of a crawl case; case "
                               f"{args.case.name!r} is a goto case, whose yardstick steers a field "
                               "turning clockwise (--period, default the case's [yardstick] "
                               f"steering_period, {args.case.yardstick.steering_turn:g} s) toward the target")
    try:
        turn = None if args.turn_in_place is None else args.turn_in_place == "yes"
        policy = SteeringFieldPolicy(args.case, args.period, turn_in_place=turn)
    except ValueError as exc:
        raise CommandError(f"--period: {exc}") from None
    if args.ring is not None:
        return _ring_result(policy, args)
    if args.workers is not None:
        raise CommandError("--workers is the number of --ring targets run at a time; one target "
                           "runs one rollout, in one process: leave it out, or give --ring")
    if args.duration is None:
        args.duration = (DEFAULT_ROLLOUT_S if args.waypoints is None and args.heading is None
                         else args.case.task.episode_duration)
    if args.period is not None and args.period > args.duration:
        raise CommandError(_period_past_duration(args.period, args.duration, "the steering field"))
    result = generate(policy, duration=args.duration, out=args.out, physics=args.physics,
                      progress=not args.no_progress, pictures=_pictures(args),
                      force=args.force, kind="baseline", target=_where(args))
    return _print_rollout_result(result, args.json)


def _baseline_sweep(args: argparse.Namespace) -> int:
    """``msr field baseline`` without ``--period``: the sweep, its table and the best run."""
    from ..shipping.baseline_sweep import (
        DEFAULT_PERIODS,
        periods_that_turn,
        sweep_baseline,
        yardstick_spec,
    )

    periods = DEFAULT_PERIODS
    if args.periods is not None:
        try:
            periods = tuple(float(p) for p in args.periods.split(","))
        except ValueError:
            raise CommandError(f"--periods must be comma-separated times in s, got {args.periods!r}") \
                from None
        if not all(math.isfinite(p) and p > 0 for p in periods):
            raise CommandError(f"--periods must be positive finite times in s, got {args.periods!r}")
        twice = sorted({p for p in periods if periods.count(p) > 1})
        if twice:  # each would be simulated again (minutes each in the accurate physics)
            raise CommandError(f"--periods: {', '.join(f'{p:g}' for p in twice)} s given twice; give each "
                               "period once")
    if args.counterclockwise:
        raise CommandError("--counterclockwise needs --period (the sweep tries both directions)")
    try:
        dropped = periods_that_turn(periods, args.duration)[1]  # the sweep leaves them out
    except ValueError as exc:
        raise CommandError(f"--periods: {exc}") from None
    if args.set_yardstick is not None:  # checked before the sweep's minutes
        from elastica_magnetic.result_file import check_result_file
        from elastica_magnetic.specfile import SPEC_FILE

        from ..shipping.policy_files import check_policy_case

        check_result_file(args.set_yardstick, force=args.force, option="--set-yardstick",
                          kind=SPEC_FILE)
        check_policy_case(args.set_yardstick, args.case, option="--set-yardstick",
                          what="this spec is")
    if dropped:  # after every refusal: the warning is for a sweep that runs
        left_out = ", ".join(f"{p:g}" for p in dropped)
        print(f"msr {command_name(args)}: warning: --periods {left_out} s left out: longer "
              f"than --duration {args.duration:g} s, the field would not turn once",
              file=sys.stderr)
    try:
        result = sweep_baseline(args.case, periods, args.duration, args.physics, args.out,
                                args.workers, not args.no_progress, not args.no_figures,
                                not args.no_gif, force=args.force)
    except ValueError as exc:
        raise CommandError(str(exc)) from None
    best = result["best"]
    if args.set_yardstick is not None:
        result["yardstick_spec"] = str(yardstick_spec(args.case, best, args.set_yardstick,
                                                      force=args.force))
    if args.json:
        print_result(result, True)
        return 0
    print(f"{result['case']}: rotating field at {1e3 * args.case.field_limit:g} mT, distance in "
          f"{result['duration_s']:g} s of {result['physics']} physics from a zero field")
    print(f"{'period s':>9} {'turned s':>9} {'direction':>18} {'distance mm':>12}")
    for r in sorted(result["runs"], key=lambda r: (r["period_s"], not r["clockwise"])):
        moved = "diverged" if r["diverged"] else f"{1e3 * r['mid_dx_m']:+.2f}"
        mark = "  <- best" if r == best else ""
        print(f"{r['period_s']:>9g} {r['period_achieved_s']:>9.4g} "
              f"{'clockwise' if r['clockwise'] else 'counter-clockwise':>18} {moved:>12}{mark}")
    if best["warning"]:
        print(f"warning: the best run {best['warning']}")
    for key in ("table_csv", "figure", "yardstick_spec"):
        if result.get(key):
            print(f"{key}: {result[key]}")
    print(f"best run's files: {args.out} (fields.csv, trajectory.csv, generate.json)")
    return 0


def demo_command(args: argparse.Namespace) -> int:
    from ..shipping.generate import demo

    result = demo(args.out, duration=args.duration, progress=not args.no_progress)
    return _print_rollout_result(result, args.json)
