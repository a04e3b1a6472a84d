"""Cases: a robot, its actuation, a task, a training recipe and a yardstick, from one spec file.

The one registry of cases. The paper's four cases (``m1-4mT``, ``m2-4mT``, ``m1-10mT``,
``m2-10mT``) and the others shipped with the package are TOML spec files in this package's
``specs/`` folder; a user's case is a spec file anywhere. :func:`load_case` takes either a
registered name or a path, so every workflow (``msr train --case``, ``gym.make(...,
case=...)``) accepts both. A case is named after its file (``my.toml`` -> ``my``) unless the
file sets ``name``.

Tables of a spec (SI units; the robot's tables are described in
:mod:`elastica_magnetic.specfile`):

- ``[actuation]``: ``field_limit`` (T), ``max_increment`` (T per action), ``control_rate`` (Hz;
  100, the only rate the environments and the firmware play), ``initial_field`` (``"random"``
  or ``"zero"``: training episodes; generated fields always start from zero). Or, with ``kind =
  "magnet-pose"``, a permanent magnet on a robot arm
  (:class:`~elastica_magnetic_rl.cases.arm_actuation.MagnetArm`): ``moment`` (A m^2),
  ``position`` (m) and ``direction`` at the start of each episode, ``workspace`` (m, the box its
  centre stays in), ``max_speed`` (m/s), ``max_turn_rate`` (rad/s) and ``min_clearance`` (m, the
  nearest it may come to the rod); the rod is clamped at its base (a catheter). Or, with ``kind =
  "coil-currents"``, fixed coils whose currents steer the clamped rod
  (:class:`~elastica_magnetic_rl.cases.coil_actuation.CoilArray`): ``current_limit`` (A),
  ``max_slew`` (A/s), ``[[actuation.coils]]`` (``radius`` m, ``centre`` m, ``axis``, ``turns``).
  Both may have an insertion stage (``insertion``, m, ``insertion_speed``, m/s).
- ``[task]``: ``kind`` (``"crawl"``, ``"reach"``, ``"goto"`` or ``"tip-reach"``, see
  :mod:`elastica_magnetic_rl.cases.tasks`) and its parameters, ``episode_duration`` (s, training
  episodes); ``goto`` needs ``[actuation] axes = "xyz"``; ``tip-reach`` (the tip of a clamped rod
  to a target in ``target_box``) goes with a magnet-pose or coil-currents actuation, the crawler
  tasks with a field.
- ``[training]``: ``recipe`` (:data:`~elastica_magnetic_rl.cases.recipes.RECIPES`), ``steps`` per seed,
  ``[training.td3]``: :class:`~elastica_magnetic_rl.td3.config.TD3Config` fields on top of the recipe,
  and ``[training.randomize]``: robot values drawn anew per training episode and crawler (domain
  randomization; ``KEY = "LOW:HIGH"`` as ``msr real robustness --vary``, or ``randomize = "default"``).
- ``[design]``: what ``msr design`` may change of the robot's magnetization
  (:mod:`elastica_magnetic_rl.cases.design_space`); optional, read by no other command.
- ``[yardstick]``: ``distance_10s`` (m, crawl: the distance in 10 s of accurate physics from a
  zero field that counts as success; 0: the case has none, and no run of it is judged) and
  ``source`` (where it comes from); a goto case's ``turn_in_place`` (default true: the steering
  yardstick turns the robot in place until the target is abeam before it walks; false: it never
  turns, the field's plane always toward the target, for a robot that goes where the plane points)
  and ``steering_period`` (s, default :data:`DEFAULT_STEERING_PERIOD`: the turn the steering
  yardstick asks of the field).
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

from elastica_magnetic import RobotSpec
from elastica_magnetic.robot_spec import ACTION_PERIOD, Physics
from elastica_magnetic.rotation import min_rotation_period
from elastica_magnetic.specfile import (
    RobotDescription,
    SpecError,
    SpecTable,
    accepted_keys,
    check_plain_name,
    describe_robot,
    dumps,
    read_spec,
)

from .arm_actuation import magnet_arm_from_table
from .coil_actuation import coil_array_from_table
from .design_space import DESIGN_TABLE, DesignSpace, design_space
from .field_actuation import ACTUATION_AXES, Actuation, field_actuation_from_table
from .steered import ACTUATION_KINDS, SteeringActuation, check_steered_reach
from .task_tables import MAX_YARDSTICK_BODY_LENGTHS, task_from_table
from .tasks import TASK_KINDS, GotoTask, ReachTask, Task, TipReachTask
from .training_tables import Training, randomize_table, training_from_table
from .variations import (
    Variation,
    resolve_variations,
)

__all__ = [
    "ACTUATION_AXES",
    "Actuation",
    "Case",
    "DEFAULT_STEERING_PERIOD",
    "SPECS_DIR",
    "Yardstick",
    "NO_TARGET",
    "case_from_dict",
    "case_from_metadata",
    "case_names",
    "load_case",
    "PAPER_CASES",
    "YARDSTICK_CONTROLLERS",
    "warmup_refusal",
    "with_randomize",
]

#: Folder of the spec files shipped with the package.
SPECS_DIR = Path(__file__).resolve().parents[1] / "specs"
#: The paper's four cases (the first shipped specs).
PAPER_CASES = ("m1-4mT", "m2-4mT", "m1-10mT", "m2-10mT")
#: s: the turn a goto case's steering yardstick asks of the field where its ``[yardstick]
#: steering_period`` is not given.
DEFAULT_STEERING_PERIOD = 1.0
#: The evaluation during training, s: the shipping criterion's episode (field from zero,
#: deterministic actions, the yardstick's 10 s) in the physics the run trains in.
EVAL_DURATION = 10.0
#: :attr:`Case.target_label` of a case without a yardstick (crawl, ``distance_10s`` = 0).
NO_TARGET = "none (the case has no yardstick: msr field baseline --case measures one)"
#: Units of the case tables, written next to values by :meth:`Case.toml`.
CASE_UNITS: dict[tuple[str, str], str] = {
    ("actuation", "field_limit"): "T", ("actuation", "max_increment"): "T per action",
    ("actuation", "control_rate"): "Hz", ("actuation", "initial_field"): "training episodes",
    ("task", "reward_scale"): "per m", ("task", "episode_duration"): "s, training episodes",
    ("task", "target"): "m ahead of the start", ("task", "tolerance"): "m",
    ("task", "slow_zone"): "m", ("task", "speed_penalty"): "x reward_scale per m moved near the target",
    ("task", "distance"): "m from the start, the targets' ring",
    ("task", "angle_low"): "rad, bearing from ahead, counter-clockwise seen from above",
    ("task", "angle_high"): "rad, bearing from ahead, counter-clockwise seen from above",
    ("task", "heading_share"): "of the drawn training episodes: a heading to crawl along",
    ("task", "time_penalty"): "m/s, each second away from the target costs reward_scale x this",
    ("actuation", "moment"): "A m^2", ("actuation", "position"): "m, the magnet's centre at the start",
    ("actuation", "direction"): "the moment's direction at the start",
    ("actuation", "workspace"): "m, the box the magnet's centre stays in", ("actuation", "max_speed"): "m/s",
    ("actuation", "max_turn_rate"): "rad/s", ("actuation", "min_clearance"): "m, nearest the magnet comes",
    ("actuation", "insertion"): "m, the stage's travel [low, high] along +x",
    ("actuation", "insertion_speed"): "m/s, the stage's fastest",
    ("actuation", "current_limit"): "A, each coil's largest current", ("actuation", "max_slew"): "A/s",
    ("actuation.coils", "radius"): "m", ("actuation.coils", "centre"): "m",
    ("actuation.coils", "axis"): "the current turns counter-clockwise about it",
    ("actuation.coils", "turns"): "turns",
    ("task", "target_box"): "m, [[xmin, ymin, zmin], [xmax, ymax, zmax]]",
    ("training", "steps"): "environment steps per seed",
    ("yardstick", "distance_10s"): "m in 10 s, accurate physics, field from zero",
    ("yardstick", "period"): "s, one turn of the rotating field that made distance_10s",
    ("yardstick", "turn_in_place"): "goto: false, the steering yardstick walks toward every target",
    ("yardstick", "steering_period"): "s, goto: the turn the steering yardstick asks of the field",
}


@dataclass(frozen=True)
class Yardstick:
    """What counts as success for a seed's actor (10 s, accurate physics, field from zero): for
    ``crawl``, reaching ``distance_10s`` m (0: no yardstick, so no success or failure either: a
    verdict is absent, not "any forward motion"); for ``reach``, ending within the task's
    tolerance. ``source`` says where the number comes from."""

    distance_10s: float = 0.0
    source: str = ""
    #: The rotating field that made ``distance_10s``: its period (s; ``None``: not recorded) and
    #: sense (clockwise seen from +z rolls the robot toward +x). A training may start from it
    #: (``yardstick_warmup``).
    period: float | None = None
    clockwise: bool = True
    #: A goto case's steering yardstick: whether it turns the robot in place until the target is
    #: abeam before walking (``None``: not given, which means it does); ``False``: it walks toward
    #: every target, the field's plane toward it
    #: (:class:`~elastica_magnetic_rl.envs.yardsticks.SteeringFieldPolicy`).
    turn_in_place: bool | None = None
    #: A goto case's steering yardstick: the turn its law asks of the field, s (``None``: not
    #: given, which means :data:`DEFAULT_STEERING_PERIOD`). Shorter than the rate limit's
    #: shortest uniform turn, the field turns as fast as the increments let it and its amplitude
    #: shrinks: a gait of its own, which may be faster.
    steering_period: float | None = None

    @property
    def steering_turn(self) -> float:
        """s: the turn a goto case's steering yardstick asks of the field (``steering_period``, or
        :data:`DEFAULT_STEERING_PERIOD` where not given)."""
        return DEFAULT_STEERING_PERIOD if self.steering_period is None else self.steering_period

    def to_dict(self) -> dict[str, Any]:
        """Plain data; the field's keys only where its period is recorded, ``turn_in_place`` and
        ``steering_period`` only where given."""
        out: dict[str, Any] = {"distance_10s": self.distance_10s, "source": self.source}
        if self.period is not None:
            out.update(period=self.period, clockwise=self.clockwise)
        if self.turn_in_place is not None:
            out["turn_in_place"] = self.turn_in_place
        if self.steering_period is not None:
            out["steering_period"] = self.steering_period
        return out


@dataclass(frozen=True)
class Case:
    """A complete case (see the module docstring); :meth:`to_dict` is its canonical plain data."""

    name: str
    description: str
    robot: RobotDescription
    actuation: Actuation | SteeringActuation
    task: Task
    training: Training
    yardstick: Yardstick
    source: str = "<spec>"
    #: The ``[design]`` table (what ``msr design`` may change), ``None`` when the spec has none.
    design: DesignSpace | None = None

    def robot_spec(self, physics: Physics = "training") -> RobotSpec:
        """The robot in one physics setting."""
        return self.robot.robot(physics)

    @property
    def field_limit(self) -> float:
        return self.actuation.field_limit

    @property
    def field_actuated(self) -> bool:
        """Whether a uniform field (the paper's coils) actuates the robot; ``False`` for a case
        steered by a source (a magnet on an arm, fixed coils' currents)."""
        return not isinstance(self.actuation, SteeringActuation)

    @property
    def has_yardstick_controller(self) -> bool:
        """Whether a hand-designed controller can play the case's warm-up (``yardstick_warmup``):
        a goto task's steering field, a field-actuated crawl or reach whose ``[yardstick]``
        records its rotating field's ``period``, or the steering law of a case steered by a source
        (:func:`~elastica_magnetic_rl.envs.yardsticks.yardstick_controller` makes it)."""
        if not self.field_actuated:
            return True
        return isinstance(self.task, GotoTask) or self.yardstick.period is not None

    @property
    def training_episodes(self) -> str:
        """How the case's training episodes start, in words (for summaries of training returns)."""
        if not self.field_actuated:
            return f"{self.actuation.start_words()}, to targets drawn in the task's target_box"
        return "from random initial fields" if self.actuation.initial_field == "random" else "from zero field"

    @property
    def n_elements(self) -> int:
        return self.robot.n_elements

    @property
    def obs_dim(self) -> int:
        """Observation size: the robot's ``4 n + 4`` plus the actuation's and the task's extra
        blocks."""
        if not self.field_actuated:  # the rod's node positions, then its blocks
            extra = (*self.actuation.observation_blocks, *self.task.extra_observation)
            return 3 * (self.n_elements + 1) + sum(size for _, size in extra)
        extra = (*self.actuation.observation_blocks, *self.task.extra_observation)
        return 4 * self.n_elements + 4 + sum(size for _, size in extra)

    @property
    def builtin(self) -> bool:
        """Whether this is the registered case of its name, unchanged."""
        return self.name in case_names() and load_case(self.name).to_dict() == self.to_dict()

    @property
    def evaluation_duration(self) -> float:
        """The periodic evaluation's episode during training, s: :data:`EVAL_DURATION` (the
        yardstick's 10 s), or a goto task's whole episode (reaching a target takes longer)."""
        whole = isinstance(self.task, GotoTask | TipReachTask)
        return self.task.episode_duration if whole else EVAL_DURATION

    @property
    def has_yardstick(self) -> bool:
        """Whether the case has a success test of one 10 s evaluation: a reach task (its
        tolerance) or a crawl task with a ``[yardstick] distance_10s`` above 0. A goto task has
        none of one run: it is judged on a ring of targets
        (:func:`~elastica_magnetic_rl.shipping.goto.evaluate_ring`)."""
        return isinstance(self.task, ReachTask) or self.yardstick.distance_10s > 0.0

    @property
    def target_label(self) -> str:
        """The yardstick in words, e.g. ``"+20.5 mm in 10 s"`` or ``"within 1.0 mm of +10.0 mm"``;
        for a case without one, :data:`NO_TARGET`."""
        if isinstance(self.task, ReachTask):
            return f"within {1e3 * self.task.tolerance:.1f} mm of {1e3 * self.task.target:+.1f} mm"
        if isinstance(self.task, GotoTask):
            return (f"within {1e3 * self.task.tolerance:.1f} mm of a target "
                    f"{1e3 * self.task.distance:.1f} mm away in {self.task.episode_duration:g} s")
        if isinstance(self.task, TipReachTask):
            return (f"the tip within {1e3 * self.task.tolerance:.1f} mm of a target in its box in "
                    f"{self.task.episode_duration:g} s")
        if self.yardstick.distance_10s > 0.0:
            return f"{1e3 * self.yardstick.distance_10s:+.1f} mm in 10 s"
        return NO_TARGET

    def meets_yardstick(self, mid_dx_m: float, node_dx_m: float, duration_s: float,
                        diverged: Any = None) -> bool | None:
        """Whether an evaluation (accurate physics, field from zero) succeeds: crawl, the middle's
        displacement ``mid_dx_m`` (m) in 10 s reaches ``distance_10s``; reach, the reward's middle
        node ends (``node_dx_m``, m) within the tolerance of the target. ``None`` (no verdict: the
        writers of results then leave ``meets_target`` out) for a case without a yardstick
        (:attr:`has_yardstick`) and for a crawl evaluation not 10 s long; otherwise a diverged
        evaluation is a fail."""
        if not self.has_yardstick:
            return None
        if diverged:
            return False
        if isinstance(self.task, ReachTask):
            return bool(self.task.within_tolerance(node_dx_m - self.task.target))
        if abs(duration_s - 10.0) > 1e-9:
            return None
        return bool(mid_dx_m >= self.yardstick.distance_10s)

    def to_dict(self) -> dict[str, Any]:
        """Every table, every default written out, plain data (round-trips through TOML/JSON); a
        new copy each call (editing it changes no case)."""
        training = {"recipe": self.training.recipe, "steps": self.training.steps}
        if self.training.td3:  # layer sizes as lists: plain data, as TOML and JSON write them
            training["td3"] = {k: list(v) if isinstance(v, tuple) else v
                               for k, v in self.training.td3.items()}
        if self.training.randomize:
            training["randomize"] = randomize_table(self.training.randomize)
        return copy.deepcopy({
            "name": self.name,
            "description": self.description,
            **self.robot.tables,
            "actuation": self.actuation.to_dict(),
            "task": self.task.to_dict(),
            "training": training,
            "yardstick": self.yardstick.to_dict(),
            **({} if self.design is None else {DESIGN_TABLE: self.design.to_dict()}),
        })

    def toml(self, *, with_name: bool = False) -> str:
        """The complete spec as TOML with units in comments, every default written out: a file to
        copy and edit. ``name`` is left out (a case from a file is named after the file) unless
        ``with_name``: a copy of this very case under another file name (its runs, policies and
        results keep the case's name)."""
        data = self.to_dict()
        if not with_name:
            del data["name"]
        header = (f"# Case spec, from the case {self.name!r}. SI units (m, kg, s, Pa, A/m, T).\n"
                  "# The case is named after this file (my.toml -> my) unless you set name = \"...\".\n"
                  "# Every key is described in the package's docs (Spec files).\n")
        return header + dumps(data, CASE_UNITS)


#: Which cases have a hand-designed controller to play a warm-up (:attr:`Case.has_yardstick_controller`),
#: in words, for the messages that refuse ``yardstick_warmup``.
YARDSTICK_CONTROLLERS = ("a goto task's steering field is one; a crawl's rotating field once [yardstick] "
                         "period is recorded; a catheter's steering law is one")


def case_names() -> tuple[str, ...]:
    """Names of the shipped cases: the paper's four first, then the others alphabetically."""
    found = sorted(p.stem for p in SPECS_DIR.glob("*.toml"))
    return tuple([n for n in PAPER_CASES if n in found] + [n for n in found if n not in PAPER_CASES])


@cache
def _shipped(name: str) -> Case:
    return case_from_dict(read_spec(SPECS_DIR / f"{name}.toml"), f"{name}.toml", default_name=name)


def load_case(case: str | Path | Case | Mapping[str, Any]) -> Case:
    """A case from a shipped name (``"m1-4mT"``), a spec file path, a :class:`Case` or a spec dict.

    Raises:
        SpecError: unknown name, unreadable file or invalid spec (the message names the file and
            the key).
    """
    if isinstance(case, Case):
        return case
    if isinstance(case, Mapping):
        return case_from_dict(case, "<spec>")
    text = str(case)
    if text in case_names():
        return _shipped(text)
    path = Path(case)
    if path.suffix == ".toml" or path.exists():
        return case_from_dict(read_spec(path), str(path), default_name=path.stem)
    raise SpecError(f"unknown case {text!r}: not a shipped case ({', '.join(case_names())}) "
                    "and not a spec file (.toml)")


def case_from_metadata(meta: Mapping[str, Any], source: str) -> Case:
    """The case of a run or policy file: its stored ``case_spec`` (complete, so the original spec
    file is not needed), else the shipped case named by ``case`` (files from before specs)."""
    spec = meta.get("case_spec")
    name = meta.get("case")
    if spec is not None:
        case = case_from_dict(spec, f"{source} (case_spec)")
        if name is not None and name != case.name:
            raise SpecError(f"{source}: case = {name!r} but its case_spec is of case {case.name!r}: "
                            "the file contradicts itself (edited by hand?); restore it (e.g. from "
                            "git), or make the two agree")
        return case
    if isinstance(name, str) and name in case_names():
        return load_case(name)
    raise SpecError(f"{source}: case {name!r} is not a shipped case ({', '.join(case_names())}) "
                    "and the file stores no case_spec")


def case_from_dict(spec: Mapping[str, Any], source: str = "<spec>", default_name: str | None = None) -> Case:
    """Check a parsed spec (see the module docstring) and return the :class:`Case`."""
    robot = describe_robot(spec, source)
    top = SpecTable(spec, source)
    name = top.string("name", default_name)
    if not name:
        raise top.error("name", "missing: set name = \"...\" (or load the spec from a file)")
    if not top.has("name") and default_name is not None:
        try:  # named after its file: the file name must make a plain name (a folder of its own)
            check_plain_name(top, "name", name)
        except SpecError as exc:
            raise SpecError(f"{source}: the case is named after the file, and {str(exc).split(': ', 2)[-1]}"
                            "; set name = \"...\" in the spec or give the file a shorter name") from None
    description = top.string("description", "")
    actuation = _actuation(top.table("actuation"), float(robot.tables["robot"]["length"]))
    _check_sideways_model(actuation, robot, spec, source)
    length = float(robot.tables["robot"]["length"])
    stage = actuation.insertion if isinstance(actuation, SteeringActuation) else None
    task_table = spec.get("task")
    kind = task_table.get("kind") if isinstance(task_table, Mapping) else None
    if isinstance(kind, str) and kind in TASK_KINDS:  # the pairing first: the keys suit the actuation
        _check_task_and_actuation(kind, actuation, source)
    task = task_from_table(top.table("task"), length, length + (stage[1] if stage else 0.0))
    if isinstance(actuation, SteeringActuation):
        check_steered_reach(SpecTable(spec["actuation"], source, "actuation", accepted_keys(spec, source)),
                            actuation, robot.robot("accurate"), task.target_box, task.episode_duration)
    training = training_from_table(top.table("training", required=False), source, robot)
    if training.randomize and isinstance(actuation, SteeringActuation):
        given = ("[training] randomize" if isinstance((spec.get("training") or {}).get("randomize"), str)
                 else "[training.randomize]")
        raise SpecError(f"{source}: {given}: domain randomization varies a crawler's robot; a case "
                        f"steered by a source ([actuation] kind = \"{actuation.kind}\") trains on its "
                        f"nominal robot: remove {given}")
    fastest = (None if isinstance(actuation, SteeringActuation) else
               min_rotation_period(min(actuation.limits[:2]), min(actuation.increments[:2])))
    yardstick = _yardstick(top.table("yardstick", required=False), length,
                           _rotating_yardstick_refusal(actuation, task), fastest,
                           isinstance(task, GotoTask))
    if yardstick.distance_10s > 0.0 and task.kind in _JUDGED_ON:  # nothing would judge it
        judged = _JUDGED_ON[task.kind]
        raise SpecError(f"{source}: [yardstick] distance_10s: {yardstick.distance_10s:g} m is a crawl's "
                        f"distance in 10 s, and a {task.kind} case is judged on {judged}, not on it: "
                        "remove distance_10s (or set it to 0)")
    if not robot.robot("training").magnetization.any():
        raise SpecError(f"{source}: [robot.magnetization]: no magnetization: no field can move it "
                        "(every element is at 0 A/m), so there is nothing to learn; give the robot "
                        "its magnetization (docs/specs.md)")
    if robot.robot("training").ground is None and not isinstance(actuation, SteeringActuation):
        raise SpecError(f"{source}: [robot.ground] missing: the crawler tasks need a ground (add the "
                        "table; every key in it has a default)")
    design = _design(top.raw(DESIGN_TABLE, None), robot, actuation, source, top.accept)
    for key in ("robot", "physics", "checks"):  # read by describe_robot
        top.raw(key, None)
    top.finish()
    return Case(name, description, robot, actuation, task, training, yardstick, source, design)


def warmup_refusal(case: Case) -> str | None:
    """Why ``msr train`` cannot train ``case`` (``None`` when it can): its ``[training.td3]
    yardstick_warmup`` needs the case's hand-designed controller, which a field-driven crawl has
    once ``[yardstick] period`` is recorded (a goto case and a case steered by a source always
    have one). Such a crawl's spec is valid until then (a sweep, ``msr field baseline
    --set-yardstick`` or ``msr loop``, records it): only the training refuses it, and ``msr case
    check`` warns."""
    warmup, residual = case.training.td3.get("yardstick_warmup"), case.training.td3.get("residual")
    if not (warmup or residual) or case.has_yardstick_controller:
        return None
    fix = ("give [yardstick] period (msr field baseline --case SPEC --set-yardstick FILE writes it; msr "
           "loop finds it itself) or remove the setting")
    what = (f"yardstick_warmup = {warmup}: the warm-up is played by" if warmup else
            f"residual = {residual}: the actor learns a correction of")
    return (f"{case.source}: [training.td3] {what} the "
            f"case's hand-designed controller, and this case has none ({YARDSTICK_CONTROLLERS}): {fix}")


def _check_task_and_actuation(kind: str, actuation: Actuation | SteeringActuation, source: str) -> None:
    """A tip-reach task (``[task] kind``) goes with a steering actuation (a magnet arm, coil
    currents), the crawler tasks with a field: the other pairs are refused, naming both."""
    steered, tip = isinstance(actuation, SteeringActuation), kind == TipReachTask.kind
    if steered and not tip:
        raise SpecError(f"{source}: [task] kind = {kind!r} is a crawler's task (a uniform field "
                        f"moves the robot on its ground); [actuation] kind = \"{actuation.kind}\" "
                        "steers a clamped rod's tip: set [task] kind = \"tip-reach\"")
    if tip and not steered:
        raise SpecError(f"{source}: [task] kind = \"tip-reach\" steers a clamped rod's tip with a "
                        "source: set [actuation] kind = \"magnet-pose\" (a magnet on an arm: its moment, "
                        "position, direction, workspace) or \"coil-currents\" (fixed coils)")
    if kind == GotoTask.kind and actuation.axes != "xyz":
        raise SpecError(f"{source}: [task] kind = \"goto\" needs the third coil pair: a field "
                        f"confined to the x-y plane (axes = {actuation.axes!r}) moves the robot "
                        "only along its line; set [actuation] axes = \"xyz\"")


def _design(table: Any, robot: RobotDescription, actuation: Actuation | SteeringActuation, source: str,
            accept: frozenset[str]) -> DesignSpace | None:
    """The checked ``[design]`` table (``None`` when absent)."""
    if table is None:
        return None
    if isinstance(actuation, SteeringActuation):
        raise SpecError(f"{source}: [{DESIGN_TABLE}]: msr design searches magnetizations under a "
                        f"rotating uniform field; a {actuation.kind} case has none (remove the table)")
    return design_space(table, robot.tables["robot"], actuation.axes, source,
                        robot.robot("accurate").magnetization, accept)


def _actuation(t: SpecTable, rod_length: float) -> Actuation | SteeringActuation:
    kind = t.string("kind", "field", choices=ACTUATION_KINDS)
    if kind == "magnet-pose":
        return magnet_arm_from_table(t, rod_length)
    if kind == "coil-currents":
        return coil_array_from_table(t, rod_length)
    return field_actuation_from_table(t)


def _check_sideways_model(actuation: Actuation | SteeringActuation, robot: RobotDescription,
                          spec: Mapping[str, Any], source: str) -> None:
    """A three-axis case on a band whose ground rolls it sideways like a round rod (the default
    model): warned, naming the model of a flat band (``[checks] accept = ["actuation.axes"]``
    keeps the rolling model on purpose)."""
    if isinstance(actuation, SteeringActuation) or actuation.axes != "xyz":
        return
    rod = robot.robot("training")
    if rod.section == "band" and rod.ground is not None and rod.ground.sideways == "rolling":
        SpecTable(spec["actuation"], source, "actuation", accepted_keys(spec, source)).warn(
            "axes", '"xyz" moves the robot out of the x-y plane, and [robot.ground] sideways is '
            '"rolling" (the default): the band rolls sideways like a round rod; set sideways = '
            '"sliding" to model a flat band that cannot roll')


def with_randomize(case: Case, variations: tuple[Variation, ...]) -> Case:
    """``case`` training on robots randomized by ``variations`` (checked against its robot)."""
    variations = tuple(resolve_variations(list(variations), case.robot.tables, option="randomize"))
    return dataclasses.replace(case, training=dataclasses.replace(case.training,
                                                                  randomize=variations))


#: What the tasks that take no crawl's distance in 10 s as their yardstick are judged on, in words
#: (a reach case's sweep of rotating fields does record one: ``msr field baseline --set-yardstick``).
_JUDGED_ON = {"goto": "a ring of targets (msr policy generate --ring)",
              "tip-reach": "its held-out targets, beside its steering yardstick"}


def _rotating_yardstick_refusal(actuation: Actuation | SteeringActuation, task: Task) -> str | None:
    """Why ``[yardstick] period``/``clockwise`` (a crawl's rotating field) cannot act on a case of
    ``actuation`` and ``task``, or ``None`` where they can."""
    if isinstance(actuation, SteeringActuation):
        return (f"a case steered by [actuation] kind = \"{actuation.kind}\" has no rotating-field yardstick "
                "(nothing would play it)")
    if isinstance(task, GotoTask):
        return ("a goto case's yardstick is its steering field toward the target (msr field baseline "
                "steers), not a rotating field: nothing would play it")
    return None


def _yardstick(t: SpecTable | None, robot_length: float, rotating_refusal: str | None = None,
               fastest: float | None = None, steers: bool = False) -> Yardstick:
    """``[yardstick]``; ``rotating_refusal``: why this case cannot take a rotating field's
    ``period``/``clockwise`` (refused by name), ``None`` where it can; ``fastest``: the shortest
    uniform turn (s) the case's rate limit allows at its amplitude (a shorter period is warned
    about: the field would turn slower than it says); ``steers``: a goto case, whose steering
    yardstick may be told not to turn in place (``turn_in_place``) and given the turn it asks
    (``steering_period``: not warned about, asking more than the field can follow is a gait)."""
    if t is None:
        return Yardstick()
    for key in ("period", "clockwise"):
        if rotating_refusal is not None and t.has(key):
            raise t.error(key, f"{rotating_refusal}: remove period and clockwise")
    if t.has("turn_in_place") and not steers:
        raise t.error("turn_in_place", "it tells a goto case's steering yardstick whether to turn the robot "
                                       "in place; this case has no goto task: remove it")
    if t.has("steering_period") and not steers:
        raise t.error("steering_period", "it is the turn a goto case's steering yardstick asks of the field; "
                                         "this case has no goto task: remove it (a crawl's rotating field "
                                         "is [yardstick] period)")
    out = Yardstick(distance_10s=t.number("distance_10s", "m", 0.0, low=0.0),
                    source=t.string("source", ""),
                    period=t.number("period", "s", None, low=0.0, low_open=True, plausible="rotation period"),
                    clockwise=t.boolean("clockwise", True),
                    turn_in_place=t.boolean("turn_in_place", None),
                    steering_period=t.number("steering_period", "s", None, low=0.0, low_open=True,
                                             plausible="rotation period"))
    for key, usual in (("period", "a rotating field of the baseline sweep turns once in 0.5 to 6 s"),
                       ("steering_period", "the shipped goto cases' yardsticks ask 0.15 and 2 s")):
        value = getattr(out, key)
        if value is not None and value <= 2 * ACTION_PERIOD:
            raise t.error(key, f"{value:g} s is at or under 2 x the {ACTION_PERIOD:g} s control "
                               f"period: no field the coils play turns that fast ({usual})")
    if out.period is not None and fastest is not None and out.period < fastest * (1.0 - 1e-9):
        t.warn("period", f"{out.period:g} s is shorter than the case's rate limit allows: at most "
                         "max_increment per axis per step at the field limit, its shortest uniform turn "
                         f"takes {fastest:.4g} s (the field would turn slower than the period says)")
    if t.has("clockwise") and out.period is None:
        raise t.error("clockwise", "the sense of a rotating field without its period: give period "
                                   "(s) too, or leave clockwise out")
    lengths = out.distance_10s / robot_length
    if lengths > MAX_YARDSTICK_BODY_LENGTHS:
        hint = (f"; it looks like mm written where m is expected ({out.distance_10s:g} mm is "
                f"{1e-3 * out.distance_10s:g} m)" if lengths / 1e3 <= MAX_YARDSTICK_BODY_LENGTHS
                else "")
        raise t.error("distance_10s", f"{out.distance_10s:g} m in 10 s is {lengths:.0f} body "
                                      f"lengths of this {robot_length:g} m robot, more than "
                                      f"{MAX_YARDSTICK_BODY_LENGTHS:g}: no crawler's{hint}")
    t.finish()
    return out
