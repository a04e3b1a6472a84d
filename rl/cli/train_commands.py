"""``msr train`` and ``msr refine``: thin wrappers over
:func:`elastica_magnetic_rl.sweep.training.train_cases` and :func:`elastica_magnetic_rl.sweep.refine.refine`
(heavy imports happen inside the commands); their options checked at parse time, the TD3 overrides
among them."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from elastica_magnetic.cli import CommandError, output_path, print_result
from elastica_magnetic.cli.options import number
from elastica_magnetic.interrupts import signals_as_exceptions
from elastica_magnetic.io import display_path

from ..cases.recipes import RECIPE_SUMMARIES, RECIPES
from ..runfiles.rundir import CaseDir, RunDir
from .options import CASE_HELP, CHECKPOINT_HELP, print_rollout_result, trainable_case_option

if TYPE_CHECKING:
    from ..cases.case import Case


def register(sub: argparse._SubParsersAction) -> None:
    """Add this module's sub-commands to ``msr``."""
    for add in (_add_train_command, _add_refine_command):
        add(sub)


def _add_train_command(sub: argparse._SubParsersAction) -> None:
    """``msr train``."""
    from ..sweep.randomize_settings import RANDOMIZE_CHOICES

    p = sub.add_parser(
        "train",
        help="train TD3 crawling policies for one or more cases, several seeds in parallel",
        description="Train TD3 on one or more cases in the mass-scaled training physics (random "
        "initial fields, 20 s truncated episodes by default: the case's). Each seed writes "
        "OUT/<case>/seed<k>/ (episodes.csv, TensorBoard scalars, checkpoint.pt, run.json, which "
        "store the complete case spec); OUT/<case>/summary.json collects the final mean episode "
        "returns of every seed of the case.",
    )
    p.add_argument("--case", type=trainable_case_option, required=True, nargs="+", action="extend",
                   help=CASE_HELP + "; several make one sweep (cases x seeds jobs)")
    p.add_argument("--seeds", type=int, default=8, help="number of seeds (default 8)")
    p.add_argument("--seed-offset", type=int, default=0, help="first seed (default 0)")
    p.add_argument("--steps", type=int, default=None,
                   help="environment steps per seed (default: the case's, 100000 for the paper's)")
    p.add_argument("--workers", type=int, default=None,
                   help="groups of seeds trained at a time (processes, or Ray tasks in flight; "
                        "default: the fastest layout for this machine, one per core); alone, a "
                        "case's seeds are split among W workers (1: all side by side)")
    p.add_argument("--out", type=output_path, default="runs", help="output folder")
    p.add_argument("--resume", action="store_true", help="continue runs from their checkpoints")
    p.add_argument("--physics", choices=("training", "accurate"), default="training")
    p.add_argument("--episode-duration", type=number("s", 0.0, low_open=True), default=None,
                   help="s (truncation; default: the case's, 20 s for the paper's)")
    p.add_argument("--threads", type=int, default=None,
                   help="torch threads per worker (default: the cores shared among the workers, no "
                        "more than OMP_NUM_THREADS where it is set)")
    p.add_argument("--envs", type=int, default=1,
                   help="crawlers per seed in one batched simulator (vector env; N transitions and "
                        "N TD3 updates per vector step; default 1: the single environment)")
    p.add_argument("--seeds-per-simulator", type=int, default=None, metavar="K",
                   help="K seeds train side by side in one worker, their crawlers in one batched "
                        "simulator and their networks updated as one computation (default: the "
                        "fastest layout, seeds / cores; docs/performance.md says how exactly a "
                        "seed's run equals training it alone)")
    p.add_argument("--rebalance", action=argparse.BooleanOptionalAction, default=True,
                   help="when a worker is idle at the end, move seeds of a busy one onto it at "
                        "their next common episode end (default; each moved seed ends bit-identical "
                        "to staying, tested and confirmed on an 8-seed campaign: benchmarks/results/LOG.md); "
                        "--no-rebalance keeps every group on its worker")
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
                        .replace("%", "%%")  # argparse formats help with %
                        + " (docs/training.md)")
    p.add_argument("--randomize", choices=RANDOMIZE_CHOICES, default=None,
                   help="robots of the training episodes: default: drawn anew per episode and "
                        "crawler from the default variation set (magnetization +-15 %%, modulus "
                        "+-20 %%, friction +-25 %%, density +-10 %%); none: the nominal robot "
                        "(default: the spec's [training.randomize], else the recipe's: robust "
                        "randomizes); evaluations stay on the nominal robot")
    _add_stop_options(p)
    _add_td3_overrides(p)
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=train_command)


