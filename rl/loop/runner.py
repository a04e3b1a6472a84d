"""Running the loop (:func:`run_loop`): the loop's folder checked, marked and locked, the plan
checked before any work, each step run in order with a line on stderr at its start and end, its
record written to ``loop.json`` and the report rewritten after it."""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TextIO

from elastica_magnetic.io import display_path, normalized_path
from elastica_magnetic.locks import FolderLock
from elastica_magnetic.result_markers import (
    MARKER,
    describe_result,
    mark_folder,
    read_marker,
    unrecorded_files,
)
from elastica_magnetic.results import check_result_folder, remove_tree

from ..cases.case import Case
from ..runfiles.locking import is_run_file
from .report import write_report
from .settings import LoopSettings
from .state import AFRESH, STEPS, LoopError, LoopPlan, LoopState, plan_loop
from .steps import STEP_FUNCTIONS, LoopContext

__all__ = ["LOOP_KIND", "check_loop_folder", "headline", "run_loop", "step_line"]

#: The loop's folder's marker kind (:func:`elastica_magnetic.result_markers.mark_folder`).
LOOP_KIND = "loop"


def check_loop_folder(out: str | Path, case_name: str | None = None) -> LoopState | None:
    """Refuse, before any work, an ``out`` that is not a loop's folder: one holding other files,
    or another command's result (``ResultExistsError`` / ``OutputPathError`` naming ``--out``).
    Returns the loop's recorded state (``None``: a new or empty folder). ``case_name``: the loop's
    case, for the messages (a loop holds results of no case too: no policy's ``seeds/`` takes it)."""
    folder = normalized_path(out)
    marker = read_marker(folder) if folder.is_dir() else None
    if marker is None or marker.get("kind") != LOOP_KIND:
        subject = (f"a loop of case {case_name}, whose firmware step is a result of no case" if case_name
                   else None)
        check_result_folder(folder, kind=LOOP_KIND, subject=subject, force=True, option="--out")
        return None
    return LoopState.read(folder)


def step_line(number: int, step: str, text: str) -> str:
    """One progress line: ``loop: [3/8] train: started``."""
    return f"loop: [{number}/{len(STEPS)}] {step}: {text}"


def _duration(seconds: float) -> str:
    return f"{seconds:.1f} s" if seconds < 60 else f"{seconds / 60:.1f} min"


def _mm(distance: float | None) -> str:
    return "diverged" if distance is None else f"{1e3 * distance:+.3g} mm"


def headline(step: str, summary: dict[str, Any]) -> str:
    """The result of a step in a few words, for its progress line."""
    if step == "check":
        return f"{len(summary['warnings'])} warning(s)"
    if step == "yardstick":
        if summary.get("stand_in"):  # a smoke run's sweep moved nothing forward
            return (f"the sweep's best {_mm(summary.get('swept_m'))} in {summary['duration_s']:g} s "
                    f"(a smoke run); the spec's own {_mm(summary['distance_m'])} in 10 s stands in")
        return f"rotating field {_mm(summary['distance_m'])} (period {summary['period_s']:g} s)"
    if step == "train":
        return f"best seed {summary['best_seed']} {_mm(summary['best_distance_m'])}"
    if step == "generate":
        ratio = summary["of_yardstick"]
        return _mm(summary["distance_m"]) + (f", {ratio:.3g}x the yardstick" if ratio else "")
    if step in ("robustness", "robustness-refined"):
        parts = [f"{m.replace('_', ' ')} worst {_mm(s['worst_m'])}"
                 for m, s in summary["summary"].items()]
        return ", ".join(parts)
    if step == "refine":
        return f"{summary['steps']} steps ({summary['physics']} physics)"
    if step == "firmware":
        return f"{summary['rows']} rows, calibration {summary['calibration']}"
    return ""


