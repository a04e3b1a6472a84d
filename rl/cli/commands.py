"""``msr case``, ``bench``, ``generate``, ``baseline``, ``figures``, ``demo`` (training is
:mod:`elastica_magnetic_rl.cli.train_commands`, the policy commands
:mod:`elastica_magnetic_rl.cli.policy_commands`): thin wrappers over
:mod:`elastica_magnetic_rl.cases.case`, :mod:`elastica_magnetic_rl.reports.bench`,
:mod:`elastica_magnetic_rl.shipping.generate`, :mod:`elastica_magnetic_rl.envs.yardsticks` and
:mod:`elastica_magnetic_rl.reports.figures` (heavy imports happen inside the commands)."""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

from elastica_magnetic.cli import (
    CommandError,
    command_name,
    duration_option,
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
    checked_spec_option,
    print_rollout_result,
    ring_option,
    target_option,
)

#: ``--duration`` of a rollout when not given, s.
DEFAULT_ROLLOUT_S = 10.0


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


def register(sub: argparse._SubParsersAction) -> None:
    """Add this module's sub-commands to ``msr``."""
    for add in (_add_case_command, _add_bench_command, _add_generate_command, _add_baseline_command,
                _add_figures_command, _add_demo_command):
        add(sub)


def _add_case_command(sub: argparse._SubParsersAction) -> None:
    """``msr case``."""
    p = sub.add_parser(
        "case",
        help="list the shipped cases, or show one as a spec file to copy and edit",
        description="`msr case list`: the shipped cases (robot, field limit, task, yardstick). "
        "`msr case show NAME_OR_PATH`: a readable summary; `msr case check NAME_OR_PATH`: the spec's "
        "derived quantities, time-step margins, sag and warnings; `msr case show NAME_OR_PATH "
        "--toml > my.toml`: the complete spec, every default written "
        "out, units in comments; edit it and use it anywhere a case is taken (msr train --case "
        "my.toml, msr field simulate --robot my.toml).",
    )
    case_sub = p.add_subparsers(dest="case_command", required=True, metavar="{list,show,check}")
    q = case_sub.add_parser("list", help="the shipped cases")
    q.add_argument("--json", action="store_true")
    q.set_defaults(func=case_list_command)
    q = case_sub.add_parser("show", help="one case's complete spec")
    q.add_argument("case", type=case_option, help=CASE_HELP)
    form = q.add_mutually_exclusive_group()  # one printed form: each option would ignore the other
    form.add_argument("--toml", action="store_true", help="print the spec as TOML (a file to edit)")
    form.add_argument("--json", action="store_true", help="print the complete spec as JSON")
    q.set_defaults(func=case_show_command)
    q = case_sub.add_parser(
        "check", help="what a spec's numbers amount to, and what in them is outside the model",
        description="Derived quantities (shear modulus, equivalent radius, mass, bending "
        "stiffness, magnetic bending number), each physics' time step against its estimated "
        "stable step, the static sag into the ground under the weight and at the field limit "
        "(simulated, a few seconds), and warnings; exits 1 when it finds an error.")
    q.add_argument("case", type=checked_spec_option,
                   help=CASE_HELP + "; a spec without [task] (a robot for msr field simulate --robot) "
                   "has its robot checked")
    q.add_argument("--no-sag", action="store_true", help="skip the sag simulations")
    q.add_argument("--json", action="store_true")
    q.set_defaults(func=case_check_command)


