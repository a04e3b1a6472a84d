"""Many copies of one robot in one PyElastica simulator, with all their forcing in one numba call.

PyElastica 1.0 puts every plain :class:`~elastica.CosseratRod` appended to a simulator into one
memory block and computes the internal forces of the whole block in one vectorized call, but it
applies forcing and contact one rod at a time from Python (five calls per rod and per step for the
paper's robot: magnetic torques, two dampings, gravity and the ground contact; about 15 us per rod
and step). :class:`BatchedRobots` keeps PyElastica's block, its internal forces and its
``PositionVerlet`` stepper, and replaces the per-rod forcing by a single numba kernel that loops
over the robots of the block, each driven by its own field (a row of :attr:`BatchedRobots.fields`).

The kernel is the per-rod physics, operation for operation:

- :class:`~elastica_magnetic.forcing.MagneticTorques` (magnetization fixed in the material frame,
  given in the lab frame of the initial configuration),
- :class:`~elastica_magnetic.forcing.RelativeVelocityDamping`,
- :class:`~elastica_magnetic.forcing.LegacyInternalDamping`,
- :class:`elastica.GravityForces`,
- :class:`~elastica_magnetic.ground.FrictionalGroundContact` (PyElastica's
  ``RodPlaneContactWithAnisotropicFriction`` with an adjustable surface tolerance),

in the order :func:`~elastica_magnetic.build_simulation` registers them, with the floating-point
operations of each element in the same order as PyElastica's array code, so a batched robot follows
the same trajectory as a robot built by :func:`~elastica_magnetic.build_simulation` and driven by
the same field, bit for bit (``tests/test_batch.py`` checks it).

Where the kernel runs: one :class:`elastica.NoForces` object is registered on the first rod with
``add_forcing_to``; PyElastica calls it inside ``synchronize``, after the block's internal forces
and before the accelerations, exactly where the per-rod forcing runs. It ignores the rod it is
handed and works on the memory block (found after ``finalize``). This uses only PyElastica's public
extension point (no override of the ``@final`` ``synchronize``), keeps anything else a user
registers (constraints, callbacks, more forcing) working, and costs two Python calls per step
for all robots together.

Units: those of the spec (SI for the presets): m, kg, s, N, T.
"""

from __future__ import annotations

import math
from typing import Any

import elastica as ea
import numpy as np
from elastica.boundary_conditions import ConstraintBase
from elastica.external_forces import NoForces
from elastica.memory_block.memory_block_rod import MemoryBlockCosseratRod
from numpy.typing import ArrayLike, NDArray

from ._batch_clamp import BatchedClamp
from ._batch_kernels import (
    N_SCRATCH,
    S_NO_CONTACT,
    block_forcing,
    first_unhealthy,
    robot_times,
)
from ._batch_parameters import kernel_parameters
from ._batch_sources import BatchedSources
from .forcing import evaluate_field
from .insertion import Advancer
from .robot_spec import RobotSpec
from .simulation import FieldFunction, SimulationDivergedError, robot_rod, trajectory_row
from .spatial_fields import is_spatial

__all__ = ["BatchedPhysicsNotSupportedError", "BatchedRobots", "BatchedRobotSimulator",
           "BatchedSimulationDivergedError", "SpatialFieldNotSupportedError", "batched_refusal",
           "BATCHED_UNMODELLED_KEYS",
           "batched_unsupported"]


class SpatialFieldNotSupportedError(TypeError):
    """A source that varies in space (``at``/``gradient``) given where a uniform field is
    expected (a row of :attr:`BatchedRobots.fields`); give it to the robot with
    :meth:`BatchedRobots.set_source` (or ``sources=``) instead."""


#: The name of earlier releases (kept so that users' scripts run; it will go).
SpatialFieldNotSupported = SpatialFieldNotSupportedError


