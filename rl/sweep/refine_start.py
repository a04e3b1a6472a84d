"""Where ``msr refine`` starts: a run's training state (``checkpoint.pt``: replay buffer, Adam
moments, RNG states, counters) with the networks of the actor it refines, the final one's own or
``best.pt``'s (which holds only networks: :mod:`~elastica_magnetic_rl.runfiles.checkpoint`)."""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from ..runfiles.checkpoint import load_checkpoint, refuse_networks_only, save_checkpoint
from ..runfiles.locking import check_not_owned
from ..runfiles.rundir import RunDir

__all__ = ["check_refine_output", "default_refine_output", "refine_source", "starting_file"]

#: The networks ``best.pt`` holds, and the target networks that start equal to them.
_NETWORKS = {"actor": "actor_target", "critic": "critic_target"}


def default_refine_output(source: str | os.PathLike) -> Path:
    """Where a refinement of ``source`` (a run folder or one of its checkpoint files) goes without
    ``--out``: the run folder's ``refined/``."""
    source = Path(source)
    return (RunDir(source) if source.is_dir() else RunDir.of_checkpoint(source)).refined.path


def check_refine_output(out: str | os.PathLike, resume: bool,
                        source: str | os.PathLike | None = None) -> None:
    """Refuse ``out`` before anything runs: a folder of another command (a training run's),
    unless ``resume`` one already holding a refined checkpoint, and with ``resume`` one without
    (nothing to continue; where the ``source`` given is itself a refinement, the message gives
    the command that continues it). ``FileExistsError`` / ``FileNotFoundError`` / ``ValueError``
    naming it."""
    check_not_owned(out, "refine")  # never a training run's folder (its checkpoint, run.json)
    _check_refine_place(out, source)
    held = RunDir(out).checkpoint.exists()
    if held and not resume:
        raise FileExistsError(f"{out} already holds a refined checkpoint (use --resume or --out)")
    if resume and not held:
        origin = _refined_from(source)
        if origin is not None:
            raise FileNotFoundError(
                f"cannot resume: {source} is itself a refinement (of {origin}), and a refinement "
                f"of it would go to {out}, which holds none; to continue {source}: msr refine "
                f"{origin} --out {source} --resume")
        raise FileNotFoundError(f"cannot resume: {out} holds no refined {RunDir.CHECKPOINT} "
                                "(drop --resume to start the refinement)")


def _check_refine_place(out: str | os.PathLike, source: str | os.PathLike | None = None) -> None:
    """A refinement lives in the run it refines (``RUN/refined``, a run's or a refinement's folder;
    ``source``: the run or checkpoint refined) or in a folder of no command's: not inside another
    run, nor inside another command's result (an export, a simulation), nor in a training's case
    folder beside its seed folders (msr train --resume would refuse that folder). ``ValueError``
    naming the folder."""
    from elastica_magnetic.io import display_path, normalized_path
    from elastica_magnetic.locks import held_here
    from elastica_magnetic.result_markers import describe_result, recognized_marker
    from elastica_magnetic.result_places import (
        held_refusal,
        inside_building,
        inside_result,
        result_above,
        training_run_in,
    )

    final = normalized_path(out)
    for parent in final.parents:
        # a folder this process writes (msr loop's) or builds (a loop started over) holds its steps' runs
        if held_here(parent) or inside_building(parent):
            return
        # recognized, not only marked: a committed seed campaign or a result written before markers
        # carries no marker file and is still another command's result
        marker = recognized_marker(parent)
        if marker is not None and marker.get("kind") in ("train", "refine"):
            if source is None or parent == (mine := _run_folder(source)) or parent in mine.parents:
                return  # the run refined (or one holding it: a refinement of its refinement)
            raise ValueError(f"--out {display_path(final)}: lies in {display_path(parent)}, which holds "
                             f"{describe_result(marker)}, not the run refined ({display_path(mine)}): a "
                             "refinement goes in the run it refines, or in a folder of no command's; "
                             "choose another --out (default: RUN/refined)")
        if marker is not None:
            raise ValueError(f"--out {display_path(final)}: lies in {display_path(parent)}, which holds "
                             f"{describe_result(marker)}: a result is replaced whole, so nothing goes inside "
                             "another; choose another --out (default: RUN/refined)")
        if (refusal := held_refusal(parent, final, "--out")) is not None:  # a shipped policy's folder
            if (outer := result_above(parent)) is not None:  # a seed of a campaign: the campaign named
                raise ValueError(inside_result(final, *outer, "--out") + " (default: RUN/refined)")
            raise ValueError(refusal)
        if (run := training_run_in(parent, final)) is not None:
            raise ValueError(f"--out {display_path(final)}: lies in {display_path(parent)}, which holds the "
                             f"runs of a training ({run.name}): that folder holds its runs alone (msr train "
                             "--resume refuses anything else there); choose another --out (default: "
                             "RUN/refined)")


