"""How far candidate robots go under rotating fields: many robots in one batched simulator.

Every candidate of a design generation is a robot of its own in one
:class:`~elastica_magnetic.batch.BatchedRobots` block (its own magnetization through
:meth:`~elastica_magnetic.batch.BatchedRobots.set_robot`), driven by the field the rotating-field
yardstick (:class:`~elastica_magnetic_rl.envs.yardsticks.RotatingFieldPolicy`) plays: that field
depends only on the field before it (the policy reads the field back, not the robot), so it is
computed once per period and direction (:func:`rotating_waveform`) and the same rows drive every
robot. The batch is split over worker processes.

The distance is the x displacement of the middle of the robot (the two central element
centres, as ``msr policy generate`` reports ``mid_dx_m``), m, from a zero field.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic import RobotSpec
from elastica_magnetic.batch import BatchedRobots, BatchedSimulationDivergedError
from elastica_magnetic.fields import ControlledField
from elastica_magnetic.robot_spec import ACTION_PERIOD

from ..cases.case import Case
from ..envs.crawler_observation import OBSERVATION_SCALES
from ..envs.yardsticks import RotatingFieldPolicy

__all__ = ["Trial", "rotating_waveform", "run_trials"]


def rotating_waveform(case: Case, period: float, clockwise: bool, duration: float) -> NDArray[np.float64]:
    """The field ``(steps, 3)`` (T, one row per 0.01 s action) the rotating-field yardstick of
    ``case`` plays for ``duration`` s from a zero field: its actions applied by the case's rate
    and amplitude limits, as the environment applies them."""
    return _waveform(case, float(period), bool(clockwise), int(round(duration / ACTION_PERIOD))).copy()


#: Waveforms already computed, by the actuation, period, sense and length they were made for.
_WAVEFORMS: dict[tuple[str, float, bool, int], NDArray[np.float64]] = {}


def _waveform(case: Case, period: float, clockwise: bool, steps: int) -> NDArray[np.float64]:
    key = (repr(case.actuation), period, clockwise, steps)
    if key not in _WAVEFORMS:
        if len(_WAVEFORMS) > 256:
            _WAVEFORMS.clear()
        _WAVEFORMS[key] = _compute_waveform(case, period, clockwise, steps)
    return _WAVEFORMS[key]


def _compute_waveform(case: Case, period: float, clockwise: bool, steps: int) -> NDArray[np.float64]:
    policy = RotatingFieldPolicy(case, period, clockwise)
    actuation = case.actuation
    field = ControlledField(actuation.limits, actuation.increments, (0.0, 0.0, 0.0))
    increments = np.array(actuation.increments[: actuation.n_axes])
    layout = policy.layout
    obs = np.zeros(case.obs_dim, dtype=np.float64)
    rows = np.empty((steps, 3))
    for k in range(steps):
        b = field.value
        # what the policy reads of an observation (float32, as the environment hands it over)
        obs[layout["field_amplitude"]] = OBSERVATION_SCALES["field_amplitude"] * math.hypot(b[0], b[1])
        obs[layout["field_angle"]] = math.atan2(b[1], b[0])
        if "field_z" in layout:
            obs[layout["field_z"]] = OBSERVATION_SCALES["field_z"] * b[2]
        action = policy.act(obs.astype(np.float32)).astype(np.float64)
        delta = np.zeros(3)
        delta[: len(action)] = action * increments
        rows[k] = field.apply_increment(delta)
    return rows


@dataclass(frozen=True)
class Trial:
    """One robot under one rotating field: its ``spec`` (a robot of the physics to run), the
    field's ``period`` (s) and sense (``clockwise`` seen from +z)."""

    spec: RobotSpec
    period: float
    clockwise: bool


def run_trials(case: Case, trials: Sequence[Trial], duration: float, workers: int = 1
               ) -> NDArray[np.float64]:
    """The distance (m, x displacement of the middle) of each trial after ``duration`` s from a
    zero field, ``(len(trials),)``; ``nan`` for a robot whose simulation diverged. The trials
    share one batched simulator per worker process (``workers`` >= 1; ``case``: the actuation
    the fields follow)."""
    from ..sweep.backends import run_in_processes

    if not trials:
        return np.zeros(0)
    chunks = [list(range(k, len(trials), workers)) for k in range(min(workers, len(trials)))]
    jobs = [(case, [trials[i] for i in chunk], duration) for chunk in chunks]
    if len(jobs) == 1:
        parts = [_run_chunk(jobs[0])]
    else:
        parts = run_in_processes(_run_chunk, jobs, len(jobs), quiet_interrupt=True)
    out = np.full(len(trials), np.nan)
    for chunk, part in zip(chunks, parts, strict=True):
        out[chunk] = part
    return out


def _run_chunk(job: tuple[Case, list[Trial], float]) -> list[float]:
    """The distances (m) of one worker's trials, in one batched simulator."""
    case, trials, duration = job
    steps = int(round(duration / ACTION_PERIOD))
    waves = np.stack([_waveform(case, t.period, t.clockwise, steps) for t in trials])
    robots = BatchedRobots(trials[0].spec, len(trials))
    for i, trial in enumerate(trials):
        if i:
            robots.set_robot(i, trial.spec)
    start = np.array([_middle_x(robots, i) for i in range(len(trials))])
    alive = np.ones(len(trials), dtype=bool)
    per_action = trials[0].spec.steps_per_action
    for k in range(steps):
        robots.fields[:] = np.where(alive[:, None], waves[:, k, :], 0.0)
        _step(robots, per_action, alive)
    return [(_middle_x(robots, i) - start[i]) if alive[i] else math.nan for i in range(len(trials))]


def _step(robots: BatchedRobots, steps: int, alive: NDArray[np.bool_]) -> None:
    """``steps`` steps; a robot that diverges is put back at its start, unfielded, and counted out
    (the others go on: robots of one block do not interact)."""
    try:
        robots.step(steps)
    except BatchedSimulationDivergedError as exc:
        bad: Any = exc
        while bad is not None:
            alive[bad.robot] = False
            robots.reset_robot(bad.robot)
            robots.fields[bad.robot] = 0.0
            try:
                robots.check_health()
                bad = None
            except BatchedSimulationDivergedError as again:
                bad = again


def _middle_x(robots: BatchedRobots, i: int) -> float:
    return float(robots.markers(i)["mid_x_m"])
