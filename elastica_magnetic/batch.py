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

import elastica as ea
import numpy as np
from elastica.external_forces import NoForces
from elastica.memory_block.memory_block_rod import MemoryBlockCosseratRod
from numba import njit
from numpy.typing import ArrayLike, NDArray

from .presets import RobotSpec
from .simulation import SimulationDiverged, robot_rod, trajectory_row

__all__ = ["BatchedRobots", "BatchedRobotSimulator", "BatchedSimulationDiverged"]

# Layout of the float parameter vector handed to the kernel.
_P_RELATIVE_NU = 0
_P_LEGACY_FORCE = 1
_P_LEGACY_TORQUE = 2
_P_GRAVITY = 3  # 3 entries, m/s^2
_P_PLANE_ORIGIN = 6  # 3 entries, m
_P_PLANE_NORMAL = 9  # 3 entries
_P_K = 12
_P_NU = 13
_P_SURFACE_TOL = 14
_P_SLIP_TOL = 15
_P_STATIC_MU = 16  # forward, backward, sideways
_P_KINETIC_MU = 19  # forward, backward, sideways
_N_PARAMS = 22

# Layout of the integer option vector.
_O_DAMPING = 0
_O_NODE_OFFSET = 1
_O_GRAVITY = 2
_O_GROUND = 3

# Rows of the per-robot scratch array (each row has one column per element).
_S_VELOCITY = 0  # 3 rows: mass-weighted element velocity
_S_RESPONSE = 3  # 3 rows: total plane response (normal part) of the element
_S_RESPONSE_MAG = 6
_S_NO_CONTACT = 7
_S_AXIAL = 8  # 3 rows
_S_ROLLING = 11  # 3 rows
_S_SLIP_AXIAL = 14
_S_SLIP_ROLLING = 15
_S_ARM = 16  # 3 rows: torque arm -normal * radius
_S_FRICTION = 19  # 3 rows: kinetic rolling, then static axial friction force
_S_ELEMENT_FORCE = 22  # 3 rows: element total force before the static friction
_N_SCRATCH = 25


class BatchedRobotSimulator(ea.BaseSystemCollection, ea.Constraints, ea.Forcing, ea.CallBacks):
    """The simulator :class:`BatchedRobots` builds (the ground is not a system: the kernel has it)."""


class BatchedSimulationDiverged(SimulationDiverged):
    """A batched robot produced NaN or a runaway velocity; ``robot`` is its index."""

    def __init__(self, message: str, time: float, element: int, robot: int) -> None:
        super().__init__(message, time=time, element=element)
        self.robot = robot


class _BlockForcing(NoForces):
    """Registered once, on the first rod: runs the block kernel of its :class:`BatchedRobots`."""

    def __init__(self, owner: BatchedRobots) -> None:
        super().__init__()
        self._owner = owner

    def apply_forces(self, system, time: np.float64 = np.float64(0.0)) -> None:
        # ``system`` is the first rod; the kernel works on the whole memory block instead.
        _block_forcing(*self._owner._kernel_args)

    def apply_torques(self, system, time: np.float64 = np.float64(0.0)) -> None:
        pass  # torques are applied together with the forces, in the kernel