#: The earlier one-flag-per-setting spellings, hidden aliases of ``--set KEY=VALUE``.
OLD_SETTING_FLAGS = {
    "--learning-starts": "learning_starts", "--batch-size": "batch_size", "--hidden": "hidden_sizes",
    "--actor-hidden": "actor_hidden_sizes", "--updates-per-step": "updates_per_step",
    "--buffer-size": "buffer_size", "--target-noise-clip": "target_noise_clip",
    "--checkpoint-every": "checkpoint_every", "--eval-every": "eval_every",
}


def td3_setting(text: str) -> tuple[str, object]:
    """The argparse ``type`` of ``--set KEY=VALUE``: a TD3 setting checked against
    :class:`~elastica_magnetic_rl.td3.config.TD3Config` (as RL Zoo's ``--hyperparams``)."""
    from ..td3.config import TD3Config

    key, equals, value = text.partition("=")
    if not equals or not key.strip():
        raise argparse.ArgumentTypeError(f"{text!r}: expected KEY=VALUE, e.g. batch_size=128")
    try:
        return key.strip(), TD3Config.parse_setting(key.strip(), value)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


class _OldSettingFlag(argparse.Action):
    """``--batch-size 64`` of earlier releases: stored as ``--set batch_size=64`` with a note."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: object, option_string: str | None = None) -> None:
        key = OLD_SETTING_FLAGS[option_string]
        try:
            setting = td3_setting(f"{key}={values}")
        except argparse.ArgumentTypeError as exc:
            raise argparse.ArgumentError(self, str(exc)) from None
        print(f"{parser.prog}: note: {option_string} is now --set {key}=VALUE (the old spelling "
              "works in this release)", file=sys.stderr)
        namespace.settings = [*(namespace.settings or []), setting]


def _add_td3_overrides(p: argparse.ArgumentParser) -> None:
    """``msr train``'s TD3 settings that override the recipe's (read by :func:`_overrides`)."""
    from ..td3.config import TD3Config

    g = p.add_argument_group("TD3 settings (default: the recipe's, else the paper's)")
    g.add_argument("--set", dest="settings", type=td3_setting, action="append", default=None,
                   metavar="KEY=VALUE",
                   help="a TD3 setting over the recipe's, repeatable: e.g. --set batch_size=128 "
                        "--set hidden_sizes=64,64 (layer widths comma-separated). Keys: "
                        + ", ".join(TD3Config.settable())
                        + " (docs/training.md); a spec's [training.td3] takes the same keys")
    for flag in OLD_SETTING_FLAGS:
        g.add_argument(flag, action=_OldSettingFlag, help=argparse.SUPPRESS)
    g.add_argument("--precision", choices=("fp32", "bf16"), default=None,
                   help="arithmetic of the networks' matrix products in the updates: fp32 (the "
                        "paper's, default) or bf16 (bfloat16 products on float32 weights; falls "
                        "back to fp32 on a CPU without bfloat16 units)")
    g.add_argument("--device", choices=("cpu", "cuda"), default=None,
                   help="where the networks train (default cpu)")


def _stop_tolerance(text: str) -> float:
    """``--stop-tolerance F``: a fraction of the best return in [0, 1); 1 or more reads as a
    percentage (2 is 200 %: no improvement would ever count)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a fraction such as 0.02, got {text!r}") from None
    if not (math.isfinite(value) and 0.0 <= value < 1.0):
        hint = (f"; it looks like a percentage ({value:g} % is {value / 100:g})"
                if 1.0 <= value <= 100.0 else "")
        raise argparse.ArgumentTypeError(f"expected a fraction of the best return in [0, 1), got "
                                         f"{value:g} ({100 * value:g} %: an improvement would "
                                         f"never count){hint}")
    return value


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
    g.add_argument("--stop-tolerance", type=_stop_tolerance, default=None, metavar="F",
                   help="plateau: an improvement counts above F x |best| (default 0.02; a "
                        "fraction in [0, 1), not a percentage)")
    g.add_argument("--stop-confirm", choices=("accurate", "none"), default=None,
                   help="target: when the rule fires, the seed's actor runs 10 s from a zero field "
                        "in the accurate physics (about a minute) and the seed stops only if it "
                        "reaches the yardstick there too (default accurate; none: no confirmation)")