def _add_bench_command(sub: argparse._SubParsersAction) -> None:
    """``msr bench``."""
    p = sub.add_parser(
        "bench",
        help="step cost, batched robots, environment and TD3 rates, training time of 8 seeds",
        description="In one run: the paper robot's step cost (ours vs per-element Python loops, "
        "training and accurate physics), the per-robot-step cost of N = 1, 4, 16, 64 robots in one "
        "batched simulator, environment steps/s (single and vector environment), TD3 updates/s "
        "(one seed, and seeds stacked, fp32 and bf16) against the matrix-product rate, and the wall "
        "time of 8 seeds x 1e5 steps extrapolated from a real run in the default layout "
        "(train_8_seeds_1e5_s), and the step cost under fields in space (a point dipole, a moving "
        "dipole, a Helmholtz pair) with its ratio to the uniform field's (target at most 2x). A few "
        "minutes; --quick --train-seeds 0 for a rough look in under a minute.",
    )
    p.add_argument("--steps", type=number("", 1, integer=True), default=None,
                   help="time steps per step-cost measurement (default 1000; --quick: 200)")
    p.add_argument("--repeats", type=number("", 1, integer=True), default=None,
                   help="measurements per configuration (default 3; --quick: 1)")
    p.add_argument("--vector-envs", type=number("", 1, integer=True), default=16,
                   help="crawlers in the vector environment measured (default 16)")
    p.add_argument("--train-seeds", type=number("", 0, integer=True), default=8, metavar="N",
                   help="seeds of the real training run behind train_8_seeds_1e5_s (default 8; the key "
                        "keeps its name for N seeds, train_seeds says N; the run's settings over the "
                        "recipe in training_time.settings_over_recipe; 0: skip it)")
    p.add_argument("--quick", action="store_true", help="tiny measurements (smoke test; rough numbers)")
    p.add_argument("--memory-seeds", type=number("", 0, integer=True), default=0, metavar="N",
                   help="also measure the peak memory of a real N-seed training run in the default "
                   "layout (Linux; a few minutes for N = 8; default 0: skip)")
    p.add_argument("--memory-steps", type=number("", 1, integer=True), default=None,
                   help="environment steps per seed of that run (default 3000: past the warm-up)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=bench_command)


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


def _goto_args(args: argparse.Namespace, case) -> None:
    """Refuse ``--target``/``--ring`` for a case that is not goto (a tip-reach case's own
    checks: :func:`_tip_reach_args`), and a ``--target`` of three numbers (X,Y,Z, a tip-reach
    case's)."""
    from ..cases.tasks import GotoTask

    given = "--target" if args.target is not None else "--ring" if args.ring is not None else None
    if given and not isinstance(case.task, GotoTask):
        raise CommandError(f"{given} is for a goto case; case {case.name!r} has the "
                           f"{case.task.kind} task (it goes where its task says)")
    if args.target is not None and len(args.target) != 2:
        raise CommandError(f"--target of a goto case is FORWARD,LEFT in m from the start (two numbers); "
                           f"got {len(args.target)} (X,Y,Z is a tip-reach case's)")


def _tip_reach_args(args: argparse.Namespace, case, command: str, refused: dict) -> None:
    """The options of ``command`` on a tip-reach case (a catheter steered by a source): those in
    ``refused`` (option: value) that cannot act are refused by name; ``--target`` is X,Y,Z; the
    duration defaults to the task's episode."""
    for option, value in refused.items():
        if value:
            raise CommandError(f"{option} does not apply to case {case.name!r}, steered by a source "
                               f"([actuation] kind = \"{case.actuation.kind}\"): {command} steers the tip to "
                               "each of the case's 20 held-out targets at once, or to --target X,Y,Z (m)")
    if args.target is not None and len(args.target) != 3:
        raise CommandError(f"--target of a tip-reach case is X,Y,Z in m, in the spec's frame (three "
                           f"numbers); got {len(args.target)} (FORWARD,LEFT is a goto case's)")


def _ring_result(policy, args: argparse.Namespace, kind: str) -> int:
    """``--ring``: the ring written into ``--out``, printed."""
    from ..shipping.goto import write_ring

    result = write_ring(policy, args.out, args.duration, args.physics, args.ring, force=args.force,
                        progress=not args.no_progress, kind=kind,
                        workers=args.workers or os.cpu_count() or 1)
    print_notes(result.pop("notes", ()))
    print_result(result, args.json)
    return 0


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
                        "yardstick's period, default 1 s)")
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
    _add_goto_options(p)
    _add_rollout_options(p, "out/baseline")
    p.set_defaults(func=baseline_command)


def _add_figures_command(sub: argparse._SubParsersAction) -> None:
    """``msr policy figures``."""
    p = sub.add_parser(
        "figures",
        help="regenerate figures of training runs or of a generate output",
        description="PATH is a training output (learning curves per case) or a generate output "
        "(holding rollout.npz: gait, field, contact and Q-value figures, GIF).",
    )
    p.add_argument("path", type=Path)
    p.add_argument("--out", type=output_path, default=None, help="default: PATH")
    p.add_argument("--force", action="store_true",
                   help="replace figures already in --out (other files there are never touched)")
    p.add_argument("--no-gif", action="store_true")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=figures_command)


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