class BatchedRobots:
    """``n_robots`` copies of one robot in one simulator, each with its own uniform field.

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

    Attributes
    ----------
    spec : RobotSpec
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
    ) -> None:
        if int(n_robots) != n_robots or n_robots < 1:
            raise ValueError(f"n_robots must be a positive integer, got {n_robots!r}")
        n_robots = int(n_robots)
        self.spec = spec
        self.n_robots = n_robots
        self.stepper = ea.PositionVerlet()
        self.step_count = 0
        self.robot_step_count = np.zeros(n_robots, dtype=np.int64)
        if max_speed is None:
            max_speed = 10.0 * spec.units.factor("velocity")
        self.max_speed = float(max_speed)
        self._fields = np.zeros((n_robots, 3), dtype=np.float64)
        if fields is not None:
            self.fields = fields  # type: ignore[assignment]

        simulator = BatchedRobotSimulator()
        rods = []
        for _ in range(n_robots):
            rod = robot_rod(spec)
            simulator.append(rod)
            rods.append(rod)
        simulator.add_forcing_to(rods[0]).using(_BlockForcing, owner=self)
        simulator.finalize()
        self.simulator = simulator
        self.rods = rods

        blocks = [s for s in simulator.final_systems() if isinstance(s, MemoryBlockCosseratRod)]
        if len(blocks) != 1 or blocks[0].n_rods != n_robots:
            raise RuntimeError("expected all robots in one PyElastica memory block")
        block = blocks[0]
        self.block = block
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

        # Magnetic moments V M in the material frame, (3, n_block_elements), A m^2: the same numpy
        # expression as MagneticTorques with frame="lab" (the rods start at rest, so the directors
        # of the initial configuration are those MagneticTorques sees at its first call).
        self._moments = np.zeros((3, block.n_elems))
        magnetization = np.asarray(spec.magnetization, dtype=np.float64)
        for i, rod in enumerate(rods):
            moment = np.einsum("ijk,jk->ik", rod.director_collection, magnetization)
            self._moments[:, self._elem_start[i] : self._elem_end[i]] = moment * rod.volume[None, :]

        params = np.zeros(_N_PARAMS)
        options = np.zeros(4, dtype=np.int64)
        if spec.damping is not None:
            options[_O_DAMPING] = 1
            options[_O_NODE_OFFSET] = spec.damping.node_offset
            if spec.damping.node_offset >= spec.n_elements + 1:
                raise ValueError(
                    f"node_offset {spec.damping.node_offset} must be smaller than the number of nodes "
                    f"({spec.n_elements + 1})"
                )
            params[_P_RELATIVE_NU] = spec.damping.relative_nu
            params[_P_LEGACY_FORCE] = spec.damping.legacy_force
            params[_P_LEGACY_TORQUE] = spec.damping.legacy_torque
        if spec.gravity > 0.0:
            options[_O_GRAVITY] = 1
            params[_P_GRAVITY : _P_GRAVITY + 3] = [0.0, -spec.effective_gravity, 0.0]
        if spec.ground is not None:
            g = spec.ground
            options[_O_GROUND] = 1
            params[_P_PLANE_ORIGIN : _P_PLANE_ORIGIN + 3] = [0.0, -spec.radius, 0.0]
            params[_P_PLANE_NORMAL : _P_PLANE_NORMAL + 3] = [0.0, 1.0, 0.0]
            params[_P_K] = g.k
            params[_P_NU] = g.nu
            params[_P_SURFACE_TOL] = g.surface_tolerance
            params[_P_SLIP_TOL] = g.slip_velocity_tol
            params[_P_STATIC_MU : _P_STATIC_MU + 3] = _mu3(g.static_mu)
            params[_P_KINETIC_MU : _P_KINETIC_MU + 3] = _mu3(g.kinetic_mu)
        self._params = params
        self._options = options
        self._scratch = np.zeros((_N_SCRATCH, spec.n_elements))
        self._kernel_args = (
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
        # Every array of every rod at the start, to reset a robot (state, rates, accelerations,
        # loads and the derived geometry: a reset robot is indistinguishable from a fresh one).
        self._initial_state = [
            {name: value.copy() for name, value in vars(rod).items() if isinstance(value, np.ndarray)}
            for rod in rods
        ]

    # ----------------------------------------------------------------------------------------------
    @property
    def fields(self) -> NDArray[np.float64]:
        """``(N, 3)`` field of each robot, T (lab frame). Write it in place between steps."""
        return self._fields

    @fields.setter
    def fields(self, value: ArrayLike) -> None:
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

        Raises :class:`BatchedSimulationDiverged` (a :class:`SimulationDiverged`) naming the robot,
        its time and the element if a node of some robot is NaN or faster than :attr:`max_speed`.
        """
        simulator, step, dt = self.simulator, self.stepper.step, self.spec.dt
        start = self.step_count
        for k in range(n_steps):
            # Time from the step counter, as in RobotSimulation (the kernel itself ignores time).
            step(simulator, (start + k) * dt, dt)
        self.step_count = start + n_steps
        self.robot_step_count += n_steps
        self.check_health()

    def check_health(self) -> None:
        """Raise :class:`BatchedSimulationDiverged` for the first robot with NaN or a runaway node."""
        block = self.block
        robot, node, is_nan, speed2, n_bad = _first_unhealthy(
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
        raise BatchedSimulationDiverged(
            f"robot {robot}: simulation diverged at t = {time:.6f} s: {what} at node {node} "
            f"(element {element}){others}; reduce dt (now {self.spec.dt:g}) or check the parameters",
            time=time,
            element=element,
            robot=robot,
        )

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


def _mu3(mu: float | ArrayLike) -> NDArray[np.float64]:
    """Friction coefficients as ``(forward, backward, sideways)``."""
    array = np.asarray(mu, dtype=np.float64)
    return np.full(3, float(array)) if array.ndim == 0 else array.reshape(3)


# --------------------------------------------------------------------------------------------------
# Kernels. They repeat, element by element, the floating-point operations of PyElastica's array code
# (``_calculate_contact_forces_rod_plane_with_anisotropic_friction`` and its helpers) and of the
# per-rod forcing kernels, in the same order, so the results are bit-identical. Do not "simplify"
# expressions such as ``0.0 + a * b``: they mirror accumulators that start from zero.


@njit(cache=True, error_model="numpy")
def _sign(x: float) -> float:
    """``np.sign``: 1, -1, 0, or NaN for NaN."""
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    if x == 0.0:
        return 0.0
    return x


@njit(cache=True, error_model="numpy")
def _minimum(a: float, b: float) -> float:
    """``np.minimum`` of two scalars (NaN propagates)."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a <= b else b


@njit(cache=True, error_model="numpy")
def _slip_function(v0: float, v1: float, v2: float, tolerance: float) -> float:
    """PyElastica's ``_find_slipping_elements`` for one element: 1 sticking, 0 slipping."""
    speed = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    if math.fabs(speed) > tolerance:
        return math.fabs(1.0 - _minimum(1.0, speed / tolerance - 1.0))
    return 1.0


@njit(cache=True, error_model="numpy")
def _block_forcing(
    fields: NDArray[np.float64],
    moments: NDArray[np.float64],
    node_start: NDArray[np.int64],
    node_end: NDArray[np.int64],
    elem_start: NDArray[np.int64],
    elem_end: NDArray[np.int64],
    options: NDArray[np.int64],
    params: NDArray[np.float64],
    mass: NDArray[np.float64],
    radius: NDArray[np.float64],
    lengths: NDArray[np.float64],
    tangents: NDArray[np.float64],
    positions: NDArray[np.float64],
    directors: NDArray[np.float64],
    velocities: NDArray[np.float64],
    omegas: NDArray[np.float64],
    internal_forces: NDArray[np.float64],
    external_forces: NDArray[np.float64],
    internal_torques: NDArray[np.float64],
    external_torques: NDArray[np.float64],
    scratch: NDArray[np.float64],
) -> None:
    """All forcing of all robots of a memory block, in the per-rod registration order.

    Shapes: ``fields (N, 3)`` T; ``moments (3, n_elems)`` A m^2 (material frame); index arrays
    ``(N,)`` (start inclusive, end exclusive, block indices, ghosts excluded); block arrays as in
    :class:`~elastica.memory_block.memory_block_rod.MemoryBlockCosseratRod` (``(n_nodes,)``,
    ``(3, n_nodes)``, ``(n_elems,)``, ``(3, n_elems)``, ``(3, 3, n_elems)``); ``scratch
    (_N_SCRATCH, n_elements_per_robot)``. Forces in N, torques in N m (material frame), added to
    ``external_forces`` and ``external_torques``.
    """
    offset = options[_O_NODE_OFFSET]
    for r in range(fields.shape[0]):
        ns = node_start[r]
        ne = node_end[r]
        es = elem_start[r]
        ee = elem_end[r]
        # Magnetic torques, m x (Q B) (MagneticTorques).
        bx = fields[r, 0]
        by = fields[r, 1]
        bz = fields[r, 2]
        for e in range(es, ee):
            b0 = directors[0, 0, e] * bx + directors[0, 1, e] * by
            b0 += directors[0, 2, e] * bz
            b1 = directors[1, 0, e] * bx + directors[1, 1, e] * by
            b1 += directors[1, 2, e] * bz
            b2 = directors[2, 0, e] * bx + directors[2, 1, e] * by
            b2 += directors[2, 2, e] * bz
            m0 = moments[0, e]
            m1 = moments[1, e]
            m2 = moments[2, e]
            external_torques[0, e] += m1 * b2 - m2 * b1
            external_torques[1, e] += m2 * b0 - m0 * b2
            external_torques[2, e] += m0 * b1 - m1 * b0
        if options[_O_DAMPING]:
            # RelativeVelocityDamping.
            nu = params[_P_RELATIVE_NU]
            for j in range(ne - ns - offset):
                c = nu * lengths[es + j]
                a = ns + j
                for d in range(3):
                    f = c * (velocities[d, a + offset] - velocities[d, a])
                    external_forces[d, a] += f
                    external_forces[d, a + offset] -= f
            # LegacyInternalDamping: forces, then torques.
            coefficient = params[_P_LEGACY_FORCE]
            for k in range(ee - es):
                c = 0.25 * coefficient * lengths[es + k]
                a = ns + k
                for d in range(3):
                    f = c * (velocities[d, a] + velocities[d, a + 1])
                    external_forces[d, a] -= f
                    external_forces[d, a + 1] -= f
            coefficient = params[_P_LEGACY_TORQUE]
            for e in range(es, ee):
                c = coefficient * lengths[e]
                for d in range(3):
                    external_torques[d, e] -= c * omegas[d, e]
        if options[_O_GRAVITY]:
            for d in range(3):
                g = params[_P_GRAVITY + d]
                for a in range(ns, ne):
                    external_forces[d, a] += g * mass[a]
        if options[_O_GROUND]:
            _ground_contact(
                ns,
                es,
                ee - es,
                params,
                mass,
                radius,
                tangents,
                positions,
                directors,
                velocities,
                omegas,
                internal_forces,
                external_forces,
                internal_torques,
                external_torques,
                scratch,
            )


@njit(cache=True, error_model="numpy")
def _ground_contact(
    ns: int,
    es: int,
    n: int,
    params: NDArray[np.float64],
    mass: NDArray[np.float64],
    radius: NDArray[np.float64],
    tangents: NDArray[np.float64],
    positions: NDArray[np.float64],
    directors: NDArray[np.float64],
    velocities: NDArray[np.float64],
    omegas: NDArray[np.float64],
    internal_forces: NDArray[np.float64],
    external_forces: NDArray[np.float64],
    internal_torques: NDArray[np.float64],
    external_torques: NDArray[np.float64],
    s: NDArray[np.float64],
) -> None:
    """Rod-plane contact with anisotropic Coulomb friction for one robot of the block.

    PyElastica's ``_calculate_contact_forces_rod_plane_with_anisotropic_friction`` restricted to
    nodes ``ns .. ns + n`` and elements ``es .. es + n - 1``; ``s`` is scratch ``(_N_SCRATCH, >= n)``.
    Elements farther than the surface tolerance from the plane are skipped: PyElastica computes
    their response and friction and then sets all of them to zero, so skipping them gives the same
    loads (up to the sign of zero).
    """
    o0 = params[_P_PLANE_ORIGIN]
    o1 = params[_P_PLANE_ORIGIN + 1]
    o2 = params[_P_PLANE_ORIGIN + 2]
    n0 = params[_P_PLANE_NORMAL]
    n1 = params[_P_PLANE_NORMAL + 1]
    n2 = params[_P_PLANE_NORMAL + 2]
    k_contact = params[_P_K]
    nu_contact = params[_P_NU]
    surface_tol = params[_P_SURFACE_TOL]
    slip_tol = params[_P_SLIP_TOL]
    static_forward = params[_P_STATIC_MU]
    static_backward = params[_P_STATIC_MU + 1]
    static_sideways = params[_P_STATIC_MU + 2]
    kinetic_forward = params[_P_KINETIC_MU]
    kinetic_backward = params[_P_KINETIC_MU + 1]
    kinetic_sideways = params[_P_KINETIC_MU + 2]
    last = n - 1

    # 1. Normal response (_calculate_contact_forces_rod_plane): computed for every element in
    # contact from the loads accumulated so far, then spread to the nodes.
    for k in range(n):
        a = ns + k
        e = es + k
        distance = 0.0 + n0 * (0.5 * (positions[0, a + 1] + positions[0, a]) - o0)
        distance += n1 * (0.5 * (positions[1, a + 1] + positions[1, a]) - o1)
        distance += n2 * (0.5 * (positions[2, a + 1] + positions[2, a]) - o2)
        gap = distance - radius[e]
        if gap > surface_tol:
            # Lifted off: PyElastica computes this element's loads and then zeroes them all.
            s[_S_NO_CONTACT, k] = 1.0
            continue
        s[_S_NO_CONTACT, k] = 0.0
        ef0 = 0.0 + 0.5 * (
            (internal_forces[0, a] + external_forces[0, a])
            + (internal_forces[0, a + 1] + external_forces[0, a + 1])
        )
        ef1 = 0.0 + 0.5 * (
            (internal_forces[1, a] + external_forces[1, a])
            + (internal_forces[1, a + 1] + external_forces[1, a + 1])
        )
        ef2 = 0.0 + 0.5 * (
            (internal_forces[2, a] + external_forces[2, a])
            + (internal_forces[2, a + 1] + external_forces[2, a + 1])
        )
        if k == 0:
            ef0 += 0.5 * (internal_forces[0, a] + external_forces[0, a])
            ef1 += 0.5 * (internal_forces[1, a] + external_forces[1, a])
            ef2 += 0.5 * (internal_forces[2, a] + external_forces[2, a])
        if k == last:
            ef0 += 0.5 * (internal_forces[0, a + 1] + external_forces[0, a + 1])
            ef1 += 0.5 * (internal_forces[1, a + 1] + external_forces[1, a + 1])
            ef2 += 0.5 * (internal_forces[2, a + 1] + external_forces[2, a + 1])
        f_normal = 0.0 + n0 * ef0
        f_normal += n1 * ef1
        f_normal += n2 * ef2
        if f_normal > 0.0:
            r0 = -0.0
            r1 = -0.0
            r2 = -0.0
        else:
            r0 = -(n0 * f_normal)
            r1 = -(n1 * f_normal)
            r2 = -(n2 * f_normal)
        penetration = _minimum(gap, 0.0)
        m_sum = mass[a + 1] + mass[a]
        v0 = (mass[a + 1] * velocities[0, a + 1] + mass[a] * velocities[0, a]) / m_sum
        v1 = (mass[a + 1] * velocities[1, a + 1] + mass[a] * velocities[1, a]) / m_sum
        v2 = (mass[a + 1] * velocities[2, a + 1] + mass[a] * velocities[2, a]) / m_sum
        v_normal = 0.0 + n0 * v0
        v_normal += n1 * v1
        v_normal += n2 * v2
        t0 = (r0 + -k_contact * (n0 * penetration)) + -nu_contact * (n0 * v_normal)
        t1 = (r1 + -k_contact * (n1 * penetration)) + -nu_contact * (n1 * v_normal)
        t2 = (r2 + -k_contact * (n2 * penetration)) + -nu_contact * (n2 * v_normal)
        s[_S_VELOCITY, k] = v0
        s[_S_VELOCITY + 1, k] = v1
        s[_S_VELOCITY + 2, k] = v2
        s[_S_RESPONSE, k] = t0
        s[_S_RESPONSE + 1, k] = t1
        s[_S_RESPONSE + 2, k] = t2
        s[_S_RESPONSE_MAG, k] = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
    for k in range(n):
        if s[_S_NO_CONTACT, k] != 0.0:
            continue
        a = ns + k
        for d in range(3):
            half = 0.5 * s[_S_RESPONSE + d, k]
            external_forces[d, a] += half
            external_forces[d, a + 1] += half

    # 2. Kinetic friction, axial then rolling (reads no loads: axial forces are spread in the loop).
    for k in range(n):
        if s[_S_NO_CONTACT, k] != 0.0:
            continue
        a = ns + k
        e = es + k
        tg0 = tangents[0, e]
        tg1 = tangents[1, e]
        tg2 = tangents[2, e]
        tg_normal = 0.0 + n0 * tg0
        tg_normal += n1 * tg1
        tg_normal += n2 * tg2
        p0 = tg0 - n0 * tg_normal
        p1 = tg1 - n1 * tg_normal
        p2 = tg2 - n2 * tg_normal
        inv = 1 / (math.sqrt(p0 * p0 + p1 * p1 + p2 * p2) + 1e-14)
        ax0 = inv * p0
        ax1 = inv * p1
        ax2 = inv * p2
        v0 = s[_S_VELOCITY, k]
        v1 = s[_S_VELOCITY + 1, k]
        v2 = s[_S_VELOCITY + 2, k]
        v_axial = 0.0 + v0 * ax0
        v_axial += v1 * ax1
        v_axial += v2 * ax2
        va0 = v_axial * ax0
        va1 = v_axial * ax1
        va2 = v_axial * ax2
        sign = _sign(v_axial)
        kinetic_mu = 0.5 * (kinetic_forward * (1 + sign) + kinetic_backward * (1 - sign))
        slip_axial = _slip_function(va0, va1, va2, slip_tol)
        ro0 = ax1 * n2 - ax2 * n1
        ro1 = ax2 * n0 - ax0 * n2
        ro2 = ax0 * n1 - ax1 * n0
        arm0 = -n0 * radius[e]
        arm1 = -n1 * radius[e]
        arm2 = -n2 * radius[e]
        v_rolling = 0.0 + v0 * ro0
        v_rolling += v1 * ro1
        v_rolling += v2 * ro2
        # Q^T (omega x (Q arm))
        q0 = 0.0 + directors[0, 0, e] * arm0
        q0 += directors[0, 1, e] * arm1
        q0 += directors[0, 2, e] * arm2
        q1 = 0.0 + directors[1, 0, e] * arm0
        q1 += directors[1, 1, e] * arm1
        q1 += directors[1, 2, e] * arm2
        q2 = 0.0 + directors[2, 0, e] * arm0
        q2 += directors[2, 1, e] * arm1
        q2 += directors[2, 2, e] * arm2
        w0 = omegas[0, e]
        w1 = omegas[1, e]
        w2 = omegas[2, e]
        c0 = w1 * q2 - w2 * q1
        c1 = w2 * q0 - w0 * q2
        c2 = w0 * q1 - w1 * q0
        rv0 = 0.0 + directors[0, 0, e] * c0
        rv0 += directors[1, 0, e] * c1
        rv0 += directors[2, 0, e] * c2
        rv1 = 0.0 + directors[0, 1, e] * c0
        rv1 += directors[1, 1, e] * c1
        rv1 += directors[2, 1, e] * c2
        rv2 = 0.0 + directors[0, 2, e] * c0
        rv2 += directors[1, 2, e] * c1
        rv2 += directors[2, 2, e] * c2
        rv_rolling = 0.0 + rv0 * ro0
        rv_rolling += rv1 * ro1
        rv_rolling += rv2 * ro2
        slip_speed = v_rolling + rv_rolling
        sr0 = slip_speed * ro0
        sr1 = slip_speed * ro1
        sr2 = slip_speed * ro2
        slip_rolling = _slip_function(sr0, sr1, sr2, slip_tol)
        u0 = sr0 + va0
        u1 = sr1 + va1
        u2 = sr2 + va2
        d0 = u0 + 1e-14
        d1 = u1 + 1e-14
        d2 = u2 + 1e-14
        u_norm = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        u0 = u0 / u_norm
        u1 = u1 / u_norm
        u2 = u2 / u_norm
        magnitude = s[_S_RESPONSE_MAG, k]
        u_axial = 0.0 + u0 * ax0
        u_axial += u1 * ax1
        u_axial += u2 * ax2
        scale = (1.0 - slip_axial) * kinetic_mu * magnitude * u_axial
        fa0 = -(scale * ax0)
        fa1 = -(scale * ax1)
        fa2 = -(scale * ax2)
        u_rolling = 0.0 + u0 * ro0
        u_rolling += u1 * ro1
        u_rolling += u2 * ro2
        scale = (1.0 - slip_rolling) * kinetic_sideways * magnitude * u_rolling
        fr0 = -(scale * ro0)
        fr1 = -(scale * ro1)
        fr2 = -(scale * ro2)
        half = 0.5 * fa0
        external_forces[0, a] += half
        external_forces[0, a + 1] += half
        half = 0.5 * fa1
        external_forces[1, a] += half
        external_forces[1, a + 1] += half
        half = 0.5 * fa2
        external_forces[2, a] += half
        external_forces[2, a + 1] += half
        s[_S_AXIAL, k] = ax0
        s[_S_AXIAL + 1, k] = ax1
        s[_S_AXIAL + 2, k] = ax2
        s[_S_ROLLING, k] = ro0
        s[_S_ROLLING + 1, k] = ro1
        s[_S_ROLLING + 2, k] = ro2
        s[_S_SLIP_AXIAL, k] = slip_axial
        s[_S_SLIP_ROLLING, k] = slip_rolling
        s[_S_ARM, k] = arm0
        s[_S_ARM + 1, k] = arm1
        s[_S_ARM + 2, k] = arm2
        s[_S_FRICTION, k] = fr0
        s[_S_FRICTION + 1, k] = fr1
        s[_S_FRICTION + 2, k] = fr2
    for k in range(n):
        if s[_S_NO_CONTACT, k] != 0.0:
            continue
        a = ns + k
        for d in range(3):
            half = 0.5 * s[_S_FRICTION + d, k]
            external_forces[d, a] += half
            external_forces[d, a + 1] += half
    for k in range(n):
        if s[_S_NO_CONTACT, k] != 0.0:
            continue
        # external_torques += Q (arm x f_rolling)
        e = es + k
        _add_arm_torque(directors, external_torques, e, s, k, _S_FRICTION)

    # 3. Static axial friction, from the loads after the kinetic friction.
    for k in range(n):
        if s[_S_NO_CONTACT, k] != 0.0:
            continue
        a = ns + k
        ef0 = 0.0 + 0.5 * (
            (internal_forces[0, a] + external_forces[0, a])
            + (internal_forces[0, a + 1] + external_forces[0, a + 1])
        )
        ef1 = 0.0 + 0.5 * (
            (internal_forces[1, a] + external_forces[1, a])
            + (internal_forces[1, a + 1] + external_forces[1, a + 1])
        )
        ef2 = 0.0 + 0.5 * (
            (internal_forces[2, a] + external_forces[2, a])
            + (internal_forces[2, a + 1] + external_forces[2, a + 1])
        )
        if k == 0:
            ef0 += 0.5 * (internal_forces[0, a] + external_forces[0, a])
            ef1 += 0.5 * (internal_forces[1, a] + external_forces[1, a])
            ef2 += 0.5 * (internal_forces[2, a] + external_forces[2, a])
        if k == last:
            ef0 += 0.5 * (internal_forces[0, a + 1] + external_forces[0, a + 1])
            ef1 += 0.5 * (internal_forces[1, a + 1] + external_forces[1, a + 1])
            ef2 += 0.5 * (internal_forces[2, a + 1] + external_forces[2, a + 1])
        ax0 = s[_S_AXIAL, k]
        ax1 = s[_S_AXIAL + 1, k]
        ax2 = s[_S_AXIAL + 2, k]
        f_axial = 0.0 + ef0 * ax0
        f_axial += ef1 * ax1
        f_axial += ef2 * ax2
        sign = _sign(f_axial)
        static_mu = 0.5 * (static_forward * (1 + sign) + static_backward * (1 - sign))
        max_friction = s[_S_SLIP_AXIAL, k] * static_mu * s[_S_RESPONSE_MAG, k]
        scale = _minimum(math.fabs(f_axial), max_friction) * sign
        s[_S_FRICTION, k] = -(scale * ax0)
        s[_S_FRICTION + 1, k] = -(scale * ax1)
        s[_S_FRICTION + 2, k] = -(scale * ax2)
        s[_S_ELEMENT_FORCE, k] = ef0
        s[_S_ELEMENT_FORCE + 1, k] = ef1
        s[_S_ELEMENT_FORCE + 2, k] = ef2
    for k in range(n):
        if s[_S_NO_CONTACT, k] != 0.0:
            continue
        a = ns + k
        for d in range(3):
            half = 0.5 * s[_S_FRICTION + d, k]
            external_forces[d, a] += half
            external_forces[d, a + 1] += half

    # 4. Static rolling friction (reads element loads computed before the static axial friction and
    # the torques of its own element only, so it can be spread to the nodes in the loop).
    for k in range(n):
        if s[_S_NO_CONTACT, k] != 0.0:
            continue
        a = ns + k
        e = es + k
        tw0 = internal_torques[0, e] + external_torques[0, e]
        tw1 = internal_torques[1, e] + external_torques[1, e]
        tw2 = internal_torques[2, e] + external_torques[2, e]
        tt0 = 0.0 + directors[0, 0, e] * tw0
        tt0 += directors[1, 0, e] * tw1
        tt0 += directors[2, 0, e] * tw2
        tt1 = 0.0 + directors[0, 1, e] * tw0
        tt1 += directors[1, 1, e] * tw1
        tt1 += directors[2, 1, e] * tw2
        tt2 = 0.0 + directors[0, 2, e] * tw0
        tt2 += directors[1, 2, e] * tw1
        tt2 += directors[2, 2, e] * tw2
        tt_axial = 0.0 + tt0 * s[_S_AXIAL, k]
        tt_axial += tt1 * s[_S_AXIAL + 1, k]
        tt_axial += tt2 * s[_S_AXIAL + 2, k]
        ro0 = s[_S_ROLLING, k]
        ro1 = s[_S_ROLLING + 1, k]
        ro2 = s[_S_ROLLING + 2, k]
        f_rolling = 0.0 + s[_S_ELEMENT_FORCE, k] * ro0
        f_rolling += s[_S_ELEMENT_FORCE + 1, k] * ro1
        f_rolling += s[_S_ELEMENT_FORCE + 2, k] * ro2
        r = radius[e]
        noslip = -((r * f_rolling - 2.0 * tt_axial) / 3.0 / r)
        max_friction = s[_S_SLIP_ROLLING, k] * static_sideways * s[_S_RESPONSE_MAG, k]
        scale = _minimum(math.fabs(noslip), max_friction) * _sign(noslip)
        f0 = scale * ro0
        f1 = scale * ro1
        f2 = scale * ro2
        half = 0.5 * f0
        external_forces[0, a] += half
        external_forces[0, a + 1] += half
        half = 0.5 * f1
        external_forces[1, a] += half
        external_forces[1, a + 1] += half
        half = 0.5 * f2
        external_forces[2, a] += half
        external_forces[2, a + 1] += half
        s[_S_FRICTION, k] = f0
        s[_S_FRICTION + 1, k] = f1
        s[_S_FRICTION + 2, k] = f2
        _add_arm_torque(directors, external_torques, e, s, k, _S_FRICTION)


@njit(cache=True, error_model="numpy")
def _add_arm_torque(
    directors: NDArray[np.float64],
    external_torques: NDArray[np.float64],
    e: int,
    s: NDArray[np.float64],
    k: int,
    row: int,
) -> None:
    """``external_torques[:, e] += Q_e (arm_k x f_k)`` with ``f`` in scratch rows ``row .. row + 2``."""
    arm0 = s[_S_ARM, k]
    arm1 = s[_S_ARM + 1, k]
    arm2 = s[_S_ARM + 2, k]
    f0 = s[row, k]
    f1 = s[row + 1, k]
    f2 = s[row + 2, k]
    c0 = arm1 * f2 - arm2 * f1
    c1 = arm2 * f0 - arm0 * f2
    c2 = arm0 * f1 - arm1 * f0
    for i in range(3):
        t = 0.0 + directors[i, 0, e] * c0
        t += directors[i, 1, e] * c1
        t += directors[i, 2, e] * c2
        external_torques[i, e] += t


@njit(cache=True, error_model="numpy")
def _first_unhealthy(
    positions: NDArray[np.float64],
    velocities: NDArray[np.float64],
    node_start: NDArray[np.int64],
    node_end: NDArray[np.int64],
    limit2: float,
) -> tuple[int, int, bool, float, int]:
    """First robot with a non-finite position or a node speed^2 above ``limit2`` (m^2/s^2).

    Returns ``(robot, node, is_nan, speed2, n_bad_robots)`` with ``robot = -1`` if all are
    healthy; ``node`` is the robot's own node index. Ghost nodes are not checked.
    """
    first_robot = -1
    first_node = -1
    first_nan = False
    first_speed2 = 0.0
    n_bad = 0
    for r in range(node_start.shape[0]):
        for a in range(node_start[r], node_end[r]):
            speed2 = (
                velocities[0, a] * velocities[0, a]
                + velocities[1, a] * velocities[1, a]
                + velocities[2, a] * velocities[2, a]
            )
            finite = (
                math.isfinite(positions[0, a])
                and math.isfinite(positions[1, a])
                and math.isfinite(positions[2, a])
            )
            if not (speed2 <= limit2) or not finite:
                if first_robot < 0:
                    first_robot = r
                    first_node = a - node_start[r]
                    first_nan = not (finite and math.isfinite(speed2))
                    first_speed2 = speed2
                n_bad += 1
                break
    return first_robot, first_node, first_nan, first_speed2, n_bad
