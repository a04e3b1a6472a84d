"""What ``msr train --resume`` checks in each seed's checkpoint before any work (issue 35): the
checkpoint is of the case being resumed (not another case's checkpoint copied into the folder),
and no hyperparameter given on the command line differs from the one the run was trained with
(the run keeps its own; a silently ignored option would be a wrong record); and that it has
something to train (a resume to steps a run has already done would only rewrite its records)."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping
from typing import Any

from elastica_magnetic.io import display_path

from ..runfiles.checkpoint import load_checkpoint, replay_problem
from ..runfiles.rundir import RunDir
from ..td3.config import KEPT_ON_RESUME, Schedule, setting_option

__all__ = ["check_resumed_checkpoints", "check_steps_left"]

#: Settings a resumed run may change (when to checkpoint, log and evaluate: no weight changes).
_MAY_CHANGE = frozenset(f.name for f in dataclasses.fields(Schedule)) - KEPT_ON_RESUME


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return list(a) == list(b)
    return a == b


def check_resumed_checkpoints(runs: Iterable[tuple[str, RunDir]],
                              overrides: Mapping[str, Any] | None) -> None:
    """For each ``(case name, run folder)`` resumed: refuse (``ValueError``) a checkpoint whose
    metadata names another case, and any of ``overrides`` (the TD3 settings given on the command
    line) that differs from the checkpoint's, naming the option, the run's value and the new one."""
    for case, run in runs:
        ckpt = load_checkpoint(run.checkpoint, with_buffer=False)
        buffer = ckpt.get("buffer")
        if isinstance(buffer, dict) and "file" in buffer:  # found now, not after the others trained
            if (problem := replay_problem(run.path / buffer["file"], buffer)) is not None:
                raise ValueError(f"cannot resume {display_path(run.path)}: {problem}")
        meta = ckpt.get("metadata") or {}
        if meta.get("case") not in (None, case):
            raise ValueError(f"{display_path(run.checkpoint)}: a checkpoint of case {meta['case']!r}, not of "
                             f"{case!r}: cannot resume it as {case} (was it copied here?)")
        config = ckpt.get("config") or {}
        changed = [f"{setting_option(k)}: the run's {config[k]!r}, given {v!r}"
                   for k, v in (overrides or {}).items()
                   if k not in _MAY_CHANGE and k in config and not _same(config[k], v)]
        if changed:
            raise ValueError(f"cannot resume {display_path(run.path)} with other hyperparameters ("
                             + "; ".join(changed) + "): a resumed run keeps the ones it was "
                             "trained with; drop these options, or train a new run (another "
                             "--out or --seed-offset)")


def check_steps_left(runs: Iterable[tuple[str, RunDir]], steps: int) -> None:
    """Refuse (``ValueError``) a resume to ``steps`` per seed that trains nothing of a case: each
    of its runs (``(case name, run folder)``) is already at ``steps`` or beyond, or was stopped by
    its rule. Names each run's step and the ``--steps`` that would train, before any file is
    touched (``summary.json``, ``run.json``, ``best.pt`` and the logs stay byte for byte)."""
    done: dict[str, list[str]] = {}
    reached: dict[str, int] = {}
    to_train: set[str] = set()
    for case, run in runs:
        ckpt = load_checkpoint(run.checkpoint, with_buffer=False)
        step, stopped = int(ckpt["global_step"]), ckpt.get("stopped")
        if stopped:
            done.setdefault(case, []).append(f"{display_path(run.path)} was stopped by its rule at step "
                                             f"{stopped['step']} (never trained further)")
        elif step >= steps:
            done.setdefault(case, []).append(f"{display_path(run.path)} is already at {step} steps")
            reached[case] = max(reached.get(case, 0), step)
        else:
            to_train.add(case)
    for case, lines in done.items():
        if case not in to_train:
            hint = (f"; give --steps above {reached[case]}" if case in reached
                    else "; train new seeds instead (--seed-offset)")
            raise ValueError("nothing to train: " + "; ".join(lines) + f" (--steps {steps}){hint}")
