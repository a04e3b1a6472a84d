"""One robot under a uniform field held between calls (an agent's 100 Hz actuation, a waveform's
rows), simulated on the batched kernel: the trajectory of :func:`~elastica_magnetic.build_simulation`
to the last bit, in about half its time.

The single-robot simulator registers each forcing (magnetic torques, both dampings, gravity, the
ground's contact and friction) as its own PyElastica object, each a Python call per time step; the
batched simulator applies them all in one numba call. Where a field is constant over the steps of a
call to :meth:`HeldFieldSimulation.step`, as a :class:`~elastica_magnetic.ControlledField` is, the
two compute the same numbers in the same order (a test compares them bit for bit).
"""

from __future__ import annotations

import numpy as np

from .batch import BatchedRobots, BatchedSimulationDivergedError, batched_unsupported
from .robot_spec import RobotSpec
from .simulation import RobotSimulation, SimulationDivergedError, build_simulation

__all__ = ["HeldFieldSimulation", "held_field_simulation"]


class HeldFieldSimulation:
    """A finalized simulator of one robot whose field is ``field.value`` (T, ``(3,)``, spec units),
    read at each :meth:`step` and held over its time steps. It offers what
    :class:`~elastica_magnetic.simulation.RobotSimulation` offers for stepping and reading
    (``spec``, ``rod``, ``step_count``, ``time``, ``max_speed``, :meth:`step`, :meth:`advance`,
    :meth:`check_health`, :meth:`markers`).

    Parameters
    ----------
    spec : RobotSpec
        Robot and physics; one the batched simulator models (:func:`held_field_simulation`
        chooses for you).
    field : object with ``value``
        The field source, e.g. :class:`~elastica_magnetic.ControlledField`; its ``value`` (T)
        may change between steps, never within one.
    max_speed : float, optional
        Blow-up threshold for node speeds; default 10 m/s (in the spec's units).
    """

    def __init__(self, spec: RobotSpec, field: object, max_speed: float | None = None) -> None:
        missing = batched_unsupported(spec)
        if missing:
            raise ValueError(f"the batched kernel does not model {', '.join(missing)}: use build_simulation")
        self.spec = spec
        self.field = field
        self.robots = BatchedRobots(spec, 1, max_speed=max_speed)
        self.rod = self.robots.rods[0]
        self.max_speed = self.robots.max_speed

    @property
    def step_count(self) -> int:
        """Time steps taken; ``time == step_count * spec.dt``."""
        return self.robots.step_count

    @property
    def time(self) -> float:
        """Simulated time, s (spec units)."""
        return self.robots.time

    def step(self, n_steps: int) -> None:
        """Take ``n_steps`` time steps under the field's present value, then check that the state is
        finite and not running away (:class:`~elastica_magnetic.simulation.SimulationDivergedError`)."""
        self.robots.fields[0] = np.asarray(self.field.value, dtype=np.float64)
        try:
            self.robots.step(n_steps)
        except BatchedSimulationDivergedError as exc:
            raise _one_robot(exc) from None

    def advance(self, duration: float) -> None:
        """Step for ``duration`` seconds (rounded to whole time steps), checking every 0.01 s."""
        n_total = int(round(duration / self.spec.dt))
        block = max(1, self.spec.steps_per_action)
        while n_total > 0:
            n = min(block, n_total)
            self.step(n)
            n_total -= n

    def check_health(self) -> None:
        """Raise :class:`~elastica_magnetic.simulation.SimulationDivergedError` if any node has NaN
        or moves faster than ``max_speed``."""
        try:
            self.robots.check_health()
        except BatchedSimulationDivergedError as exc:
            raise _one_robot(exc) from None

    def markers(self) -> dict[str, float]:
        """One trajectory row (see :data:`~elastica_magnetic.simulation.TRAJECTORY_COLUMNS`)."""
        return self.robots.markers(0)


def _one_robot(exc: BatchedSimulationDivergedError) -> SimulationDivergedError:
    """The batch's divergence as the single-robot simulator words it (no robot index)."""
    return SimulationDivergedError(str(exc).removeprefix("robot 0: "), time=exc.time, element=exc.element)


def held_field_simulation(spec: RobotSpec, field: object) -> HeldFieldSimulation | RobotSimulation:
    """The fastest simulator of one robot under ``field`` (an object whose ``value``, T, holds
    between steps, also callable as ``field(time)``): :class:`HeldFieldSimulation` where the
    batched kernel models the spec, else :func:`~elastica_magnetic.build_simulation` (magnetic
    self-interaction, Kelvin-Voigt viscosity). Both give the same trajectory."""
    if batched_unsupported(spec):
        return build_simulation(spec, field)
    return HeldFieldSimulation(spec, field)