def _run_folder(source: str | os.PathLike) -> Path:
    """The run folder (normalized) of ``source``, a run folder or one of its checkpoint files."""
    from elastica_magnetic.io import normalized_path

    source = Path(source)
    return normalized_path((RunDir(source) if source.is_dir() else RunDir.of_checkpoint(source)).path)


def _refined_from(source: str | os.PathLike | None) -> str | None:
    """The run a refinement folder (or its checkpoint) ``source`` refined, from its ``run.json``;
    ``None`` for anything else."""
    if source is None:
        return None
    source = Path(source)
    run = RunDir(source) if source.is_dir() else RunDir.of_checkpoint(source)
    with contextlib.suppress(OSError, ValueError):
        record = json.loads(run.run_json.read_text(encoding="utf-8"))
        if isinstance(record, dict) and record.get("command") == "refine":
            origin = record.get("refined_from")
            return str(RunDir.of_checkpoint(origin).path) if origin else None
    return None


def refine_source(path: str | os.PathLike) -> tuple[dict[str, Any], dict[str, Any]]:
    """The checkpoint a refinement of ``path`` starts from, and where it came from.

    ``path``: a run's ``checkpoint.pt`` (returned as loaded) or a ``best.pt`` (its actor and critic,
    also as the target networks, put into the training state of the ``checkpoint.pt`` beside it:
    that run's replay buffer, Adam moments, RNG states and counters, so learning continues at
    once). Returns ``(checkpoint, provenance)``; ``provenance``: ``actor`` (``"final"`` or
    ``"best"``), ``actor_step`` (the global step the networks are from) and ``state_from`` (the file
    the training state is from). Raises ``ValueError`` naming the file for a checkpoint that cannot
    be continued (an older format, a ``best.pt`` of other networks than its run's) and
    ``FileNotFoundError`` for a ``best.pt`` without its run's ``checkpoint.pt``."""
    path = Path(path)
    ckpt = load_checkpoint(path)
    if ckpt.get("kind") != "best":
        refuse_networks_only(ckpt, path)
        return ckpt, {"actor": "final", "actor_step": int(ckpt["global_step"]),
                      "state_from": str(path)}
    state_path = RunDir.of_checkpoint(path).checkpoint
    if not state_path.is_file():
        raise FileNotFoundError(f"{path} holds only the networks of the best evaluation; refining "
                                f"them needs the training state of its run's {RunDir.CHECKPOINT} "
                                f"(replay buffer, optimisers), and {state_path} does not exist")
    state = load_checkpoint(state_path)
    refuse_networks_only(state, state_path)
    for key in ("obs_dim", "act_dim"):
        if ckpt.get(key) != state.get(key):
            raise ValueError(f"{path}: its networks ({key} {ckpt.get(key)}) are not those of "
                             f"{state_path} ({key} {state.get(key)})")
    agent = dict(state["agent"])
    for name, target in _NETWORKS.items():
        shapes = {k: tuple(v.shape) for k, v in agent[name].items()}
        if {k: tuple(v.shape) for k, v in ckpt["agent"][name].items()} != shapes:
            raise ValueError(f"{path}: its {name} has other layers than {state_path}'s")
        agent[name] = agent[target] = ckpt["agent"][name]
    state["agent"] = agent
    return state, {"actor": "best", "actor_step": int(ckpt["global_step"]),
                   "state_from": str(state_path)}


@contextlib.contextmanager
def starting_file(ckpt: dict[str, Any], provenance: dict[str, Any],
                  folder: str | os.PathLike) -> Iterator[Path]:
    """A file holding ``ckpt`` (from :func:`refine_source`) to start training from: the run's
    ``checkpoint.pt`` itself for its final actor, else a temporary file in ``folder`` (the replay
    buffer inside it), removed on leaving."""
    if provenance["actor"] == "final":
        yield Path(provenance["state_from"])
        return
    with tempfile.TemporaryDirectory(prefix=".refine-start-", dir=folder) as tmp:
        path = Path(tmp) / RunDir.CHECKPOINT
        buffer = {k: v for k, v in ckpt["buffer"].items() if k not in ("file", "rows")}
        save_checkpoint(path, {**ckpt, "buffer": buffer})
        yield path
