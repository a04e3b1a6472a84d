"""``msr loop SPEC --out DIR``: the whole path for a new robot in one resumable command (a thin
wrapper over :func:`elastica_magnetic_rl.loop.runner.run_loop`; heavy imports inside)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from elastica_magnetic.cli import CommandError, number, output_path
from elastica_magnetic.cli.input_places import INPUTS_ALWAYS, INPUTS_HOW
from elastica_magnetic.io import missing_folder_hint

from ..cli.options import CASE_HELP, field_case_option
from .settings import ROBUSTNESS_PHYSICS
from .state import STEPS

_STEP_LIST = ", ".join(STEPS)


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``msr loop``."""
    p = sub.add_parser(
        "loop",
        help="the whole path for a new robot in one resumable command: check, yardstick, train, "
             "generate, robustness, refine, robustness, firmware",
        description="Run, in order, what docs/own_robot.md and docs/sim_to_real.md walk by hand: "
        "msr case check; the rotating-field sweep in 10 s of the accurate physics, written into a "
        "spec copy as its yardstick; msr train --recipe fast on that copy; each seed's distance "
        "and msr policy generate with the farthest seed's farther actor; msr real robustness (the default "
        "variation set, open and closed loop); msr refine --physics training --randomize default; "
        f"msr real robustness of the refined policy; msr real firmware. Steps: {_STEP_LIST}; each "
        "writes DIR/<step>/. DIR/loop.json records each finished step: the same command again "
        "skips them and resumes an interrupted training. DIR/report.md and DIR/report.html (self-"
        "contained) are rewritten after every step.",
    )
    p.add_argument("spec", type=field_case_option, metavar="SPEC", help=CASE_HELP)
    p.add_argument("--out", type=output_path, required=True, metavar="DIR",
                   help="the loop's folder: new, empty, or a loop of the same SPEC to resume")
    p.add_argument("--seeds", type=number("seeds", 1, 1024, integer=True), default=2,
                   help="seeds trained (default 2)")
    p.add_argument("--steps", type=number("environment steps", 1, integer=True), default=None,
                   help="environment steps per seed (default: the case's step budget); more than a "
                        "loop in DIR trained resumes its seeds to this budget and runs the steps "
                        "after the training again")
    p.add_argument("--workers", type=number("processes", 1, 1024, integer=True), default=None,
                   help="worker processes of the sweep, the training and the robustness runs "
                        "(default: one per core)")
    p.add_argument("--skip", default=None, metavar="STEP,...",
                   help=f"steps not to run (recorded as skipped; a step that needs one is refused): "
                        f"{_STEP_LIST}")
    p.add_argument("--redo", default=None, metavar="STEP,...",
                   help="run these steps again, and every step that needs them")
    p.add_argument("--calibration", type=Path, default=None, metavar="FILE",
                   help="calibration JSON of the firmware step (default "
                        "stm32/calibration/default.json)")
    p.add_argument("--physics-robustness", choices=ROBUSTNESS_PHYSICS, default="training",
                   help="physics of the robustness steps' runs (default training; accurate: "
                        "comparable with the yardstick, about 12x the cost)")
    p.add_argument("--quick", action="store_true",
                   help="a smoke run of every step in about a minute (tiny step budgets and "
                        "durations in the training physics; its distances mean nothing)")
    p.add_argument("--force", action="store_true",
                   help="start over a loop in DIR whose spec or settings differ from these")
    p.add_argument("--no-progress", action="store_true",
                   help="no progress within the steps (the step lines are still printed); by "
                        "default a bar on a terminal, a plain line now and then in a log file")
    p.add_argument("--json", action="store_true", help="print loop.json at the end")
    # it writes into DIR on every run (its spec copy, each step's folder; --force replaces it)
    p.set_defaults(func=loop_command, **{INPUTS_ALWAYS: True, INPUTS_HOW: LOOP_WRITES})