def run_loop(case: Case, out: str | Path, settings: LoopSettings, *, skip: tuple[str, ...] = (),
             redo: tuple[str, ...] = (), force: bool = False, progress: bool | None = None,
             log: TextIO | None = None,
             steps: dict[str, Callable[[LoopContext], dict[str, Any]]] | None = None) -> LoopState:
    """Run the loop for ``case`` in ``out`` (see :mod:`elastica_magnetic_rl.loop`): steps already
    done (``loop.json``) are skipped, ``redo`` ones (and those needing them) run again, ``skip``
    ones are recorded as skipped. Everything is checked before the first step; the folder is
    locked while the loop runs. ``progress``: each step's progress on stderr (default: yes; a bar
    on a terminal, sparse plain lines in a log file, :func:`~elastica_magnetic.progress.progress_bar`);
    ``log``: where the step lines go (default stderr). Returns the final state."""
    log = log or sys.stderr
    if progress is None:
        progress = True
    if case.task.kind == "goto":  # its steps judge a distance ahead; a goto case is judged on a ring
        raise LoopError(f"case {case.name!r} has the goto task: the loop's steps (the rotating-field "
                        "yardstick, the seeds' distances, robustness of a waveform) measure a "
                        "distance ahead. Run its steps by hand: msr field baseline --case SPEC "
                        "--ring, msr train --case SPEC --recipe fast, msr policy generate RUN --ring "
                        "(docs: Steering in 3D)")
    folder = normalized_path(out)
    check_loop_folder(folder, case.name)
    with FolderLock(folder, option="--out") as lock:
        for note in lock.notes:
            print(f"note: {note}", file=log)
        state = check_loop_folder(folder, case.name)  # again, under the lock: no one else changed it since
        spec, recorded = case.to_dict(), settings.recorded()
        replaced = [] if state is None else [s for s in state.replaced_steps() if s not in skip]
        for step in replaced:
            print(f"note: {step}/ no longer holds the result this loop wrote (replaced or removed "
                  f"by another command): step {step} and the steps that use it run again", file=log)
        plan = plan_loop(state, spec, recorded, skip, tuple(dict.fromkeys((*redo, *replaced))), force)
        _check_steps_to_redo(folder, plan)
        if force and state is not None and plan.redo == STEPS and not plan.extend:
            return _start_over_beside(folder, case, settings, plan, log, progress, steps or STEP_FUNCTIONS)
        folder.mkdir(parents=True, exist_ok=True)
        if state is not None and state.case != case.name:  # started over for another robot
            _remove_spec_copy(state)
        if state is None or plan.redo == STEPS or state.case != case.name:
            state = LoopState(folder / "loop.json", case.name, spec, recorded)
        state.spec, state.settings = spec, recorded
        _forget(state, plan)
        state.write()
        mark_folder(folder, kind=LOOP_KIND, subject=f"case {case.name}")
        ctx = LoopContext(folder, case, settings, state, progress)
        write_report(ctx)
        _run_steps(ctx, plan, log, steps or STEP_FUNCTIONS)
    return state


def _start_over_beside(folder: Path, case: Case, settings: LoopSettings, plan: LoopPlan, log: TextIO,
                       progress: bool, functions: dict[str, Callable[[LoopContext], dict[str, Any]]]
                       ) -> LoopState:
    """A loop started over with ``--force``: built in a folder beside the earlier loop and swapped
    in whole when its last step is done (an interrupted start-over leaves the earlier loop as it
    was, its trained runs included; it is not continued: a new ``--force`` starts it again)."""
    from elastica_magnetic.results import result_folder

    known = [p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file()]
    try:
        with result_folder(folder, kind=LOOP_KIND, force=True, option="--out", known_files=known) as result:
            state = LoopState(result.path / "loop.json", case.name, case.to_dict(), settings.recorded())
            state.write()
            mark_folder(result.path, kind=LOOP_KIND, subject=f"case {case.name}")
            ctx = LoopContext(result.path, case, settings, state, progress)
            write_report(ctx)
            _run_steps(ctx, plan, log, functions)
            result.subject = f"case {case.name}"
    except KeyboardInterrupt as exc:
        exc.loop_started_over = True  # the command line says: nothing to go on from
        raise
    state.path = folder / "loop.json"
    return state


def _remove_spec_copy(state: LoopState) -> None:
    """Remove the spec copy the yardstick step of ``state``'s loop wrote (``<case>.toml``, named
    in its record): a loop started over for another case writes its own, and the old one beside
    it would pass for this loop's."""
    copy = state.steps.get("yardstick", {}).get("summary", {}).get("spec_file")
    if isinstance(copy, str) and "/" not in copy and copy.endswith(".toml"):
        (state.path.parent / copy).unlink(missing_ok=True)


def _forget(state: LoopState, plan: LoopPlan) -> None:
    """Drop the records of the steps run again (loop.json no longer calls them done); one that
    starts afresh is recorded as such (:data:`~.state.AFRESH`), so that a loop interrupted before
    its turn still starts it afresh when run again (not on an earlier result, e.g. a refinement
    of the actor a lengthened training replaced). Their folders stay until each step's own turn
    (:func:`_start_afresh`): an interrupted loop leaves the earlier results as they were."""
    for step in plan.redo:
        if step in plan.extend:
            state.steps.pop(step, None)
        else:
            state.steps[step] = {"status": AFRESH}


