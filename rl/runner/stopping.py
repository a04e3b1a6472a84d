"""Stopping a seed that has learned (``msr train --stop-when``): Stable-Baselines3's
``StopTrainingOnRewardThreshold`` and ``StopTrainingOnNoModelImprovement`` as rules on a seed's
evaluation history.

A rule looks only at the returns of the seed's periodic evaluations (``evaluations.csv``, in
order), so it needs no state of its own in the checkpoints: a resumed seed replays its history
and decides as the uninterrupted one would. Two rules:

- ``target``: the evaluation return reached ``threshold`` in ``consecutive`` evaluations in a row
  (for crawling, the case's yardstick distance times the task's reward scale: the evaluation is a
  10 s episode from a zero field, so its return is ``reward_scale`` times the distance, in the
  training physics);
- ``plateau``: the best evaluation has not improved by more than ``tolerance`` (a fraction of the
  best return's magnitude, at least ``abs_tolerance`` in return units) for ``patience``
  evaluations, counted once ``min_evaluations`` have been made.

A ``target`` rule may ask for a **confirmation** (``confirm = "accurate"``): the evaluations
run in the training physics, and an actor that reaches the yardstick there may not reach it in
the accurate physics the yardstick was measured in. When such a rule fires, the training loop
runs the seed's actor once more, 10 s from a zero field in the accurate physics, and the seed
stops only if that return reaches ``threshold`` too; otherwise it trains on and the rule is asked
again at its next evaluation. The confirmation depends only on the actor's weights, so a resumed
seed confirms as the uninterrupted one.

Stopping is off by default (the paper's numbers are for runs of the full step budget).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any

#: The rules ``--stop-when`` accepts.
STOP_KINDS = ("target", "plateau")

#: Where a fired ``target`` rule may be confirmed before the seed stops (``--stop-confirm``).
CONFIRM_PHYSICS = ("accurate",)


@dataclass(frozen=True)
class StopRule:
    """When a seed stops training early (see the module docstring).

    Attributes:
        kind: ``"target"`` or ``"plateau"``.
        threshold: ``target``: the evaluation return to reach (return units; for crawling
            ``reward_scale`` (1/m) x the yardstick distance (m)).
        consecutive: ``target``: evaluations in a row at or above ``threshold``.
        patience: ``plateau``: evaluations without improvement before stopping.
        tolerance: ``plateau``: an improvement counts when the return exceeds the best so far
            by more than ``tolerance`` x ``|best|`` (and more than ``abs_tolerance``).
        abs_tolerance: ``plateau``: the smallest improvement that counts, return units.
        min_evaluations: ``plateau``: evaluations made before the rule may stop a seed.
        confirm: ``target``: the physics (``"accurate"``) in which a fired rule is confirmed by
            one more evaluation of the actor before the seed stops; ``None``: no confirmation.
    """

    kind: str
    threshold: float | None = None
    consecutive: int = 2
    patience: int = 6
    tolerance: float = 0.02
    abs_tolerance: float = 1.0
    min_evaluations: int = 4
    confirm: str | None = None

    def __post_init__(self) -> None:
        if self.kind not in STOP_KINDS:
            raise ValueError(f"stop rule must be one of {', '.join(STOP_KINDS)}, got {self.kind!r}")
        if self.kind == "target":
            if self.threshold is None or not math.isfinite(self.threshold):
                raise ValueError("the 'target' stop rule needs a finite threshold (a return); "
                                 "a case without a yardstick cannot use it")
            if int(self.consecutive) < 1:
                raise ValueError(f"--stop-consecutive must be >= 1, got {self.consecutive}")
        if int(self.patience) < 1:
            raise ValueError(f"--stop-patience must be >= 1 evaluation, got {self.patience}")
        if not (math.isfinite(self.tolerance) and self.tolerance >= 0):
            raise ValueError(f"--stop-tolerance must be a fraction >= 0, got {self.tolerance}")
        if not (math.isfinite(self.abs_tolerance) and self.abs_tolerance >= 0):
            raise ValueError(f"abs_tolerance must be >= 0, got {self.abs_tolerance}")
        if int(self.min_evaluations) < 1:
            raise ValueError(f"min_evaluations must be >= 1, got {self.min_evaluations}")
        if self.confirm is not None:
            if self.kind != "target":
                raise ValueError("--stop-confirm is for --stop-when target")
            if self.confirm not in CONFIRM_PHYSICS:
                raise ValueError(f"--stop-confirm must be one of {', '.join(CONFIRM_PHYSICS)} or none, "
                                 f"got {self.confirm!r}")

    @property
    def evaluations_needed(self) -> int:
        """The fewest evaluations after which the rule can fire: ``target``, ``consecutive``;
        ``plateau``, ``patience`` after a first one, and at least ``min_evaluations``."""
        if self.kind == "target":
            return int(self.consecutive)
        return max(int(self.min_evaluations), int(self.patience) + 1)

    def decide(self, returns: Sequence[float]) -> str | None:
        """Why the seed stops after the evaluations ``returns`` (in order), or None to go on."""
        if self.kind == "target":
            return self._target(returns)
        return self._plateau(returns)

    def _target(self, returns: Sequence[float]) -> str | None:
        k = int(self.consecutive)
        assert self.threshold is not None
        if len(returns) >= k and all(r >= self.threshold for r in returns[-k:]):
            return (f"target: evaluation return >= {self.threshold:g} in {k} consecutive "
                    f"evaluation{'s' if k > 1 else ''}")
        return None

    def _plateau(self, returns: Sequence[float]) -> str | None:
        if len(returns) < max(int(self.min_evaluations), int(self.patience) + 1):
            return None
        best, since = -math.inf, 0
        for r in returns:
            margin = max(self.tolerance * abs(best), self.abs_tolerance) if math.isfinite(best) else 0.0
            if r > best + margin:
                best, since = r, 0
            else:
                since += 1
        if since >= int(self.patience):
            return (f"plateau: no improvement over {best:g} by more than "
                    f"{100 * self.tolerance:g} % in {since} evaluations")
        return None

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form (stored in the run's ``run.json`` and checkpoints); ``confirm`` only
        when set, so a rule without it reads as the rules stored before confirmations existed."""
        data = asdict(self)
        if data["confirm"] is None:
            del data["confirm"]
        return data

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> StopRule:
        known = set(cls.__dataclass_fields__)
        unknown = set(data) - known
        if unknown:
            raise ValueError(f"unknown stop-rule keys: {', '.join(sorted(unknown))}")
        return cls(**dict(data))


def stop_reason(rule: StopRule | None, returns: Sequence[float]) -> str | None:
    """``rule.decide(returns)``, or None without a rule."""
    return None if rule is None else rule.decide(returns)


__all__ = ["CONFIRM_PHYSICS", "STOP_KINDS", "StopRule", "stop_reason"]
