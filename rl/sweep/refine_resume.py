"""What ``msr refine --resume`` continues (issue 48): the refinement as its own ``run.json``
records it, never the options' defaults. The agent in the refined ``checkpoint.pt`` was trained on
the recorded robot (``case_spec``: a ``--spec``'s values, its ``[training.randomize]``), physics
and episode length, so a resume takes them from the record and keeps its provenance
(``spec_from``, ``physical_changes``, ``refine_randomize``, ``refined_from``); an option given
that contradicts the record is refused, naming it; and a resume at its target steps is refused
before any file is touched (``resume_checks.check_steps_left`` does the same for ``msr train``).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..cases.case import Case, case_from_metadata
from ..runfiles.checkpoint import load_checkpoint
from ..runfiles.rundir import RunDir
from .randomize_settings import randomized_cases
from .run_records import first_difference

__all__ = ["ResumedRefinement", "resumed_refinement"]

#: Keys of a refinement's ``run.json`` that each training call writes anew (not its settings).
_PER_CALL = ("steps", "config", "versions", "torch_threads", "resumed")

#: What the record must hold to be continued.
_NEEDED = ("case_spec", "physics", "episode_duration_s", "refine_start_step", "refine_steps")


@dataclass(frozen=True)
class ResumedRefinement:
    """A refinement to continue: the case it trains on, its record (``run.json`` less the
    per-call keys, ``refine_steps`` updated to the target) and the global step it trains to."""

    case: Case
    metadata: dict[str, Any]
    total: int

    @property
    def physics(self) -> str:
        return str(self.metadata["physics"])

    @property
    def episode_duration(self) -> float:
        """s."""
        return float(self.metadata["episode_duration_s"])


def resumed_refinement(out: RunDir, run: str | os.PathLike, *, steps: int | None,
                       physics: str | None, episode_duration: float | None,
                       randomize: str | None, spec_case: tuple[str, Case] | None
                       ) -> ResumedRefinement:
    """The refinement in ``out`` to continue, checked against what the resume was given: ``run``
    (the run folder, or the checkpoint file whose actor was refined), ``steps`` (``None``: the
    recorded ``refine_steps``), ``physics`` and ``episode_duration`` (s; ``None``: the record's),
    ``randomize`` and ``spec_case`` (``(options, case)``: the case a ``--spec`` makes, when one
    was given). Raises ``ValueError`` naming each contradicting option with the record's value,
    or saying there is nothing to refine; nothing is written."""
    record = _refinement_record(out)
    recorded = case_from_metadata(record, str(out.run_json))
    wrong = _contradictions(record, recorded, Path(run), physics, episode_duration, randomize,
                            spec_case)
    if wrong:
        raise ValueError(f"cannot resume the refinement in {out.path} with other settings ("
                         + "; ".join(wrong) + f"): its checkpoint was trained as {RunDir.RUN_JSON} "
                         "records; drop these options (a resume takes the record's), or refine "
                         "into another --out")
    start = int(record["refine_start_step"])
    refine_steps = int(steps) if steps is not None else int(record["refine_steps"])
    _check_steps_left(out, start, refine_steps, steps is None)
    metadata = {k: v for k, v in record.items() if k not in _PER_CALL}
    return ResumedRefinement(recorded, {**metadata, "refine_steps": refine_steps},
                             start + refine_steps)


def _refinement_record(out: RunDir) -> dict[str, Any]:
    """``out``'s ``run.json``, refused (``ValueError`` naming the file) when it is missing,
    unreadable or not a refinement's record (one that cannot be continued as it was made)."""
    path = out.run_json
    try:
        record = json.loads(path.read_text())
    except FileNotFoundError:
        raise ValueError(f"cannot resume the refinement in {out.path}: its {RunDir.RUN_JSON} (the "
                         "record of its robot, physics and provenance) is missing") from None
    except (OSError, ValueError) as err:
        raise ValueError(f"{path}: not readable JSON ({err}); cannot resume the refinement "
                         "without its record") from None
    missing = [k for k in _NEEDED if k not in record] if isinstance(record, dict) else list(_NEEDED)
    if missing or record.get("command") != "refine":
        raise ValueError(f"{path}: not the record of a `msr refine` (missing: "
                         f"{', '.join(missing) or 'command = refine'}); cannot resume it")
    return record


def _contradictions(record: dict[str, Any], recorded: Case, run: Path, physics: str | None,
                    episode_duration: float | None, randomize: str | None,
                    spec_case: tuple[str, Case] | None) -> list[str]:
    """Each option given that differs from the record: ``"--OPTION VALUE: the refinement's
    VALUE"``."""
    wrong = []
    if physics is not None and physics != record["physics"]:
        wrong.append(f"--physics {physics}: the refinement's {record['physics']}")
    if episode_duration is not None and episode_duration != record["episode_duration_s"]:
        wrong.append(f"--episode-duration {episode_duration:g} s: the refinement's "
                     f"{record['episode_duration_s']:g} s")
    trained_on = recorded.to_dict()
    if spec_case is not None:
        options, case = spec_case
        if case.to_dict() != trained_on:
            wrong.append(f"{options}: its robot differs from the refinement's at "
                         f"{first_difference(trained_on, case.to_dict())} (the refinement's: "
                         f"{_robot_source(record)})")
    elif randomize is not None:
        case = randomized_cases({recorded.name: recorded}, randomize,
                                recorded.training.recipe)[recorded.name]
        if case.to_dict() != trained_on:
            wrong.append(f"--randomize {randomize}: the refinement's [training.randomize] is "
                         f"{_randomize_text(trained_on)} ({_robot_source(record)})")
    source = _other_source(run, record.get("refined_from"))
    if source:
        wrong.append(source)
    return wrong


def _robot_source(record: dict[str, Any]) -> str:
    """Where the refinement's robot came from, in words."""
    spec = f"--spec {record['spec_from']}" if "spec_from" in record else "the run's robot"
    randomize = record.get("refine_randomize")
    return spec + (f", randomize {randomize}" if randomize else "")


def _randomize_text(spec: dict[str, Any]) -> str:
    table = (spec.get("training") or {}).get("randomize") or {}
    return "{" + ", ".join(f"{k} = {v!r}" for k, v in table.items()) + "}" if table else "none"


def _other_source(run: Path, refined_from: str | None) -> str | None:
    """``run`` (a run folder, or a checkpoint file) when it is not what the refinement continued
    (``refined_from``, a checkpoint file); ``None`` when it is, or when either cannot be found
    (a moved run: the record is kept as it is)."""
    if not refined_from or not run.exists() or not Path(refined_from).exists():
        return None
    recorded = Path(refined_from)
    same = (os.path.samefile(run, recorded.parent) if run.is_dir()
            else os.path.samefile(run, recorded))
    if same:
        return None
    return f"RUN or --checkpoint {run}: the refinement continued {refined_from}"


def _check_steps_left(out: RunDir, start: int, refine_steps: int, recorded_steps: bool) -> None:
    """Refuse a resume whose target (``start + refine_steps``) the refined checkpoint has reached:
    it would train nothing and only rewrite the records."""
    step = int(load_checkpoint(out.checkpoint, with_buffer=False)["global_step"])
    if step < start + refine_steps:
        return
    given = "its recorded --steps" if recorded_steps else "--steps"
    raise ValueError(f"nothing to refine: {out.path} is already at step {step}, the target of "
                     f"{given} {refine_steps} from step {start} (nothing was changed); give "
                     f"--steps above {step - start} to refine further")