def _add_refine_command(sub: argparse._SubParsersAction) -> None:
    """``msr refine``."""
    from ..sweep.randomize_settings import RANDOMIZE_CHOICES

    p = sub.add_parser(
        "refine",
        help="continue training a run (agent and replay buffer): in the accurate physics, on "
             "another robot's values or on randomized robots",
        description="Load a run's agent and replay buffer and continue training for --steps "
        "environment steps, by default in the accurate physics (true density, dt 8e-6 s: ~12.5x the "
        "cost of a training step); --spec: on the run's robot with other physical values; "
        "--physics training --randomize default: fine-tune the policy for robots drawn from the "
        "default variation set. Writes RUN/refined/ unless --out is given.",
    )
    p.add_argument("run", type=Path, help="run directory (or its checkpoint.pt)")
    p.add_argument("--checkpoint", default="auto", metavar="auto|final|best|PATH",
                   help=CHECKPOINT_HELP + " (evaluated for 10 s); best.pt's networks continue with "
                   "the run's replay buffer and optimisers")
    p.add_argument("--steps", type=int, default=None,
                   help="environment steps of the refinement (default 1000; --resume: its own, "
                        "counted from where it started)")
    p.add_argument("--out", type=output_path, default=None, help="default: RUN/refined")
    p.add_argument("--resume", action="store_true",
                   help="continue an interrupted refinement as its run.json records it (robot, "
                        "--spec, --randomize, --physics, --episode-duration); options that "
                        "contradict the record are refused")
    p.add_argument("--spec", type=Path, default=None,
                   help="train on this spec's robot: the run's robot with other physical values "
                        "(e.g. msr real identify's identified.toml), randomized by its "
                        "[training.randomize] if it has one; recorded in run.json")
    p.add_argument("--physics", choices=("accurate", "training"), default=None,
                   help="physics of the refinement's episodes (default accurate; training: the "
                        "mass-scaled physics the run trained in, 12.5x cheaper)")
    p.add_argument("--randomize", choices=RANDOMIZE_CHOICES, default=None,
                   help="robots of the refinement's episodes: default: drawn anew per episode "
                        "from the default variation set (magnetization +-15 %%, modulus +-20 %%, "
                        "friction +-25 %%, density +-10 %%), none: the nominal robot (default: the "
                        "--spec's [training.randomize], else the run's setting; one that "
                        "disagrees with the spec's table is refused); recorded in run.json")
    p.add_argument("--episode-duration", type=number("s", 0.0, low_open=True), default=None,
                   help="s (truncation; default the case's [task] episode_duration, as msr train's: "
                   "20 s for the paper's crawlers; at least one 0.01 s control step)")
    p.add_argument("--device", choices=("cpu", "cuda"), default=None,
                   help="where the networks train (default: the run's)")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=refine_command)


