"""Refinement of a trained run (``msr refine``): its agent, replay buffer, RNGs and counters
continued for more steps in ``RUN/refined/``, in the accurate physics, on another robot's values,
or on randomized robots (a nominal policy fine-tuned for the robots a lab may build).
"""

from __future__ import annotations

import dataclasses
import functools
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from elastica_magnetic.batch import batched_refusal
from elastica_magnetic.io import atomic_write_json
from elastica_magnetic.robot_spec import ACTION_PERIOD

from ..cases.case import Case, case_from_metadata, load_case
from ..cases.training_tables import randomize_table
from ..cases.variations import VariationError, default_variations, physical_differences
from ..runfiles.checkpoint import checkpoint_metadata
from ..runfiles.locking import held_run_folders, mark_run_folder
from ..runfiles.provenance import versions
from ..runfiles.rundir import CaseDir, RunDir
from .randomize_settings import randomized_cases
from .refine_resume import resumed_refinement
from .refine_start import check_refine_output, default_refine_output, refine_source, starting_file
from .run_records import run_metadata
from .summaries import summarize_run

if TYPE_CHECKING:  # torch is imported only when a refinement runs
    from ..td3.config import TD3Config

__all__ = ["DEFAULT_PHYSICS", "DEFAULT_STEPS", "check_refined_case",
           "refine"]


#: A new refinement's environment steps and physics when not given (its episode: the case's; a resume
#: takes its own record's).
DEFAULT_STEPS = 1000
DEFAULT_PHYSICS = "accurate"


def refine(
    run: str | Path,
    steps: int | None = None,
    out: str | Path | None = None,
    resume: bool = False,
    progress: bool = True,
    episode_duration: float | None = None,
    physics: str | None = None,
    device: str | None = None,
    spec: str | Path | None = None,
    randomize: str | None = None,
) -> dict[str, Any]:
    """Continue training a run for ``steps`` more environment steps (default
    :data:`DEFAULT_STEPS`) in ``physics`` (``"accurate"``, default, or ``"training"``) on
    ``device`` (default the run's), episodes of ``episode_duration`` s (default the case's
    ``[task] episode_duration``, as ``msr train``'s: 20 s for the paper's crawlers).

    ``run``: a run folder or its ``checkpoint.pt``, whose final actor is refined, or its ``best.pt``
    (:func:`~elastica_magnetic_rl.sweep.refine_start.refine_source`: best.pt's networks, the rest of
    the run's training state; which actor to refine is the command line's choice, the rule of
    ``msr policy generate``). The agent (networks, targets, optimisers), its replay buffer, RNG states and
    counters come from the run's checkpoint (``init_from``), so learning continues at once (the
    counters are past the warm-up) with the training-physics transitions still in the buffer,
    gradually displaced by accurate ones. Episodes keep the training setting (random initial
    field, 20 s). The refined run goes to ``out`` (default ``RUN/refined``) with its own
    ``episodes.csv``, TensorBoard scalars, ``checkpoint.pt`` and ``run.json``; ``resume``
    continues an interrupted refinement as its ``run.json`` records it (robot, randomization,
    physics, episode length, provenance; ``steps`` counted from its start, default its own): an
    option given that contradicts the record is refused, and so is a resume at its target
    (:mod:`~elastica_magnetic_rl.sweep.refine_resume`).

    ``spec``: a spec file (or shipped case) of the same robot with other physical values (e.g.
    the ``identified.toml`` of ``msr real identify``): the refinement trains on that robot. Anything
    else that differs (elements, magnetization pattern, task, actuation) is refused, naming the
    key; the changed values are recorded in ``run.json`` (``spec_from``, ``physical_changes``:
    key -> [run's value, new value], SI). The spec's ``[training.randomize]``, when it has one,
    randomizes the refinement's robots around that robot (as ``randomize`` would; recorded as
    ``refine_randomize = "spec"``); a ``randomize`` that disagrees with it is refused, naming
    both. Its other ``[training]`` settings are the run's (the agent continues as it trained).

    ``randomize``: the robots of the refinement's episodes: ``"default"``, drawn anew per episode
    from the default variation set (domain randomization; with ``physics="training"`` this
    fine-tunes a policy learned on the nominal robot for the robots a lab may build), ``"none"``,
    the nominal robot, ``None``, the run's own setting. Recorded in ``run.json`` (the case's
    ``[training.randomize]`` and ``refine_randomize``). A refinement runs no evaluations: its
    final actor is what ``msr policy generate`` and ``msr real robustness`` play.

    Cost: one accurate step is 1250 substeps (~0.1 s here), 12.5x a training step.
    """
    if steps is not None and steps < 1:
        raise ValueError("steps must be >= 1")
    source = RunDir.checkpoint_of(run)
    out = RunDir(out if out is not None else default_refine_output(source))
    check_refine_output(out.path, resume)
    if resume:
        return _resume_refinement(run, source, out, steps, physics, episode_duration, device,
                                  spec, randomize, progress)
    ckpt, start = refine_source(source)
    meta = checkpoint_metadata(ckpt, start["state_from"])
    case, changes = _refined_case(case_from_metadata(meta, str(source)), spec, randomize)
    physics = physics or DEFAULT_PHYSICS
    # the case's episode, as msr train's default (20 s for the paper's crawlers; a catheter's 3 s)
    duration = case.task.episode_duration if episode_duration is None else episode_duration
    steps = DEFAULT_STEPS if steps is None else int(steps)
    start_step = int(ckpt["global_step"])
    config = _refinement_config(ckpt, device, source, physics)
    _check_refinement_learns(ckpt, source, steps)
    metadata = run_metadata(
        case, physics, duration, config.seed, command="refine",
        refined_from=str(source), refine_start_step=start_step, refine_steps=steps,
        training_steps=int(meta.get("training_steps", start_step)), refined_actor=start["actor"],
        refined_actor_step=start["actor_step"], **changes,
    )
    begin = time.perf_counter()
    _train_refinement(case, (ckpt, start), out, config, metadata, start_step + steps,
                      progress=progress)
    return _refinement_result(case, out, metadata, begin)


