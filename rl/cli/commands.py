"""``msr case``, ``train``, ``bench``, ``refine``, ``generate``, ``baseline``, ``figures``, ``demo``
(the policy commands are :mod:`elastica_magnetic_rl.cli.policy_commands`): thin wrappers over
:mod:`elastica_magnetic_rl.cases.case`, :mod:`elastica_magnetic_rl.sweep.training`,
:mod:`elastica_magnetic_rl.shipping.generate`, :mod:`elastica_magnetic_rl.shipping.baselines` and
:mod:`elastica_magnetic_rl.reports.figures` (heavy imports happen inside the commands)."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from elastica_magnetic.cli import CommandError, duration_option, number, print_notes, print_result

from ..cases.recipes import RECIPE_SUMMARIES, RECIPES
from ..runfiles.rundir import CaseDir, RunDir

CHECKPOINT_HELP = ("which actor of a run: auto (default: the final actor and best.pt evaluated in "
                   "the accurate physics from a zero field, the farther used), final, best, or a "
                   "checkpoint file")
CASE_HELP = "a shipped case (`msr case list`: m1-4mT, m2-4mT, m1-10mT, m2-10mT, ...) or a spec file (.toml)"


def case_option(value: str):
    """``--case NAME_OR_PATH``: the case, loaded and checked at parse time (a bad spec file is an
    argparse error naming the file and the key, before any work starts)."""
    from elastica_magnetic.specfile import SpecError

    from ..cases.case import load_case

    try:
        return load_case(value)
    except SpecError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _add_rollout_options(p: argparse.ArgumentParser, out: Path) -> None:
    """The options of the commands that roll a policy out and write what ``generate`` writes."""
    p.add_argument("--duration", type=duration_option(), default=10.0, help="s")
    p.add_argument("--out", type=Path, default=out)
    p.add_argument("--physics", choices=("accurate", "training"), default="accurate")
    p.add_argument("--no-figures", action="store_true", help="skip the figures and the GIF")
    p.add_argument("--no-gif", action="store_true", help="skip the GIF")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--json", action="store_true")
    p.add_argument("--force", action="store_true", help=FORCE_HELP)


FORCE_HELP = ("replace an earlier result of this command for the same case in --out (without it "
              "an existing result is refused; another command's or case's result always is)")


def _print_rollout_result(result: dict, as_json: bool) -> int:
    """Print a generate-like result (its notes first, on stderr); 1 if the rollout diverged."""
    print_notes(result.pop("notes", ()))
    print_rollout_result(result, as_json)
    return 0 if not result["diverged"] else 1


def register(sub: argparse._SubParsersAction) -> None:
    """Add this module's sub-commands to ``msr``."""
    for add in (_add_case_command, _add_train_command, _add_bench_command, _add_refine_command,
                _add_generate_command, _add_baseline_command, _add_figures_command, _add_demo_command):
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
        "my.toml, msr simulate --robot my.toml).",
    )
    case_sub = p.add_subparsers(dest="case_command", required=True, metavar="{list,show,check}")
    q = case_sub.add_parser("list", help="the shipped cases")
    q.add_argument("--json", action="store_true")
    q.set_defaults(func=case_list_command)
    q = case_sub.add_parser("show", help="one case's complete spec")
    q.add_argument("case", type=case_option, help=CASE_HELP)
    q.add_argument("--toml", action="store_true", help="print the spec as TOML (a file to edit)")
    q.add_argument("--json", action="store_true", help="print the complete spec as JSON")
    q.set_defaults(func=case_show_command)
    q = case_sub.add_parser(
        "check", help="what a spec's numbers amount to, and what in them is outside the model",
        description="Derived quantities (shear modulus, equivalent radius, mass, bending "
        "stiffness, magnetic bending number), each physics' time step against its estimated "
        "stable step, the static sag into the ground under the weight and at the field limit "
        "(simulated, a few seconds), and warnings; exits 1 when it finds an error.")
    q.add_argument("case", type=case_option, help=CASE_HELP)
    q.add_argument("--no-sag", action="store_true", help="skip the sag simulations")
    q.add_argument("--json", action="store_true")
    q.set_defaults(func=case_check_command)


