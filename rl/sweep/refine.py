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

from elastica_magnetic.io import atomic_write_json

from ..cases.case import Case, case_from_metadata, load_case, randomize_table
from ..cases.variations import VariationError, default_variations, physical_differences
from ..runfiles.checkpoint import checkpoint_metadata
from ..runfiles.locking import held_run_folders, mark_run_folder
from ..runfiles.provenance import versions
from ..runfiles.rundir import CaseDir, RunDir
from .randomize_settings import randomized_cases
from .refine_start import check_refine_output, default_refine_output, refine_source, starting_file
from .run_records import run_metadata
from .summaries import summarize_run

if TYPE_CHECKING:  # torch is imported only when a refinement runs
    from ..td3.algorithm import TD3Config

__all__ = ["check_refined_case", "refine"]


def refine(
    run: str | Path,
    steps: int = 1000,
    out: str | Path | None = None,
    resume: bool = False,
    progress: bool = True,
    episode_duration: float = 20.0,
    physics: str = "accurate",
    device: str | None = None,
    spec: str | Path | None = None,
    randomize: str | None = None,
) -> dict[str, Any]:
    """Continue training a run for ``steps`` more environment steps in ``physics`` (``"accurate"``,
    default, or ``"training"``) on ``device`` (default the run's).

    ``run``: a run folder or its ``checkpoint.pt``, whose final actor is refined, or its ``best.pt``
    (:func:`~elastica_magnetic_rl.sweep.refine_start.refine_source`: best.pt's networks, the rest of
    the run's training state; which actor to refine is the command line's choice, the rule of
    ``msr generate``). The agent (networks, targets, optimisers), its replay buffer, RNG states and
    counters come from the run's checkpoint (``init_from``), so learning continues at once (the
    counters are past the warm-up) with the training-physics transitions still in the buffer,
    gradually displaced by accurate ones. Episodes keep the training setting (random initial
    field, 20 s). The refined run goes to ``out`` (default ``RUN/refined``) with its own
    ``episodes.csv``, TensorBoard scalars, ``checkpoint.pt`` and ``run.json``; ``resume``
    continues an interrupted refinement.

    ``spec``: a spec file (or shipped case) of the same robot with other physical values (e.g.
    the ``identified.toml`` of ``msr identify``): the refinement trains on that robot. Anything
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
    final actor is what ``msr generate`` and ``msr robustness`` play.

    Cost: one accurate step is 1250 substeps (~0.1 s here), 12.5x a training step.
    """
    from ..td3.algorithm import TD3Config

    if steps < 1:
        raise ValueError("steps must be >= 1")
    source = RunDir.checkpoint_of(run)
    ckpt, start = refine_source(source)
    meta = checkpoint_metadata(ckpt, start["state_from"])
    case, changes = _refined_case(case_from_metadata(meta, str(source)), spec, randomize)
    out = RunDir(out if out is not None else default_refine_output(source))
    start_step = int(ckpt["global_step"])
    config = TD3Config.from_dict(ckpt["config"])
    if device is not None:
        config.device = device
    _check_refinement_learns(ckpt, source, steps)
    metadata = run_metadata(
        case, physics, episode_duration, config.seed, command="refine",
        refined_from=str(source), refine_start_step=start_step, refine_steps=int(steps),
        training_steps=int(meta.get("training_steps", start_step)), refined_actor=start["actor"],
        refined_actor_step=start["actor_step"], **changes,
    )
    check_refine_output(out.path, resume)
    begin = time.perf_counter()
    _train_refinement(case, ckpt, start, out, config, metadata, start_step + int(steps),
                      physics=physics, episode_duration=episode_duration, resume=resume,
                      progress=progress)
    summary = summarize_run(out.path, reward_scale=case.task.reward_scale)
    return {"case": case.name, "source": str(source), "run_dir": str(out.path),
            "checkpoint": str(out.checkpoint), "start_step": start_step, "steps": int(steps),
            "actor": start["actor"], "actor_step": start["actor_step"],
            "physics": physics, **{k: summary[k] for k in ("episodes", "final_mean_return")},
            "wall_s": time.perf_counter() - begin}


def check_refined_case(source: str | Path, steps: int, spec: str | Path | None,
                       randomize: str | None) -> None:
    """Check a refinement of ``source`` (a run folder or one of its checkpoint files) for
    ``steps`` more steps on ``spec`` with ``randomize`` before any work (the command line's
    evaluations that choose the actor take a minute): ``ValueError`` naming the key or the
    setting, as :func:`refine` would raise it."""
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
    return case, changes


def _train_refinement(case: Case, ckpt: dict[str, Any], start: dict[str, Any], out: RunDir,
                      config: TD3Config, metadata: dict[str, Any], total: int, *, physics: str,
                      episode_duration: float, resume: bool, progress: bool) -> None:
    """Train ``out`` to ``total`` steps from ``ckpt`` under the run-folder lock, its ``run.json``
    written first (a killed refinement leaves a folder that ``resume`` continues)."""
    from ..envs.vector_env import make_vector_env
    from ..runner.loop import train_seeds

    with held_run_folders([out.path]) as notes:
        for note in notes:  # a stale lock of a killed refinement taken over, its leftovers removed
            print(f"note: {note}", file=sys.stderr)
        mark_run_folder(out.path, "refine", case.name)
        atomic_write_json(out.run_json, {**metadata, "steps": total, "config": config.to_dict(),
                                         "versions": versions()})
        with starting_file(ckpt, start, out.path) as init_from:
            train_seeds(functools.partial(make_vector_env, case, physics=physics,
                                          initial_field="random", duration=episode_duration,
                                          randomize=case.training.randomize),
                        [config], total, [out.path], resume=resume, progress=progress,
                        init_from=[init_from], metadata=[metadata],
                        progress_desc=f"refine {case.name} {CaseDir.seed_name(config.seed)}")
        mark_run_folder(out.path, "refine", case.name)


def _other_robot(case: Case, spec: str | Path, randomize: str | None
                 ) -> tuple[Case, dict[str, Any]]:
    """The case of ``spec`` and what the refined run records of it, after checking that it is the
    run's robot with other physical values only (its name, yardstick and training settings stay
    the run's, but for the spec's ``[training.randomize]``, applied when it has one)."""
    try:
        other = load_case(spec)
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