def case_list_command(args: argparse.Namespace) -> int:
    from ..cases.case import case_names, load_case

    rows = []
    for name in case_names():
        case = load_case(name)
        rows.append({"name": name, "robot": case.robot.name,
                     "magnetization": case.robot.tables["robot"]["magnetization"]["kind"],
                     "actuation": "field" if case.field_actuated else case.actuation.kind,
                     "field_limit_mT": 1e3 * case.field_limit if case.field_actuated else None,
                     "task": case.task.kind, "target": case.target_label,
                     "description": case.description})
    if args.json:
        print_result({"cases": rows}, True)
    else:
        for r in rows:
            actuation = ({"magnet-pose": "magnet", "coil-currents": "coils"}[r["actuation"]]
                         if r["field_limit_mT"] is None else f"{r['field_limit_mT']:g} mT")
            print(f"{r['name']:<14} {r['robot']:<12} {r['magnetization']:<18} "
                  f"{actuation:>8}  {r['task']:<6} target {r['target']}")
    return 0


def case_show_command(args: argparse.Namespace) -> int:
    case = args.case
    if args.toml:
        sys.stdout.write(case.toml())
    elif args.json:
        print_result(case.to_dict(), True)
    else:
        from ..cases.check import case_summary

        print(case_summary(case))
    return 0


def case_check_command(args: argparse.Namespace) -> int:
    from elastica_magnetic.spec_check import format_check

    from ..cases.check import RobotOnlySpec, check_with_warnings, coverage

    sag = not args.no_sag
    check = check_with_warnings(args.case, sag=sag)
    # a spec without a task: what is checked, and what cannot be, is said
    covered = coverage(args.case, check, sag=sag) if isinstance(args.case, RobotOnlySpec) else {}
    if args.json:
        print_result({**check.to_dict(), **covered}, True)
    else:
        print(format_check(check))
        if covered:
            print(f"  checked: {', '.join(covered['checked'])}; not checked: "
                  f"{'; '.join(covered['not_checked'])}")
    return 1 if check.has_errors else 0


def bench_command(args: argparse.Namespace) -> int:
    from ..reports.bench import QUICK_REPEATS, QUICK_STEPS, benchmark, benchmark_text, training_peak_memory

    if args.quick:  # its sizes are fixed small: a larger ask would be ignored
        for option, value, most in (("--steps", args.steps, QUICK_STEPS),
                                    ("--repeats", args.repeats, QUICK_REPEATS)):
            if value is not None and value > most:
                raise CommandError(f"{option} {value}: --quick measures at most {most} (its tiny sizes "
                                   f"are fixed); leave --quick out to measure with {option} {value}")
    args.steps = 1000 if args.steps is None else args.steps
    args.repeats = 3 if args.repeats is None else args.repeats
    if args.steps < 1 or args.repeats < 1 or args.vector_envs < 1:
        raise CommandError("--steps, --repeats and --vector-envs must be >= 1")
    if args.memory_steps is not None and not args.memory_seeds:
        raise CommandError("--memory-steps sets the steps of the --memory-seeds run, which is off: "
                           "give --memory-seeds N too, or leave --memory-steps out")
    if args.memory_steps is None:
        args.memory_steps = 3000
    if args.memory_seeds < 0 or args.memory_steps < 1 or args.train_seeds < 0:
        raise CommandError("--memory-seeds and --train-seeds must be >= 0 and --memory-steps >= 1")
    result = benchmark(steps=args.steps, repeats=args.repeats, quick=args.quick,
                       vector_envs=args.vector_envs, train_seeds=args.train_seeds)
    if args.memory_seeds:
        result["training_memory"] = training_peak_memory(args.memory_seeds, args.memory_steps)
    if args.json:
        print_result(result, True)
    else:
        print(benchmark_text(result))
    return 0


