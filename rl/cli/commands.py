"""``msr case``, ``bench``, ``figures`` (the rollouts ``generate``, ``baseline`` and ``demo`` are
:mod:`elastica_magnetic_rl.cli.rollout_commands`, training
:mod:`elastica_magnetic_rl.cli.train_commands`, the policy commands
:mod:`elastica_magnetic_rl.cli.policy_commands`): thin wrappers over
:mod:`elastica_magnetic_rl.cases.case`, :mod:`elastica_magnetic_rl.reports.bench` and
:mod:`elastica_magnetic_rl.reports.figures` (heavy imports happen inside the commands)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from elastica_magnetic.cli import CommandError, number, output_path, print_result
from elastica_magnetic.cli.input_places import REPLACED_FOLDER, no_folder_replaced_whole

from .options import CASE_HELP, case_option, checked_spec_option


def register(sub: argparse._SubParsersAction) -> None:
    """Add this module's sub-commands to ``msr``."""
    for add in (_add_case_command, _add_bench_command, _add_figures_command):
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
    p.set_defaults(func=figures_command, **{REPLACED_FOLDER: no_folder_replaced_whole})


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
        columns = [[r["name"], r["robot"], r["magnetization"],
                    {"magnet-pose": "magnet", "coil-currents": "coils"}[r["actuation"]]
                    if r["field_limit_mT"] is None else f"{r['field_limit_mT']:g} mT", r["task"]]
                   for r in rows]
        # each column as wide as its longest entry (a user's case may have a long name)
        widths = [max(len(row[i]) for row in columns) for i in range(5)] if columns else []
        for r, row in zip(rows, columns, strict=True):
            name, robot, magnetization, actuation, task = (
                value.rjust(width) if i == 3 else value.ljust(width)
                for i, (value, width) in enumerate(zip(row, widths, strict=True)))
            print(f"{name} {robot} {magnetization} {actuation}  {task} target {r['target']}")
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


def figures_command(args: argparse.Namespace) -> int:
    from ..reports.figures import make_figures
    from ..shipping.policy_files import check_policy_case, figure_cases, other_result_refusal, resolve_policy

    out = args.out if args.out is not None else args.path
    for case in figure_cases(args.path):  # a shipped policy's seeds/ takes its own case's figures only
        check_policy_case(out, case, option="--out", what="these figures are")
    try:
        result = make_figures(args.path, args.out, gif=not args.no_gif, load_policy=resolve_policy,
                              force=args.force)
    except FileNotFoundError:  # another command's result (a ring, an export...) is named
        refusal = other_result_refusal(Path(args.path), "a generate output (rollout.npz) or training "
                                                        "runs (episodes.csv)")
        if refusal is None:
            raise
        raise CommandError(refusal) from None
    print_result(result, args.json)
    return 0
