"""Progress a researcher can plan with: a group's training rate and the time it still needs,
evaluations included (shown on the progress bar of the group's first seed).

The rate is measured on this session's training steps alone (acting, physics, updates, logs and
checkpoints); each evaluation round (all the seeds due evaluated together) is timed apart and the
rounds still to come are counted from the schedule (one per ``eval_every`` steps, and a last one at
the end of the run), so the estimate does not jump when an evaluation pauses training.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

__all__ = ["GroupProgress", "evaluations_left", "format_duration"]


def evaluations_left(step: int, steps: int, eval_every: int, last_eval_step: int,
                     warmup_end: int = 0) -> int:
    """Evaluation rounds still to come after ``step`` for a budget of ``steps``: one at the first
    episode boundary at or after each multiple of ``eval_every`` still ahead, and the last one at
    ``steps`` (unless a periodic one falls there). Before ``warmup_end`` (the end of a warm-up the
    yardstick plays, :attr:`~elastica_magnetic_rl.runner.evaluation.PeriodicEvaluation.warmup_end`)
    none falls but the clone's, at its end. 0 without evaluations."""
    if eval_every <= 0 or step >= steps:
        return 0
    if step < warmup_end:
        return 1 + evaluations_left(warmup_end, steps, eval_every, warmup_end)
    next_multiple = (max(step, last_eval_step) // eval_every + 1) * eval_every
    periodic = 0 if next_multiple > steps else (steps - next_multiple) // eval_every + 1
    return periodic + (0 if steps % eval_every == 0 and periodic else 1)


def format_duration(seconds: float) -> str:
    """``h:mm:ss`` or ``m:ss``; ``?`` when unknown."""
    if not math.isfinite(seconds) or seconds < 0:
        return "?"
    s = int(round(seconds))
    h, rest = divmod(s, 3600)
    m, sec = divmod(rest, 60)
    return f"{h}:{m:02d}:{sec:02d}" if h else f"{m}:{sec:02d}"


class GroupProgress:
    """The rate and ETA of one group of seeds, from the loop's cumulative ``timing`` (s by part,
    :data:`~elastica_magnetic_rl.runner.group.TIMING_KEYS`), taken at the start of this session."""

    def __init__(self, timing: Mapping[str, float], start_step: int) -> None:
        self.start_train = sum(v for k, v in timing.items() if k != "evaluation")
        self.start_eval = float(timing.get("evaluation", 0.0))
        self.start_step = int(start_step)
        self.rounds = 0

    def evaluated(self) -> None:
        """One evaluation round was made."""
        self.rounds += 1

    def estimate(self, timing: Mapping[str, float], step: int, steps: int, seeds: int,
                 eval_every: int, last_eval_step: int, warmup_end: int = 0) -> dict[str, float]:
        """``rate`` (environment steps per second of the whole group, all ``seeds``),
        ``eval_s`` (s per evaluation round; nan before the first), ``evals_left`` and ``eta_s``
        (s, the evaluations left included; before the first round they are counted at 0 s)."""
        train = sum(v for k, v in timing.items() if k != "evaluation") - self.start_train
        done = int(step) - self.start_step
        rate = seeds * done / train if train > 0 and done > 0 else math.nan
        eval_s = (float(timing.get("evaluation", 0.0)) - self.start_eval) / self.rounds \
            if self.rounds else math.nan
        left = evaluations_left(step, steps, eval_every, last_eval_step, warmup_end)
        eta = seeds * max(0, steps - step) / rate if rate > 0 else math.nan
        eta += left * (eval_s if math.isfinite(eval_s) else 0.0)
        return {"rate": rate, "eval_s": eval_s, "evals_left": left, "eta_s": eta}

    @staticmethod
    def describe(estimate: Mapping[str, float]) -> str:
        """One line for a progress bar, e.g. ``group 212 steps/s, ETA 41:10 (9 evaluations, 14 s
        each)``."""
        rate = estimate["rate"]
        text = f"group {rate:.0f} steps/s" if math.isfinite(rate) else "group ? steps/s"
        text += f", ETA {format_duration(estimate['eta_s'])}"
        left = int(estimate["evals_left"])
        if left:
            each = estimate["eval_s"]
            text += (f" ({left} evaluation{'s' if left > 1 else ''}, "
                     + (f"{each:.0f} s each)" if math.isfinite(each) else "not yet timed)"))
        return text