def _overrides(args: argparse.Namespace) -> dict:
    """TD3 settings given on the command line (``--set``, checked as they were parsed; a key
    given twice is refused: which one was meant cannot be guessed), with ``--precision`` and
    ``--device``."""
    out: dict = {}
    for key, value in getattr(args, "settings", None) or []:
        if key in out and out[key] != value:
            raise CommandError(f"--set {key} given twice ({out[key]} and {value}); give it once")
        out[key] = value
    for name in ("precision", "device"):
        if getattr(args, name, None) is not None:
            out[name] = getattr(args, name)
    return out


def _check_run_options(args: argparse.Namespace) -> None:
    """Numeric options of train/refine, checked at parse time (finite, in range, with the unit),
    and ``--device`` (one this PyTorch has)."""
    _check_episode_duration(args.episode_duration)
    if args.steps is not None and args.steps < 1:
        raise CommandError(f"--steps must be >= 1, got {args.steps}")
    for name in ("seeds", "workers", "threads", "envs", "seeds_per_simulator"):
        value = getattr(args, name, None)
        if value is not None and value < 1:
            raise CommandError(f"--{name.replace('_', '-')} must be >= 1, got {value}")
    per_simulator, seeds = getattr(args, "seeds_per_simulator", None), getattr(args, "seeds", None)
    if per_simulator is not None and seeds is not None and per_simulator > seeds:
        raise CommandError(f"--seeds-per-simulator {per_simulator} is more than --seeds {seeds}: a "
                           f"simulator holds at most the {seeds} seed(s) trained; give at most {seeds}")
    if getattr(args, "seed_offset", 0) < 0:
        raise CommandError(f"--seed-offset must be >= 0, got {args.seed_offset}")
    if args.device is not None:
        _check_device(args.device)


def _warn_unstable_steps(cases: list, physics: str) -> None:
    """Say, before the training, what ``msr case check`` calls an error: a time step above the
    estimated stable one (a run may blow up, its seeds then fail)."""
    from elastica_magnetic.spec_check import unstable_time_step

    for case in cases:
        problem = unstable_time_step(case.robot_spec(physics), physics)
        if problem is not None:
            print(f"warning: {case.source}: {problem} (msr case check {case.source} says why)",
                  file=sys.stderr)


#: The longest ``--episode-duration`` (s) train and refine take.
MAX_EPISODE_DURATION_S = 3600.0


def _check_episode_duration(duration: float | None) -> None:
    """``--episode-duration`` (s): finite, at least one control step (an episode with no action
    fails only after start-up, with a run folder written) and at most an hour."""
    from elastica_magnetic.robot_spec import ACTION_PERIOD

    if duration is None:
        return
    if not (math.isfinite(duration) and 0 < duration <= MAX_EPISODE_DURATION_S):
        raise CommandError(f"--episode-duration must be a finite duration in [{ACTION_PERIOD:g}, "
                           f"{MAX_EPISODE_DURATION_S:g}] s, got {duration}")
    if duration < ACTION_PERIOD:
        raise CommandError(f"--episode-duration {duration:g} s is shorter than one control step "
                           f"({ACTION_PERIOD:g} s, {1 / ACTION_PERIOD:g} Hz): an episode needs at "
                           f"least one action; give a duration in [{ACTION_PERIOD:g}, "
                           f"{MAX_EPISODE_DURATION_S:g}] s")


def _check_device(device: str) -> None:
    """``--device``: refused unless this PyTorch can put the networks there (a CPU build has no
    CUDA), before any run folder is made."""
    from ..td3.devices import device_problem

    problem = device_problem(device)
    if problem is not None:
        raise CommandError(f"--device {device}: {problem}; use --device cpu")


