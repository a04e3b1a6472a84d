"""The yardstick of a tip-reach case (a catheter steered by a magnet on an arm or by fixed coils): its
steering law built from the case, and the same law as a controller that reads only an
observation, which plays a training's warm-up (``yardstick_warmup``) as a crawl's rotating field
does. Lengths in m, times in s.

The law is the bearing law of :class:`~elastica_magnetic.steering.MagnetBearingSteering` (the
magnet kept at its start distance from the straight tip) or of
:class:`~elastica_magnetic.steering.CoilFieldSteering` (:data:`COIL_FIELD_FRACTION` of the coils'
strongest field at the straight tip); with an insertion stage, the stage is pushed or pulled until
the tip is as far from the base's start as the target (:data:`INSERTION_GAIN`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic import CoilCurrents, MagnetPose
from elastica_magnetic.robot_spec import ACTION_PERIOD
from elastica_magnetic.steering import CoilFieldSteering, MagnetBearingSteering

from ..cases.case import Case
from ..cases.steered import SteeringActuation
from .catheter_env import CATHETER_OBSERVATION_SCALES, catheter_observation_layout

__all__ = ["COIL_FIELD_FRACTION", "INSERTION_GAIN", "SteeringYardstick", "insertion_command", "steering_law"]

#: 1/s: with an insertion stage, the yardstick commands its velocity as this gain times the gap
#: between the target's and the tip's distance from the base's start (m), over the stage's top speed.
INSERTION_GAIN = 5.0

#: The fraction of the coils' strongest field at the straight tip that the coils' yardstick asks
#: (headroom: a tip away from the start, where the coils give less, still gets the field asked).
COIL_FIELD_FRACTION = 0.5

#: m: the clamped base's start (the spec's frame: the rod along +x from the origin).
BASE_START = (0.0, 0.0, 0.0)


def steering_law(actuation: SteeringActuation, rod_length: float,
                 actuator: MagnetPose | CoilCurrents | Any) -> MagnetBearingSteering | CoilFieldSteering:
    """The case's steering law for one ``actuator`` (what it reads the magnet's pose or the coils'
    fields from): a magnet arm's bearing law at the magnet's start distance from the straight tip
    (``rod_length``, m), or the coils' at :data:`COIL_FIELD_FRACTION` of their strongest field there."""
    if actuation.kind == "magnet-pose":
        start = np.asarray(actuation.position, dtype=np.float64)
        distance = float(np.linalg.norm(start - np.array([rod_length, 0.0, 0.0])))
        return MagnetBearingSteering(actuator, base=BASE_START, distance=distance)
    field = COIL_FIELD_FRACTION * actuation.field_at_tip(rod_length)
    return CoilFieldSteering(actuator, base=BASE_START, field=field)


def insertion_command(targets: NDArray[np.float64], tips: NDArray[np.float64],
                      max_speed: float) -> NDArray[np.float64]:
    """The insertion stage's commands ``(N,)`` in [-1, 1]: push (or pull) at :data:`INSERTION_GAIN`
    times the gap between each target's and tip's distance from the base's start (m, ``(N, 3)``
    each), over the stage's top speed ``max_speed`` (m/s)."""
    gap = np.linalg.norm(targets, axis=1) - np.linalg.norm(tips, axis=1)
    return np.clip(INSERTION_GAIN * gap / max_speed, -1.0, 1.0)


class _ObservedMagnet:
    """A magnet arm's pose as one observation shows it: what the bearing law reads of the arm."""

    def __init__(self, max_speed: float) -> None:
        self.max_speed = float(max_speed)
        self.position = np.zeros(3)
        self.direction = np.array([1.0, 0.0, 0.0])

    def position_at(self, time: float) -> NDArray[np.float64]:
        return self.position

    def direction_at(self, time: float) -> NDArray[np.float64]:
        return self.direction


