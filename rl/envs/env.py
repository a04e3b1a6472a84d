"""Gymnasium environment of the crawling magnetic robot of Yao et al. 2023 (``MagneticCrawler-v0``).

The agent changes a uniform field in the x-y plane by small increments at 100 Hz; the reward is the
forward (+x) displacement of the robot's middle node. Everything is SI inside; the observation is
scaled so that the network sees the same numbers as the authors' network did in their mm units.

Geometry and conventions
------------------------
The robot (64 elements, 65 nodes) starts straight along +x from the origin, centreline at ``y = 0``
resting on the ground plane ``y = -r`` (``r`` the equivalent rod radius); gravity acts along -y and
the robot bends in the x-y plane. Angles are counter-clockwise positive seen from +z.

Observation: :mod:`~elastica_magnetic_rl.envs.crawler_observation` (float32, ``(260,)`` for the
paper's 64 elements: the rod's bending, orientation, height, contact and the field).

Action: ``Box([-1, 1]^2)`` float32, mapped to a field increment ``(dB_x, dB_y) = 0.3 mT * a``; the
new field is clipped per component and by amplitude to the field limit (4 or 10 mT) by
:class:`~elastica_magnetic.ControlledField`, then held for the 0.01 s of the step.

Three-axis actuation (a case with ``[actuation] axes = "xyz"``: the third coil pair, z across the
robot in the floor plane): the action is ``Box([-1, 1]^3)``, ``(dB_x, dB_y, dB_z)`` with the
case's increment and limit per axis, and the observation gains one block after ``field_angle``:
``field_z`` = ``200 * B_z`` (T, signed; the amplitude and angle blocks keep describing the x-y
part, so a planar policy's inputs mean the same). Planar cases are unchanged.

Reward: ``1e4 * dx`` with ``dx`` (m) the x displacement of node 32 (the middle node, as the
authors) during the step: the authors' ``10 x displacement in mm``.

Episode end: the time limit (default 20 s = 2000 steps) is a **truncation** (the task is
continuing; bootstrap through it). Only a numerical blow-up terminates: ``terminated=True`` with
the reward :attr:`MagneticCrawlerEnv.divergence_penalty` (default -10) and the last finite
observation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from elastica_magnetic import (
    ControlledField,
    RobotSpec,
    SimulationDivergedError,
    yao2023_robot,
)
from elastica_magnetic.robot_spec import ACTION_PERIOD
from elastica_magnetic.uniform_simulation import uniform_field_simulation

from ..cases.case import Case, load_case
from ..cases.field_actuation import ACTUATION_OBSERVATION
from ..cases.tasks import CrawlTask, GotoTask, Task
from .crawler_observation import (  # re-exported: their documented home before the split
    OBSERVATION_LAYOUT,
    OBSERVATION_SCALES,
    crawler_observation,
    crawler_observation_space,
    observation_layout,
    observation_spec,
)

__all__ = [
    "CrawlerSetup",
    "MagneticCrawlerEnv",
    "OBSERVATION_LAYOUT",
    "OBSERVATION_SCALES",
    "MAX_FIELD_INCREMENT",
    "crawler_observation",
    "crawler_observation_space",
    "crawler_setup",
    "initial_field_value",
    "observation_layout",
    "observation_spec",
]

#: Largest change of a field component per step, T (the paper's 0.3 mT).
MAX_FIELD_INCREMENT = 0.3e-3

def initial_field_value(
    initial: str | Any, field_limit: float | Any, rng: np.random.Generator, axes: str = "xy"
) -> Any:
    """Initial field of an episode, T: ``(3,)`` tuple or array (clipped later by the field rule).

    ``"random"``: each controlled component (``axes``) uniform in ``+-0.7 *`` its limit
    (``field_limit``: T, one for every axis or one per lab axis ``(3,)``; one draw of
    ``len(axes)`` values from ``rng``), the others 0 (the paper's: B_x, B_y, then B_z = 0);
    ``"zero"``; or a 2- or 3-vector in T (a 2-vector gets B_z = 0).
    """
    if isinstance(initial, str):
        if initial == "random":
            limits = np.broadcast_to(np.asarray(field_limit, dtype=np.float64), (3,))
            bound = 0.7 * (limits[0] if np.all(limits == limits[0]) else limits[: len(axes)])
            drawn = rng.uniform(-bound, bound, size=len(axes))
            return (drawn[0], drawn[1], drawn[2] if len(axes) == 3 else 0.0)
        if initial == "zero":
            return (0.0, 0.0, 0.0)
        raise ValueError(f"initial_field must be 'random', 'zero' or a vector, got {initial!r}")
    initial = np.asarray(initial, dtype=np.float64).reshape(-1)
    if initial.shape == (2,):
        initial = np.append(initial, 0.0)
    return initial


@dataclass(frozen=True)
class CrawlerSetup:
    """Everything an environment needs, checked: the robot (in the chosen physics), the field
    limit (T) and increment per unit action (T), the initial field of episodes, the episode length
    (s and 0.01 s steps), the task and the case it comes from (``None`` for a bare robot)."""

    robot_spec: RobotSpec
    field_limit: float
    max_increment: float
    initial_field: str
    duration: float
    n_steps: int
    task: Task
    case: Case | None
    axes: str = "xy"
    limits: tuple[float, float, float] | None = None
    increments: tuple[float, float, float] | None = None

    @property
    def field_limits(self) -> NDArray[np.float64]:
        """The limit of each lab axis (x, y, z), T (the amplitude limit on each when not given)."""
        return np.array(self.limits or (self.field_limit,) * 3, dtype=np.float64)

    @property
    def field_increments(self) -> NDArray[np.float64]:
        """The largest increment of each controlled axis per unit action, ``(len(axes),)`` T."""
        return np.array(self.increments or (self.max_increment,) * 3,
                        dtype=np.float64)[: len(self.axes)]


def crawler_setup(
    case: str | Case | None = None,
    *,
    pattern: int | None = None,
    field_limit: float | None = None,
    physics: str = "training",
    initial_field: str | None = None,
    duration: float | None = None,
    spec: RobotSpec | None = None,
    max_increment: float | None = None,
    task: Task | None = None,
) -> CrawlerSetup:
    """Check an environment's arguments (shared by the single and the vector environment).

    With ``case`` (a shipped name, a spec file path or a :class:`~elastica_magnetic_rl.cases.case.Case`),
    the robot, field limit, increment, task, initial field and episode length come from it;
    ``initial_field`` and ``duration`` may still be given (evaluations: zero field, 10 s), the
    others may not. Without it: the paper's robot of ``pattern`` (default 1) or ``spec``, field
    limit (default 4e-3 T), the crawl task, random initial fields, 20 s episodes.
    """
    if physics not in ("training", "accurate"):
        raise ValueError(f"physics must be 'training' or 'accurate', got {physics!r}")
    loaded = None
    if case is not None:
        given = {k: v for k, v in (("pattern", pattern), ("field_limit", field_limit), ("spec", spec),
                                   ("max_increment", max_increment), ("task", task)) if v is not None}
        if given:
            raise ValueError(f"give either case or {', '.join(given)}, not both")
        loaded = load_case(case)
        spec = loaded.robot_spec(physics)  # type: ignore[arg-type]
        field_limit, max_increment, task = (loaded.field_limit, loaded.actuation.max_increment,
                                            loaded.task)
        initial_field = loaded.actuation.initial_field if initial_field is None else initial_field
        duration = loaded.task.episode_duration if duration is None else duration
    else:
        if spec is None:
            pattern = 1 if pattern is None else pattern
            if pattern not in (1, 2):
                raise ValueError(f"pattern must be 1 or 2, got {pattern!r}")
            spec = yao2023_robot(int(pattern), physics)  # type: ignore[arg-type]
        field_limit = 4e-3 if field_limit is None else field_limit
        max_increment = MAX_FIELD_INCREMENT if max_increment is None else max_increment
        task = CrawlTask() if task is None else task
        initial_field = "random" if initial_field is None else initial_field
        duration = 20.0 if duration is None else duration
    if spec.ground is None:
        raise ValueError("the crawler environment needs a robot spec with a ground")
    if not (field_limit > 0.0 and math.isfinite(field_limit)):
        raise ValueError(f"field_limit must be a positive field in T, got {field_limit}")
    if not (max_increment > 0.0 and math.isfinite(max_increment)):
        raise ValueError(f"max_increment must be a positive field in T, got {max_increment}")
    if initial_field not in ("random", "zero"):
        raise ValueError(f"initial_field must be 'random' or 'zero', got {initial_field!r}")
    n_steps = int(round(duration / ACTION_PERIOD))
    if n_steps < 1:
        raise ValueError(f"duration must be at least one 0.01 s step, got {duration} s")
    if loaded is None:
        return CrawlerSetup(spec, float(field_limit), float(max_increment), initial_field,
                            float(duration), n_steps, task, loaded)
    actuation = loaded.actuation
    return CrawlerSetup(spec, float(field_limit), float(max_increment), initial_field,
                        float(duration), n_steps, task, loaded, actuation.axes, actuation.limits,
                        actuation.increments)


def adopt_setup(env: Any, setup: CrawlerSetup, physics: str,
                divergence_penalty: float) -> gym.spaces.Box:
    """The attributes the single and the vector environment both take from their checked
    ``setup`` (robot, physics, field limit and increment in T, initial field, episode length in s
    and steps, task, the observation layout); returns the observation space of one robot."""
    env.setup = setup
    env.case = setup.case
    env.task = setup.task
    # heading episodes: the target moves after every step (GotoTask.follow)
    env.moving_target = isinstance(setup.task, GotoTask) and setup.task.moves_target
    env.robot_spec = spec = setup.robot_spec
    env.physics = physics
    env.field_limit = setup.field_limit
    env.initial_field = setup.initial_field
    env.duration = setup.duration
    env.max_episode_steps = setup.n_steps
    env.max_increment = setup.max_increment
    env.axes = setup.axes
    env.field_limits = setup.field_limits
    env.field_increments = setup.field_increments
    env.divergence_penalty = float(divergence_penalty)
    n = spec.n_elements
    env.n_elements = n
    env.middle_node = n // 2
    extra = (*ACTUATION_OBSERVATION[setup.axes], *env.task.extra_observation)
    env.layout = observation_layout(n, extra)
    env.surface_tolerance = float(spec.ground.surface_tolerance)
    return crawler_observation_space(n, env.field_limit, extra, float(env.field_limits[2]))


def new_field(env: Any, initial: Any) -> ControlledField:
    """The field of a new episode of ``env`` (after :func:`adopt_setup`) starting at ``initial``
    (T), with the case's limits and increments per axis."""
    return ControlledField(env.field_limits, env.setup.increments or env.max_increment, initial)


def action_space(setup: CrawlerSetup) -> gym.spaces.Box:
    """The action of one robot: ``Box([-1, 1]^k)`` float32, one normalised field increment per
    controlled axis (``k = 2``: dB_x, dB_y; ``3``: dB_x, dB_y, dB_z)."""
    return gym.spaces.Box(-1.0, 1.0, shape=(len(setup.axes),), dtype=np.float32)


class MagneticCrawlerEnv(gym.Env):
    """The crawling robot driven by field increments (see the module docstring for the spaces).

    Parameters
    ----------
    case : str, os.PathLike or Case, optional
        A shipped case name (``"m1-4mT"``), a spec file or a
        :class:`~elastica_magnetic_rl.cases.case.Case`: robot, field limit, increment, task, initial
        field and episode length from it (``gym.make("MagneticCrawler-v0", case="m1-4mT")``).
        Then ``pattern``, ``field_limit``, ``spec``, ``max_increment`` and ``task`` are not given.
    pattern : int
        Magnetization pattern of the paper's robot, 1 (along -x / +x, default) or 2 (along -y / +y).
    field_limit : float
        Largest field component and amplitude, T (default 4e-3; the paper: 4e-3 or 10e-3).
    physics : {"training", "accurate"}
        ``"training"``: mass-scaled, dt = 1e-4 s (100 substeps per step); ``"accurate"``: true
        density, dt = 8e-6 s (1250 substeps per step, ~12.5x the cost) (the case's time steps).
    initial_field : {"random", "zero"}
        Field at reset: each of B_x, B_y uniform in ``+-0.7 * field_limit`` then clipped (the
        authors' training setting, the default), or zero (the coils start from zero current: for
        generating fields). ``reset(options={"initial_field": ...})`` overrides it for one episode;
        there it may also be a 2- or 3-vector in T.
    duration : float
        Episode length, s (100 steps per s; default 20 or the case's); reaching it **truncates**.
    render_mode : None or "rgb_array"
    spec : RobotSpec, optional
        A robot/physics to use instead of ``yao2023_robot(pattern, physics)`` (custom robots,
        tests). Must have a ground.
    max_increment : float
        Field increment per unit action, T (default 0.3e-3).
    task : CrawlTask or ReachTask, optional
        The reward and success rule (default: crawl, the paper's).
    divergence_penalty : float
        Reward of the step on which the simulation blows up (then ``terminated=True``).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 100}

    def __init__(
        self,
        pattern: int | None = None,
        field_limit: float | None = None,
        physics: Literal["training", "accurate"] = "training",
        initial_field: Literal["random", "zero"] | None = None,
        duration: float | None = None,
        render_mode: str | None = None,
        spec: RobotSpec | None = None,
        max_increment: float | None = None,
        divergence_penalty: float = -10.0,
        case: str | Case | None = None,
        task: Task | None = None,
    ) -> None:
        setup = crawler_setup(case, pattern=pattern, field_limit=field_limit, physics=physics,
                              initial_field=initial_field, duration=duration, spec=spec,
                              max_increment=max_increment, task=task)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.observation_space = adopt_setup(self, setup, physics, divergence_penalty)
        spec = setup.robot_spec
        self.pattern = None if pattern is None and (case is not None or spec is not None) else (
            1 if pattern is None else int(pattern))
        self.render_mode = render_mode
        self.action_space = action_space(setup)

        self.simulation = None
        self.field: ControlledField | None = None
        self.steps = 0
        self.task_state: NDArray[np.float64] | None = None
        self._start_pose: NDArray[np.float64] | None = None
        self._last_obs: NDArray[np.float32] | None = None
        self._diverged = False
        self._renderer: _SideViewRenderer | None = None

    # -- observation ------------------------------------------------------------------------------
    def observation(self) -> NDArray[np.float32]:
        """The observation of the current state (see the module docstring), float32
        ``(4n+4+k,)`` (``k`` the task's extra entries)."""
        extra = None
        if self.task.extra_observation:
            extra = self.task.observe(self._task_position(), self.task_state, self.steps * ACTION_PERIOD)
        return crawler_observation(self.simulation.rod, self.field.value, self.layout,
                                   self.surface_tolerance, extra)

    def _task_position(self) -> Any:
        """What the task reads of the rod (the middle's x; the floor pose for the goto task)."""
        return self.task.position(self.simulation.rod, self.middle_node)

    def _mid_x(self) -> float:
        return float(self.simulation.rod.position_collection[0, self.middle_node])

    def contact_strength(self) -> NDArray[np.float64]:
        """Per-node contact indicator (the observation's ``contact`` block, float64 ``(n+1,)``)."""
        y = self.simulation.rod.position_collection[1]
        sc = OBSERVATION_SCALES
        return np.where(y <= self.surface_tolerance,
                        sc["contact_base"] + sc["contact_penetration"] * np.maximum(-y, 0.0), 0.0)

    @property
    def time(self) -> float:
        """Simulated time of the episode, s."""
        return self.steps * ACTION_PERIOD

    def _info(self) -> dict[str, Any]:
        return {
            "time_s": self.time,
            "field_T": self.field.value.copy(),
            "mid_x_m": self._mid_x(),
            "diverged": self._diverged,
        }

    def retarget(self, target: Any) -> NDArray[np.float32]:
        """Move a goto episode's target to ``target`` (forward, left; m in the episode's *start*
        frame, as ``reset(options={"target": ...})``), mid-episode: the next waypoint of a path.
        Returns the observation with the new target (what the policy acts on next), float32."""
        if not isinstance(self.task, GotoTask):
            raise ValueError(f"retarget() moves a goto task's target; this environment's task is "
                             f"{self.task.kind}")
        if self.simulation is None:
            raise RuntimeError("call reset() before retarget()")
        self.task_state = self.task.start(self._start_pose, target=target)
        self._last_obs = self.observation()
        return self._last_obs.copy()

    @property
    def start_pose(self) -> Any:
        """What the task read of the rod at the episode's start (a goto task's floor pose
        ``(x, z, heading)``: m, m, rad); ``None`` before the first reset."""
        return self._start_pose

    # -- Gymnasium API ------------------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        """Rebuild the straight robot at rest and set the initial field (random or zero).

        ``options``: ``{"initial_field": "random" | "zero" | (Bx, By[, Bz]) in T, "target":
        (forward, left) in m}`` (``target``: the goto task's target in the start frame, instead of
        a drawn one).
        """
        super().reset(seed=seed)
        initial = initial_field_value((options or {}).get("initial_field", self.initial_field),
                                      self.field_limits, self.np_random, self.axes)
        self.field = new_field(self, initial)
        # the field is held over each step's 0.01 s: the batched kernel where it models the spec
        self.simulation = uniform_field_simulation(self.robot_spec, self.field)
        self.steps = 0
        self._diverged = False
        self._start_pose = self._task_position()
        self.task_state = self.task.start(self._start_pose, self.np_random,
                                          (options or {}).get("target"))
        self._last_obs = self.observation()
        return self._last_obs.copy(), self._info()

    def step(
        self, action: NDArray[np.float32]
    ) -> tuple[NDArray[np.float32], float, bool, bool, dict[str, Any]]:
        """Apply the field increment ``0.3 mT * action`` (the case's increment per axis) and
        simulate 0.01 s."""
        if self.simulation is None:
            raise RuntimeError("call reset() before step()")
        if self._diverged:
            raise RuntimeError("the simulation diverged (terminated=True): call reset()")
        a = np.asarray(action, dtype=np.float64)
        k = len(self.axes)
        if a.size != k:
            raise ValueError(f"action must have {k} components (normalised "
                             f"{', '.join('dB_' + axis for axis in self.axes)}), got shape {a.shape}")
        a = np.clip(a.reshape(k), -1.0, 1.0)
        if not np.all(np.isfinite(a)):
            raise ValueError(f"action must be finite, got {action!r}")
        self.field.apply_increment(a * self.field_increments)
        before = self._task_position()
        terminated = False
        self.steps += 1  # before the observation: its clock reads the time the step ends at
        try:
            self.simulation.step(self.robot_spec.steps_per_action)
            obs = self.observation()
            if not np.all(np.isfinite(obs)):
                raise SimulationDivergedError("non-finite observation", self.simulation.time, -1)
            after = self._task_position()
            reward = float(self.task.reward(before, after, self.task_state))
            if self.moving_target:  # the next target, which the policy sees next
                self.task_state = self.task.follow(self.task_state, after)
                obs = self.observation()
            self._last_obs = obs
        except SimulationDivergedError as exc:
            terminated = True
            self._diverged = True
            obs = self._last_obs
            reward = self.divergence_penalty
            info_extra = {"divergence": str(exc)}
        else:
            info_extra = {}
        truncated = (not terminated) and self.steps >= self.max_episode_steps
        info = self._info()
        info.update(info_extra)
        return obs.copy(), float(reward), terminated, truncated, info

    def render(self) -> NDArray[np.uint8] | None:
        """``rgb_array``: side view of the rod (mm), the ground line and an arrow for the field."""
        if self.render_mode is None:
            gym.logger.warn("render() called without render_mode; use render_mode='rgb_array'")
            return None
        if self.simulation is None:
            raise RuntimeError("call reset() before render()")
        if self._renderer is None:
            self._renderer = _SideViewRenderer(self.robot_spec, self.field_limit)
        return self._renderer.draw(
            self.simulation.rod.position_collection, self.field.value, self.time
        )

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


class _SideViewRenderer:
    """Draws the rod from the side with matplotlib (Agg) into an RGB array; the figure is reused."""

    def __init__(self, spec: RobotSpec, field_limit: float, size_px: tuple[int, int] = (480, 240)):
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        dpi = 80
        self.fig = Figure(figsize=(size_px[0] / dpi, size_px[1] / dpi), dpi=dpi)
        self.canvas = FigureCanvasAgg(self.fig)
        self.ax = self.fig.add_axes((0.08, 0.15, 0.9, 0.8))
        self.length_mm = 1e3 * spec.length
        self.ground_mm = -1e3 * spec.radius
        self.field_limit = field_limit
        (self.rod_line,) = self.ax.plot([], [], "-", color="C0", lw=3, solid_capstyle="round")
        (self.ground_line,) = self.ax.plot([], [], "-", color="0.4", lw=1.5)
        self.arrow = None
        self.text = self.ax.text(0.01, 0.95, "", transform=self.ax.transAxes, va="top", fontsize=8)
        self.ax.set_aspect("equal")
        self.ax.set_xlabel("x (mm)", fontsize=8)
        self.ax.tick_params(labelsize=7)

    def draw(self, positions: NDArray[np.float64], field: NDArray[np.float64], time: float):
        x, y = 1e3 * positions[0], 1e3 * positions[1]
        centre = float(x.mean())
        half = 0.8 * self.length_mm
        self.ax.set_xlim(centre - half, centre + half)
        self.ax.set_ylim(self.ground_mm - 2.0, self.ground_mm - 2.0 + half)
        self.rod_line.set_data(x, y)
        self.ground_line.set_data([centre - 2 * half, centre + 2 * half], [self.ground_mm] * 2)
        if self.arrow is not None:
            self.arrow.remove()
        scale = 0.25 * half / self.field_limit  # full field = a quarter of the view width
        ox, oy = centre + 0.7 * half, self.ground_mm + 0.5 * half
        self.arrow = self.ax.annotate(
            "", xy=(ox + scale * field[0], oy + scale * field[1]), xytext=(ox, oy),
            arrowprops={"arrowstyle": "->", "color": "C3", "lw": 2},
        )
        self.text.set_text(f"t = {time:.2f} s   |B| = {1e3 * math.hypot(field[0], field[1]):.2f} mT")
        self.canvas.draw()
        rgba = np.asarray(self.canvas.buffer_rgba())
        return np.ascontiguousarray(rgba[..., :3])

    def close(self) -> None:
        self.fig.clear()


def make_env(
    case: str | Path | Case,
    physics: str = "training",
    initial_field: str | None = "random",
    duration: float | None = 20.0,
    render_mode: str | None = None,
) -> MagneticCrawlerEnv:
    """The environment of a case (a shipped name, a spec file or a
    :class:`~elastica_magnetic_rl.cases.case.Case`; module-level so that ``functools.partial`` of it
    pickles). ``initial_field`` / ``duration`` ``None``: the case's."""
    return MagneticCrawlerEnv(case=load_case(case), physics=physics, initial_field=initial_field,
                              duration=duration, render_mode=render_mode)