def _add_train_command(sub: argparse._SubParsersAction) -> None:
    """``msr train``."""
    p = sub.add_parser(
        "train",
        help="train TD3 crawling policies for one or more cases, several seeds in parallel",
        description="Train TD3 on one or more cases in the mass-scaled training physics (random "
        "initial fields, 20 s truncated episodes by default: the case's). Each seed writes "
        "OUT/<case>/seed<k>/ (episodes.csv, TensorBoard scalars, checkpoint.pt, run.json, which "
        "store the complete case spec); OUT/<case>/summary.json collects the final mean episode "
        "returns of every seed of the case.",
    )
    p.add_argument("--case", type=case_option, required=True, nargs="+", action="extend",
                   help=CASE_HELP + "; several make one sweep (cases x seeds jobs)")
    p.add_argument("--seeds", type=int, default=8, help="number of seeds (default 8)")
    p.add_argument("--seed-offset", type=int, default=0, help="first seed (default 0)")
    p.add_argument("--steps", type=int, default=None,
                   help="environment steps per seed (default: the case's, 100000 for the paper's)")
    p.add_argument("--workers", type=int, default=None,
                   help="groups of seeds trained at a time (processes, or Ray tasks in flight; "
                        "default: the fastest layout for this machine, one per core); alone, a "
                        "case's seeds are split among W workers (1: all side by side)")
    p.add_argument("--out", type=Path, default=Path("runs"), help="output folder")
    p.add_argument("--resume", action="store_true", help="continue runs from their checkpoints")
    p.add_argument("--physics", choices=("training", "accurate"), default="training")
    p.add_argument("--episode-duration", type=float, default=None,
                   help="s (truncation; default: the case's, 20 s for the paper's)")
    p.add_argument("--threads", type=int, default=None, help="torch threads per worker")
    p.add_argument("--envs", type=int, default=1,
                   help="crawlers per seed in one batched simulator (vector env; N transitions and "
                        "N TD3 updates per vector step; default 1: the single environment)")
    p.add_argument("--seeds-per-simulator", type=int, default=None, metavar="K",
                   help="K seeds train side by side in one worker, their crawlers in one batched "
                        "simulator and their networks updated as one computation; each seed's run "
                        "is bit-identical to training it alone (default: the fastest layout, "
                        "seeds / cores)")
    p.add_argument("--backend", choices=("process", "ray"), default="process",
                   help="where the seeds run: worker processes on this machine (default) or Ray tasks "
                        "(a local Ray instance with --workers x --threads CPUs, or the cluster at "
                        "--address); same run directories and summary.json")
    p.add_argument("--address", default=None,
                   help="Ray cluster address for --backend ray (auto, HOST:PORT, ray://HOST:10001); "
                        "--out must then be on a filesystem all nodes see at the same path")
    p.add_argument("--recipe", choices=tuple(RECIPES), default=None,
                   help="training recipe (default: the case's, pink-ln for the paper's cases; "
                        "--recipe paper: the authors'): "
                        + "; ".join(f"{name}: {line}" for name, line in RECIPE_SUMMARIES.items())
                        + " (docs/training.md)")
    _add_stop_options(p)
    g = p.add_argument_group("TD3 overrides (default: the paper's settings)")
    g.add_argument("--learning-starts", type=int, default=None, help="warm-up steps (2500)")
    g.add_argument("--batch-size", type=int, default=None, help="minibatch (256)")
    g.add_argument("--hidden", type=str, default=None,
                   help="hidden sizes of the critics, and of the actor unless --actor-hidden, e.g. 256,256")
    g.add_argument("--actor-hidden", type=str, default=None,
                   help="hidden sizes of the actor when they differ from the critics', e.g. 64,64")
    g.add_argument("--updates-per-step", type=float, default=None,
                   help="TD3 updates per environment transition after the warm-up (1; a fraction "
                        "such as 0.5 makes one update every second transition)")
    g.add_argument("--buffer-size", type=int, default=None, help="replay capacity (1e6)")
    g.add_argument("--target-noise-clip", type=float, default=None, help="(0.8, the authors')")
    g.add_argument("--checkpoint-every", type=int, default=None, help="steps (10000)")
    g.add_argument("--precision", choices=("fp32", "bf16"), default=None,
                   help="arithmetic of the networks' matrix products in the updates: fp32 (the "
                        "paper's, default) or bf16 (bfloat16 products on float32 weights; falls "
                        "back to fp32 on a CPU without bfloat16 units)")
    g.add_argument("--device", choices=("cpu", "cuda"), default=None,
                   help="where the networks train (default cpu)")
    g.add_argument("--eval-every", type=int, default=None,
                   help="steps between evaluations of the deterministic policy from a zero field, "
                        "10 s, best actor kept in best.pt (5000; 0: none)")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=train_command)


