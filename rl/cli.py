"""``msr train``, ``refine``, ``generate``, ``baseline``, ``ship``, ``export``, ``figures``,
``demo``: thin wrappers over :mod:`rl.pipeline`, :mod:`rl.baselines` and :mod:`rl.figures` (heavy
imports happen inside the commands)."""

from __future__ import annotations

import argparse
from pathlib import Path

from elastica_magnetic.cli import CommandError, duration_option, number, print_result

CASE_NAMES = ("m1-4mT", "m2-4mT", "m1-10mT", "m2-10mT")


def _add_rollout_options(p: argparse.ArgumentParser, out: Path) -> None:
    """The options of the commands that roll a policy out and write what ``generate`` writes."""
    p.add_argument("--duration", type=duration_option(), default=10.0, help="s")
    p.add_argument("--out", type=Path, default=out)
    p.add_argument("--physics", choices=("accurate", "training"), default="accurate")
    p.add_argument("--no-figures", action="store_true", help="skip the figures and the GIF")
    p.add_argument("--no-gif", action="store_true", help="skip the GIF")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--json", action="store_true")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "train",
        help="train TD3 crawling policies for one or more cases, several seeds in parallel",
        description="Train TD3 on one or more cases in the mass-scaled training physics (random "
        "initial fields, 20 s truncated episodes). Each seed writes OUT/<case>/seed<k>/ "
        "(episodes.csv, TensorBoard scalars, checkpoint.pt, run.json); OUT/<case>/summary.json "
        "collects the final mean episode returns of every seed of the case.",
    )
    p.add_argument("--case", choices=CASE_NAMES, required=True, nargs="+",
                   help="one or more cases; several make one sweep (cases x seeds jobs)")
    p.add_argument("--seeds", type=int, default=8, help="number of seeds (default 8)")
    p.add_argument("--seed-offset", type=int, default=0, help="first seed (default 0)")
    p.add_argument("--steps", type=int, default=100_000, help="environment steps per seed")
    p.add_argument("--workers", type=int, default=1,
                   help="seeds trained at a time (processes, or Ray tasks in flight)")
    p.add_argument("--out", type=Path, default=Path("runs"), help="output folder")
    p.add_argument("--resume", action="store_true", help="continue runs from their checkpoints")
    p.add_argument("--physics", choices=("training", "accurate"), default="training")
    p.add_argument("--episode-duration", type=float, default=20.0, help="s (truncation)")
    p.add_argument("--threads", type=int, default=None, help="torch threads per worker")
    p.add_argument("--envs", type=int, default=1,
                   help="crawlers per seed in one batched simulator (vector env; N transitions and "
                        "N TD3 updates per vector step; default 1: the single environment)")
    p.add_argument("--seeds-per-simulator", type=int, default=1, metavar="K",
                   help="K seeds train side by side in one worker, their crawlers in one batched "
                        "simulator; each seed's run is bit-identical to training it alone, the "
                        "simulation costs less per robot (default 1)")
    p.add_argument("--backend", choices=("process", "ray"), default="process",
                   help="where the seeds run: worker processes on this machine (default) or Ray tasks "
                        "(a local Ray instance with --workers x --threads CPUs, or the cluster at "
                        "--address); same run directories and summary.json")
    p.add_argument("--address", default=None,
                   help="Ray cluster address for --backend ray (auto, HOST:PORT, ray://HOST:10001); "
                        "--out must then be on a filesystem all nodes see at the same path")
    g = p.add_argument_group("TD3 overrides (default: the paper's settings)")
    g.add_argument("--learning-starts", type=int, default=None, help="warm-up steps (2500)")
    g.add_argument("--batch-size", type=int, default=None, help="minibatch (256)")
    g.add_argument("--hidden", type=str, default=None, help="hidden sizes, e.g. 256,256")
    g.add_argument("--buffer-size", type=int, default=None, help="replay capacity (1e6)")
    g.add_argument("--target-noise-clip", type=float, default=None, help="(0.8, the authors')")
    g.add_argument("--checkpoint-every", type=int, default=None, help="steps (10000)")
    g.add_argument("--eval-every", type=int, default=None,
                   help="steps between evaluations of the deterministic policy from a zero field, "
                        "10 s, best actor kept in best.pt (5000; 0: none)")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=train_command)

    p = sub.add_parser(
        "refine",
        help="continue training a run in the accurate physics (agent and replay buffer)",
        description="Load a run's agent and replay buffer and continue training for --steps "
        "environment steps in the accurate physics (true density, dt 8e-6 s: ~12.5x the cost of a "
        "training step). Writes RUN/refined/ unless --out is given.",
    )
    p.add_argument("run", type=Path, help="run directory (or its checkpoint.pt)")
    p.add_argument("--steps", type=int, default=1000)
    p.add_argument("--out", type=Path, default=None, help="default: RUN/refined")
    p.add_argument("--resume", action="store_true", help="continue an interrupted refinement")
    p.add_argument("--episode-duration", type=float, default=20.0, help="s (truncation)")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=refine_command)

    p = sub.add_parser(
        "generate",
        help="generate a field waveform with a policy (accurate physics, field from zero)",
        description="Run a policy deterministically in the accurate physics with the field starting "
        "at zero; write fields.csv (index, mag_x, mag_y, mag_z in mT, 100 rows/s), trajectory.csv, "
        "rollout.npz, generate.json, the figures and gait.gif.",
    )
    p.add_argument("policy", help="run directory, checkpoint, shipped-policy folder or shipped name "
                                  "(e.g. m1-4mT)")
    _add_rollout_options(p, Path("out/generate"))
    p.set_defaults(func=generate_command)

    p = sub.add_parser(
        "baseline",
        help="generate with a hand-designed rotating field (the yardstick for learned policies)",
        description="Turn the field at the case's limit at a constant rate, through the agent's "
        "own action channel (0.3 mT per axis per 0.01 s, field from zero), and write the same "
        "files as `msr generate`: a rotating field rolls the robot, the gait to beat.",
    )
    p.add_argument("--case", choices=CASE_NAMES, required=True)
    p.add_argument("--period", type=number("s", 0.0, low_open=True), default=2.0,
                   help="s per turn of the field (2)")
    p.add_argument("--counterclockwise", action="store_true",
                   help="turn counter-clockwise (rolls towards -x)")
    _add_rollout_options(p, Path("out/baseline"))
    p.set_defaults(func=baseline_command)

    p = sub.add_parser(
        "ship",
        help="pack a run into a shipped policy (rl/policies/<name>/) with a model card",
        description="Write actor.pt, critic.pt, policy.json and MODEL_CARD.md for a run's checkpoint "
        "into DEST/<name> (default rl/policies/<name>); measures the 10 s distance in the accurate "
        "physics unless --no-measure.",
    )
    p.add_argument("run", type=Path, help="run directory or checkpoint (e.g. runs/m1-4mT/seed3/refined)")
    p.add_argument("--name", required=True, help="policy name, e.g. m1-4mT")
    p.add_argument("--dest", type=Path, default=None, help="default: the package's rl/policies")
    p.add_argument("--no-measure", action="store_true", help="skip the evaluation run")
    p.add_argument("--duration", type=duration_option(), default=10.0, help="evaluation length, s")
    p.add_argument("--force", action="store_true", help="overwrite an existing policy")
    p.add_argument("--evaluate-seeds", action="store_true",
                   help="also run every seed of the case (final checkpoints) in the accurate physics "
                   "and list their distances in the model card (cached per seed)")
    p.add_argument("--notes", type=Path, default=None,
                   help="Markdown file whose text becomes the model card's Notes section")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=ship_command)

    p = sub.add_parser(
        "export",
        help="export a policy's actor as TorchScript plus its observation/action JSON",
    )
    p.add_argument("policy", help="run directory, checkpoint, shipped-policy folder or shipped name")
    p.add_argument("--out", type=Path, default=Path("out/export"))
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=export_command)

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
    out = {}
    for name in ("learning_starts", "batch_size", "buffer_size", "target_noise_clip",
                 "checkpoint_every", "eval_every"):
        value = getattr(args, name)
        if value is not None:
            out[name] = value
    if args.hidden:
        try:
            out["hidden_sizes"] = tuple(int(h) for h in args.hidden.split(","))
        except ValueError:
            raise CommandError(f"--hidden must be comma-separated integers, got {args.hidden!r}") from None
    return out