#: Steps between a refinement's checkpoints, by physics: about a minute of either on one core (an
#: accurate step is 1250 substeps, ~0.1 s; a training step ~15 ms with its update).
REFINE_CHECKPOINT_STEPS = {"accurate": 500, "training": 5000}


def _resume_refinement(run: str | Path, source: Path, out: RunDir, steps: int | None,
                       physics: str | None, episode_duration: float | None, device: str | None,
                       spec: str | Path | None, randomize: str | None,
                       progress: bool) -> dict[str, Any]:
    """:func:`refine` with ``resume``: the refinement in ``out`` continued as its ``run.json``
    records it, after the checks of
    :func:`~elastica_magnetic_rl.sweep.refine_resume.resumed_refinement` (nothing is written
    before them)."""
    from ..runfiles.checkpoint import load_checkpoint

    spec_case = None
    if spec is not None:  # the case the --spec makes from the run's, to compare with the record
        source_ckpt = load_checkpoint(source, with_buffer=False)
        source_case = case_from_metadata(checkpoint_metadata(source_ckpt, source), str(source))
        options = f"--spec {spec}" + (f" --randomize {randomize}" if randomize else "")
        spec_case = (options, _refined_case(source_case, spec, randomize)[0])
    plan = resumed_refinement(out, run, steps=steps, physics=physics,
                              episode_duration=episode_duration, randomize=randomize,
                              spec_case=spec_case)
    config = _resumed_config(out, device)
    begin = time.perf_counter()
    _train_refinement(plan.case, None, out, config, plan.metadata, plan.total, progress=progress)
    return _refinement_result(plan.case, out, plan.metadata, begin)


def _resumed_config(out: RunDir, device: str | None) -> TD3Config:
    """The TD3 settings of the refinement in ``out``, resumed on its checkpoint's device (the
    runner keeps it): a ``device`` given that differs, or one this PyTorch lacks, is refused
    (``ValueError``) before any work."""
    from ..runfiles.checkpoint import load_checkpoint
    from ..td3.config import TD3Config
    from ..td3.devices import device_problem

    config = TD3Config.from_dict(load_checkpoint(out.checkpoint, with_buffer=False)["config"])
    if device is not None and device != config.device:
        raise ValueError(f"cannot resume the refinement in {out.path} on --device {device}: it "
                         f"trains on {config.device!r} (a resume keeps its checkpoint's device); "
                         "drop --device, or refine into another --out")
    problem = device_problem(config.device)
    if problem is not None:
        raise ValueError(f"cannot resume the refinement in {out.path} here: it trains on "
                         f"{config.device!r} and {problem} (a resume keeps its checkpoint's "
                         "device); resume it where PyTorch has that device")
    return config