def _add_stop_options(p: argparse.ArgumentParser) -> None:
    """``msr train --stop-when`` and its settings (rl/sweep/stop_settings.py)."""
    from ..sweep.stop_settings import STOP_CHOICES

    g = p.add_argument_group("stopping seeds that have learned (default: off, or the recipe's)")
    g.add_argument("--stop-when", choices=STOP_CHOICES, default=None,
                   help="target: a seed stops once its evaluation return reached the case's yardstick "
                        "(reward scale x [yardstick] distance_10s) in K consecutive evaluations; "
                        "plateau: once its best evaluation has not improved by more than a tolerance "
                        "for N evaluations; none: off (also for a recipe that has a rule). A stopped "
                        "seed frees its share of the worker; recorded in the run, kept by --resume")
    g.add_argument("--stop-consecutive", type=int, default=None, metavar="K",
                   help="target: evaluations in a row at the threshold (default 2)")
    g.add_argument("--stop-patience", type=int, default=None, metavar="N",
                   help="plateau: evaluations without improvement (default 6)")
    g.add_argument("--stop-tolerance", type=float, default=None, metavar="F",
                   help="plateau: an improvement counts above F x |best| (default 0.02)")


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
        "(train_8_seeds_1e5_s). A few minutes.",
    )
    p.add_argument("--steps", type=number("", 1, integer=True), default=1000,
                   help="time steps per step-cost measurement")
    p.add_argument("--repeats", type=number("", 1, integer=True), default=3,
                   help="measurements per configuration")
    p.add_argument("--vector-envs", type=number("", 1, integer=True), default=16,
                   help="crawlers in the vector environment measured (default 16)")
    p.add_argument("--train-seeds", type=number("", 0, integer=True), default=8, metavar="N",
                   help="seeds of the real training run behind train_8_seeds_1e5_s (default 8; "
                        "0: skip it)")
    p.add_argument("--quick", action="store_true", help="tiny measurements (smoke test; rough numbers)")
    p.add_argument("--memory-seeds", type=number("", 0, integer=True), default=0, metavar="N",
                   help="also measure the peak memory of a real N-seed training run in the default "
                   "layout (Linux; a few minutes for N = 8; default 0: skip)")
    p.add_argument("--memory-steps", type=number("", 1, integer=True), default=3000,
                   help="environment steps per seed of that run (default 3000: past the warm-up)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=bench_command)


def _add_refine_command(sub: argparse._SubParsersAction) -> None:
    """``msr refine``."""
    p = sub.add_parser(
        "refine",
        help="continue training a run in the accurate physics (agent and replay buffer)",
        description="Load a run's agent and replay buffer and continue training for --steps "
        "environment steps in the accurate physics (true density, dt 8e-6 s: ~12.5x the cost of a "
        "training step). Writes RUN/refined/ unless --out is given.",
    )
    p.add_argument("run", type=Path, help="run directory (or its checkpoint.pt)")
    p.add_argument("--checkpoint", default="auto", metavar="auto|final|best|PATH",
                   help=CHECKPOINT_HELP + " (evaluated for 10 s); best.pt's networks continue with "
                   "the run's replay buffer and optimisers")
    p.add_argument("--steps", type=int, default=1000)
    p.add_argument("--out", type=Path, default=None, help="default: RUN/refined")
    p.add_argument("--resume", action="store_true", help="continue an interrupted refinement")
    p.add_argument("--episode-duration", type=float, default=20.0, help="s (truncation)")
    p.add_argument("--device", choices=("cpu", "cuda"), default=None,
                   help="where the networks train (default: the run's)")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=refine_command)