def train_command(args: argparse.Namespace) -> int:
    from .pipeline import train_cases

    try:
        summaries = train_cases(
            args.case, seeds=args.seeds, steps=args.steps, workers=args.workers, out=args.out,
            resume=args.resume, seed_offset=args.seed_offset, config_overrides=_overrides(args),
            physics=args.physics, episode_duration=args.episode_duration,
            progress=not args.no_progress, threads=args.threads, envs=args.envs,
            backend=args.backend, address=args.address,
            seeds_per_simulator=args.seeds_per_simulator,
        )
    except (FileExistsError, ValueError, ConnectionError) as exc:  # ConnectionError: --address
        raise CommandError(str(exc)) from None
    failed = any(s["failed"] for s in summaries.values())
    if not args.json:
        summaries = {case: {k: v for k, v in summary.items() if k != "seeds"} | {
            f"seed{r['seed']}": r.get("error") or f"final mean return {r['final_mean_return']:.4g} "
            f"({r['episodes']} episodes)" for r in summary["seeds"]} for case, summary in summaries.items()}
    # one case: its summary, as before; several: the summaries by case
    print_result(summaries[args.case[0]] if len(summaries) == 1 else summaries, args.json)
    return 1 if failed else 0


def refine_command(args: argparse.Namespace) -> int:
    from .pipeline import refine

    try:
        result = refine(args.run, steps=args.steps, out=args.out, resume=args.resume,
                        progress=not args.no_progress, episode_duration=args.episode_duration)
    except (FileExistsError, ValueError) as exc:
        raise CommandError(str(exc)) from None
    print_result(result, args.json)
    return 0