def _refinement_config(ckpt: dict[str, Any], device: str | None, source: str | Path,
                       physics: str = DEFAULT_PHYSICS) -> TD3Config:
    """The TD3 settings a refinement continues with: ``ckpt``'s, on ``device`` when given,
    refused (``ValueError``) before any work when this PyTorch has no such device (a run trained
    on a GPU, refined on a machine without one); checkpoints at least every
    :data:`REFINE_CHECKPOINT_STEPS` of ``physics`` (the run's own interval, 10000 steps, is
    minutes to hours of refinement: an interrupted refinement resumes instead of starting over);
    without ``yardstick_regularization`` (a refinement plays no warm-up to hold its actor to) and
    without ``yardstick_dagger`` (nor a yardstick to label its states)."""
    from ..td3.config import TD3Config
    from ..td3.devices import device_problem

    config = TD3Config.from_dict(ckpt["config"])
    config.checkpoint_every = min(config.checkpoint_every, REFINE_CHECKPOINT_STEPS[physics])
    # a refinement has no warm-up of its own (its buffer starts empty): nothing to hold the actor to
    config.yardstick_regularization = 0.0
    config.yardstick_dagger = 0
    if device is not None:
        config.device = device
    problem = device_problem(config.device)
    if problem is not None:
        given = f"--device {device}" if device is not None else \
            f"{source} trained on device {config.device!r}"
        raise ValueError(f"{given}: {problem}; use --device cpu")
    return config


def _refinement_result(case: Case, out: RunDir, metadata: dict[str, Any],
                       begin: float) -> dict[str, Any]:
    """What :func:`refine` returns: the refinement's provenance and its episodes' summary."""
    summary = summarize_run(out.path, reward_scale=case.task.reward_scale, travels=case.field_actuated)
    result = {"case": case.name, "source": metadata["refined_from"], "run_dir": str(out.path),
              "checkpoint": str(out.checkpoint), "start_step": metadata["refine_start_step"],
              "steps": metadata["refine_steps"], "actor": metadata["refined_actor"],
              "actor_step": metadata["refined_actor_step"], "physics": metadata["physics"],
              **{k: summary[k] for k in ("episodes", "final_mean_return")},
              **_robots_trained_on(case, metadata, summary["episodes"]),
              "wall_s": time.perf_counter() - begin}
    if not summary["episodes"]:
        episode_steps = int(round(metadata["episode_duration_s"] / ACTION_PERIOD))
        result["note"] = (f"no episode finished: the refinement's {metadata['refine_steps']} steps "
                          f"are fewer than one episode ({metadata['episode_duration_s']:g} s = "
                          f"{episode_steps} steps), so there is no mean return; the agent learned "
                          "from the steps of the unfinished episode all the same")
    return result


def _robots_trained_on(case: Case, metadata: dict[str, Any], episodes: int) -> dict[str, Any]:
    """How many robots the refinement's episodes ran: one per episode begun (each draws anew
    from the randomization; the vector environment's episodes in progress included); one, the
    nominal, without randomization."""
    if not case.training.randomize:
        return {"robots": "the nominal robot (no randomization)"}
    envs = int(metadata.get("envs", 1) or 1)
    return {"randomized_robots": episodes + envs,
            "randomize": randomize_table(case.training.randomize)}


def check_refined_case(source: str | Path, steps: int, spec: str | Path | None,
                       randomize: str | None, device: str | None = None) -> None:
    """Check a refinement of ``source`` (a run folder or one of its checkpoint files) for
    ``steps`` more steps on ``spec`` with ``randomize`` on ``device`` (default the run's) before
    any work (the command line's evaluations that choose the actor take a minute): ``ValueError``
    naming the key or the setting, as :func:`refine` would raise it."""
    from ..runfiles.checkpoint import load_checkpoint

    path = RunDir.checkpoint_of(source)
    ckpt = load_checkpoint(path, with_buffer=False)
    meta = checkpoint_metadata(ckpt, path)
    _refined_case(case_from_metadata(meta, str(path)), spec, randomize)
    state = RunDir.of_checkpoint(path).checkpoint  # best.pt's training state is beside it
    if ckpt.get("kind") == "best" and state.is_file():
        ckpt, path = load_checkpoint(state, with_buffer=False), state
    if "config" in ckpt and "global_step" in ckpt:
        _check_refinement_learns(ckpt, path, steps)
        _refinement_config(ckpt, device, path)


def _check_refinement_learns(ckpt: dict[str, Any], source: str | Path, steps: int) -> None:
    """Refuse a refinement that ends inside its run's warm-up (no update: a run of its warm-up
    only, e.g. a benchmark's)."""
    start, warm_up = int(ckpt["global_step"]), int(ckpt["config"].get("learning_starts", 0))
    if start + int(steps) <= warm_up:
        raise ValueError(f"the refinement would not learn: {source} is at step {start}, inside its "
                         f"warm-up (learning_starts {warm_up}: random actions, no update), and "
                         f"--steps {steps} ends it at step {start + int(steps)}; give --steps "
                         f"above {warm_up - start}")


