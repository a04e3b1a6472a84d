"""``msr policy export-seeds``, ``seeds``, ``ship``, ``notes``, ``export``, ``diagnose``: what a
user does with trained policies (collect every seed, compare recipes, pack, annotate, export,
diagnose). Thin wrappers over :mod:`elastica_magnetic_rl.shipping.seed_export`,
:mod:`elastica_magnetic_rl.shipping.seed_report`, :mod:`elastica_magnetic_rl.shipping.ship`,
:mod:`elastica_magnetic_rl.shipping.export` and :mod:`elastica_magnetic_rl.reports.diagnostics`
(heavy imports happen inside the commands); training is in
:mod:`elastica_magnetic_rl.cli.train_commands`, rollouts in
:mod:`elastica_magnetic_rl.cli.commands`."""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from pathlib import Path

from elastica_magnetic.cli import (
    CommandError,
    duration_option,
    number,
    output_path,
    print_notes,
    print_result,
)
from elastica_magnetic.cli.input_places import REPLACED_FOLDER, no_folder_replaced_whole
from elastica_magnetic.cli.options import add_old_option
from elastica_magnetic.filesets import check_files, replace_files
from elastica_magnetic.io import display_path, missing_folder_hint

from .options import CASE_HELP, CHECKPOINT_HELP, FORCE_HELP, field_case_option, print_rollout_result


def register(sub: argparse._SubParsersAction) -> None:
    """Add this module's sub-commands to ``msr``."""
    for add in (_add_export_seeds_command, _add_seeds_command, _add_ship_command, _add_notes_command,
                _add_export_command, _add_diagnose_command):
        add(sub)


def _add_export_seeds_command(sub: argparse._SubParsersAction) -> None:
    """``msr policy export-seeds``."""
    p = sub.add_parser(
        "export-seeds",
        help="every seed of a case as a policy folder, with seeds.json (10 s distances)",
        description="Evaluate every seed of a training case folder (OUT/<case>: its final "
        "checkpoint and best.pt, 10 s in the accurate physics from a zero field, cached per seed) "
        "and write, for each seed, the farther of the two actors as a policy folder "
        "DIR/seed<k>/ (actor.pt, policy.json: msr policy generate accepts it) and DIR/seeds.json.",
    )
    p.add_argument("case_dir", type=Path, help="a case folder of msr train, e.g. runs/m1-4mT")
    p.add_argument("--out", type=output_path, default=None, dest="dest", metavar="DIR",
                   help="required: where the seeds go, e.g. rl/policies/m1-4mT/seeds/paper")
    add_old_option(p, "--dest", "--out", output_path, "dest")
    p.add_argument("--duration", type=duration_option(), default=10.0, help="evaluation length, s")
    p.add_argument("--workers", type=number("processes", 1, 1024, integer=True), default=1,
                   help="seeds evaluated at a time (processes)")
    p.add_argument("--force", action="store_true",
                   help="replace seeds of the same case already in --out (seeds of another case, "
                        "or other files, are never replaced)")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=export_seeds_command, **{REPLACED_FOLDER: no_folder_replaced_whole})