def generate_command(args: argparse.Namespace) -> int:
    from .pipeline import generate

    result = generate(args.policy, duration=args.duration, out=args.out, physics=args.physics,
                      progress=not args.no_progress, figures=not args.no_figures,
                      gif=not args.no_gif)
    print_result(result, args.json)
    return 0 if not result["diverged"] else 1


def baseline_command(args: argparse.Namespace) -> int:
    from .baselines import RotatingFieldPolicy
    from .pipeline import generate

    try:
        policy = RotatingFieldPolicy(args.case, args.period, clockwise=not args.counterclockwise)
    except ValueError as exc:
        raise CommandError(f"--period: {exc}") from None
    result = generate(policy, duration=args.duration, out=args.out, physics=args.physics,
                      progress=not args.no_progress, figures=not args.no_figures,
                      gif=not args.no_gif)
    print_result(result, args.json)
    return 0 if not result["diverged"] else 1


def ship_command(args: argparse.Namespace) -> int:
    from .pipeline import ship

    notes = None
    if args.notes is not None:
        if not args.notes.is_file():
            raise CommandError(f"--notes {args.notes}: no such file")
        notes = args.notes.read_text()
    try:
        result = ship(args.run, args.name, dest=args.dest, measure=not args.no_measure,
                      duration=args.duration, progress=not args.no_progress, overwrite=args.force,
                      evaluate_all_seeds=args.evaluate_seeds, notes=notes)
    except (FileExistsError, FileNotFoundError) as exc:
        raise CommandError(str(exc)) from None
    print_result(result, args.json)
    return 0


def export_command(args: argparse.Namespace) -> int:
    from .pipeline import export_policy

    print_result(export_policy(args.policy, args.out), args.json)
    return 0


def figures_command(args: argparse.Namespace) -> int:
    from .figures import make_figures

    print_result(make_figures(args.path, args.out, gif=not args.no_gif), args.json)
    return 0


def demo_command(args: argparse.Namespace) -> int:
    from .pipeline import demo

    result = demo(args.out, duration=args.duration, progress=not args.no_progress)
    print_result(result, args.json)
    return 0 if not result["diverged"] else 1
