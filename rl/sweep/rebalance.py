"""An idle core takes over seeds of a busy one (:class:`GroupRebalancing`).

A sweep trains groups of seeds side by side, one group per worker process. Seeds that stop when
they have learned (``--stop-when``) leave their group early, so one worker may finish its group
while another still trains several seeds: one core then sits idle to the end. Measured on the
``fast`` recipe's 8-seed campaigns (2 workers x 4 seeds): the workers ended 102-541 s apart.

When a worker is idle and no group waits, every running group is asked to hand its seeds back
(a file whose existence is the request, :attr:`~elastica_magnetic_rl.sweep.jobs.GroupJob.hand_back_file`).
A group with at least two seeds still training does so at its next step where every episode has
just ended: each seed's checkpoint is written there, the worker returns the results of its
finished seeds and the folders of the others
(:func:`~elastica_magnetic_rl.runner.loop.train_seeds`, ``hand_back``). Those seeds are split
into as many new groups as there are free workers and resumed there. At such a step the
environments restart from episode seeds, so the move changes nothing but the size of the moved
seeds' stacks, and a seed's training does not depend on that
(:mod:`elastica_magnetic_rl.td3.algorithm`): the moved seeds end bit-identical to seeds never
moved (tested). The first campaign with moves (``m1-10mT``, ``fast``, 8 seeds) found three moved
seeds leaving their first course within 1-9 episodes: PyTorch's fused Adam then rounded the
last layers' biases by the stack's size, fixed since by padding each seed's share of a
parameter (:class:`~elastica_magnetic_rl.td3.stacked.StackedMLP`). A second campaign
(``m1-10mT``, 2026-11-27) moved four seeds as [4, 5] and [6, 7] at 78k steps; continued instead as
one group from a copy taken at the move, they end bit-identical (weights, replay buffers, every
episode and evaluation). Moves are therefore on by default (``msr train --no-rebalance``: off). A
move saves the idle core's time (~1.5 min measured in the first campaign) and costs a restart
(~10 s).

Every running group is asked at once: with several groups running beside an idle worker (a
sweep of several cases), the one that hands back last may find no worker free and go on as one
group again (a restart, ~10 s, nothing else lost).

Used by ``msr train`` (unless ``--no-rebalance``) with the process backend, several workers and
one torch thread per worker (the default layout; with more threads the products also round by the
stack's size).
"""

from __future__ import annotations

import shutil
import sys
import tempfile
from dataclasses import replace
from pathlib import Path
from typing import Any

from .backends import Rebalancing
from .jobs import GroupJob
from .summaries import failed_group_results

__all__ = ["GroupRebalancing", "split_evenly"]


def split_evenly(items: list[Any], parts: int) -> list[list[Any]]:
    """``items`` in ``min(parts, len(items))`` consecutive chunks whose sizes differ by at most
    one, the larger first (``[]`` for no items)."""
    parts = max(1, min(parts, len(items)))
    size, extra = divmod(len(items), parts)
    chunks, start = [], 0
    for i in range(parts):
        end = start + size + (i < extra)
        chunks.append(items[start:end])
        start = end
    return [c for c in chunks if c]


class GroupRebalancing:
    """The requests, splits and merges of :class:`~elastica_magnetic_rl.sweep.backends.Rebalancing`
    for groups of seeds (:func:`~elastica_magnetic_rl.sweep.training._train_group` jobs). A context
    manager: the request files live in a temporary folder removed at the end."""

    def __init__(self) -> None:
        self.folder: Path | None = None
        self.made = 0

    def __enter__(self) -> GroupRebalancing:
        self.folder = Path(tempfile.mkdtemp(prefix="msr-hand-back-"))
        return self

    def __exit__(self, *exc: Any) -> None:
        if self.folder is not None:
            shutil.rmtree(self.folder, ignore_errors=True)

    def protocol(self) -> Rebalancing:
        return Rebalancing(request=self.request, split=self.split, merge=self.merge)

    def askable(self, jobs: list[GroupJob]) -> list[GroupJob]:
        """``jobs``, each with its own request file (not made yet: not asked)."""
        return [self._askable(job) for job in jobs]

    def _askable(self, job: GroupJob) -> GroupJob:
        assert self.folder is not None, "use GroupRebalancing as a context manager"
        self.made += 1
        return replace(job, hand_back_file=str(self.folder / f"group-{self.made}"))

    @staticmethod
    def request(job: GroupJob) -> None:
        """Ask ``job``'s group to hand its seeds back (a job without a request file is never
        asked)."""
        if job.hand_back_file is not None:
            Path(job.hand_back_file).touch()

    def split(self, job: GroupJob, result: dict[str, Any], free_workers: int) -> list[GroupJob]:
        """The jobs that go on with the seeds ``job`` handed back (``result["handed_back"]``), split
        evenly over ``free_workers``; each resumes its seeds' folders and may be asked again."""
        handed = [str(d) for d in result.get("handed_back") or ()]
        if not handed:
            return []
        index = {d: i for i, d in enumerate(job.run_dirs)}
        unknown = [d for d in handed if d not in index]
        if unknown:
            raise ValueError(f"the group of seeds {job.seeds} handed back folders it does not "
                             f"hold: {', '.join(unknown)}")
        jobs = []
        chunks = split_evenly([index[d] for d in handed], free_workers)
        groups = " and ".join(str([job.seeds[i] for i in chunk]) for chunk in chunks)
        print(f"note: {job.case}: seeds of a busy worker move to an idle one: they go on as "
              f"{groups}", file=sys.stderr, flush=True)
        for chunk in chunks:
            jobs.append(self._askable(replace(
                job, configs=tuple(job.configs[i] for i in chunk),
                run_dirs=tuple(job.run_dirs[i] for i in chunk), position=job.position + chunk[0],
                resume=True, continued=True)))
        return jobs

    @staticmethod
    def merge(result: dict[str, Any], continuation: GroupJob, outcome: Any) -> dict[str, Any]:
        """``result`` (of the job a continuation goes on from) with the continuation's seeds
        added: their results, or, when its worker raised ``outcome``, what their folders hold
        with the error."""
        if isinstance(outcome, BaseException):
            error = f"{type(outcome).__name__}: {outcome}"
            added = failed_group_results(continuation.configs, continuation.run_dirs, error)
        elif "group" in outcome:
            added = list(outcome["group"])
        else:  # an error result of the worker itself
            added = failed_group_results(continuation.configs, continuation.run_dirs,
                                         outcome.get("error", "failed"))
        return {"group": list(result.get("group", [])) + added}