def _add_generate_command(sub: argparse._SubParsersAction) -> None:
    """``msr generate``."""
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
    _add_rollout_options(p, Path("out/generate"))
    p.set_defaults(func=generate_command)


def _add_baseline_command(sub: argparse._SubParsersAction) -> None:
    """``msr baseline``."""
    p = sub.add_parser(
        "baseline",
        help="generate with a hand-designed rotating field (the yardstick for learned policies)",
        description="Turn the field at the case's limit at a constant rate, through the agent's "
        "own action channel (0.3 mT per axis per 0.01 s, field from zero), and write the same "
        "files as `msr generate`: a rotating field rolls the robot, the gait to beat. Without "
        "--period, sweep the periods in both directions (worker processes; sweep.csv, sweep.png) "
        "and keep the farthest; the period the field really turned at under the rate limit is "
        "reported. Each 10 s run in the accurate physics takes about a minute; --physics training "
        "--duration 2 gives a quick look.",
    )
    p.add_argument("--case", type=case_option, required=True, help=CASE_HELP)
    p.add_argument("--period", type=number("s", 0.0, low_open=True), default=None,
                   help="s per turn of the field; without it, a sweep of --periods in both "
                        "directions, the farthest one's files written")
    p.add_argument("--counterclockwise", action="store_true",
                   help="turn counter-clockwise (rolls towards -x; with --period)")
    p.add_argument("--periods", type=str, default=None, metavar="P1,P2,...",
                   help="the sweep's periods, s (default 0.5,0.75,1,1.5,2,2.5,3,4,5,6)")
    p.add_argument("--workers", type=number("", 1, integer=True), default=None,
                   help="sweep runs at a time (processes; default one per core)")
    p.add_argument("--set-yardstick", type=Path, default=None, metavar="OUT.toml",
                   help="write a copy of the case's spec with the sweep's best distance as "
                        "[yardstick] distance_10s (needs the accurate physics and 10 s)")
    _add_rollout_options(p, Path("out/baseline"))
    p.set_defaults(func=baseline_command)


def _add_figures_command(sub: argparse._SubParsersAction) -> None:
    """``msr figures``."""
    p = sub.add_parser(
        "figures",
        help="regenerate figures of training runs or of a generate output",
        description="PATH is a training output (learning curves per case) or a generate output "
        "(holding rollout.npz: gait, field, contact and Q-value figures, GIF).",
    )
    p.add_argument("path", type=Path)
    p.add_argument("--out", type=Path, default=None, help="default: PATH")
    p.add_argument("--no-gif", action="store_true")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=figures_command)


def _add_demo_command(sub: argparse._SubParsersAction) -> None:
    """``msr demo``."""
    p = sub.add_parser(
        "demo",
        help="generate with the shipped pattern-1 4 mT policy (fields, figures, animation)",
    )
    p.add_argument("--out", type=Path, default=Path("out/demo"))
    p.add_argument("--duration", type=duration_option(), default=10.0, help="s")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=demo_command)


