"""Where a result may be written: the path rule every writer of msr follows before any work.

A result (a folder :mod:`elastica_magnetic.results` replaces whole, or one file
:mod:`elastica_magnetic.filesets` writes) goes in a place of its own: not inside another command's
result (replaced whole, it would take the new one with it, or be left mixed), not inside a folder
another process is writing, not inside a training's case folder (``RUNS/<case>/``, which holds its
runs alone), not a path through a file; the folder swapped is the real one (links resolved), never
the file system's root, the current folder or one above it, and where it will be made must be
writable. A folder this process is building a result in (``msr loop``'s steps, a sweep that writes
a baseline into its own result) may hold results: such temporary folders are registered here while
they are built (:func:`building`).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterable, Iterator
from pathlib import Path

from .io import OutputPathError, display_path, normalized_path, output_path_problem, unwritable_reason
from .locks import FolderLockedError, describe_owner, held_here, live_owner
from .result_markers import (
    MARKER,
    describe_result,
    manifest_holder,
    manifest_results_in,
    read_marker,
    recognized_marker,
)

__all__ = [
    "TRAINING_RUNS",
    "TRAINING_SUMMARY",
    "ResultExistsError",
    "building",
    "check_creatable",
    "check_enclosing",
    "check_inputs_outside",
    "check_not_another_result",
    "check_output_path",
    "held_refusal",
    "inside_result",
    "result_above",
    "inside_building",
    "swap_target",
    "training_run_in",
]


class ResultExistsError(OutputPathError):
    """An output folder that holds something the command will not replace (another command's or
    another robot's result, files it did not write, or its own result without ``force``)."""


#: The temporary folders (``.X.msr-new-...``) this process is building a result in: a result
#: folder written inside one (a command writing another's result into its own, as the baseline
#: sweep does) is msr's, not the user's, and is not listed by
#: :func:`~elastica_magnetic.results.aborted_results`.
_building: set[str] = set()


@contextlib.contextmanager
def building(staging: Path) -> Iterator[None]:
    """``staging`` registered, while the block runs, as a temporary folder this process builds a
    result in (results written inside it are msr's own: :func:`check_enclosing`)."""
    real = os.path.realpath(staging)
    _building.add(real)
    try:
        yield
    finally:
        _building.discard(real)


def inside_building(target: Path) -> bool:
    """Whether ``target`` is, or is inside, a temporary folder this process is building a result
    in (:func:`building`): its results are msr's own, not the user's."""
    real = Path(os.path.realpath(target))
    return any(str(folder) in _building for folder in (real, *real.parents))


#: ``subject`` of :func:`check_output_path` when the writer does not say what its result is about.
UNSAID = "<unsaid>"


def check_output_path(final: Path, option: str, subject: str | None = UNSAID) -> None:
    """Refuse (:class:`~elastica_magnetic.io.OutputPathError`, naming ``option``) a path that is no
    place for a result: an odd spelling (:func:`~elastica_magnetic.io.output_path_problem`), a path
    through a file, or a place inside another result (:func:`check_enclosing`; ``subject``, what
    the result is about, e.g. ``"case m1-4mT"``, ``None`` for nothing said)."""
    if (problem := output_path_problem(final)) is not None:
        raise OutputPathError(f"{option} {display_path(final)}: {problem}")
    for parent in (final, *final.parents):
        if parent.exists() and not parent.is_dir():
            raise OutputPathError(f"{option} {display_path(final)}: {display_path(parent)} is a "
                                  "file, not a folder")
    check_enclosing(final, option, subject)


def check_enclosing(final: Path, option: str, subject: str | None = UNSAID) -> None:
    """Refuse a folder or file inside another command's result (replaced whole, it would take this one
    with it, or be left mixed) or inside a folder another process is writing: a result of its own
    goes beside them. A folder this process writes (``msr loop``'s steps, a result it builds) may
    hold results. ``subject``: what the result is about (:func:`held_refusal`)."""
    for parent in final.parents:
        if held_here(parent) or inside_building(parent):
            return
        if (owner := live_owner(parent)) is not None:
            raise FolderLockedError(f"{option} {display_path(final)}: lies in {display_path(parent)}, which "
                                    f"{describe_owner(owner)} is writing: a result goes in a folder of "
                                    f"its own; choose another {option}")
        if (marker := recognized_marker(parent)) is not None:
            raise OutputPathError(inside_result(final, parent, marker, option))
        if (refusal := held_refusal(parent, final, option, subject)) is not None:
            # a seed's policy inside a seed campaign: the campaign is the result to name ("beside
            # the seed" is inside the campaign, refused too)
            if (outer := result_above(parent)) is not None:
                raise OutputPathError(inside_result(final, *outer, option))
            raise OutputPathError(refusal)
        if (run := training_run_in(parent, final)) is not None:
            raise OutputPathError(f"{option} {display_path(final)}: lies in {display_path(parent)}, which "
                                  f"holds the runs of a training ({run.name} among them): that folder "
                                  "holds its runs alone (msr train --resume refuses anything else "
                                  f"there); choose another {option}")


def inside_result(final: Path, parent: Path, marker: dict, option: str) -> str:
    """The refusal of ``final`` lying in ``parent``, which holds another command's result (its
    ``marker``)."""
    return (f"{option} {display_path(final)}: lies in {display_path(parent)}, which holds "
            f"{describe_result(marker)}: a result is replaced whole, so nothing goes inside another; "
            f"choose another {option}")


def result_above(folder: Path) -> tuple[Path, dict] | None:
    """The nearest folder above ``folder`` that holds another command's result, and its marker
    (``None`` where none does, or a folder this process writes comes first)."""
    for parent in folder.parents:
        if held_here(parent) or inside_building(parent):
            return None
        if (marker := recognized_marker(parent)) is not None:
            return parent, marker
    return None


def held_refusal(parent: Path, final: Path, option: str, subject: str | None = UNSAID) -> str | None:
    """Why ``final`` may not lie in ``parent`` when a result holds ``parent`` whole (a shipped
    policy: :func:`~elastica_magnetic.result_markers.manifest_holder`), outside the subfolders
    it keeps for other results (its ``seeds/``, named as a place only to a case's result), or inside
    them as a result of no case (a ``subject`` said, not ``"case ..."``: a robot's simulation, a
    validation report, a firmware export; or none: a robustness study, a design, a calibration,
    which are no seed campaign or run of the policy's case); ``None`` when it may."""
    held = manifest_holder(parent)
    if held is None:
        return None
    of_a_case = subject == UNSAID or (subject is not None and subject.startswith("case "))
    if final.relative_to(parent).parts[0] in manifest_results_in(parent):
        if of_a_case:
            return None  # a case's result: the writer checks that it is the policy's case
        about = (f"is of {subject}" if subject else
                 "is none of them (a study, a design, a calibration or a hardware file)")
        return (f"{option} {display_path(final)}: lies in {display_path(parent)}, which holds {held}, "
                f"whose {final.relative_to(parent).parts[0]}/ holds its own case's results (seed "
                f"campaigns, runs of its case), and this result {about}: it goes beside the policy; "
                f"choose another {option}")
    # only a case's result may go in the folders the policy keeps for them
    kept = manifest_results_in(parent) if of_a_case else ()
    places = " or ".join(f"{display_path(parent / p)}/" for p in kept)
    return (f"{option} {display_path(final)}: lies in {display_path(parent)}, which holds {held}, whose "
            f"folder holds its files alone: a result goes beside it{f' (or in {places})' if places else ''}; "
            f"choose another {option}")


#: How the run folders of a training are named in its case folder (``seed0``, ``seed1``...), and
#: the summary ``msr train`` writes beside them.
TRAINING_RUNS = "seed*"
TRAINING_SUMMARY = "summary.json"


def training_run_in(folder: Path, within: Path | None = None) -> Path | None:
    """A run of ``msr train`` in ``folder`` when it is a training's case folder (its summary and its
    runs: it has no marker of its own, its runs each have one), or ``None``; a run that is
    ``within`` or holds it is not counted (the path being judged: a run itself is judged by its own
    marker). A run copied alone into a folder does not make that folder a training's."""
    if not (folder / TRAINING_SUMMARY).is_file():
        return None
    for found in sorted(folder.glob(f"{TRAINING_RUNS}/{MARKER}")):
        run = found.parent
        if within is not None and (run == within or run in within.parents):
            continue
        marker = read_marker(run)
        if marker is not None and marker.get("kind") == "train":
            return run
    return None


def check_not_another_result(folder: str | Path, option: str, *, held_ok: bool = False) -> None:
    """A folder files are put into (figures, a set of files: not a result of their own) is not
    another command's result, a folder a result holds whole (a shipped policy; ``held_ok``: the
    writer is that result's, ``msr policy ship`` replacing a policy) or a training's case folder,
    and does not lie in a result: there they would be files that result does not know, removed or
    refused when it is replaced."""
    final = normalized_path(folder)
    if (marker := recognized_marker(final)) is not None:
        raise ResultExistsError(f"{option} {display_path(final)}: holds {describe_result(marker)}: files put "
                                "there are no part of it (replacing that result would remove them); choose "
                                f"another {option}")
    if not held_ok and (held := manifest_holder(final)) is not None:
        raise ResultExistsError(f"{option} {display_path(final)}: holds {held}, whose files are its own: "
                                f"nothing else goes in that folder; choose another {option}")
    if (run := training_run_in(final)) is not None:
        raise ResultExistsError(f"{option} {display_path(final)}: holds the runs of a training ({run.name} "
                                "among them): that folder holds its runs alone (msr train --resume refuses "
                                f"anything else there); choose another {option}")
    check_enclosing(final, option)


#: What happens to an input inside the folder a command replaces whole (with ``--force``).
REPLACED_WHOLE = "replaces whole: the input would be deleted with the old result"


def check_inputs_outside(out: str | Path, inputs: Iterable[tuple[str, str | Path | None]],
                         option: str = "--out", *, force: bool = True, how: str = REPLACED_WHOLE) -> None:
    """No input file (``inputs``: the option or argument that names it, and its path; ``None`` for
    one not given) lies in the folder ``out`` a command replaces whole (with ``--force``): the
    input would be deleted with the old result. :class:`OutputPathError` naming both, before any
    work. Without ``force`` nothing is replaced (an existing folder is refused by its writer).
    ``how``: what the command does to its folder and so to the input (a command that writes into
    its folder on every run, as ``msr loop`` does, passes ``force=True`` always)."""
    if not force:
        return
    final = normalized_path(out)
    for name, path in inputs:
        if path is None or not str(path) or not Path(path).exists():
            continue  # not a file of the user's (a shipped case's name, a default)
        given = normalized_path(path)
        if given == final or final in given.parents:
            raise OutputPathError(f"{name} {display_path(given)}: lies in {option} {display_path(final)}, "
                                  f"which this command {how}; copy it elsewhere first, or choose another "
                                  f"{option}")


def check_creatable(target: Path, option: str) -> None:
    """The folder that will receive ``target``'s temporary sibling (its parent, or the nearest
    existing folder above, where the parents will be made) must be writable: found before any
    work, not when the result is swapped in."""
    existing = next(p for p in target.parents if p.exists())
    if (reason := unwritable_reason(existing)) is not None:
        raise OutputPathError(f"{option} {display_path(target)}: cannot write in "
                              f"{display_path(existing)}: {reason}")


def swap_target(final: Path, option: str) -> Path:
    """The real folder that will be swapped (links resolved), refused when it cannot be renamed:
    the file system's root, or the current folder or one above it (a shell would be left in a
    deleted folder)."""
    target = normalized_path(final)
    cwd = Path(os.path.realpath(os.getcwd()))
    if target == target.parent or target == cwd or target in cwd.parents:
        raise OutputPathError(f"{option} {display_path(final)}: is the current folder or one above "
                              "it; a result folder is replaced by renaming it, so give a folder inside it")
    return target