def _settings(args: argparse.Namespace, skip: tuple[str, ...] = ()):
    """The steps' settings from the options, every file checked before any work; ``skip``: the
    steps skipped (an option only a skipped step reads cannot act: refused)."""
    import dataclasses

    from elastica_magnetic.batch import batched_refusal
    from elastica_magnetic.hardware.calibration import load_calibration

    from ..cases.case import warmup_refusal
    from .settings import LoopSettings

    if args.calibration is not None and "firmware" in skip:
        raise CommandError(f"--calibration {args.calibration}: only the firmware step reads it, and "
                           "--skip firmware skips that step: drop one of them")
    if args.calibration is not None:
        if not args.calibration.is_file():
            raise CommandError(f"--calibration {args.calibration}: no such file (a calibration "
                               "JSON, e.g. stm32/calibration/default.json or msr real calibrate's)"
                               f"{missing_folder_hint(args.calibration)}")
        calibration = load_calibration(args.calibration)  # its named error now, not after the training
        _check_calibration_drives(calibration, args.calibration, args.spec)
    spec = getattr(args, "spec", None)  # the case (parsed); absent where only the settings are asked
    refusal = None if spec is None else batched_refusal(spec.robot_spec("training"), "msr loop")
    if refusal:  # its sweep, training and robustness run the batched simulator
        raise CommandError(f"{spec.source}: {refusal}")
    if args.quick and "train" not in skip and spec is not None and warmup_refusal(spec):
        raise CommandError(f"--quick: {spec.source}: [training.td3] yardstick_warmup needs [yardstick] "
                           "period, and a smoke run's sweep does not record its field (too short to be a "
                           "yardstick a training may clone): give [yardstick] period in the spec, or run the "
                           "loop without --quick (its sweep records the field)")
    base = LoopSettings.smoke() if args.quick else LoopSettings()
    changes = {"seeds": args.seeds, "workers": args.workers,
               "robustness_physics": args.physics_robustness,
               "calibration": args.calibration.resolve() if args.calibration else None}
    if args.steps is None:
        kept = None if getattr(args, "force", False) else _recorded_steps(getattr(args, "out", None),
                                                                          base, bool(args.quick))
        if kept is not None:
            changes["steps"] = kept
    else:
        changes["steps"] = args.steps
        if args.quick and args.steps > base.steps:  # said: the smoke run is a minute's no longer
            print(f"note: --steps {args.steps} replaces --quick's {base.steps} training steps per seed: "
                  "the training is no smoke run of a minute (the other steps stay --quick's)",
                  file=sys.stderr)
    settings = dataclasses.replace(base, **changes)
    if spec is not None and "train" not in skip and args.steps is not None:
        _check_steps_learn(settings, spec)
    return settings


def _check_steps_learn(settings, spec) -> None:
    """``--steps`` no longer than the training's warm-up (or its first minibatch) would train no
    weight: refused now, in the loop's words, not by the training after the yardstick's sweep."""
    from ..cases.recipes import crawler_config
    from ..cases.training_tables import MAX_TRAIN_STEPS

    if settings.steps > MAX_TRAIN_STEPS:
        raise CommandError(f"--steps {settings.steps}: more than {MAX_TRAIN_STEPS:.0e} steps per seed, "
                           "months of training; a count written with extra digits?")
    td3 = dict(spec.training.td3)
    try:
        config = crawler_config(0, settings.recipe, **{**td3, **dict(settings.train_overrides)})
    except (TypeError, ValueError):  # the spec's own fault: the check step names it
        return
    first = max(config.learning_starts, config.batch_size - 1)
    if settings.steps > first:
        return
    whose = ("--quick's" if "learning_starts" in settings.train_overrides else
             "the spec's [training.td3]" if "learning_starts" in td3 else f"the {settings.recipe} recipe's")
    raise CommandError(f"--steps {settings.steps}: within the training's warm-up ({whose} "
                       f"learning_starts {config.learning_starts}, batch_size {config.batch_size}): no "
                       "weight would be updated and the seeds would end untrained; give --steps above "
                       f"{first}")


def _recorded_steps(out, base, quick: bool) -> int | None:
    """Without ``--steps``, the training steps of the loop already in ``out`` when they are not the
    default's (a loop given ``--steps`` once, or lengthened by it, goes on with its own: the same
    command again never asks a shorter training), said in a note; else ``None``."""
    from .state import LoopError, LoopState

    try:
        state = LoopState.read(out) if out is not None and out.is_dir() else None
    except (LoopError, OSError):
        return None  # the loop's own checks name a damaged state under its lock
    if state is None or bool(state.settings.get("quick")) != quick:
        return None
    steps = state.settings.get("steps")
    if not isinstance(steps, int) or steps == base.steps:
        return None
    print(f"note: --out {out}: its loop trains {steps} steps per seed (--steps {steps} given before); "
          "without --steps it keeps them", file=sys.stderr)
    return steps