#: Files a step writes after its folders' records (the seeds' evaluation cache, the case's summary).
STEP_FILES_UNRECORDED = {"train": ("summary.json", "evaluation.json")}


def _check_steps_to_redo(folder: Path, plan: LoopPlan) -> None:
    """Refuse, before any work, to run again a step whose folder holds files msr did not write:
    the step's folder is removed at its turn, and they are the user's."""
    for step in plan.redo:
        own = STEP_FILES_UNRECORDED.get(step, ())
        foreign = [f for f in unrecorded_files(folder / step)
                   if f.rsplit("/", 1)[-1] not in own and not _an_unfinished_seeds_file(folder / step, f)]
        if foreign:
            shown = ", ".join(f"{step}/{f}" for f in foreign[:5]) + (
                f" and {len(foreign) - 5} more" if len(foreign) > 5 else "")
            raise LoopError(f"--out {display_path(folder)}: step {step} runs again (its folder is "
                            f"written anew) but {step}/ holds files msr did not write ({shown}); "
                            "move them out of the loop's folder first")
        if step not in plan.extend and (other := _other_result_in(folder / step, step)) is not None:
            where, marker = other
            raise LoopError(f"--out {display_path(folder)}: step {step} runs again (its folder is written "
                            f"anew) but {step}/{where} holds {describe_result(marker)}, not the loop's: "
                            "move it out of the loop's folder first")


def _an_unfinished_seeds_file(step_folder: Path, relative: str) -> bool:
    """Whether ``relative`` (a file under ``step_folder``, unrecorded) is a training run's own
    file in a seed folder of the train step (``<case>/seed<k>/run.json``) whose marker is a
    training's: a seed interrupted before it recorded its files (an interrupted ``--redo``)."""
    parts = relative.split("/")
    if step_folder.name != "train" or len(parts) != 3 or not is_run_file(parts[2]):
        return False
    marker = read_marker(step_folder / parts[0] / parts[1]) or {}
    return marker.get("kind") == "train"


def _other_result_in(step_folder: Path, step: str) -> tuple[str, dict] | None:
    """A result of another command inside a step's folder (``msr refine``'s ``RUN/refined`` in a
    seed of ``train/``), as ``(its place relative to the step's folder, its marker)``; the step's
    own (the folder itself, the training's seeds) are not."""
    if not step_folder.is_dir():
        return None
    for path in sorted(step_folder.rglob(MARKER)):
        place = path.parent.relative_to(step_folder)
        if place == Path("."):
            continue
        marker = read_marker(path.parent) or {}
        if step == "train" and len(place.parts) == 2 and marker.get("kind") == "train":
            continue  # train/<case>/seed<k>: the step's own runs
        return place.as_posix(), marker
    return None


def _start_afresh(ctx: LoopContext, step: str, plan: LoopPlan) -> None:
    """A redone step starts from an empty folder: its earlier result is removed at its turn (a
    step run on its earlier result, ``plan.extend``, keeps it)."""
    folder = ctx.folder / step
    if step in plan.redo and step not in plan.extend and folder.exists():
        remove_tree(folder)
    if ctx.state.steps.get(step, {}).get("status") == AFRESH:  # started: a kill now leaves it to resume
        ctx.state.steps.pop(step)
        ctx.state.write()


def _run_steps(ctx: LoopContext, plan: LoopPlan, log: TextIO,
               functions: dict[str, Callable[[LoopContext], dict[str, Any]]]) -> None:
    for number, step in enumerate(STEPS, start=1):
        if step in plan.done:
            print(step_line(number, step, "already done (loop.json), skipped"), file=log)
            continue
        if step in plan.skip:
            ctx.state.record(step, "skipped")
            print(step_line(number, step, "skipped (--skip)"), file=log)
        else:
            print(step_line(number, step, "started"), file=log, flush=True)
            _start_afresh(ctx, step, plan)
            begin = time.perf_counter()
            summary = functions[step](ctx)
            wall = time.perf_counter() - begin
            ctx.state.record(step, "done", summary, wall)
            print(step_line(number, step, f"done in {_duration(wall)}: {headline(step, summary)}"),
                  file=log, flush=True)
        mark_folder(ctx.folder, kind=LOOP_KIND, subject=f"case {ctx.case.name}")
        write_report(ctx)