def generate_command(args: argparse.Namespace) -> int:
    from ..shipping.generate import generate
    from ..shipping.policy_files import resolve_policy

    try:
        loaded = resolve_policy(args.policy)
    except FileNotFoundError as exc:
        raise CommandError(str(exc)) from None
    if not loaded.case.field_actuated:
        return _tip_reach_generate(args, loaded)
    if args.workers is not None and args.ring is None:
        raise CommandError("--workers is the number of --ring targets run at a time; a single "
                           "rollout runs in one process: leave it out, or give --ring")
    if args.ring is None and args.duration is None:
        args.duration = DEFAULT_ROLLOUT_S
    if args.target is not None or args.ring is not None:
        _goto_args(args, loaded.case)
        if args.ring is not None:
            return _ring_result(loaded, args, "generate")
    try:
        result = generate(args.policy, duration=args.duration, out=args.out, physics=args.physics,
                          progress=not args.no_progress, pictures=_pictures(args),
                          checkpoint=args.checkpoint, force=args.force, target=args.target)
    except FileNotFoundError as exc:
        raise CommandError(str(exc)) from None
    return _print_rollout_result(result, args.json)


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
                    {"--ring": args.ring is not None, "--workers": args.workers, "--no-gif": args.no_gif})
    try:
        choice = choose_tip_reach_actor(args.policy, args.checkpoint)
    except FileNotFoundError as exc:
        raise CommandError(str(exc)) from None
    if choice is not None:
        loaded = resolve_policy(choice.path)
    print_notes(target_notes(loaded.case, args.target) if args.target is not None else ())
    steering = Steering(actor_controller(loaded.actor), f"policy {loaded.source}")
    result = write_targets(loaded.case, args.out, steering, physics=args.physics, duration=args.duration,
                           force=args.force, kind="generate", figures=not args.no_figures,
                           targets=args.target, drive=_drive_of(loaded.case, args.target))
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
    _goto_args(args, args.case)
    if isinstance(args.case.task, GotoTask):
        return _steering_baseline(args)
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
        raise CommandError(f"--period {args.period:g} s is longer than --duration {args.duration:g} "
                           "s: the field would not turn once in the run; give a longer --duration "
                           "or a shorter --period")
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


def _tip_reach_baseline(args: argparse.Namespace) -> int:
    """``msr field baseline`` of a case steered by a source: the steering yardstick on the
    case's held-out targets (or ``--target X,Y,Z``), written into ``--out``."""
    from ..shipping.tip_reach import Steering, steering_controller, target_notes, write_targets

    _tip_reach_args(args, args.case, "its yardstick", {
        "--period": args.period, "--counterclockwise": args.counterclockwise, "--periods": args.periods,
        "--set-yardstick": args.set_yardstick, "--workers": args.workers, "--ring": args.ring is not None,
        "--no-gif": args.no_gif})
    print_notes(target_notes(args.case, args.target) if args.target is not None else ())
    result = write_targets(args.case, args.out, Steering(steering_controller), physics=args.physics,
                           duration=args.duration, force=args.force, figures=not args.no_figures,
                           targets=args.target, drive=_drive_of(args.case, args.target))
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
                               "turning clockwise (--period, default 1 s) toward the target")
    try:
        policy = SteeringFieldPolicy(args.case, args.period if args.period is not None else 1.0)
    except ValueError as exc:
        raise CommandError(f"--period: {exc}") from None
    if args.ring is not None:
        return _ring_result(policy, args, "baseline")
    if args.workers is not None:
        raise CommandError("--workers is the number of --ring targets run at a time; one target "
                           "runs one rollout, in one process: leave it out, or give --ring")
    if args.duration is None:
        args.duration = DEFAULT_ROLLOUT_S
    if args.period is not None and args.period > args.duration:
        raise CommandError(f"--period {args.period:g} s is longer than --duration {args.duration:g} "
                           "s: the steering field would not turn once in the run; give a longer "
                           "--duration or a shorter --period")
    result = generate(policy, duration=args.duration, out=args.out, physics=args.physics,
                      progress=not args.no_progress, pictures=_pictures(args),
                      force=args.force, kind="baseline", target=args.target)
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


def figures_command(args: argparse.Namespace) -> int:
    from ..reports.figures import make_figures
    from ..shipping.policy_files import check_policy_case, figure_cases, resolve_policy

    out = args.out if args.out is not None else args.path
    for case in figure_cases(args.path):  # a shipped policy's seeds/ takes its own case's figures only
        check_policy_case(out, case, option="--out", what="these figures are")
    print_result(make_figures(args.path, args.out, gif=not args.no_gif, load_policy=resolve_policy,
                              force=args.force), args.json)
    return 0


def demo_command(args: argparse.Namespace) -> int:
    from ..shipping.generate import demo

    result = demo(args.out, duration=args.duration, progress=not args.no_progress)
    return _print_rollout_result(result, args.json)