def _interrupted(folders: list[Path], signal_number: int = 2) -> int:
    """The message of an interrupted training or refinement: where its checkpoints are, only
    those that exist (a run stopped before its first checkpoint has none to resume from)."""
    import signal

    saved = [f for f in folders if RunDir(f).has_checkpoint()]
    name = signal.Signals(signal_number).name
    if saved:
        print(f"interrupted ({name}): training stopped. The last checkpoints are in "
              f"{', '.join(display_path(f) for f in saved)}; continue with the same command and "
              "--resume", file=sys.stderr)
    else:
        print(f"interrupted ({name}): training stopped before its first checkpoint, so there is nothing to "
              "resume; run the same command again (without --resume) to start over",
              file=sys.stderr)
    return 128 + signal_number  # 130 after Ctrl-C, 143 after SIGTERM


def train_command(args: argparse.Namespace) -> int:
    from ..shipping.policy_files import check_policy_case
    from ..sweep.case_folders import check_not_in_a_result
    from ..sweep.training import train_cases

    _check_run_options(args)
    try:
        check_not_in_a_result(args.out)
    except ValueError as exc:
        raise CommandError(str(exc)) from None
    for case in args.case:  # a shipped policy's seeds/ takes runs of its own case only
        check_policy_case(args.out / case.name, case, option="--out")
    _warn_unstable_steps(args.case, args.physics)
    overrides = _overrides(args)
    try:
        # SIGTERM/SIGHUP stop it as Ctrl-C does (the checkpoints are named), not silently
        with signals_as_exceptions():
            summaries = train_cases(
                args.case, seeds=args.seeds, steps=args.steps, workers=args.workers, out=args.out,
                resume=args.resume, seed_offset=args.seed_offset, config_overrides=overrides,
                physics=args.physics, episode_duration=args.episode_duration,
                progress=not args.no_progress, threads=args.threads, envs=args.envs,
                backend=args.backend, address=args.address,
                seeds_per_simulator=args.seeds_per_simulator, recipe=args.recipe,
                stop_when=args.stop_when, stop_options=_stop_options(args),
                randomize=args.randomize, rebalance=args.rebalance,
            )
    except (FileExistsError, FileNotFoundError, ValueError, ConnectionError) as exc:
        raise CommandError(str(exc)) from None  # ConnectionError: --address
    except KeyboardInterrupt as exc:
        return _interrupted(sorted(f for case in args.case
                                   for f in (args.out / case.name).glob(f"{CaseDir.SEED_PREFIX}*")
                                   if f.is_dir()), getattr(exc, "signum", 2))
    failed = any(s["failed"] for s in summaries.values())
    if not args.json:
        cases = {case.name: case for case in args.case}
        # "failed: 0" read as "none failed": for people, the failed seeds by their folder names
        summaries = {case: {k: v for k, v in summary.items() if k not in ("seeds", "failed")} | {
            "failed seeds": ", ".join(CaseDir.seed_name(k) for k in summary["failed"]) or "none"} | {
            CaseDir.seed_name(r["seed"]): r.get("error") or _seed_line(r, cases[case])
            for r in summary["seeds"]} for case, summary in summaries.items()}
    # one case: its summary, as before; several: the summaries by case
    print_result(next(iter(summaries.values())) if len(summaries) == 1 else summaries, args.json)
    return 1 if failed else 0


def _stop_options(args: argparse.Namespace) -> dict:
    """The stop rule's settings given (checked by the library, naming the option)."""
    return {k: v for k, v in (("consecutive", args.stop_consecutive), ("patience", args.stop_patience),
                              ("tolerance", args.stop_tolerance), ("confirm", args.stop_confirm))
            if v is not None}


