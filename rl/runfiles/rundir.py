"""The folders a training writes, and the name of every file in them (one home: no other module
spells a run file's name).

A **case folder** ``OUT/<case>/`` (:class:`CaseDir`) holds ``summary.json`` (every seed of the
case, written by ``msr train``) and one run folder per seed, ``seed<k>/``. A **run folder**
(:class:`RunDir`) holds

- ``checkpoint.pt`` and ``replay.bin``: the checkpoint and the replay buffer's rows
  (format: :mod:`elastica_magnetic_rl.runfiles.checkpoint`);
- ``best.pt``: the networks of the best evaluation during training;
- ``episodes.csv`` (one row per finished episode) and ``evaluations.csv`` (one row per
  evaluation), next to TensorBoard's event files;
- ``run.json``: the run's case, settings, steps reached and versions;
- ``evaluation.json``: the shipping criterion's cached evaluation of the seed (``msr policy export-seeds``);
- ``refined/``: the run folder of its refinement (``msr refine``).

An exported seed folder (``msr policy export-seeds``: ``<policies>/<case>/seeds/<recipe>/seed<k>/``) keeps
the same names for the training logs it copies (:attr:`RunDir.TRAINING_LOGS`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

__all__ = ["CaseDir", "RunDir", "seed_runs_hint"]


@dataclass(frozen=True)
class RunDir:
    """One seed's run folder (``path``; it need not exist yet). Its attributes are the paths of
    the files a run writes there."""

    path: Path

    CHECKPOINT = "checkpoint.pt"
    BEST = "best.pt"
    REPLAY = "replay.bin"
    EPISODES_CSV = "episodes.csv"
    EVALUATIONS_CSV = "evaluations.csv"
    RUN_JSON = "run.json"
    EVALUATION_JSON = "evaluation.json"
    REFINED = "refined"
    #: The training logs copied with an exported seed.
    TRAINING_LOGS = (EPISODES_CSV, EVALUATIONS_CSV)

    def __init__(self, path: str | os.PathLike) -> None:
        object.__setattr__(self, "path", Path(path))

    def __fspath__(self) -> str:
        return os.fspath(self.path)

    @property
    def checkpoint(self) -> Path:
        return self.path / self.CHECKPOINT

    @property
    def best(self) -> Path:
        return self.path / self.BEST

    @property
    def replay(self) -> Path:
        return self.path / self.REPLAY

    @property
    def episodes_csv(self) -> Path:
        return self.path / self.EPISODES_CSV

    @property
    def evaluations_csv(self) -> Path:
        return self.path / self.EVALUATIONS_CSV

    @property
    def run_json(self) -> Path:
        return self.path / self.RUN_JSON

    @property
    def evaluation_json(self) -> Path:
        return self.path / self.EVALUATION_JSON

    @property
    def refined(self) -> RunDir:
        """The folder ``msr refine`` writes by default: ``<run>/refined/``."""
        return RunDir(self.path / self.REFINED)

    def leftover_temporaries(self) -> list[Path]:
        """Temporary files a writer of this folder leaves only when it is killed mid-write: the
        checkpoints' and logs' ``NAME.tmp`` and the ``.STEM.tmpPID.SUFFIX`` of an atomic write
        (:func:`elastica_magnetic.io.atomic_write`) of a run file. Safe to remove only under the
        folder's lock."""
        names = (self.CHECKPOINT, self.BEST, self.EPISODES_CSV, self.EVALUATIONS_CSV,
                 self.RUN_JSON, self.EVALUATION_JSON)
        found = [self.path / f"{name}.tmp" for name in names]
        for name in names:
            stem, suffix = os.path.splitext(name)
            found += [p for p in self.path.glob(f".{stem}.tmp*{suffix}")
                      if p.name[len(stem) + 5:len(p.name) - len(suffix)].isdigit()]
        return [p for p in found if p.is_file()]

    def has_checkpoint(self) -> bool:
        return self.checkpoint.is_file()

    def has_episodes(self) -> bool:
        return self.episodes_csv.is_file()

    @staticmethod
    def checkpoint_of(run: str | os.PathLike) -> Path:
        """The checkpoint file of ``run``: a run folder (its ``checkpoint.pt``) or a checkpoint
        file itself. Raises ``FileNotFoundError`` naming ``run`` when there is none."""
        run = Path(run)
        path = RunDir(run).checkpoint if run.is_dir() else run
        if not path.is_file():
            if hint := being_written_hint(run):
                raise FileNotFoundError(f"{run}: no {RunDir.CHECKPOINT} yet: {hint}")
            raise FileNotFoundError(f"{run}: no {RunDir.CHECKPOINT} (expected a run directory or a "
                                    "checkpoint)")
        return path

    @staticmethod
    def of_checkpoint(path: str | os.PathLike) -> RunDir:
        """The run folder holding the checkpoint file ``path``."""
        return RunDir(Path(path).parent)