def _add_seeds_command(sub: argparse._SubParsersAction) -> None:
    """``msr policy seeds``."""
    p = sub.add_parser(
        "seeds",
        help="every committed seed of a case, by recipe: successes and distances",
        description="Read rl/policies/<case>/seeds/<recipe>/seeds.json (written by msr "
        "export-seeds) for each case and print, per recipe, how many seeds meet the case's target "
        "and each seed's 10 s distance; optionally draw them and keep the table in the case's "
        "shipped model card.",
    )
    p.add_argument("case", nargs="+", type=field_case_option, help=CASE_HELP)
    p.add_argument("--policies", type=Path, default=None,
                   help="folder of policy folders (default: the shipped policies, rl/policies)")
    p.add_argument("--figure", type=output_path, default=None, metavar="DIR",
                   help="write DIR/seeds_<case>.png (every seed's distance per recipe) and "
                   "DIR/learning_curves_<case>.png (from the logs the exported seeds keep)")
    p.add_argument("--force", action="store_true",
                   help="replace the figures already in --figure (other files there stay)")
    p.add_argument("--card", action="store_true",
                   help="also write the table into the model card of every policy of the case "
                        "(<policies>/<case>/MODEL_CARD.md, and e.g. <case>-robust's)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=seeds_command)


def _add_ship_command(sub: argparse._SubParsersAction) -> None:
    """``msr policy ship``."""
    p = sub.add_parser(
        "ship",
        help="pack a run into a shipped policy (rl/policies/<name>/) with a model card",
        description="Write actor.pt, critic.pt, policy.json and MODEL_CARD.md for a run's checkpoint "
        "into DIR/<name> (--out DIR; default rl/policies/<name>); measures the 10 s distance in the accurate "
        "physics unless --no-measure.",
    )
    p.add_argument("run", type=Path, help="run directory or checkpoint (e.g. runs/m1-4mT/seed3/refined)")
    p.add_argument("--name", required=True, help="policy name, e.g. m1-4mT")
    p.add_argument("--checkpoint", default="auto", metavar="auto|final|best|PATH",
                   help=CHECKPOINT_HELP + " (evaluated for --duration s)")
    p.add_argument("--out", type=output_path, default=None, dest="dest", metavar="DIR",
                   help="the folder of policies the policy goes into, as DIR/<name> (default: the "
                        "package's rl/policies)")
    add_old_option(p, "--dest", "--out", output_path, "dest")
    p.add_argument("--no-measure", action="store_true", help="skip the evaluation run")
    p.add_argument("--duration", type=duration_option(), default=None,
                   help="evaluation length, s (default 10; not with --no-measure; a goto policy's ring "
                   "of targets is measured for the task's episode whatever it is)")
    p.add_argument("--force", action="store_true",
                   help="replace an existing policy in DIR/<name>: its files (the waveform and critic of the "
                        "replaced policy go with it, even when this one has none: --no-measure); "
                        "your other files stay")
    p.add_argument("--evaluate-seeds", action="store_true",
                   help="also run every seed of the case (final checkpoints) in the accurate physics "
                   "and list their distances in the model card (cached per seed)")
    p.add_argument("--notes", type=Path, default=None,
                   help="Markdown file whose text becomes the model card's Notes section")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=ship_command, **{REPLACED_FOLDER: no_folder_replaced_whole})


def _add_notes_command(sub: argparse._SubParsersAction) -> None:
    """``msr policy notes``."""
    p = sub.add_parser(
        "notes",
        help="show or replace a shipped policy's notes (policy.json and its model card's Notes)",
        description="Without --file, print the notes. With --file, its Markdown replaces them in "
        "policy.json and in MODEL_CARD.md's Notes section together; --clear removes them.",
    )
    p.add_argument("policy", help="shipped-policy name or folder, e.g. m2-4mT")
    # --notes too: msr policy ship takes the notes by that name
    p.add_argument("--file", "--notes", dest="file", type=Path, default=None,
                   help="Markdown file with the new notes (--notes: the same)")
    p.add_argument("--clear", action="store_true",
                   help="remove the notes (an empty --file is refused: more often a mistake)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=notes_command)


def _add_export_command(sub: argparse._SubParsersAction) -> None:
    """``msr policy export``."""
    p = sub.add_parser(
        "export",
        help="export a policy's actor as TorchScript plus its observation/action JSON",
    )
    p.add_argument("policy", help="run directory, checkpoint, shipped-policy folder or shipped name")
    p.add_argument("--checkpoint", default="auto", metavar="auto|final|best|PATH",
                   help=CHECKPOINT_HELP + " (10 s)")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--out", type=output_path, default="out/export")
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=export_command)


