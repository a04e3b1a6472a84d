"""The unit of work of a sweep: a group of seeds of one case that trains side by side in one
worker (:class:`GroupJob`). Plain data only, so that it pickles to worker processes and Ray tasks."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

__all__ = ["GroupJob"]


@dataclass(frozen=True)
class GroupJob:
    """A group of seeds of one case, trained side by side in one worker process or Ray task.

    ``configs``: one TD3 configuration per seed, as dicts (:meth:`TD3Config.to_dict`);
    ``run_dirs``: one run folder per seed (absolute for Ray: workers may run elsewhere);
    ``duration``: episode length, s; ``steps``: each seed's total environment steps;
    ``envs``: crawlers per seed; ``threads``: torch threads of the worker; ``position``: the
    progress bar of the group's first seed; ``stop_rule``: when a seed stops early.
    """

    case: str
    case_spec: dict[str, Any]
    physics: str
    duration: float
    steps: int
    resume: bool
    progress: bool
    position: int
    threads: int
    envs: int
    recipe: str
    configs: tuple[dict[str, Any], ...]
    run_dirs: tuple[str, ...]
    stop_rule: dict[str, Any] | None = None
    """The seeds' stop rule (:meth:`StopRule.to_dict`), ``None``: they run their whole budget."""
    hand_back_file: str | None = None
    """A file whose existence asks the group to hand its unfinished seeds back at its next
    episode boundary (:mod:`elastica_magnetic_rl.sweep.rebalance`); ``None``: never asked."""
    continued: bool = False
    """The job goes on with seeds another job handed back (a resume the user did not ask for:
    not counted as one in ``run.json``)."""

    @property
    def seed(self) -> int:
        """The group's first seed (how the backends name a group in their messages)."""
        return int(self.configs[0]["seed"])

    @property
    def seeds(self) -> list[int]:
        return [int(c["seed"]) for c in self.configs]

    @property
    def run_dir(self) -> str:
        """The run folder of the group's first seed."""
        return self.run_dirs[0]
