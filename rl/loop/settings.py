"""The settings of the loop's steps (:class:`LoopSettings`): what the command line's options set,
and what a smoke run (``msr loop --quick``, the tests) shrinks."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..cases.case import EVAL_DURATION
from ..shipping.baseline_sweep import DEFAULT_PERIODS

__all__ = ["LoopSettings", "ROBUSTNESS_PHYSICS"]

#: The physics ``--physics-robustness`` takes (the robustness steps' varied robots).
ROBUSTNESS_PHYSICS = ("training", "accurate")


@dataclass(frozen=True)
class LoopSettings:
    """Everything the steps of ``msr loop`` need besides the spec. Durations in s.

    The defaults are the hand-walked path of ``docs/own_robot.md``: the yardstick swept in 10 s of
    the accurate physics, the ``fast`` recipe with 2 seeds at the case's step budget, each seed's
    distance and the generated waveform in 10 s of the accurate physics, the default variation set
    open and closed loop, a refinement of 1000 steps in the training physics on randomized
    robots. :meth:`quick` is a smoke run of the whole path in about a minute (its distances mean
    nothing)."""

    seeds: int = 2
    steps: int | None = None  # None: the case's step budget
    workers: int | None = None  # None: one per core
    recipe: str = "fast"
    train_overrides: dict[str, Any] = field(default_factory=dict)  # TD3 settings on the recipe's
    stop_when: str | None = None  # None: the recipe's rule
    episode_duration: float | None = None  # None: the case's
    check_sag: bool = True
    yardstick_periods: tuple[float, ...] = DEFAULT_PERIODS
    yardstick_duration: float = EVAL_DURATION
    yardstick_physics: str = "accurate"
    evaluation_duration: float = EVAL_DURATION  # each seed's distance and the generated waveform
    robustness_physics: str = "training"
    robustness_duration: float = EVAL_DURATION
    robustness_corners: bool = True
    refine_steps: int = 1000
    refine_physics: str = "training"
    refine_randomize: str = "default"
    refine_episode_duration: float | None = None  # None: refine's default (20 s)
    calibration: Path | None = None  # None: stm32/calibration/default.json
    gif: bool = True
    quick: bool = False

    @classmethod
    def smoke(cls, **changes: Any) -> LoopSettings:
        """A smoke run (``--quick``): tiny networks and step budgets, 0.02-0.5 s runs in the
        training physics, one sweep period, no corners: every step runs, nothing it measures
        means anything."""
        quick = cls(
            steps=240, recipe="fast", stop_when="none", check_sag=False,
            train_overrides={"learning_starts": 60, "batch_size": 32, "hidden_sizes": (32, 32),
                             "checkpoint_every": 80, "eval_every": 120, "eval_duration": 0.2},
            # a period no longer than the sweep's runs: a run shorter than one never turns it
            episode_duration=0.8, yardstick_periods=(0.5,), yardstick_duration=0.5,
            yardstick_physics="training", evaluation_duration=0.2, robustness_duration=0.2,
            robustness_corners=False, refine_steps=3, refine_episode_duration=0.02, gif=False,
            quick=True)
        return dataclasses.replace(quick, **changes)

    @property
    def evaluation_physics(self) -> str:
        """The physics of each seed's distance and of the generated waveform: the accurate one, the
        training physics in a smoke run (``--quick``: its numbers mean nothing either way, and the
        accurate physics' small time step made most of its training step's time)."""
        return "training" if self.quick else "accurate"

    def yardstick_is_the_definition(self) -> bool:
        """Whether the yardstick step measures the yardstick as defined (10 s, accurate physics)."""
        return self.yardstick_physics == "accurate" and abs(self.yardstick_duration - 10.0) < 1e-9

    def recorded(self) -> dict[str, Any]:
        """The settings ``loop.json`` records and a re-run must repeat (not the worker count)."""
        data = dataclasses.asdict(self)
        data.pop("workers")
        data["calibration"] = str(self.calibration) if self.calibration else None
        # its contents too: a calibration measured again into the same file is a new calibration
        data["calibration_sha256"] = _file_sha256(self.calibration) if self.calibration else None
        data["yardstick_periods"] = list(self.yardstick_periods)
        data["train_overrides"] = {k: list(v) if isinstance(v, tuple) else v
                                   for k, v in self.train_overrides.items()}
        return data


def _file_sha256(path: Path) -> str | None:
    """The SHA-256 of the file ``path`` (hex), ``None`` when it cannot be read."""
    import hashlib

    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError:
        return None
