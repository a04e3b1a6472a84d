"""Hand-designed policies to compare learned ones against.

:class:`RotatingFieldPolicy` turns the field at a constant rate at the field limit, through the
same action channel as the agent (increments of at most 0.3 mT per axis every 0.01 s, field
starting at zero), so its waveform is one the coils could play and its distance is directly
comparable with a learned policy's. A rotating field makes these robots roll (the paper's gait 2 at
10 mT); it is the obvious open-loop gait a learned policy should beat.

:class:`SteeringFieldPolicy` is the goto task's yardstick: the same rotating field, its rotation
plane turned toward the target at every step from the tracked position (the feedback an
experimentalist with a camera would close), and the field ramped to zero once the robot is there.

Both act on the observation alone (the steering field also on the manoeuvre it is in): they read
the field back from the observation's amplitude, angle and ``field_z``, the target from the goto
task's blocks, so they run wherever a learned actor runs: ``msr field baseline`` writes the same
files as ``msr policy generate``. A training may start from one (``yardstick_warmup``:
:func:`yardstick_controller`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic.robot_spec import ACTION_PERIOD

from ..cases.case import Case, load_case
from ..cases.tasks import GOTO_CLOCK_PERIOD, TARGET_OFFSET_SCALE, GotoTask
from .crawler_observation import OBSERVATION_SCALES, observation_layout
from .steering_yardstick import SteeringYardstick

__all__ = ["RotatingFieldPolicy", "SteeringFieldPolicy", "rotating_amplitude", "yardstick_controller"]


def _check_period(period: float, case: Case) -> None:
    """Refuse a rotation period (s) that is not a positive time above the Nyquist limit."""
    if not (period > 0.0 and math.isfinite(period)):
        raise ValueError(f"period must be a positive time in s, got {period}")
    if period <= 2.0 * ACTION_PERIOD:
        # half a turn or more per 0.01 s step: the sampled field does not turn this way (a
        # period of 0.001 s asks for ten whole turns per step, a static field)
        raise ValueError(f"period {period:g} s is at or under 2 x the {ACTION_PERIOD:g} s "
                         f"control period (the Nyquist limit of the {1 / ACTION_PERIOD:g} Hz "
                         f"field updates): the field would alias to a slower or static one; "
                         f"give more than {2 * ACTION_PERIOD:g} s (the rate limit of "
                         f"{1e3 * case.actuation.max_increment:g} mT per step keeps the "
                         "field at the limit only for much longer periods)")


def rotating_amplitude(case: Case) -> float:
    """The amplitude (T) of the rotating-field yardstick: the field limit, or the weaker of the
    x and y limits where they differ (a field turning in the x-y plane at a larger amplitude
    would be clipped on the weaker axis, no longer a uniform turn)."""
    return min(case.actuation.limits[:2])


class _FieldReader:
    """What the hand-designed policies share: the case's limits and increments, the attributes
    that let them stand in for a loaded policy, and the field read back from an observation."""

    def _setup(self, case: str | Case) -> Case:
        case = load_case(case)
        actuation = case.actuation
        self.field_limit = case.field_limit
        self.max_increment = actuation.max_increment
        self.layout = observation_layout(case.n_elements, (*actuation.observation_blocks,
                                                           *case.task.extra_observation))
        self._limits = np.array(actuation.limits[: actuation.n_axes])
        self._increments = np.array(actuation.increments[: actuation.n_axes])
        self.obs_dim = case.obs_dim
        self.act_dim = actuation.n_axes
        self.critic = None
        self.actor = None
        self.kind = "baseline"
        return case

    def _field(self, obs: NDArray[np.float32]) -> NDArray[np.float64]:
        """The present field ``(B_x, B_y, B_z)``, T, from the observation (``B_z`` 0 on two axes)."""
        amplitude = float(obs[self.layout["field_amplitude"].start]) / OBSERVATION_SCALES["field_amplitude"]
        angle = float(obs[self.layout["field_angle"].start]) / OBSERVATION_SCALES["field_angle"]
        bz = (float(obs[self.layout["field_z"].start]) / OBSERVATION_SCALES["field_z"]
              if "field_z" in self.layout else 0.0)
        return np.array([amplitude * math.cos(angle), amplitude * math.sin(angle), bz])

    def _toward(self, field: NDArray[np.float64], wanted: NDArray[np.float64]) -> NDArray[np.float32]:
        """The action that moves ``field`` toward ``wanted`` (both ``(3,)``, T) as far as one
        step's increments allow, in units of each axis's increment, ``(k,)``."""
        change = (wanted - field)[: self.act_dim] / self._increments
        return np.clip(change, -1.0, 1.0).astype(np.float32)


@dataclass
class RotatingFieldPolicy(_FieldReader):
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
        self.case = self._setup(self.case)
        _check_period(self.period, self.case)
        self._amplitude = rotating_amplitude(self.case)
        turn = "clockwise" if self.clockwise else "counter-clockwise"
        self.source = f"rotating field, {turn}, period {self.period:g} s"
        self.meta = {"period_s": self.period, "clockwise": self.clockwise}

    def reset(self) -> None:
        """A new episode (nothing to forget: the action is a function of the observation)."""

    def state(self) -> dict[str, Any]:
        """What it remembers between steps (nothing)."""
        return {}

    def set_state(self, state: dict[str, Any]) -> None:
        """Restore a :meth:`state`."""

    def label(self, obs: NDArray[np.float32]) -> NDArray[np.float32]:
        """Its command at ``obs`` while another controller drives (DAgger's label,
        :attr:`~elastica_magnetic_rl.td3.config.TD3Config.yardstick_dagger`): :meth:`act`, as the
        field it turns is the one the observation shows."""
        return self.act(obs)

    def act(self, obs: NDArray[np.float32]) -> NDArray[np.float32]:
        """Normalised action in [-1, 1]^k (k: the case's axes) for one observation ``(obs_dim,)``;
        on three axes the z pair holds B_z at zero (the paper's field, in the x-y plane)."""
        field = self._field(obs)
        angle = float(obs[self.layout["field_angle"].start]) / OBSERVATION_SCALES["field_angle"]
        step = 2.0 * math.pi * ACTION_PERIOD / self.period
        target_angle = angle - step if self.clockwise else angle + step
        wanted = self._amplitude * np.array([math.cos(target_angle), math.sin(target_angle), 0.0])
        return self._toward(field, wanted)


@dataclass
class SteeringFieldPolicy(_FieldReader):
    """The goto task's yardstick: a field rotating clockwise (``period`` s per turn) in a vertical
    plane chosen from the robot's tracked pose at every step, as an experimentalist with a camera
    would steer it.

    Measured on the paper's pattern-1 band at 4 mT (a flat band that slides sideways): a field
    rotating in a vertical plane walks it along that plane, and it walks across its body (about
    6 mm per turn of the field); a plane between ahead and across also yaws the body until the
    plane is across it; a plane along the body barely moves it. So the yardstick has two
    manoeuvres. **Walk**: the plane toward the target (the band walks there and turns to keep the
    plane across it), once the target is within ``walk_band`` rad of abeam and until it is more
    than ``turn_band`` rad from abeam. **Turn** otherwise: the plane ``turn_bearing`` rad from the
    body's axis, its sense of rotation reversed after every turn of the field (both senses yaw the
    body the same way and their steps cancel: about 8 degrees per second), toward bringing the
    target abeam on the nearer side. The field's amplitude is the largest the per-axis limits
    allow in the plane. Within ``stop_radius`` m of the target it ramps the field to zero (at the
    increment limit) and waits.

    A band that goes where the plane points whatever its heading needs no turn: at 10 mT the
    pattern-1 band tumbles end over end along a plane along its body (130 mm in 10 s at one turn
    per second, training physics), walks across a plane across it (114 mm at the z pair's 6 mT)
    and goes along a plane in between, turning its body across it. ``turn_in_place = False``
    walks toward every target (the plane always toward it): on the 10 mT ring (training physics,
    30 s) 12 of 12 in 8.8 s, where turning first takes 9.7 s (the two targets on the body's axis
    take 7.6 s only while the field stays exactly in the band's plane of symmetry: 0.5 degrees off
    the axis, 9.8 s); at 4 mT, where a plane along the body barely moves the band, 2 of 12 (the two
    abeam). All of these at one turn a second; the shipped cases ask the turn that was fastest on
    their rings (``[yardstick] steering_period``, training physics): at 10 mT 0.15 s, more than
    the increments can turn a 10 mT field, which then turns at about 8 mT once in 1.4 s (12 of 12
    in 7.3 s); at 4 mT 2 s (12 of 12 in 4.6 s, against 6.7 s at 1 s).

    Args:
        case: a case with the goto task and three axes (name, spec file or
            :class:`~elastica_magnetic_rl.cases.case.Case`).
        period: time of one turn the law asks of the field, s; default the case's ``[yardstick]
            steering_period`` (1 s where not given; the memoryless law's: ``GOTO_CLOCK_PERIOD / 2``).
            Shorter than the rate limit's shortest uniform turn, the field turns as fast as the
            increments allow and its amplitude shrinks (see above).
        walk_band, turn_band: rad from abeam where walking starts and where it stops.
        turn_bearing: rad between the plane and the body's axis while turning.
        stop_radius: m; default half the task's tolerance.
        markov: the law without memory, a function of the observation alone (what DAgger's labels
            need, :meth:`label`): it walks while the target is within ``markov_walk`` rad of abeam
            (no hysteresis) and reverses its turning field by the observation's ``clock`` (every
            ``GOTO_CLOCK_PERIOD / 2`` s, which must be ``period``), not by the turn's own start.
            Measured on the ring of ``m1-4mT-goto`` (training physics, 30 s): 12 of 12, mean
            time to target 10.3 s (the default law: 12 of 12, 6.7 s); without the reversal 6 of 12.
        markov_walk: rad from abeam within which the memoryless law walks.
        turn_in_place: ``False``: walk toward every target, never turning in place (both laws);
            ``None`` (default): the case's ``[yardstick] turn_in_place``, true where not given.

    The default law remembers its manoeuvre:
    :func:`~elastica_magnetic_rl.shipping.policy_runs.run_policy` calls :meth:`reset` at the start
    of each rollout.
    """

    case: str | Case
    period: float | None = None
    walk_band: float = math.pi / 12
    turn_band: float = math.pi / 3
    turn_bearing: float = math.pi / 12
    stop_radius: float | None = None
    markov: bool = False
    markov_walk: float = math.pi / 9
    turn_in_place: bool | None = None

    def __post_init__(self) -> None:
        self.case = self._setup(self.case)
        if self.turn_in_place is None:
            self.turn_in_place = self.case.yardstick.turn_in_place is not False
        task = self.case.task
        if not isinstance(task, GotoTask):
            raise ValueError(f"the steering yardstick steers to a target: case {self.case.name!r} "
                             f"has the {task.kind} task, not goto")
        if self.period is None:
            self.period = GOTO_CLOCK_PERIOD / 2.0 if self.markov else self.case.yardstick.steering_turn
        _check_period(self.period, self.case)
        if self.markov and abs(self.period - GOTO_CLOCK_PERIOD / 2.0) > 1e-12:
            raise ValueError(f"the memoryless steering law reverses its turn by the observation's clock, "
                             f"every {GOTO_CLOCK_PERIOD / 2.0:g} s: its period must be that, got "
                             f"{self.period!r} s")
        for name in ("walk_band", "turn_band", "turn_bearing", "markov_walk"):
            if not 0.0 < getattr(self, name) < math.pi / 2:
                raise ValueError(f"{name} must be in (0, pi/2) rad, got {getattr(self, name)!r}")
        self.stop_radius = 0.5 * task.tolerance if self.stop_radius is None else self.stop_radius
        if not (math.isfinite(self.stop_radius) and 0.0 <= self.stop_radius <= task.tolerance):
            raise ValueError(f"stop_radius must be within the task's tolerance "
                             f"{task.tolerance:g} m, got {self.stop_radius!r}")
        self.reset()
        self.source = (f"steering rotating field, period {self.period:g} s, plane toward the "
                       "target" + ("" if self.turn_in_place else ", never turning in place"))
        self.meta = {"period_s": self.period, "walk_band_rad": self.walk_band,
                     "turn_band_rad": self.turn_band,
                     "turn_bearing_rad": self.turn_bearing,
                     "stop_radius_m": self.stop_radius, "turn_in_place": self.turn_in_place}

    def reset(self) -> None:
        """A new episode: no manoeuvre under way."""
        self._step = 0
        self._walking: bool | None = None
        self._turn_started = 0

    def state(self) -> dict[str, Any]:
        """What it remembers between steps: its step count, its manoeuvre (walking, turning or
        none yet) and the step its turn started at."""
        return {"step": int(self._step), "walking": None if self._walking is None else bool(self._walking),
                "turn_started": int(self._turn_started)}

    def set_state(self, state: dict[str, Any]) -> None:
        """Restore a :meth:`state`."""
        self._step, self._walking = int(state["step"]), state["walking"]
        self._turn_started = int(state["turn_started"])

    def label(self, obs: NDArray[np.float32]) -> NDArray[np.float32]:
        """Its command at ``obs`` while another controller drives (DAgger's label,
        :attr:`~elastica_magnetic_rl.td3.config.TD3Config.yardstick_dagger`): the memoryless law's
        (``markov``) :meth:`act`; the default law's depends on its past, so it has none."""
        if not self.markov:
            raise ValueError("the steering yardstick labels a state only as its memoryless law "
                             "(markov=True): the default law's command depends on its manoeuvre so far")
        return self.act(obs)

    def _markov_bearing(self, forward: float, left: float, clock_sin: float) -> float:
        """:meth:`plane_bearing` of the memoryless law: walking within ``markov_walk`` of abeam,
        the turn reversed in the second half of the observation's clock cycle."""
        bearing = math.atan2(left, forward)
        if not self.turn_in_place or abs(abs(bearing) - math.pi / 2) <= self.markov_walk:
            return bearing
        clockwise = (bearing > 0.0) == (abs(bearing) < math.pi / 2)
        plane = self.turn_bearing if clockwise else -self.turn_bearing
        if clock_sin < 0.0:
            plane -= math.copysign(math.pi, plane)
        return plane

    def plane_bearing(self, forward: float, left: float) -> float:
        """The rotation plane's bearing in the robot's frame (rad) for a target ``forward``,
        ``left`` (m) of it. Walking (the plane toward the target: the band walks across its body
        and turns to keep the plane across it) once the target is within ``walk_band`` rad of
        abeam, until it is more than ``turn_band`` rad from abeam; turning in place otherwise,
        toward bringing the target abeam on the nearer side (the plane at ``turn_bearing`` from the
        axis, reversed after every turn of the field: both senses turn the body the same way, their
        steps cancel). Without ``turn_in_place``: walking toward every target."""
        bearing = math.atan2(left, forward)
        off_abeam = 0.0 if not self.turn_in_place else abs(abs(bearing) - math.pi / 2)
        if self._walking is None or self._walking != (off_abeam <= (
                self.turn_band if self._walking else self.walk_band)):
            self._walking = off_abeam <= (self.turn_band if self._walking else self.walk_band)
            self._turn_started = self._step
        if self._walking:
            return bearing
        # clockwise (right) when the target is ahead-left or behind-right: it then comes abeam
        clockwise = (bearing > 0.0) == (abs(bearing) < math.pi / 2)
        plane = self.turn_bearing if clockwise else -self.turn_bearing
        turns = (self._step - self._turn_started) * ACTION_PERIOD / self.period
        if turns % 2.0 >= 1.0:
            plane -= math.copysign(math.pi, plane)
        return plane

    def plane_amplitude(self, heading: float) -> float:
        """The largest amplitude (T) of a field rotating in the vertical plane of world heading
        ``heading`` (rad) within every axis's limit."""
        x_limit, y_limit, z_limit = self._limits
        amplitude = min(self.field_limit, y_limit)
        if abs(math.cos(heading)) > 1e-12:
            amplitude = min(amplitude, x_limit / abs(math.cos(heading)))
        if abs(math.sin(heading)) > 1e-12:
            amplitude = min(amplitude, z_limit / abs(math.sin(heading)))
        return amplitude

    def act(self, obs: NDArray[np.float32]) -> NDArray[np.float32]:
        """Normalised action in [-1, 1]^3 for one observation ``(obs_dim,)``."""
        field = self._field(obs)
        self._step += 1
        cos_h, sin_h = obs[self.layout["heading"]]
        forward, left = obs[self.layout["target_offset"]] / TARGET_OFFSET_SCALE
        distance = math.hypot(forward, left)
        if distance <= self.stop_radius:
            return self._toward(field, np.zeros(3))
        if self.markov:
            clock_sin = float(obs[self.layout["clock"].start + 1])
            bearing = self._markov_bearing(float(forward), float(left), clock_sin)
        else:
            bearing = self.plane_bearing(float(forward), float(left))
        plane = math.atan2(float(sin_h), float(cos_h)) + bearing
        along = np.array([math.cos(plane), 0.0, -math.sin(plane)])
        # the field's phase in the plane, then one step further clockwise
        phase = math.atan2(field[1], float(field @ along)) - 2.0 * math.pi * ACTION_PERIOD / self.period
        up = np.array([0.0, 1.0, 0.0])
        wanted = self.plane_amplitude(plane) * (math.cos(phase) * along + math.sin(phase) * up)
        return self._toward(field, wanted)


def yardstick_controller(case: Case) -> Callable[[], Any] | None:
    """What makes the case's hand-designed controller for a warm-up it plays
    (:attr:`~elastica_magnetic_rl.td3.config.TD3Config.yardstick_warmup`): a goto case's
    :class:`SteeringFieldPolicy`, its memoryless law (``markov``: the labels of DAgger); a crawl or
    reach case's :class:`RotatingFieldPolicy` at its ``[yardstick]`` ``period`` and sense (what ``msr field
    baseline --set-yardstick`` and ``msr loop`` record); a case steered by a source (a magnet
    arm, coil currents), its steering law reading the observation (:class:`SteeringYardstick`);
    ``None`` for a case without one."""
    if not case.has_yardstick_controller:
        return None
    if not case.field_actuated:
        return functools.partial(SteeringYardstick, case)
    if isinstance(case.task, GotoTask):  # the memoryless law: DAgger can label any state by it
        return functools.partial(SteeringFieldPolicy, case, markov=True)
    return functools.partial(RotatingFieldPolicy, case, case.yardstick.period, case.yardstick.clockwise)
