"""``msr design SPEC --out DIR``: search a magnetization (a thin wrapper over
:func:`elastica_magnetic_rl.design.run.run_design`; heavy imports inside)."""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

from elastica_magnetic.cli import CommandError, number, output_path

from ..cli.options import CASE_HELP
from .search import OBJECTIVES

#: A design's wall time past this many times its --minutes is said (the budget is a forecast).
OVER_BUDGET = 1.5


def design_spec_option(value: str):
    """``SPEC``: a shipped case or a spec file, checked at parse time (with its ``[design]``
    table), so a bad spec is named before any work."""
    from elastica_magnetic.specfile import SpecError

    from .folder import DesignError
    from .run import load_design

    try:
        return load_design(value)
    except (SpecError, DesignError) as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``msr design``."""
    p = sub.add_parser(
        "design",
        help="search a magnetization a lab can make (segments, directions, magnitudes) for the "
             "farthest rotating-field walk, or the best worst case over fabrication errors",
        description="CMA-ES over the magnetization of SPEC's robot (its [design] table: segments, "
        "lengths, directions, magnitude, remanence; without one, the robot's own segment count or 6 "
        "equal segments at its own magnitude, directions free in the bending plane). Each candidate "
        "runs, with all others of its generation in one batched simulation, under a rotating field "
        "whose period the search chooses too, both senses. The starting and the best design are "
        "then judged by the same sweep of rotating fields (10 s of the accurate physics): DIR/"
        "summary.json (objective_start_m, objective_best_m), DIR/best.toml (a spec ready for msr "
        "train), DIR/history.csv, figures, DIR/gait/. Killed, it continues with --resume from the "
        "last whole generation (the same result as an uninterrupted run with the same --seed and "
        "--generations).",
    )
    p.add_argument("spec", type=design_spec_option, metavar="SPEC",
                   help=CASE_HELP + ", with or without a [design] table")
    p.add_argument("--out", type=output_path, required=True, metavar="DIR",
                   help="the design's folder: new or empty, or a design to continue (--resume) or "
                        "replace (--force)")
    p.add_argument("--minutes", type=number("minutes", 0, 10080, low_open=True), default=None,
                   help="wall-time budget of the whole command, final judgement included "
                        "(default 30 unless --generations is given)")
    p.add_argument("--generations", type=number("generations", 1, 100000, integer=True), default=None,
                   help="CMA-ES generations (a budget that gives the same result on every machine)")
    p.add_argument("--seed", type=number("seed", 0, 2**31 - 1, integer=True), default=0,
                   help="seed of the search (default 0)")
    p.add_argument("--objective", choices=OBJECTIVES, default="yardstick",
                   help="yardstick: the farthest rotating field; robust: its worst case over the "
                        "default fabrication errors, corners included (25 robots: 25x the cost per "
                        "candidate; see --search-physics)")
    p.add_argument("--search-physics", choices=("accurate", "training"), default="accurate",
                   help="the physics each candidate runs in during the search (default accurate, as "
                        "judged); training: about 12x cheaper, its best distinct candidates "
                        "(--finalists) then run again in the accurate physics before the best is chosen")
    p.add_argument("--finalists", type=number("candidates", 1, 100, integer=True), default=None,
                   help="with --search-physics training, how many of the search's best distinct "
                        "candidates the accurate physics judges again (default 6)")
    p.add_argument("--popsize", type=number("candidates", 2, 1000, integer=True), default=None,
                   help="candidates per generation (default CMA-ES's 4 + 3 ln(dimension))")
    p.add_argument("--workers", type=number("processes", 1, 1024, integer=True), default=None,
                   help="processes sharing each generation's simulation (default: one per core)")
    p.add_argument("--resume", action="store_true", help="continue the design in DIR")
    p.add_argument("--force", action="store_true", help="replace the design in DIR")
    p.add_argument("--quick", action="store_true",
                   help="a smoke run in a minute or two (0.5 s runs of the training physics, two "
                        "periods judged, no GIF): its distances mean nothing")
    p.add_argument("--no-gif", action="store_true", help="no GIF of the best design's gait")
    p.add_argument("--no-progress", action="store_true", help="no progress lines")
    p.add_argument("--json", action="store_true", help="print summary.json")
    p.set_defaults(func=design_command)


def _settings(args: argparse.Namespace):
    from .run import DesignSettings

    minutes = args.minutes if args.minutes is not None else (None if args.generations else 30.0)
    if args.finalists is not None and args.search_physics == "accurate" and not args.quick:
        raise CommandError(f"--finalists {args.finalists}: acts only with --search-physics training (a "
                           "search in the accurate physics measures what the judgement measures: its "
                           "best is the one judged)")
    settings = DesignSettings(objective=args.objective, seed=args.seed, minutes=minutes,
                              generations=args.generations, popsize=args.popsize,
                              physics=args.search_physics,
                              workers=args.workers or os.cpu_count() or 1, gif=not args.no_gif,
                              **({} if args.finalists is None else {"finalists": args.finalists}))
    if args.quick:
        from dataclasses import replace

        settings = replace(settings, physics="training", search_duration=0.5,
                           final_physics="training", final_duration=0.5, final_periods=(0.5, 1.0),
                           gif=False)
    return settings


def design_command(args: argparse.Namespace) -> int:
    from .folder import DesignError, holds_design
    from .run import run_design

    settings = _settings(args)

    def progress(state: dict) -> None:
        if not args.no_progress:
            print(f"design: generation {state['generation']}, {state['evaluations']} candidates, "
                  f"best {1e3 * state['best_objective_m']:+.2f} mm, "
                  f"{state['elapsed_s'] / 60:.1f} min", file=sys.stderr, flush=True)

    from elastica_magnetic.interrupts import signals_as_exceptions

    replacing = args.force and holds_design(args.out)
    continuing_finished = args.resume and not replacing and (args.out / "summary.json").is_file()
    if not args.no_progress:  # the first line comes after a whole generation: say what runs first
        budget = (f"up to {settings.generations} generations" if settings.generations else
                  f"--minutes {settings.minutes:g} stops it between generations")
        print(f"design: searching ({budget}; a line after each generation); the first generation and "
              "the final judgement of the best run whatever the budget", file=sys.stderr, flush=True)
    try:
        began = time.perf_counter()
        with signals_as_exceptions():  # SIGTERM/SIGHUP as Ctrl-C: the message below, not silence
            summary = run_design(args.spec, args.out, settings,
                                 resume=args.resume, force=args.force, progress=progress)
    except DesignError as exc:
        raise CommandError(str(exc)) from None
    except KeyboardInterrupt:
        if replacing:
            print(f"design: interrupted; the earlier design in {args.out} is kept as it was (the "
                  "replacement is dropped: start it again with --force)", file=sys.stderr)
        elif continuing_finished:
            print(f"design: interrupted; the finished design in {args.out} is kept as it was (its "
                  "continued search is dropped: continue it again with --resume)", file=sys.stderr)
        else:
            print(f"design: interrupted; the design's progress (its last whole generation, if any) "
                  f"is in {args.out}: continue with the same command and --resume", file=sys.stderr)
        raise
    stopped = summary["search"].get("stopped")
    if stopped and stopped.get("generations_asked") is not None:
        print(f"design: stopped by --minutes {stopped['minutes']:g} after {stopped['generations']} of "
              f"{stopped['generations_asked']} generations (continue with --resume and a larger "
              "--minutes)", file=sys.stderr)
    took = time.perf_counter() - began
    if settings.minutes is not None and took > 60.0 * settings.minutes * OVER_BUDGET:
        print(f"design: warning: took {took:.0f} s, beyond --minutes {settings.minutes:g} "
              f"({60.0 * settings.minutes:.3g} s): the search runs at least one generation "
              f"({stopped['generations'] if stopped else '?'} run) and the final judgement whatever the "
              "budget; give a budget of at least the time above", file=sys.stderr)
    if args.json:
        print(json.dumps(summary, indent=2, default=str))
    else:
        from ..reports.text import millimetres

        start, best = summary["objective_start_m"], summary["objective_best_m"]
        ratio = summary["ratio"]
        print(f"design: {summary['objective']} objective: start {millimetres(start)}, "
              f"best {millimetres(best)}"
              + (f" ({ratio:.2f}x)" if ratio else ""))
        print(f"best design: {args.out / 'best.toml'}; report: {args.out / 'report.md'}")
    sys.stdout.flush()
    return 0