def _overrides(args: argparse.Namespace) -> dict:
    """TD3 settings given on the command line, checked before any work starts."""
    out = {}
    for name in ("learning_starts", "batch_size", "buffer_size", "target_noise_clip",
                 "checkpoint_every", "eval_every", "precision", "device"):
        value = getattr(args, name)
        if value is not None:
            out[name] = value
    for name, least in (("learning_starts", 0), ("batch_size", 1), ("buffer_size", 1),
                        ("checkpoint_every", 1), ("eval_every", 0)):
        if out.get(name, least) < least:
            raise CommandError(f"--{name.replace('_', '-')} must be >= {least}, got {out[name]}")
    clip = out.get("target_noise_clip", 0.0)
    if not (math.isfinite(clip) and clip >= 0):
        raise CommandError(f"--target-noise-clip must be a finite number >= 0 (a fraction of the "
                           f"action half-range), got {clip}")
    for option, name in (("hidden", "hidden_sizes"), ("actor_hidden", "actor_hidden_sizes")):
        if getattr(args, option, None):
            out[name] = _widths(f"--{option.replace('_', '-')}", getattr(args, option))
    ratio = getattr(args, "updates_per_step", None)
    if ratio is not None:
        if not (math.isfinite(ratio) and ratio > 0):
            raise CommandError(f"--updates-per-step must be a finite number > 0 (updates per "
                               f"transition), got {ratio}")
        out["updates_per_step"] = ratio
    if args.device == "cuda":
        import torch

        if not torch.cuda.is_available():
            raise CommandError("--device cuda: no CUDA device is available to this torch build")
    return out


def _widths(option: str, text: str) -> tuple[int, ...]:
    """Hidden layer widths from ``"256,256"``."""
    try:
        widths = tuple(int(h) for h in text.split(","))
    except ValueError:
        raise CommandError(f"{option} must be comma-separated integers, got {text!r}") from None
    if not widths or min(widths) < 1:
        raise CommandError(f"{option}: every layer needs at least 1 unit, got {text!r}")
    return widths


def _check_run_options(args: argparse.Namespace) -> None:
    """Numeric options of train/refine, checked at parse time (finite, in range, with the unit)."""
    duration = args.episode_duration
    if duration is not None and not (math.isfinite(duration) and 0 < duration <= 3600):
        raise CommandError(f"--episode-duration must be a finite duration in (0, 3600] s, got {duration}")
    if args.steps is not None and args.steps < 1:
        raise CommandError(f"--steps must be >= 1, got {args.steps}")
    for name in ("seeds", "workers", "threads", "envs", "seeds_per_simulator"):
        value = getattr(args, name, None)
        if value is not None and value < 1:
            raise CommandError(f"--{name.replace('_', '-')} must be >= 1, got {value}")
    if getattr(args, "seed_offset", 0) < 0:
        raise CommandError(f"--seed-offset must be >= 0, got {args.seed_offset}")


def _interrupted(folders: str) -> int:
    print(f"interrupted: training stopped. The last checkpoints are in {folders}; continue with "
          "the same command and --resume", file=sys.stderr)
    return 130


def train_command(args: argparse.Namespace) -> int:
    from ..sweep.training import train_cases

    _check_run_options(args)
    overrides = _overrides(args)
    try:
        summaries = train_cases(
            args.case, seeds=args.seeds, steps=args.steps, workers=args.workers, out=args.out,
            resume=args.resume, seed_offset=args.seed_offset, config_overrides=overrides,
            physics=args.physics, episode_duration=args.episode_duration,
            progress=not args.no_progress, threads=args.threads, envs=args.envs,
            backend=args.backend, address=args.address,
            seeds_per_simulator=args.seeds_per_simulator, recipe=args.recipe,
            stop_when=args.stop_when, stop_options=_stop_options(args),
        )
    except (FileExistsError, FileNotFoundError, ValueError, ConnectionError) as exc:
        raise CommandError(str(exc)) from None  # ConnectionError: --address
    except KeyboardInterrupt:
        return _interrupted(", ".join(str(args.out / case.name / f"{CaseDir.SEED_PREFIX}*")
                                      for case in args.case))
    failed = any(s["failed"] for s in summaries.values())
    if not args.json:
        summaries = {case: {k: v for k, v in summary.items() if k != "seeds"} | {
            CaseDir.seed_name(r["seed"]): r.get("error") or _seed_line(r)
            for r in summary["seeds"]} for case, summary in summaries.items()}
    # one case: its summary, as before; several: the summaries by case
    print_result(next(iter(summaries.values())) if len(summaries) == 1 else summaries, args.json)
    return 1 if failed else 0