class BatchedPhysicsNotSupportedError(ValueError):
    """A robot whose spec asks for physics the batched simulator does not model (its magnetic
    self-interaction and self-contact, a Kelvin-Voigt viscosity): refused by name, never dropped
    without a word. :func:`batched_unsupported` lists them for a check before any work."""


#: The spec keys (dotted, and the keys under them) whose physics the batched simulator does not
#: model (:func:`batched_unsupported` says which a spec sets), with what each is.
BATCHED_UNMODELLED_KEYS = {
    "robot.interaction": "the magnetic interaction between the robot's own elements and its contact "
                         "with itself",
    "robot.damping.kelvin_voigt": "the Kelvin-Voigt internal viscosity",
}


def batched_unsupported(spec: RobotSpec) -> list[str]:
    """What of ``spec`` the batched simulator does not model, each as the spec's key and what it
    is (empty: all of it is modelled). The single-robot simulator
    (:func:`~elastica_magnetic.build_simulation`) models them all."""
    missing = []
    if spec.interaction is not None:
        missing.append(f"[robot.interaction] ({BATCHED_UNMODELLED_KEYS['robot.interaction']})")
    if spec.damping is not None and spec.damping.kelvin_voigt > 0.0:  # None: no damping at all
        missing.append(f"[robot.damping] kelvin_voigt = {spec.damping.kelvin_voigt:g} Pa s "
                       f"({BATCHED_UNMODELLED_KEYS['robot.damping.kelvin_voigt']})")
    return missing


def batched_refusal(spec: RobotSpec, who: str | None = None) -> str | None:
    """The message refusing ``spec`` in ``who`` (a command that runs the batched simulator; the
    simulator itself when ``None``), or ``None`` when it models all of the spec."""
    missing = batched_unsupported(spec)
    if not missing:
        return None
    subject = (f"{who} runs many robots in one batched simulator, which" if who
               else "the batched simulator (many robots in one simulation)")
    return (f"{subject} does not model {' and '.join(missing)}: "
            "a result there would silently leave it out. Leave it out of the spec for this command, or "
            "simulate the robot with it alone (msr field simulate, build_simulation)")


class BatchedRobotSimulator(ea.BaseSystemCollection, ea.Constraints, ea.Forcing, ea.CallBacks):
    """The simulator :class:`BatchedRobots` builds (the ground is not a system: the kernel has it)."""


class BatchedSimulationDivergedError(SimulationDivergedError):
    """A batched robot produced NaN or a runaway velocity; ``robot`` is its index."""

    def __init__(self, message: str, time: float, element: int, robot: int) -> None:
        super().__init__(message, time=time, element=element)
        self.robot = robot


#: The name of earlier releases (kept so that users' scripts run; it will go).
BatchedSimulationDiverged = BatchedSimulationDivergedError


class _BlockForcing(NoForces):
    """Registered once, on the first rod: runs the block kernel of its :class:`BatchedRobots`."""

    def __init__(self, owner: BatchedRobots) -> None:
        super().__init__()
        self._owner = owner

    def apply_forces(self, system, time: np.float64 = np.float64(0.0)) -> None:
        # ``system`` is the first rod; the kernel works on the whole memory block instead.
        self._owner.force(time)

    def apply_torques(self, system, time: np.float64 = np.float64(0.0)) -> None:
        pass  # torques are applied together with the forces, in the kernel