def _add_diagnose_command(sub: argparse._SubParsersAction) -> None:
    """``msr policy diagnose``."""
    p = sub.add_parser(
        "diagnose",
        help="is a run's critic calibrated, is its actor saturated? (from its checkpoint)",
        description="For each run (a run directory or its checkpoint.pt), on its last --recent "
        "transitions: the critic's Q against the discounted return of the same transitions "
        "(Monte-Carlo, from the stored rewards), and how often the actor's outputs before tanh "
        "are beyond |3| (saturated: the actor stops learning). --figure DIR draws both per run.",
    )
    p.add_argument("run", type=Path, nargs="+", help="run directory or checkpoint")
    p.add_argument("--recent", type=int, default=20_000, help="last transitions to use (default 20000)")
    p.add_argument("--figure", type=output_path, default=None, help="write health_<case>_seed<k>.png here")
    p.add_argument("--force", action="store_true",
                   help="replace the figures already in --figure (other files there stay)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=diagnose_command)


def export_seeds_command(args: argparse.Namespace) -> int:
    from ..shipping.seed_export import export_seeds

    if args.dest is None:
        raise CommandError("--out DIR is required: the folder the seeds are written to")
    if not (math.isfinite(args.duration) and 0 < args.duration <= 600):
        raise CommandError(f"--duration must be a finite time in (0, 600] s, got {args.duration}")
    from ..shipping.policy_files import other_result_refusal

    if (refusal := other_result_refusal(Path(args.case_dir), "a case's training runs: give the folder "
                                        "holding its seed<k>/ runs")) is not None:
        raise CommandError(refusal)
    for checkpoint in sorted(Path(args.case_dir).glob("seed*/checkpoint.pt"))[:1]:  # the case's seeds
        _refuse_tip_reach(checkpoint.parent, "export-seeds")
        _refuse_goto(checkpoint.parent)
    try:
        result = export_seeds(args.case_dir, args.dest, args.duration,
                              progress=not args.no_progress, workers=args.workers, force=args.force)
    except (FileNotFoundError, ValueError) as exc:
        error = CommandError(str(exc))
        for note in getattr(exc, "__notes__", ()):  # a killed export's leftovers recovered first
            error.add_note(note)
        raise error from None
    print_notes(result.pop("notes", ()))
    if result.get("meeting_target") is None and not args.json:  # "none" would read as zero seeds
        result["meeting_target"] = (
            f"not judged: the yardstick is a distance in 10 s, these runs are {args.duration:g} s"
            if args.duration != 10.0 else "not judged: the case has no yardstick")
    print_result(result, args.json)
    return 0


def seeds_command(args: argparse.Namespace) -> int:
    from ..shipping.policy_files import POLICIES_DIR
    from ..shipping.seed_report import (
        card_spec_problem,
        case_cards,
        case_seeds,
        learning_curves_by_recipe,
        recipes_markdown,
        seeds_figure,
        seeds_markdown,
        update_model_card,
    )

    policies = args.policies if args.policies is not None else POLICIES_DIR
    if not policies.is_dir():
        raise CommandError(f"--policies {policies}: no such folder")
    if args.figure is not None:  # before any figure is drawn
        from elastica_magnetic.result_places import check_not_another_result

        from ..shipping.policy_files import check_policy_case

        check_not_another_result(args.figure, "--figure")
        for case in args.case:  # a shipped policy's seeds/ takes its own case's figures only
            check_policy_case(args.figure, case, option="--figure", what="these figures are")
        check_files(args.figure, [name for case in args.case for name in _seed_figure_names(case)],
                    force=args.force, option="--figure")
    reports, by_case = [], {}
    for case in args.case:
        left_out: list[str] = []
        try:
            groups = case_seeds(case, policies, left_out)
        except ValueError as exc:
            raise CommandError(str(exc)) from None
        for note in left_out:
            print(f"note: {note}", file=sys.stderr)
        by_case[case.name] = groups
        report = {"case": case.name, "recipes": [g.to_dict() for g in groups],
                  "table": seeds_markdown(case, groups, policies), "left_out": left_out}
        if args.figure is not None and groups:
            names = _seed_figure_names(case)
            with replace_files(args.figure, names, force=args.force, option="--figure") as files:
                report["figure"] = str(files.final_path(seeds_figure(case, groups,
                                                                     files.path / names[0])))
                curves = learning_curves_by_recipe(case, groups, files.path / names[1])
            if curves is not None:
                report["learning_curves"] = str(files.final_path(curves))
        if args.card:
            if not groups:  # a card's seed section is never replaced by nothing
                raise CommandError(f"--card: {seeds_markdown(case, groups, policies)} The model "
                                   "card is left as it is.")
            cards = case_cards(case, policies)
            if not cards:
                raise CommandError(f"--card: {policies / case.name / 'MODEL_CARD.md'}: no model "
                                   f"card (ship a policy of {case.name} first)")
            problems = [problem for card in cards if (problem := card_spec_problem(card, case))]
            if problems:
                raise CommandError(f"--card: {problems[0]}")
            report["cards"] = [str(card) for card in cards]
            # a list, not a generator: any() must not stop before every card is updated
            report["card_updated"] = any([update_model_card(card, case, groups) for card in cards])
        reports.append(report)
    recipes = recipes_markdown(by_case)
    if args.json:
        print_result({"cases": reports, "recipes_table": recipes}, True)
    else:
        for report in reports:
            print(f"## {report['case']}\n\n{report['table']}\n")
        if len(reports) > 1:
            print(f"## Recipes across the cases\n\n{recipes}\n")
    return 0


def _seed_figure_names(case) -> list[str]:
    return [f"seeds_{case.name}.png", f"learning_curves_{case.name}.png"]


def ship_command(args: argparse.Namespace) -> int:
    from elastica_magnetic.locks import claim

    from ..shipping.ship import check_ship_target, ship

    if args.no_measure and args.duration is not None:  # it would be ignored without a word
        raise CommandError(f"--duration {args.duration:g}: the length of the evaluation run, and "
                           "--no-measure skips it; leave one of them out")
    args.duration = 10.0 if args.duration is None else args.duration

    check_ship_target(args.name, args.dest)  # before the actors' evaluations
    _check_ship_case(args)

    from ..shipping.policy_files import POLICIES_DIR, POLICY_JSON

    target = (args.dest if args.dest is not None else POLICIES_DIR) / args.name
    notes = None
    if args.notes is not None:
        _check_notes_outside(args.notes, target, "--notes")
        notes = _read_markdown(args.notes, "--notes")
        if not notes.strip():  # as msr policy notes --file: an empty file is more often a mistake
            raise CommandError(f"--notes {args.notes}: is empty; leave --notes out to ship without notes")
    if (target / POLICY_JSON).exists() and not args.force:  # before the actors' evaluations
        given = f"--out {display_path(args.dest)}, " if args.dest is not None else ""
        where = f"{display_path(target)} ({given}--name {args.name})"
        raise CommandError(f"{where}: already holds a policy (pass --force to replace it)")
    if target.is_dir():  # held from now on: no other command writes the policy while it is measured
        held = claim(target, option="--out")
        print_notes(held.notes)  # a killed command's stale lock taken over: said once
        held.notes = []
    checkpoint = args.checkpoint
    from ..runfiles.rundir import RunDir

    is_run = (args.run.is_dir() and RunDir(args.run).has_checkpoint()) or (
        args.run.name == RunDir.CHECKPOINT)
    if args.no_measure and checkpoint == "auto" and is_run:  # no evaluation: the final actor, said
        checkpoint = "final"
        print("--no-measure: the final actor is shipped without comparing it with best.pt "
              "(--checkpoint best ships best.pt)", file=sys.stderr)
    choice = _actor_choice(args.run, checkpoint, args.duration, not args.no_progress)
    if choice is not None and checkpoint != args.checkpoint:  # chosen by --no-measure, not asked for
        choice = dataclasses.replace(choice, rule="unmeasured")
    try:
        result = ship(choice.path if choice else args.run, args.name, dest=args.dest,
                      measure=not args.no_measure,
                      duration=args.duration, progress=not args.no_progress, overwrite=args.force,
                      evaluate_all_seeds=args.evaluate_seeds, notes=notes)
    except (FileExistsError, FileNotFoundError, ValueError) as exc:
        raise CommandError(str(exc)) from None
    print_notes(result.pop("lock_notes", []))
    _print_with_choice(result, choice, args.json)
    return 0


def _check_ship_case(args: argparse.Namespace) -> None:
    """A policy shipped into a shipped policy's ``seeds/`` (``--out POLICY/seeds``) is of that
    policy's case, with its spec (refused naming both, before the actors' evaluations)."""
    from ..shipping.policy_files import check_policy_case, resolve_policy

    if args.dest is None:
        return
    try:
        case = resolve_policy(args.run).case
    except (FileNotFoundError, ValueError):
        return  # ship names what is wrong with the run itself
    check_policy_case(args.dest / args.name, case, option="--out", what="this policy is")


def _refuse_tip_reach(policy: object, command: str) -> None:
    """Refuse, naming the case, a policy of a tip-reach case (a catheter steered by a source) in a
    command that plays or measures a field waveform (export, export-seeds, ship)."""
    from ..shipping.policy_files import resolve_policy

    try:
        case = resolve_policy(policy).case
    except (FileNotFoundError, ValueError):
        return  # the command names what is wrong with the file itself
    if not case.field_actuated:
        raise CommandError(
            f"{policy}: case {case.name!r} steers a clamped catheter by a source ([actuation] kind = "
            f"\"{case.actuation.kind}\"), and msr policy {command} handles policies of a field waveform; a "
            "tip-reach policy is judged with msr policy generate (the case's held-out targets, or "
            "--target X,Y,Z)")


def _refuse_goto(run: Path) -> None:
    """Refuse the seeds of a goto case in ``msr policy export-seeds``, which scores each seed by
    the distance it goes ahead (a goto policy goes to a point in any direction: its seeds are
    judged on a ring of targets)."""
    from ..shipping.policy_files import resolve_policy

    try:
        case = resolve_policy(run).case
    except (FileNotFoundError, ValueError):
        return  # the command names what is wrong with the file itself
    if case.task.kind == "goto":
        raise CommandError(
            f"{run}: case {case.name!r} has the goto task, and msr policy export-seeds scores each seed "
            "by the distance it goes ahead; a goto policy is judged on a ring of targets: msr policy "
            "generate SEED_RUN --ring (or msr policy ship, which measures the ring)")


def _actor_choice(run, checkpoint: str, duration: float, progress: bool):
    """The actor of a run a command uses (``--checkpoint``): see
    :func:`~elastica_magnetic_rl.shipping.policy_runs.choose_actor`; for a tip-reach run
    (a catheter steered by a source), ``auto`` is its ``best.pt``, not evaluated again
    (:func:`~elastica_magnetic_rl.shipping.policy_runs.choose_tip_reach_actor`)."""
    from ..shipping.policy_files import resolve_policy
    from ..shipping.policy_runs import choose_actor, choose_tip_reach_actor

    try:
        steered = not resolve_policy(run).case.field_actuated
    except (FileNotFoundError, ValueError):
        steered = False  # choose_actor names what is wrong with the file itself
    try:
        if steered:
            return choose_tip_reach_actor(run, checkpoint)
        return choose_actor(run, checkpoint, duration, progress)
    except FileNotFoundError as exc:
        raise CommandError(str(exc)) from None


def _print_with_choice(result: dict, choice, as_json: bool) -> None:
    if choice is not None:
        result = {**result, "actor_choice": {**choice.to_dict(), "summary": choice.describe()}}
    print_rollout_result(result, as_json)


def notes_command(args: argparse.Namespace) -> int:
    from ..shipping.policy_files import resolve_policy
    from ..shipping.ship import set_notes

    if args.clear and args.file is not None:
        raise CommandError("give either --file (new notes) or --clear (no notes), not both")
    if args.file is None and not args.clear:
        policy = resolve_policy(args.policy)
        if policy.kind != "shipped":
            what = "training run's folder" if Path(args.policy).is_dir() else f"{policy.kind} file"
            raise CommandError(f"{args.policy}: a {what}, not a shipped policy: notes belong "
                               "to a shipped policy (a folder with policy.json), and a run's cannot "
                               "be written either; ship it first (msr policy ship)")
        notes = policy.meta.get("notes")
        if args.json:
            print_result({"policy": str(policy.source), "notes": notes}, True)
        else:
            print(notes or "(no notes)")
        return 0
    if args.file is not None:
        _check_not_the_policys_own(args.file, args.policy)
    text = "" if args.clear else _read_markdown(args.file, "--file")
    if not args.clear and not text.strip():
        raise CommandError(f"--file {args.file}: is empty; the notes were left as they are (to "
                           "remove them, pass --clear)")
    try:
        result = set_notes(args.policy, text)
    except ValueError as exc:
        raise CommandError(str(exc)) from None
    print_notes(result.pop("lock_notes", []))
    print_result(result, args.json)
    return 0


def _check_not_the_policys_own(path: Path, policy_name: str) -> None:
    """``--file``: not a file in the shipped policy's folder, refused saying what it is: one ship
    wrote (its card, its policy.json: the notes would then hold the card or the JSON), or another
    file there (a seed campaign's, one put there by hand): the notes are kept outside the policy.
    A missing file is left to :func:`_read_markdown` ("no such file")."""
    from ..shipping.policy_files import resolve_policy

    if not path.exists():
        return
    try:
        policy = resolve_policy(policy_name)
    except (FileNotFoundError, ValueError):
        return  # set_notes names the policy that cannot be read
    if policy.kind == "shipped":
        _check_notes_outside(path, Path(policy.source), "--file")


def _check_notes_outside(path: Path, folder: Path, option: str) -> None:
    """A notes file (``option``) is not in the shipped policy's ``folder`` (one being shipped
    included): one ship wrote there (its card, its policy.json) would nest in the notes, and
    any file there belongs to the policy and its seed campaigns."""
    from ..shipping.policy_files import SHIPPED_FILES

    folder = folder.resolve()
    if not path.exists() or not path.resolve().is_relative_to(folder):
        return
    if path.resolve().parent == folder and path.name in SHIPPED_FILES:
        raise CommandError(f"{option} {path}: is the policy's own {path.name} (msr policy ship wrote it; the "
                           "notes are a part of it); give a Markdown file of notes kept outside the policy's "
                           "folder")
    raise CommandError(f"{option} {path}: lies in the shipped policy {display_path(folder)}'s folder, which "
                       "holds the policy and its seed campaigns (the notes go into its policy.json and "
                       "card); give a Markdown file of notes kept outside the policy's folder")


def _read_markdown(path: Path, option: str) -> str:
    """A Markdown file's text (UTF-8, a leading byte-order mark dropped), or an error naming the
    option and the file."""
    from elastica_magnetic.io import UTF8_BOM

    if path.is_dir():
        raise CommandError(f"{option} {path}: is a folder, expected a Markdown file")
    if path.exists() and not path.is_file():  # /dev/null, a pipe: not a file to keep notes from
        raise CommandError(f"{option} {path}: not a regular file, expected a Markdown file (to remove "
                           "the notes, give --clear)")
    if not path.is_file():
        raise CommandError(f"{option} {path}: no such file{missing_folder_hint(path)}")
    try:
        # "UTF-8 with BOM" (Notepad): the mark is no text, and would land in policy.json and the
        # card; Markdown has no use for it, so it is dropped, as CSV tables skip it
        return path.read_text(encoding="utf-8").removeprefix(UTF8_BOM)
    except UnicodeDecodeError as exc:
        raise CommandError(f"{option} {path}: not UTF-8 text (byte {exc.start}: "
                           f"{exc.object[exc.start:exc.start + 1]!r}); save it as UTF-8") from None
    except OSError as exc:
        raise CommandError(f"{option} {path}: cannot read it: {exc.strerror or exc}") from None


def export_command(args: argparse.Namespace) -> int:
    from elastica_magnetic.results import check_result_folder

    from ..shipping.export import EXPORT_FILES, export_policy, refuse_residual_export
    from ..shipping.policy_files import check_policy_case, resolve_policy

    _refuse_tip_reach(args.policy, "export")
    # a residual run and the output folder before the actors' evaluations (minutes in the accurate physics)
    loaded = resolve_policy(args.policy)
    refuse_residual_export(loaded)
    loaded_case = loaded.case
    case = loaded_case.name
    check_policy_case(args.out, loaded_case)
    check_result_folder(args.out, kind="export", subject=f"case {case}", force=args.force,
                        known_files=EXPORT_FILES)
    choice = _actor_choice(args.policy, args.checkpoint, 10.0, not args.no_progress)
    result = export_policy(choice.path if choice else args.policy, args.out, force=args.force)
    print_notes(result.pop("notes", ()))
    _print_with_choice(result, choice, args.json)
    return 0


def _health_figure_name(run: Path) -> str:
    folder = run if run.is_dir() else run.parent
    return f"health_{folder.parent.name}_{folder.name}.png"


def diagnose_command(args: argparse.Namespace) -> int:
    from ..reports.diagnostics import health_figure, public, run_health

    if args.recent < 2:
        raise CommandError(f"--recent must be >= 2 transitions, got {args.recent}")
    from ..shipping.policy_files import other_result_refusal

    for run in args.run:  # every path checked before the slow part
        if not run.exists():
            raise CommandError(f"{run}: no such run directory or checkpoint{missing_folder_hint(run)}")
        if (refusal := other_result_refusal(run, "a training run: give a seed's run folder or its "
                                                 "checkpoint.pt")) is not None:
            raise CommandError(refusal)
    names = [_health_figure_name(run) for run in args.run]
    if args.figure is not None:
        if len(set(names)) < len(names):
            raise CommandError(f"--figure: two runs would draw the same figure ({', '.join(names)})")
        from elastica_magnetic.result_places import check_not_another_result

        from ..shipping.policy_files import check_policy_case, figure_cases

        check_not_another_result(args.figure, "--figure")  # not among another result's files
        for run in args.run:  # a shipped policy's seeds/ takes its own case's figures only
            for case in figure_cases(run if run.is_dir() else run.parent):
                check_policy_case(args.figure, case, option="--figure", what="these figures are")
        check_files(args.figure, names, force=args.force, option="--figure")
    healths = []
    for run in args.run:
        try:
            healths.append(run_health(run, args.recent))
        except ValueError as exc:
            raise CommandError(str(exc)) from None
    rows = [public(health) for health in healths]
    if args.figure is not None:  # all the figures go in together
        with replace_files(args.figure, names, force=args.force, option="--figure") as files:
            for row, health, name in zip(rows, healths, names, strict=True):
                row["figure"] = str(files.final_path(health_figure(health, files.path / name)))
    if args.json:
        print_result({"runs": rows}, True)
        return 0
    print(f"{'run':<40} {'step':>7} {'Q(s,a)':>9} {'return':>15} {'critic':>14} {'saturated':>12}")
    for r in rows:
        sat = "/".join(f"{100 * f:.0f}%" for f in r["saturated_fraction"])
        print(f"{r['run'][-40:]:<40} {r['global_step']:>7} {r['q_data_mean']:>9.3g} "
              f"{r['return_mean']:>8.3g} +-{r['return_std']:<5.2g} "
              f"{'OVERESTIMATES' if r['critic_overestimates'] else 'ok':>14} "
              f"{sat:>12}{' SATURATED' if r['actor_saturated'] else ''}")
        if "figure" in r:
            print(f"  figure: {r['figure']}")
    return 0