def _stop_options(args: argparse.Namespace) -> dict:
    """The stop rule's settings given (checked by the library, naming the option)."""
    return {k: v for k, v in (("consecutive", args.stop_consecutive), ("patience", args.stop_patience),
                              ("tolerance", args.stop_tolerance)) if v is not None}


def _seed_line(r: dict) -> str:
    """One seed of the final summary: its state (learned / stopped / still improving), return."""
    state = r.get("state", "")
    if r.get("stopped_early"):
        state = f"stopped at step {r['stop_step']} ({r['stop_reason']})"
    return (f"{state + ': ' if state else ''}final mean training return "
            f"{r['final_mean_return']:.4g} ({r['episodes']} episodes from random initial fields; not "
            "a distance: msr export-seeds measures each seed's)")


def case_list_command(args: argparse.Namespace) -> int:
    from ..cases.case import case_names, load_case

    rows = []
    for name in case_names():
        case = load_case(name)
        rows.append({"name": name, "robot": case.robot.name,
                     "magnetization": case.robot.tables["robot"]["magnetization"]["kind"],
                     "field_limit_mT": 1e3 * case.field_limit, "task": case.task.kind,
                     "target": case.target_label, "description": case.description})
    if args.json:
        print_result({"cases": rows}, True)
    else:
        for r in rows:
            print(f"{r['name']:<14} {r['robot']:<12} {r['magnetization']:<18} "
                  f"{r['field_limit_mT']:>5g} mT  {r['task']:<6} target {r['target']}")
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

    from ..cases.check import check_case

    check = check_case(args.case, sag=not args.no_sag)
    if args.json:
        print_result(check.to_dict(), True)
    else:
        print(format_check(check))
    return 1 if check.has_errors else 0


def bench_command(args: argparse.Namespace) -> int:
    from ..reports.bench import benchmark, training_peak_memory

    if args.steps < 1 or args.repeats < 1 or args.vector_envs < 1:
        raise CommandError("--steps, --repeats and --vector-envs must be >= 1")
    if args.memory_seeds < 0 or args.memory_steps < 1 or args.train_seeds < 0:
        raise CommandError("--memory-seeds and --train-seeds must be >= 0 and --memory-steps >= 1")
    result = benchmark(steps=args.steps, repeats=args.repeats, quick=args.quick,
                       vector_envs=args.vector_envs, train_seeds=args.train_seeds)
    if args.memory_seeds:
        result["training_memory"] = training_peak_memory(args.memory_seeds, args.memory_steps)
    print_result(result, args.json)
    return 0


#: s of the accurate evaluations that choose the actor ``msr refine`` continues (the yardstick's).
REFINE_CHOICE_DURATION = 10.0


def refine_command(args: argparse.Namespace) -> int:
    from ..shipping.policy_runs import CHECKPOINT_CHOICES, choose_actor
    from ..sweep.refine_start import check_refine_output, default_refine_output
    from ..sweep.training import refine

    _check_run_options(args)
    try:  # the output is checked before the actors' 10 s evaluations
        source = args.run if args.checkpoint in CHECKPOINT_CHOICES else Path(args.checkpoint)
        check_refine_output(args.out or default_refine_output(source), args.resume)
        choice = choose_actor(args.run, args.checkpoint, REFINE_CHOICE_DURATION, not args.no_progress)
        result = refine(choice.path if choice else args.run, steps=args.steps, out=args.out,
                        resume=args.resume, progress=not args.no_progress,
                        episode_duration=args.episode_duration, device=args.device)
    except (FileExistsError, FileNotFoundError, ValueError) as exc:
        raise CommandError(str(exc)) from None
    except KeyboardInterrupt:
        return _interrupted(str(args.out or RunDir(args.run).refined.path))
    if choice is not None:
        result = {**result, "actor_choice": {**choice.to_dict(), "summary": choice.describe()}}
    print_rollout_result(result, args.json)
    return 0


