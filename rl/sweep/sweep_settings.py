"""The settings of a training sweep (``msr train``) as one record: what the seeds learn and how
the sweep runs. :func:`~elastica_magnetic_rl.sweep.training.train_cases` takes one (or its fields as
keywords, changed on the defaults)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = ["SweepSettings"]


@dataclass(frozen=True)
class SweepSettings:
    """A sweep's settings. ``None`` means the case's own value (``steps``, ``episode_duration``
    s, ``recipe``; ``[training]`` and ``[task]`` of its spec), the recipe's (``stop_when``,
    ``randomize``) or the machine's fastest layout (``workers``, ``threads``,
    ``seeds_per_simulator``: :func:`~elastica_magnetic_rl.sweep.training.default_layout`).

    What the seeds learn: ``seeds`` seeds from ``seed_offset``, ``steps`` environment steps each,
    the ``recipe`` with ``config_overrides`` (:class:`~elastica_magnetic_rl.td3.config.TD3Config`
    fields, e.g. ``precision="bf16"``) on top of the case's ``[training.td3]``, in the ``physics``
    (``"training"`` or ``"accurate"``) with episodes of ``episode_duration`` s, robots randomized
    per ``randomize`` (``"default"``, ``"none"``), a stop rule ``stop_when`` (``"target"``,
    ``"plateau"``, ``"none"``) with ``stop_options`` (``consecutive``, ``patience``,
    ``tolerance``, ``confirm``); a seed succeeded when its final mean return reaches
    ``success_fraction`` of the yardstick's; ``warm_up_only`` allows runs that never leave the
    warm-up.

    How it runs: into ``out`` (``resume``: continue its runs), ``workers`` groups at a time
    (processes, or Ray tasks with ``backend="ray"`` and ``address``), ``threads`` torch threads
    each, ``seeds_per_simulator`` seeds of a case per group, ``envs`` crawlers per seed,
    ``rebalance`` (an idle worker takes over seeds of a busy one), ``progress`` bars.
    """

    seeds: int = 8
    steps: int | None = None
    seed_offset: int = 0
    recipe: str | None = None
    config_overrides: Mapping[str, Any] | None = None
    physics: str = "training"
    episode_duration: float | None = None
    randomize: str | None = None
    stop_when: str | None = None
    stop_options: Mapping[str, Any] | None = None
    success_fraction: float = 0.5
    warm_up_only: bool = False
    out: str | Path = "runs"
    resume: bool = False
    workers: int | None = None
    threads: int | None = None
    seeds_per_simulator: int | None = None
    envs: int = 1
    backend: str = "process"
    address: str | None = None
    rebalance: bool = True
    progress: bool = True
