"""Hand-designed policies to compare learned ones against.

:class:`RotatingFieldPolicy` turns the field at a constant rate at the field limit, through the
same action channel as the agent (increments of at most 0.3 mT per axis every 0.01 s, field
starting at zero), so its waveform is one the coils could play and its distance is directly
comparable with a learned policy's. A rotating field makes these robots roll (the paper's gait 2 at
10 mT); it is the obvious open-loop gait a learned policy should beat.

The policy is a function of the observation alone (it reads the field back from the observation's
amplitude and angle), so it runs wherever a learned actor runs: ``msr field baseline`` writes the same
files as ``msr policy generate``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic.robot_spec import ACTION_PERIOD

from ..cases.case import Case, load_case
from ..envs.env import OBSERVATION_SCALES, observation_layout

__all__ = ["RotatingFieldPolicy"]


@dataclass
class RotatingFieldPolicy:
    """Turn the field at the limit by ``2 pi / period`` rad/s, clockwise unless stated.

    Each step asks for the field at the limit amplitude, rotated from the present field's angle by
    ``2 pi * 0.01 s / period``; the action is the increment towards it in units of the 0.3 mT
    maximum, clipped to [-1, 1] (so from a zero field the amplitude ramps up over the first
    ~0.3 s, and a period shorter than the rate limit allows makes the field lag and shrink).

    Args:
        case: the case (a shipped name such as ``"m1-10mT"``, a spec file or a
            :class:`~elastica_magnetic_rl.cases.case.Case`): its robot, field limit and increment.
        period: time of one turn of the field, s.
        clockwise: clockwise seen from +z (x right, y up): rolls the robot towards +x.

    The attributes ``critic``/``actor`` (None), ``obs_dim``, ``source`` and ``kind`` let it stand in
    for a loaded policy in :func:`elastica_magnetic_rl.shipping.policy_runs.run_policy` and
    :func:`elastica_magnetic_rl.shipping.generate.generate`.
    """

    case: str | Case
    period: float = 2.0
    clockwise: bool = True

    def __post_init__(self) -> None:
        self.case = load_case(self.case)
        if not (self.period > 0.0 and math.isfinite(self.period)):
            raise ValueError(f"period must be a positive time in s, got {self.period}")
        if self.period <= 2.0 * ACTION_PERIOD:
            # half a turn or more per 0.01 s step: the sampled field does not turn this way (a
            # period of 0.001 s asks for ten whole turns per step, a static field)
            raise ValueError(f"period {self.period:g} s is at or under 2 x the {ACTION_PERIOD:g} s "
                             f"control period (the Nyquist limit of the {1 / ACTION_PERIOD:g} Hz "
                             "field updates): the field would alias to a slower or static one; "
                             f"give more than {2 * ACTION_PERIOD:g} s (the rate limit of "
                             f"{1e3 * self.case.actuation.max_increment:g} mT per step keeps the "
                             "field at the limit only for much longer periods)")
        self.field_limit = self.case.field_limit
        self.max_increment = self.case.actuation.max_increment
        actuation = self.case.actuation
        layout = observation_layout(self.case.n_elements,
                                    (*actuation.observation_blocks, *self.case.task.extra_observation))
        self._amplitude = layout["field_amplitude"].start
        self._angle = layout["field_angle"].start
        # a three-axis case: the z pair holds B_z at zero (the paper's field, in the x-y plane)
        self._field_z = layout["field_z"].start if "field_z" in layout else None
        self._increments = np.array(actuation.increments[: actuation.n_axes])
        self.obs_dim = self.case.obs_dim
        self.act_dim = actuation.n_axes
        self.critic = None
        self.actor = None
        self.kind = "baseline"
        turn = "clockwise" if self.clockwise else "counter-clockwise"
        self.source = f"rotating field, {turn}, period {self.period:g} s"
        self.meta = {"period_s": self.period, "clockwise": self.clockwise}

    def act(self, obs: NDArray[np.float32]) -> NDArray[np.float32]:
        """Normalised action in [-1, 1]^k (k: the case's axes) for one observation ``(obs_dim,)``."""
        amplitude = float(obs[self._amplitude]) / OBSERVATION_SCALES["field_amplitude"]  # T
        angle = float(obs[self._angle]) / OBSERVATION_SCALES["field_angle"]  # rad
        field = amplitude * np.array([math.cos(angle), math.sin(angle)])
        step = 2.0 * math.pi * ACTION_PERIOD / self.period
        target_angle = angle - step if self.clockwise else angle + step
        target = self.field_limit * np.array([math.cos(target_angle), math.sin(target_angle)])
        if self._field_z is None:
            return np.clip((target - field) / self.max_increment, -1.0, 1.0).astype(np.float32)
        bz = float(obs[self._field_z]) / OBSERVATION_SCALES["field_z"]  # T
        change = np.array([*(target - field), -bz]) / self._increments
        return np.clip(change, -1.0, 1.0).astype(np.float32)