class SteeringYardstick:
    """The steering law of a tip-reach ``case`` as one sub-environment's controller that reads
    only its observation (float32, the layout of
    :func:`~elastica_magnetic_rl.envs.catheter_env.catheter_observation_layout`): the tip and the
    base from the node positions and the insertion, the target from the offset, the magnet's pose
    from its blocks; the coils' fields from the case's coils. It plays a training's warm-up
    (:attr:`~elastica_magnetic_rl.td3.config.TD3Config.yardstick_warmup`) and acts as
    :func:`~elastica_magnetic_rl.shipping.tip_reach.steering_controller` does on the environment's
    own state (to the observation's float32 rounding, about 1e-9 m).

    ``act(obs)`` -> ``(act_dim,)`` in [-1, 1]; ``reset()`` at each episode's start;
    ``state()``/``set_state()`` for checkpoints inside episodes (the law's field direction);
    ``label(obs)``: the law's command where another controller drives (DAgger's teacher)."""

    def __init__(self, case: Case) -> None:
        actuation, spec = case.actuation, case.robot_spec("training")
        self.layout = catheter_observation_layout(spec.n_elements, actuation.observation_blocks)
        self.obs_dim = self.layout["target_offset"].stop
        self.act_dim = actuation.action_size
        if actuation.kind == "magnet-pose":
            self.magnet: _ObservedMagnet | None = _ObservedMagnet(actuation.max_speed)
            actuator: Any = self.magnet
        else:
            self.magnet, actuator = None, actuation.actuator()
        self.law = steering_law(actuation, float(spec.length), actuator)
        self.stage_speed = actuation.advancer().max_speed if actuation.insertion else None

    def reset(self) -> None:
        """A new episode: the field direction starts again along the catheter."""
        self.law.reset()

    def state(self) -> list[float] | None:
        """The law's field direction (``None`` before an episode's first step)."""
        f = self.law.field_direction
        return None if f is None else [float(v) for v in f]

    def set_state(self, state: list[float] | None) -> None:
        self.law.field_direction = None if state is None else np.asarray(state, dtype=np.float64)

    def label(self, obs: NDArray[np.float32]) -> NDArray[np.float64]:
        """The law's command at ``obs`` ``(obs_dim,)`` while another controller drives (a
        learner's, for :attr:`~elastica_magnetic_rl.td3.config.TD3Config.yardstick_dagger`): where the
        observation shows the field at the tip (``tip_field``), the law turns that field's
        direction, not its own remembered one, so the label is a function of the observation alone
        (the one a policy reading it can learn); elsewhere the law's own direction, which has
        followed the tip since the episode's start."""
        if "tip_field" in self.layout:
            field = np.asarray(obs[self.layout["tip_field"]], dtype=np.float64)
            norm = float(np.linalg.norm(field))
            self.law.field_direction = field / norm if norm > 0.0 else None
        return self.act(obs)

    def act(self, obs: NDArray[np.float32]) -> NDArray[np.float64]:
        """The law's command for the observation ``obs`` ``(obs_dim,)``."""
        obs, layout, scales = np.asarray(obs, dtype=np.float64), self.layout, CATHETER_OBSERVATION_SCALES
        base = np.zeros(3)
        if self.stage_speed is not None:
            base[0] = obs[layout["insertion"]][0] / scales["insertion"]
        tip = base + obs[layout["node_positions"]][-3:] / scales["node_positions"]
        target = tip + obs[layout["target_offset"]] / scales["target_offset"]
        if self.magnet is not None:
            self.magnet.position = base + obs[layout["magnet_position"]] / scales["magnet_position"]
            direction = obs[layout["magnet_direction"]]
            self.magnet.direction = direction / np.linalg.norm(direction)
        steer = self.law.action(tip, target, 0.0, ACTION_PERIOD)
        if self.stage_speed is None:
            return steer
        push = insertion_command(target[None], tip[None], self.stage_speed)
        return np.concatenate([steer, push])
