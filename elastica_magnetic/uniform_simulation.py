"""One robot under a uniform field, simulated on the batched kernel: the trajectory of
:func:`~elastica_magnetic.build_simulation` to the last bit, in about half its time.

The single-robot simulator registers each forcing (magnetic torques, both dampings, gravity, the
ground's contact and friction) as its own PyElastica object, each a Python call per time step; the
batched simulator applies them all in one numba call. A field held over the steps of each call to
:meth:`UniformFieldSimulation.step` (an agent's 100 Hz actuation: a
:class:`~elastica_magnetic.ControlledField`, a :class:`~elastica_magnetic.ConstantField`) is
written once per call; any other uniform field, a function of time (a rotating field, a field CSV's
table), is evaluated at every time step at the time the per-rod simulator evaluates it. Both compute
the same numbers in the same order (``tests/test_uniform_simulation.py`` compares them bit for bit).
"""

from __future__ import annotations

import numpy as np

from .batch import BatchedRobots, BatchedSimulationDivergedError, batched_unsupported
from .fields import ConstantField, ControlledField
from .robot_spec import RobotSpec
from .simulation import (
    FieldFunction,
    RobotSimulation,
    SimulationDivergedError,
    advance_in_actions,
    build_simulation,
)
from .spatial_fields import is_spatial

__all__ = ["UniformFieldSimulation", "uniform_field_simulation"]

#: Fields whose value changes only between calls of ``step`` (written once per call, not evaluated
#: at every time step).
HELD_FIELDS = (ControlledField, ConstantField)


class UniformFieldSimulation:
    """A finalized simulator of one robot under the uniform ``field`` on the batched kernel. It
    offers what :class:`~elastica_magnetic.simulation.RobotSimulation` offers for stepping and
    reading (``spec``, ``rod``, ``field``, ``step_count``, ``time``, ``max_speed``, :meth:`step`,
    :meth:`advance`, :meth:`check_health`, :meth:`markers`).

    Parameters
    ----------
    spec : RobotSpec
        Robot and physics; one the batched kernel models (:func:`uniform_field_simulation`
        chooses for you).
    field : callable
        ``field(time) -> (3,)`` in tesla (the spec's units), uniform in space. A
        :class:`~elastica_magnetic.ControlledField` or :class:`~elastica_magnetic.ConstantField`
        is read once per :meth:`step` (its ``value`` may change between steps, never within one);
        any other is evaluated at every time step.
    max_speed : float, optional
        Blow-up threshold for node speeds; default 10 m/s (in the spec's units).
    """

    def __init__(self, spec: RobotSpec, field: FieldFunction, max_speed: float | None = None) -> None:
        missing = batched_unsupported(spec)
        if missing:
            raise ValueError(f"the batched kernel does not model {', '.join(missing)}: use build_simulation")
        if is_spatial(field) or not callable(field):
            raise TypeError("field must be a uniform field(time) -> (3,) in tesla; a source that varies in "
                            "space takes build_simulation")
        self.spec = spec
        self.field = field
        self.robots = BatchedRobots(spec, 1, max_speed=max_speed)
        self._held = isinstance(field, HELD_FIELDS)
        if not self._held:
            self.robots.set_field_function(0, field)
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
        """Take ``n_steps`` time steps, then check that the state is finite and not running away
        (:class:`~elastica_magnetic.simulation.SimulationDivergedError`)."""
        if self._held:
            self.robots.fields[0] = np.asarray(self.field.value, dtype=np.float64)
        try:
            self.robots.step(n_steps)
        except BatchedSimulationDivergedError as exc:
            raise _one_robot(exc) from None

    def advance(self, duration: float) -> None:
        """Step for ``duration`` seconds (rounded to whole time steps), checking every 0.01 s."""
        advance_in_actions(self, duration)

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


def uniform_field_simulation(spec: RobotSpec, field: FieldFunction, *,
                             clamp: bool = False) -> UniformFieldSimulation | RobotSimulation:
    """The fastest simulator of one robot under ``field``: :class:`UniformFieldSimulation` where
    the field is uniform, the base free and the batched kernel models the spec; else
    :func:`~elastica_magnetic.build_simulation` (a source that varies in space, a clamped base,
    magnetic self-interaction, Kelvin-Voigt viscosity). Both give the same trajectory."""
    if clamp or is_spatial(field) or batched_unsupported(spec):
        return build_simulation(spec, field, clamp=clamp)
    return UniformFieldSimulation(spec, field)