def generate_command(args: argparse.Namespace) -> int:
    from ..shipping.generate import generate

    try:
        result = generate(args.policy, duration=args.duration, out=args.out, physics=args.physics,
                          progress=not args.no_progress, figures=not args.no_figures,
                          gif=not args.no_gif, checkpoint=args.checkpoint, force=args.force)
    except FileNotFoundError as exc:
        raise CommandError(str(exc)) from None
    return _print_rollout_result(result, args.json)


def print_rollout_result(result: dict, as_json: bool) -> None:
    """A rollout's result; in text, the actor a run's choice used comes first, in one line."""
    if as_json or "actor_choice" not in result:
        print_result(result, as_json)
        return
    print(f"actor: {result['actor_choice']['summary']}")
    print_result({k: v for k, v in result.items() if k != "actor_choice"}, False)


def baseline_command(args: argparse.Namespace) -> int:
    from elastica_magnetic import read_field_csv

    from ..shipping.baseline_sweep import achieved_period
    from ..shipping.baselines import RotatingFieldPolicy
    from ..shipping.generate import generate

    if args.set_yardstick is not None and (args.physics != "accurate" or args.duration != 10.0):
        raise CommandError("--set-yardstick: a yardstick is the distance in 10 s of the accurate "
                           f"physics; got --physics {args.physics} --duration {args.duration:g}")
    if args.period is None:
        return _baseline_sweep(args)
    if args.periods is not None or args.set_yardstick is not None:
        raise CommandError("--periods and --set-yardstick belong to the sweep: leave out --period")
    try:
        policy = RotatingFieldPolicy(args.case, args.period, clockwise=not args.counterclockwise)
    except ValueError as exc:
        raise CommandError(f"--period: {exc}") from None
    result = generate(policy, duration=args.duration, out=args.out, physics=args.physics,
                      progress=not args.no_progress, figures=not args.no_figures,
                      gif=not args.no_gif, force=args.force, kind="baseline")
    if result["fields_csv"]:
        result |= achieved_period(read_field_csv(result["fields_csv"]), args.period, args.case)
        if result["warning"]:
            print(f"warning: {result['warning']}", file=sys.stderr)
    return _print_rollout_result(result, args.json)


def _baseline_sweep(args: argparse.Namespace) -> int:
    """``msr baseline`` without ``--period``: the sweep, its table and the best run."""
    from ..shipping.baseline_sweep import DEFAULT_PERIODS, sweep_baseline, yardstick_spec

    periods = DEFAULT_PERIODS
    if args.periods is not None:
        try:
            periods = tuple(float(p) for p in args.periods.split(","))
        except ValueError:
            raise CommandError(f"--periods must be comma-separated times in s, got {args.periods!r}") \
                from None
        if not all(math.isfinite(p) and p > 0 for p in periods):
            raise CommandError(f"--periods must be positive finite times in s, got {args.periods!r}")
    if args.counterclockwise:
        raise CommandError("--counterclockwise needs --period (the sweep tries both directions)")
    try:
        result = sweep_baseline(args.case, periods, args.duration, args.physics, args.out,
                                args.workers, not args.no_progress, not args.no_figures,
                                not args.no_gif, force=args.force)
    except ValueError as exc:
        raise CommandError(str(exc)) from None
    best = result["best"]
    if args.set_yardstick is not None:
        result["yardstick_spec"] = str(yardstick_spec(args.case, best, args.set_yardstick))
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
    from ..shipping.policy_files import resolve_policy

    print_result(make_figures(args.path, args.out, gif=not args.no_gif, load_policy=resolve_policy),
                 args.json)
    return 0


def demo_command(args: argparse.Namespace) -> int:
    from ..shipping.generate import demo

    result = demo(args.out, duration=args.duration, progress=not args.no_progress)
    return _print_rollout_result(result, args.json)