def _refined_case(case: Case, spec: str | Path | None, randomize: str | None
                  ) -> tuple[Case, dict[str, Any]]:
    """The case the refinement of a run of ``case`` trains on (the run's, another robot's values,
    randomized robots) and what ``run.json`` records of the change."""
    changes: dict[str, Any] = {}
    if spec is not None:
        case, changes = _other_robot(case, spec, randomize)
    if randomize is not None:
        case = randomized_cases({case.name: case}, randomize, case.training.recipe)[case.name]
        changes["refine_randomize"] = randomize
    refusal = batched_refusal(case.robot_spec("training"), "msr refine")  # before any folder is made
    if refusal:
        raise ValueError(f"--spec {spec}: {refusal}" if spec is not None else refusal)
    return case, changes


def _train_refinement(case: Case, start: tuple[dict[str, Any], dict[str, Any]] | None,
                      out: RunDir, config: TD3Config, metadata: dict[str, Any], total: int, *,
                      progress: bool) -> None:
    """Train ``out`` to ``total`` steps under the run-folder lock, from ``start`` (the checkpoint
    and provenance of :func:`refine_source`) or, with ``None``, resumed from ``out``'s own
    checkpoint; its ``run.json`` written first (a killed refinement leaves a folder that
    ``resume`` continues). Physics and episode length: ``metadata``'s."""
    from ..envs.residual import residual_vector_env
    from ..envs.vector_env import make_vector_env
    from ..runner.loop import train_seeds

    vector = make_vector_env  # a residual learner's corrections of the yardstick (envs.residual)
    if config.residual:
        vector = functools.partial(residual_vector_env, make_vector_env, case, config.residual)
    with held_run_folders([out.path]) as notes:
        for note in notes:  # a stale lock of a killed refinement taken over, its leftovers removed
            print(f"note: {note}", file=sys.stderr)
        mark_run_folder(out.path, "refine", case.name)
        atomic_write_json(out.run_json, {**metadata, "steps": total, "config": config.to_dict(),
                                         "versions": versions()})
        env_fn = functools.partial(vector, case, physics=metadata["physics"],
                                   initial_field="random", duration=metadata["episode_duration_s"],
                                   randomize=case.training.randomize)
        train = functools.partial(
            train_seeds, env_fn, [config], total, [out.path], resume=start is None,
            progress=progress, metadata=[metadata],
            progress_desc=f"refine {case.name} {CaseDir.seed_name(config.seed)}")
        if start is None:
            train()
        else:
            with starting_file(*start, out.path) as init_from:
                train(init_from=[init_from])
        mark_run_folder(out.path, "refine", case.name)


def _other_robot(case: Case, spec: str | Path, randomize: str | None
                 ) -> tuple[Case, dict[str, Any]]:
    """The case of ``spec`` and what the refined run records of it, after checking that it is the
    run's robot with other physical values only (its name, yardstick and training settings stay
    the run's, but for the spec's ``[training.randomize]``, applied when it has one)."""
    other = load_case(spec)
    if (refusal := batched_refusal(other.robot_spec("training"), "msr refine")) is not None:
        raise ValueError(f"--spec {spec}: {refusal}")  # before comparing: the table is the reason
    try:
        changes = physical_differences(case.to_dict(), other.to_dict())
    except VariationError as err:
        raise ValueError(f"--spec {spec}: not the run's robot with other physical values: {err}") from None
    record = {"spec_from": str(spec),
              "physical_changes": {k: [a, b] for k, (a, b) in changes.items()}}
    training = case.training
    if other.training.randomize:
        _check_same_randomize(spec, other, randomize)
        training = dataclasses.replace(training, randomize=other.training.randomize)
        record["refine_randomize"] = "spec"
    other = dataclasses.replace(other, name=case.name, yardstick=case.yardstick, training=training)
    return other, record


def _check_same_randomize(spec: str | Path, other: Case, randomize: str | None) -> None:
    """Refuse a ``--randomize`` that disagrees with the ``[training.randomize]`` of ``spec``
    (whose case is ``other``), naming both."""
    if randomize is None:
        return
    table = randomize_table(other.training.randomize)
    wanted = {} if randomize == "none" else randomize_table(
        tuple(default_variations(other.robot.tables)))
    if table != wanted:
        ranges = ", ".join(f"{k} = {v!r}" for k, v in table.items())
        meant = "the nominal robot" if randomize == "none" else "the default variation set: " + \
            ", ".join(f"{k} = {v!r}" for k, v in wanted.items())
        raise ValueError(f"--spec {spec}: its [training.randomize] ({ranges}) disagrees with "
                         f"--randomize {randomize} ({meant}); give one of them (without "
                         "--randomize the spec's table applies)")