@dataclass(frozen=True)
class CaseDir:
    """A case's folder of a training output (``OUT/<case>/``): a run folder per seed and the
    case's ``summary.json``."""

    path: Path

    SUMMARY_JSON = "summary.json"
    SEED_PREFIX = "seed"

    def __init__(self, path: str | os.PathLike) -> None:
        object.__setattr__(self, "path", Path(path))

    def __fspath__(self) -> str:
        return os.fspath(self.path)

    @classmethod
    def of(cls, out: str | os.PathLike, case: str) -> CaseDir:
        """The folder of ``case`` in the training output ``out``."""
        return cls(Path(out) / case)

    @property
    def summary_json(self) -> Path:
        return self.path / self.SUMMARY_JSON

    @classmethod
    def seed_name(cls, seed: int) -> str:
        """The folder name of seed ``seed``: ``seed<k>``."""
        return f"{cls.SEED_PREFIX}{int(seed)}"

    @classmethod
    def seed_of(cls, name: str) -> int | None:
        """The seed a folder name ``seed<k>`` stands for; ``None`` for any other name."""
        tail = name[len(cls.SEED_PREFIX):]
        return int(tail) if name.startswith(cls.SEED_PREFIX) and tail.isdigit() else None

    def seed(self, seed: int) -> RunDir:
        """The run folder of seed ``seed``."""
        return RunDir(self.path / self.seed_name(seed))

    def seeds(self) -> list[tuple[int, RunDir]]:
        """``(seed, run folder)`` of every ``seed<k>/`` folder present, ordered by seed."""
        found = ((self.seed_of(p.name), p) for p in self.path.glob(f"{self.SEED_PREFIX}*"))
        return sorted((k, RunDir(p)) for k, p in found if k is not None and p.is_dir())


def being_written_hint(path: str | os.PathLike) -> str:
    """Where another msr process holds ``path``'s lock (a seed being trained, before its first
    checkpoint), a sentence naming it; otherwise ``""``. For messages of commands that read a run
    and find no checkpoint."""
    from elastica_magnetic.locks import describe_owner, host_name, live_owner

    owner = live_owner(path) if Path(path).is_dir() else None
    if owner is None or (owner.get("pid") == os.getpid() and owner.get("host") == host_name()):
        return ""
    words = str(owner.get("command") or "").split()
    command = " ".join(words[:2]) if words[:1] == ["msr"] else ""
    if command and command not in TRAINING_COMMANDS:  # a design, a replay...: never a checkpoint here
        return (f"it is being written by {describe_owner(owner)}, a `{command}` result, not a training "
                "run: it will hold no policy checkpoint")
    return (f"it is being written by another msr command, {describe_owner(owner)}, which has not "
            "written its first checkpoint yet: wait for it (the run's checkpoint comes every "
            "checkpoint_every steps, and at its end)")


#: The commands that write a run's checkpoints (``msr CMD``).
TRAINING_COMMANDS = ("msr train", "msr refine", "msr loop")


def seed_runs_hint(path: str | os.PathLike) -> str:
    """Where ``path`` is a folder of seed runs (a case folder ``OUT/<case>/``, an exported
    ``seeds/<recipe>/``) or a training output holding case folders, a sentence saying so and
    naming the run folder to give instead; otherwise ``""``. For messages of commands that take
    one run."""
    path = Path(path)
    if not path.is_dir():
        return ""
    seeds = [run for _, run in CaseDir(path).seeds() if run.has_checkpoint() or run.run_json.is_file()]
    if seeds:
        names = ", ".join(run.path.name for run in seeds)
        return (f"it is a folder of seed runs ({names}), not one run: give one of them, "
                f"e.g. {seeds[0].path}")
    cases = [child for child in sorted(path.iterdir()) if child.is_dir()
             and any(run.has_checkpoint() for _, run in CaseDir(child).seeds())]
    if cases:
        first = next(run for _, run in CaseDir(cases[0]).seeds() if run.has_checkpoint())
        return (f"it is a training output holding the case folders "
                f"{', '.join(c.name for c in cases)}: give one seed's run, e.g. {first.path}")
    return ""