class _BlockClamp(ConstraintBase):
    """Registered once, on the first rod: holds every robot's clamped base (its
    :class:`BatchedRobots`' :class:`~elastica_magnetic._batch_clamp.BatchedClamp`) in one kernel call."""

    def __init__(self, *, owner: BatchedRobots, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self._owner = owner

    def constrain_values(self, system, time: np.float64) -> None:
        self._owner.hold_bases(time, rates=False)

    def constrain_rates(self, system, time: np.float64) -> None:
        self._owner.hold_bases(time, rates=True)


class BatchedRobots:
    """``n_robots`` copies of one robot in one simulator, each with its own uniform field (and,
    after :meth:`set_robot`, its own material values, magnetization and friction).

    The robots are plain :class:`elastica.CosseratRod` objects in one PyElastica memory block,
    all starting in the spec's initial configuration (straight along +x from the origin, resting on
    the ground ``y = -radius``). They do not interact: each robot has its own ground and sees only
    its own field, so they may overlap in space.

    Parameters
    ----------
    spec : RobotSpec
        Robot and physics (e.g. :func:`~elastica_magnetic.yao2023_robot`), the same for all robots.
    n_robots : int
        Number of robots ``N`` (>= 1).
    fields : array_like, optional
        ``(N, 3)`` initial fields in tesla (spec units), lab frame; default zero.
    max_speed : float, optional
        A node faster than this counts as a numerical blow-up; default 10 m/s (spec units).
    sources : sequence, optional
        ``N`` sources that vary in space (:mod:`~elastica_magnetic.spatial_fields`, or any
        object with ``at``/``gradient``), or ``None`` for a robot driven by its uniform row
        alone (:meth:`set_source`). A robot with a source feels its field and gradient at its own
        element centres and its own time (the magnetic force and torque of
        :class:`~elastica_magnetic.MagneticTorques`, applied first, as
        :func:`~elastica_magnetic.build_simulation` registers it); its row of :attr:`fields`
        adds a uniform field on top (keep it zero for the source alone). SI specs only. The
        magnets of :class:`~elastica_magnetic.MagnetPose` arms (their ``source``) are applied
        by one kernel for all robots, which reads each arm's motion as it was commanded before
        :meth:`step` (command the arms between steps).
    clamp : bool, optional
        Clamp each robot's first node and element (position and directors), as
        :func:`~elastica_magnetic.build_simulation` does with ``clamp=True``: a catheter held
        at its base.
    advancers : list, optional
        With ``clamp``: each robot's insertion stage (:class:`~elastica_magnetic.insertion.Advancer`,
        or ``None``), pushing its clamped base along its axis on the robot's own clock.

    Attributes
    ----------
    spec : RobotSpec
        The batch's robot (the one every robot starts as).
    specs : list of RobotSpec
        ``specs[i]`` is robot ``i``'s (``spec`` until :meth:`set_robot` changes it).
    simulator : BatchedRobotSimulator
        Finalized; step it only through :meth:`step`.
    rods : list of elastica.CosseratRod
        ``rods[i]`` is robot ``i`` (its arrays are views into the memory block).
    block : elastica.memory_block.memory_block_rod.MemoryBlockCosseratRod
    step_count : int
        Time steps taken by the simulator since it was built.
    robot_step_count : numpy.ndarray
        ``(N,)`` int64, time steps taken by each robot since it was built or last reset.

    Examples
    --------
    >>> robots = BatchedRobots(yao2023_robot(1, "training"), n_robots=16)
    >>> robots.fields[:] = [0.0, 4e-3, 0.0]   # every robot, in tesla; or one row per robot
    >>> robots.step(robots.spec.steps_per_action)  # 0.01 s
    >>> x = robots.markers(3)["mid_x_m"]  # m
    """

    def __init__(
        self,
        spec: RobotSpec,
        n_robots: int,
        fields: ArrayLike | None = None,
        *,
        max_speed: float | None = None,
        sources: list[Any] | None = None,
        clamp: bool = False,
        advancers: list[Advancer | None] | None = None,
    ) -> None:
        if int(n_robots) != n_robots or n_robots < 1:
            raise ValueError(f"n_robots must be a positive integer, got {n_robots!r}")
        n_robots = int(n_robots)
        refusal = batched_refusal(spec)
        if refusal:
            raise BatchedPhysicsNotSupportedError(refusal)
        self.spec = spec
        self.n_robots = n_robots
        self.stepper = ea.PositionVerlet()
        self.step_count = 0
        self._step_index = 0  # of the step being taken (the forcing's clock)
        self._behind = np.zeros(n_robots, dtype=np.int64)  # steps each robot is behind (set by step)
        self.robot_step_count = np.zeros(n_robots, dtype=np.int64)
        if max_speed is None:
            max_speed = 10.0 * spec.units.factor("velocity")
        self.max_speed = float(max_speed)
        self._fields = np.zeros((n_robots, 3), dtype=np.float64)
        self._field_functions: list[tuple[int, FieldFunction]] = []  # set_field_function's
        if fields is not None:
            self.fields = fields  # type: ignore[assignment]
        self.specs = [spec] * n_robots
        self.clamp = bool(clamp)
        if advancers is not None and (not self.clamp or len(advancers) != n_robots):
            raise ValueError(f"advancers push clamped bases: give clamp=True and one per robot ({n_robots}, "
                             "None for a robot without one)")
        self.advancers = list(advancers) if advancers is not None else [None] * n_robots
        self._clamp = BatchedClamp(self.advancers) if self.clamp else None
        self._times = np.zeros(n_robots)  # each robot's own time (s), the clamp's scratch
        self.simulator, self.rods = self._build_simulator()
        self.block = self._locate_robots()
        self._direct = self._only_own_operators()
        if self._clamp is not None:
            self._clamp.locate(self.block, self._node_start, self._elem_start)
        self._kernel_args = self._block_kernel_arguments(spec)
        # Every array of every rod at the start, to reset a robot (state, rates, accelerations,
        # loads and the derived geometry: a reset robot is indistinguishable from a fresh one).
        self._initial_state = [
            {name: value.copy() for name, value in vars(rod).items() if isinstance(value, np.ndarray)}
            for rod in self.rods
        ]
        self._attach_sources(sources)

    def _block_kernel_arguments(self, spec: RobotSpec) -> tuple:
        """The block kernel's arguments: every robot's moments and parameters (the spec's), a
        scratch buffer and the memory block's arrays (views, so the kernel writes the rods)."""
        n_robots = self.n_robots
        self._moments = np.zeros((3, self.block.n_elems))
        for i in range(n_robots):
            self._moments[:, self._elem_start[i] : self._elem_end[i]] = self._robot_moments(i, spec)
        params, self._options = kernel_parameters(spec)
        self._params = np.tile(params, (n_robots, 1))
        self._scratch = np.zeros((N_SCRATCH, spec.n_elements))
        block = self.block
        return (
            self._fields,
            self._moments,
            self._node_start,
            self._node_end,
            self._elem_start,
            self._elem_end,
            self._options,
            self._params,
            block.mass,
            block.radius,
            block.lengths,
            block.tangents,
            block.position_collection,
            block.director_collection,
            block.velocity_collection,
            block.omega_collection,
            block.internal_forces,
            block.external_forces,
            block.internal_torques,
            block.external_torques,
            self._scratch,
        )

    def _attach_sources(self, sources: list[Any] | None) -> None:
        """Each robot's source in space (``None`` for none), driven by kind
        (:class:`~elastica_magnetic._batch_sources.BatchedSources`)."""
        self._sources = BatchedSources(self)
        if sources is None:
            return
        if len(sources) != self.n_robots:
            raise ValueError(f"sources: expected {self.n_robots} (one per robot, None for none), "
                             f"got {len(sources)}")
        for i, source in enumerate(sources):
            if source is not None:
                self.set_source(i, source)

    def _build_simulator(self) -> tuple[BatchedRobotSimulator, list[ea.CosseratRod]]:
        """The finalized simulator of ``n_robots`` rods of the spec, the block forcing registered
        once (on the first rod), and the rods."""
        simulator = BatchedRobotSimulator()
        rods = []
        for _ in range(self.n_robots):
            rod = robot_rod(self.spec)
            simulator.append(rod)
            rods.append(rod)
        simulator.add_forcing_to(rods[0]).using(_BlockForcing, owner=self)
        if self.clamp:  # as build_simulation(..., clamp=True) holds a catheter's base, all in one call
            simulator.constrain(rods[0]).using(_BlockClamp, owner=self)
        simulator.finalize()
        return simulator, rods

    def _only_own_operators(self) -> bool:
        """Whether the finalized simulator holds the one memory block and nothing but what
        :meth:`_build_simulator` registered (the block forcing's two calls, the clamp's), so that
        :meth:`_step_block` may take PyElastica's step without its operator groups."""
        sim = self.simulator
        clamps = 1 if self.clamp else 0
        counts = [len(list(group)) for group in (
            sim._feature_group_synchronize, sim._feature_group_constrain_values,
            sim._feature_group_constrain_rates, sim._feature_group_damping, sim._feature_group_callback)]
        return list(sim.final_systems()) == [self.block] and counts == [2, clamps, clamps, 0, 0] \
            and type(self.stepper) is ea.PositionVerlet

    def _step_block(self, time: float, dt: float) -> None:
        """One ``PositionVerlet`` step of the block from ``time`` (s) by ``dt`` (s): the operations
        of ``PositionVerlet.step`` on a collection of this one block, in its order and with its
        arithmetic (kinematic half step, bases held, internal forces, the block forcing,
        accelerations and dynamics, rates held, kinematic half step, bases held, loads zeroed),
        called directly rather than through the collection's operator groups (a third of a small
        batch's step)."""
        block = self.block
        simulation_time, simulation_dt = np.float64(time), np.float64(dt)
        half = 0.5 * simulation_dt
        block.update_kinematics(simulation_time, half)
        simulation_time += half
        self.hold_bases(simulation_time, rates=False)
        block.compute_internal_forces_and_torques(simulation_time)
        self.force(simulation_time)
        block.update_accelerations(simulation_time, simulation_dt)
        block.update_dynamics(simulation_time, simulation_dt)
        self.hold_bases(simulation_time, rates=True)
        block.update_kinematics(simulation_time, half)
        simulation_time += half
        self.hold_bases(simulation_time, rates=False)
        block.zeroed_out_external_forces_and_torques(simulation_time)

    def _locate_robots(self) -> MemoryBlockCosseratRod:
        """The one memory block of all robots, and each robot's node and element ranges in it
        (``_node_start`` .. ``_elem_end``, ``(N,)``), checked to be views of that robot's arrays."""
        n_robots, rods = self.n_robots, self.rods
        blocks = [s for s in self.simulator.final_systems() if isinstance(s, MemoryBlockCosseratRod)]
        if len(blocks) != 1 or blocks[0].n_rods != n_robots:
            raise RuntimeError("expected all robots in one PyElastica memory block")
        block = blocks[0]
        # Block position of each robot (PyElastica may reorder systems inside the block).
        order = [int(np.flatnonzero(block.system_idx_list == i)[0]) for i in range(n_robots)]
        self._node_start = np.array([block.start_idx_in_rod_nodes[j] for j in order], dtype=np.int64)
        self._node_end = np.array([block.end_idx_in_rod_nodes[j] for j in order], dtype=np.int64)
        self._elem_start = np.array([block.start_idx_in_rod_elems[j] for j in order], dtype=np.int64)
        self._elem_end = np.array([block.end_idx_in_rod_elems[j] for j in order], dtype=np.int64)
        for i, rod in enumerate(rods):
            n0, e0 = self._node_start[i], self._elem_start[i]
            if (
                self._node_end[i] - n0 != rod.n_elems + 1
                or self._elem_end[i] - e0 != rod.n_elems
                or not np.shares_memory(rod.position_collection, block.position_collection[:, n0 : n0 + 1])
                or not np.shares_memory(rod.director_collection, block.director_collection[..., e0 : e0 + 1])
            ):
                raise RuntimeError(f"robot {i} is not where the memory block index arrays say")
        return block

    def _robot_moments(self, i: int, spec: RobotSpec) -> NDArray[np.float64]:
        """Magnetic moments V M of robot ``i`` in the material frame, ``(3, n_elements)``, A m^2:
        the same numpy expression as MagneticTorques with frame="lab" (called while the robot is
        in its initial configuration, whose directors MagneticTorques sees at its first call)."""
        rod = self.rods[i]
        magnetization = np.asarray(spec.magnetization, dtype=np.float64)
        moment = np.einsum("ijk,jk->ik", rod.director_collection, magnetization)
        return moment * rod.volume[None, :]

    def force(self, time: float) -> None:
        """What each time step adds to the block's external loads (N, N m) at the simulator's
        ``time`` (s): the spatial sources' force and torque first, then :meth:`apply_forcing`."""
        if self._sources:
            self._sources.apply(float(time))
        for i, field in self._field_functions:  # as MagneticTorques evaluates it, at the robot's time
            self._fields[i] = evaluate_field(field, self._robot_time(time, self._behind[i]))
        self.apply_forcing()

    def set_field_function(self, i: int, field: FieldFunction | None) -> None:
        """Drive robot ``i`` by a uniform field that varies in time, ``field(time) -> (3,)`` (T, lab
        frame), evaluated at every time step at the robot's own time, as
        :func:`~elastica_magnetic.build_simulation`'s :class:`~elastica_magnetic.MagneticTorques`
        evaluates it (its row of :attr:`fields` then holds the last value); ``None``: back to the
        row written between steps."""
        if not 0 <= i < self.n_robots:
            raise IndexError(f"robot {i}: the batch has robots 0 to {self.n_robots - 1}")
        if field is not None and (is_spatial(field) or not callable(field)):
            raise SpatialFieldNotSupportedError(
                f"robot {i}: a field function is uniform, field(time) -> (3,) in tesla; give a source "
                "that varies in space with set_source(i, source)")
        self._field_functions = [(j, f) for j, f in self._field_functions if j != i]
        if field is not None:
            self._field_functions.append((i, field))

    def apply_forcing(self) -> None:
        """One call of the block kernel: every robot's uniform-field magnetic torque, damping,
        gravity and ground contact added to the block's external loads (N, N m) (public for
        benchmarks: step the simulator with :meth:`step`)."""
        block_forcing(*self._kernel_args)

    def _robot_time(self, time: float, behind: Any) -> Any:
        """The time (s) a robot ``behind`` steps behind the block's clock (reset since it started)
        is at when the block's forcing is at ``time``: at PositionVerlet's forcing time (after its
        half kinematic step), as the per-rod simulation of that robot computes it (its own steps x
        dt, plus dt / 2), so that both round alike (``behind`` an int, or an int array ``(M,)``:
        the times ``(M,)``, :func:`robot_times`)."""
        if np.ndim(behind):
            out = np.empty(len(behind))
            robot_times(float(time), self._step_index, self.spec.dt, np.asarray(behind, dtype=np.int64), out)
            return out
        dt, index, behind = self.spec.dt, self._step_index, int(behind)
        half = index * dt + 0.5 * dt
        if behind == 0:
            return time
        if time == half:  # the forcing, and the constraints after the first half step
            return (index - behind) * dt + 0.5 * dt
        if time == half + 0.5 * dt:  # the constraints after the second half step
            return (index - behind) * dt + 0.5 * dt + 0.5 * dt
        return time - behind * dt

    def hold_bases(self, time: float, rates: bool) -> None:
        """Hold every clamped robot's base (its first node and element, moved by its stage) at
        the stepper's ``time`` (s), each robot on its own clock: positions and directors, or
        with ``rates`` velocities and angular velocities (before the block is located, when
        PyElastica applies the constraints at finalization, the bases are where they are built:
        nothing to do)."""
        clamp = self._clamp
        if clamp is None or not clamp.located:
            return
        robot_times(float(time), self._step_index, self.spec.dt, self._behind, self._times)
        if rates:
            clamp.constrain_rates(self.block, self._times)
        else:
            clamp.constrain_values(self.block, self._times)

    def set_source(self, i: int, source: Any) -> None:
        """Drive robot ``i`` by a source that varies in space (``None``: by its uniform row
        alone). See ``sources`` in the class docstring."""
        self._sources.set(i, source)

    @property
    def sources(self) -> list[Any]:
        """Each robot's spatial source (``None``: its uniform row alone)."""
        return self._sources.sources

    @property
    def kernel_arguments(self) -> tuple[Any, ...]:
        """The arrays the block kernel reads and writes, in its argument order (for benchmarks of
        the call overhead)."""
        return self._kernel_args

    def base_arrays(self) -> dict[str, NDArray[np.float64]]:
        """The float arrays of the memory block that own their memory, by attribute name: every
        rod array is a view of one of them, so together they are the simulator's whole state (for
        saving and restoring it)."""
        return {name: value for name, value in vars(self.block).items()
                if isinstance(value, np.ndarray) and value.dtype.kind == "f" and value.base is None}

    def contact_fraction(self) -> float:
        """Share of the elements of the last robot the kernel handled that touched the ground at
        its last call (0 to 1)."""
        return float(1.0 - self._scratch[S_NO_CONTACT].mean())

    # ----------------------------------------------------------------------------------------------
    @property
    def fields(self) -> NDArray[np.float64]:
        """``(N, 3)`` field of each robot, T (lab frame). Write it in place between steps."""
        return self._fields

    @fields.setter
    def fields(self, value: ArrayLike) -> None:
        if is_spatial(value):
            raise SpatialFieldNotSupportedError(
                f"fields are uniform ((N, 3) in tesla), got the spatial source "
                f"{type(value).__name__}; give it to a robot with set_source(i, source) (or "
                "BatchedRobots(..., sources=[...]))")
        value = np.asarray(value, dtype=np.float64)
        if not np.all(np.isfinite(value)):
            raise ValueError(f"fields must be finite (tesla), got {value.tolist()}")
        try:
            self._fields[...] = value
        except ValueError:
            raise ValueError(
                f"fields must broadcast to ({self.n_robots}, 3) in tesla, got {value.shape}"
            ) from None

    @property
    def time(self) -> float:
        """Simulated time of the simulator, s: ``step_count * dt``."""
        return self.step_count * self.spec.dt

    def robot_time(self, i: int) -> float:
        """Time robot ``i`` has been simulated since it was built or last reset, s."""
        return int(self.robot_step_count[i]) * self.spec.dt

    def rod(self, i: int) -> ea.CosseratRod:
        """The rod of robot ``i`` (its arrays are views into the memory block)."""
        return self.rods[i]

    def markers(self, i: int) -> dict[str, float]:
        """Trajectory row of robot ``i`` (:func:`~elastica_magnetic.simulation.trajectory_row`)."""
        return trajectory_row(self.rods[i], self.robot_time(i))

    # ----------------------------------------------------------------------------------------------
    def step(self, n_steps: int) -> None:
        """Take ``n_steps`` time steps with the current :attr:`fields`, then check every robot.

        Raises :class:`BatchedSimulationDivergedError` (a :class:`SimulationDivergedError`) naming the robot,
        its time and the element if a node of some robot is NaN or faster than :attr:`max_speed`.
        """
        simulator, step, dt = self.simulator, self.stepper.step, self.spec.dt
        start = self.step_count
        # how many steps each robot is behind the block's clock: fixed while these steps run
        self._behind = self.step_count - self.robot_step_count
        self._sources.gather(self._behind)
        if self._clamp is not None:
            self._clamp.gather()
        for k in range(n_steps):
            # Time from the step counter, as in RobotSimulation (the kernel itself ignores time).
            self._step_index = start + k
            if self._direct:
                self._step_block((start + k) * dt, dt)
            else:
                step(simulator, (start + k) * dt, dt)
        self.step_count = start + n_steps
        self.robot_step_count += n_steps
        self.check_health()

    def check_health(self) -> None:
        """Raise :class:`BatchedSimulationDivergedError` for the first robot with NaN or a runaway node."""
        block = self.block
        robot, node, is_nan, speed2, n_bad = first_unhealthy(
            block.position_collection,
            block.velocity_collection,
            self._node_start,
            self._node_end,
            self.max_speed * self.max_speed,
        )
        if robot < 0:
            return
        element = min(node, self.spec.n_elements - 1)
        what = "NaN" if is_nan else f"runaway speed {math.sqrt(speed2):.3g} > {self.max_speed:.3g}"
        others = f" ({n_bad - 1} other robot(s) also diverged)" if n_bad > 1 else ""
        time = self.robot_time(robot)
        raise BatchedSimulationDivergedError(
            f"robot {robot}: simulation diverged at t = {time:.6f} s: {what} at node {node} "
            f"(element {element}){others}; reduce dt (now {self.spec.dt:g}) or check the parameters",
            time=time,
            element=element,
            robot=robot,
        )

    def set_robot(self, i: int, spec: RobotSpec) -> None:
        """Make robot ``i`` the robot of ``spec`` (other material values, magnetization, friction,
        damping or gravity; the same number of elements, time step and forcing), put it in its
        initial state and keep that state for :meth:`reset_robot`; the others are untouched.

        The robot then follows the same trajectory as a robot of ``spec`` built by
        :func:`~elastica_magnetic.build_simulation` (every array of its rod is that rod's:
        masses, stiffnesses, inertias, geometry, state). Raises ``ValueError`` naming what differs
        when ``spec`` cannot share this block (elements, time step, which forcing it has).
        """
        if not 0 <= i < self.n_robots:
            raise IndexError(f"robot index {i} out of range for {self.n_robots} robots")
        refusal = batched_refusal(spec)
        if refusal:
            raise BatchedPhysicsNotSupportedError(f"robot {i}: {refusal}")
        nominal = self.spec
        for name in ("n_elements", "dt"):
            if getattr(spec, name) != getattr(nominal, name):
                raise ValueError(f"robot {i}: {name} {getattr(spec, name)!r} differs from the "
                                 f"batch's {getattr(nominal, name)!r} (robots of one batch share it)")
        params, options = kernel_parameters(spec)
        if not np.array_equal(options, self._options):
            raise ValueError(f"robot {i}: its forcing (damping, node offset, gravity, ground) differs "
                             "from the batch's (robots of one batch share which forcing they have)")
        fresh = robot_rod(spec)
        state = {}
        for name, value in self._initial_state[i].items():
            new = getattr(fresh, name, None)
            if not isinstance(new, np.ndarray) or new.shape != value.shape:
                raise ValueError(f"robot {i}: the rod array {name!r} of the new spec does not fit")
            state[name] = np.array(new, dtype=value.dtype)
        self._initial_state[i] = state
        self.specs[i] = spec
        self.reset_robot(i)
        self._moments[:, self._elem_start[i] : self._elem_end[i]] = self._robot_moments(i, spec)
        self._params[i] = params
        self._sources.respecified(i)

    def reset_robot(self, i: int) -> None:
        """Put robot ``i`` back in its initial state (the others are untouched).

        Every array of the rod is restored (positions, directors, velocities, angular velocities,
        accelerations, loads and the geometry derived from them), so the robot then follows the
        same trajectory as a freshly built one driven by the same fields. Its field is left as is.
        """
        if not 0 <= i < self.n_robots:
            raise IndexError(f"robot index {i} out of range for {self.n_robots} robots")
        rod = self.rods[i]
        for name, value in self._initial_state[i].items():
            getattr(rod, name)[...] = value
        self.robot_step_count[i] = 0