def _check_calibration_drives(calibration, path, case) -> None:
    """A calibration whose coils cannot make the case's field limit along one of its axes alone
    (the least any waveform of that amplitude needs) would fail the firmware step after the
    training: refused now, naming the axis and the currents."""
    import numpy as np

    from elastica_magnetic.hardware.calibration import clipping_report

    limits = getattr(case.actuation, "limits", None)
    if limits is None:  # a steered case: msr loop refuses it by name elsewhere
        return
    for axis, name in enumerate("xyz"):
        if name not in case.actuation.axes:
            continue
        row = np.zeros(3)
        row[axis] = 1e3 * limits[axis]  # mT
        report = clipping_report(calibration, row[None, :])
        if report.rows:
            raise CommandError(f"--calibration {path}: its coils cannot make the case's field limit "
                               f"{1e3 * limits[axis]:g} mT along {name} alone ({report.describe()}): the "
                               "firmware step would refuse the learned waveform after the training; give "
                               "a calibration whose current limits drive it")


#: What ``msr loop`` does to a file inside its folder.
LOOP_WRITES = ("writes into on every run (its spec copy with the yardstick, each step's folder) and "
               "replaces with --force: the input would be rewritten or deleted (a loop's own spec copy "
               "is not its SPEC: give the spec it started from)")


def _say_unread_recipe(args: argparse.Namespace) -> None:
    """A note where the spec chose a recipe the loop does not train with (it trains with its own)."""
    from ..cases.recipes import DEFAULT_RECIPE
    from .settings import LoopSettings

    spec = getattr(args, "spec", None)
    training = spec.to_dict().get("training") if spec is not None else None
    written = training.get("recipe") if isinstance(training, dict) else None
    if isinstance(written, str) and written not in (LoopSettings.recipe, DEFAULT_RECIPE):  # chosen
        print(f"note: {spec.source}: [training] recipe = {written!r} is not used: msr loop trains with "
              f"the {LoopSettings.recipe} recipe (msr train --case SPEC --recipe {written} trains with "
              "it)", file=sys.stderr)


def loop_command(args: argparse.Namespace) -> int:
    from elastica_magnetic.interrupts import signals_as_exceptions

    from .runner import run_loop
    from .state import LoopError, parse_steps

    redo: tuple[str, ...] = ()
    _say_unread_recipe(args)
    try:
        skip, redo = parse_steps(args.skip, "--skip"), parse_steps(args.redo, "--redo")
        # SIGTERM/SIGHUP stop it as Ctrl-C does, in every step (the train step's too), with the
        # message below, not silently
        with signals_as_exceptions():
            state = run_loop(args.spec, args.out, _settings(args, skip), skip=skip, redo=redo,
                             force=args.force, progress=not args.no_progress)
    except LoopError as exc:
        raise CommandError(str(exc)) from None
    except FileNotFoundError as exc:
        raise CommandError(str(exc)) from None
    except KeyboardInterrupt as exc:
        if getattr(exc, "loop_started_over", False):
            print(f"loop: interrupted; the loop started over with --force was not finished, and "
                  f"{args.out} holds the earlier loop as it was (its loop.json): the same command "
                  "starts it over again from its first step", file=sys.stderr)
        else:
            again = ("run the same command again to go on from there" if not redo else
                     "run it again without --redo to go on from there (the same command starts the "
                     f"steps of --redo {','.join(redo)} again)")
            print(f"loop: interrupted; the finished steps are recorded in {args.out / 'loop.json'}: "
                  f"{again}", file=sys.stderr)
        raise
    if args.json:
        print(json.dumps({"out": str(args.out), "case": state.case, "steps": state.steps},
                         indent=2, default=str))
    else:
        done = sum(1 for r in state.steps.values() if r["status"] == "done")
        print(f"loop: {done} of {len(STEPS)} steps done in {args.out}")
        print(f"report: {args.out / 'report.md'}, {args.out / 'report.html'}")
    sys.stdout.flush()
    return 0