def _seed_line(r: dict, case: Case) -> str:
    """One seed of the final summary: its state (learned / stopped / still improving), return."""
    measure = ("msr policy export-seeds measures each seed's distance" if case.field_actuated
               else "the held-out targets of docs/steering_catheter.md measure a catheter policy")
    state = r.get("state", "")
    if r.get("stopped_early"):
        state = f"stopped at step {r['stop_step']} ({r['stop_reason']})"
    if not r.get("episodes"):  # a return of no episode is no measurement
        return (f"{state + ': ' if state else ''}no training episode ended (the run was shorter "
                f"than one episode), so no training return was measured; {measure}")
    return (f"{state + ': ' if state else ''}final mean training return "
            f"{r['final_mean_return']:.4g} ({r['episodes']} episodes {case.training_episodes}; not "
            f"a distance: {measure})")


#: s of the accurate evaluations that choose the actor ``msr refine`` continues (the yardstick's).
REFINE_CHOICE_DURATION = 10.0


def _check_refined_policy_case(args: argparse.Namespace, source: Path) -> None:
    """A refinement written into a shipped policy's ``seeds/`` is of that policy's case: the run's
    case, or the ``--spec`` robot's it refines for (refused naming both, before any evaluation)."""
    from ..cases.case import load_case
    from ..runfiles.rundir import RunDir
    from ..shipping.policy_files import check_policy_case, resolve_policy
    from ..sweep.refine_start import default_refine_output

    case = load_case(args.spec) if args.spec else resolve_policy(RunDir.checkpoint_of(args.run)).case
    check_policy_case(args.out or default_refine_output(source), case, option="--out")


def refine_command(args: argparse.Namespace) -> int:
    from ..runfiles.rundir import RunDir
    from ..shipping.policy_files import other_result_refusal, resolve_policy
    from ..shipping.policy_runs import (
        CHECKPOINT_CHOICES,
        check_checkpoint_file,
        choose_actor,
        choose_tip_reach_actor,
    )
    from ..sweep.refine import DEFAULT_STEPS, check_refined_case, refine
    from ..sweep.refine_start import check_refine_output, default_refine_output

    _check_run_options(args)
    if (refusal := other_result_refusal(Path(args.run))) is not None:  # before its default --out inside it
        raise CommandError(refusal)
    try:  # the output, --spec and --randomize are checked before the actors' 10 s evaluations
        if args.checkpoint not in CHECKPOINT_CHOICES:
            check_checkpoint_file(args.run, args.checkpoint)
        source = args.run if args.checkpoint in CHECKPOINT_CHOICES else Path(args.checkpoint)
        check_refine_output(args.out or default_refine_output(source), args.resume, source)
        if args.resume:  # continues its own checkpoint: no actor to choose (refine checks the record)
            choice = None if args.checkpoint == "auto" else choose_actor(args.run, args.checkpoint)
        else:
            check_refined_case(source, args.steps or DEFAULT_STEPS, args.spec, args.randomize,
                               args.device)
            _check_refined_policy_case(args, source)
            if resolve_policy(RunDir.checkpoint_of(args.run)).case.field_actuated:
                choice = choose_actor(args.run, args.checkpoint, REFINE_CHOICE_DURATION,
                                      not args.no_progress)
            else:  # a tip-reach run: judged on held-out targets, which must not choose its actor
                choice = choose_tip_reach_actor(args.run, args.checkpoint)
        with signals_as_exceptions():  # SIGTERM/SIGHUP: the checkpoints named, as after Ctrl-C
            result = refine(choice.path if choice else args.run, steps=args.steps, out=args.out,
                            resume=args.resume, progress=not args.no_progress,
                            episode_duration=args.episode_duration, device=args.device,
                            spec=args.spec, physics=args.physics, randomize=args.randomize)
    except (FileExistsError, FileNotFoundError, ValueError) as exc:
        raise CommandError(str(exc)) from None
    except KeyboardInterrupt as exc:
        return _interrupted([args.out or default_refine_output(source)], getattr(exc, "signum", 2))
    if choice is not None and not args.resume:
        result = {**result, "actor_choice": {**choice.to_dict(), "summary": choice.describe()}}
    print_rollout_result(result, args.json)
    return 0
