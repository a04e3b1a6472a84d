"""The training checkpoint format: one home for file names, the format tag, atomic writes and the
replay buffer's append-only file.

A run directory (:class:`~elastica_magnetic_rl.runfiles.rundir.RunDir`) holds ``checkpoint.pt`` (a
``torch.save`` dict, written atomically), and, next to it, ``replay.bin``: the replay buffer's transitions as
float32 rows appended at each checkpoint (``obs``, ``action``, ``reward``, ``next_obs``, ``terminated``, and a
DAgger run's ``label``), so a
checkpoint writes only the transitions collected since the previous one instead of the whole buffer. The
checkpoint records how many rows are valid; rows beyond that (written by a run killed between the append and
the checkpoint's rename) are ignored and cut off when the run resumes. A buffer that has wrapped around (a run
longer than the buffer's capacity) is stored whole inside the checkpoint instead.

Keys of a checkpoint (format :data:`CHECKPOINT_FORMAT`): ``config`` (the TD3 configuration), ``obs_dim``,
``act_dim``, ``action_low``, ``action_high``, ``agent`` (networks, targets and Adam moments as plain-module
state dicts, RNG states, counters: :meth:`elastica_magnetic_rl.td3.algorithm.TD3.seed_state`), ``buffer``
(:meth:`elastica_magnetic_rl.td3.replay_buffer.ReplayBuffer.state_dict` without contents, plus ``file`` and
``rows``), ``global_step``, ``episode``, ``at_episode_boundary``, ``python_rng``, ``torch_cpu_rng``,
``wall_time_s``, ``metadata``, ``evaluation`` and ``vector`` (the environments' state when the checkpoint
falls inside episodes, else ``None``). ``best.pt`` (``kind: "best"``) holds only the networks of the best
evaluation.

:func:`load_checkpoint` returns the buffer with its contents (as a checkpoint of the previous
format held them), so readers need not know about ``replay.bin``.
"""

from __future__ import annotations

import codecs
import contextlib
import os
from pathlib import Path
from typing import Any

import numpy as np
import torch

from elastica_magnetic.io import read_json

from .rundir import RunDir, being_written_hint, seed_runs_hint

CHECKPOINT_FORMAT = "td3-checkpoint-v2"
#: Earlier format: its networks can still be read (generate, export), not resumed or refined.
LEGACY_FORMATS = ("td3-checkpoint-v1",)
_BUFFER_KEYS = ("obs", "actions", "rewards", "next_obs", "terminated")


_ZIP_MAGIC = b"PK\x03\x04"  # torch.save's format is a zip archive
_PICKLE_PROTOCOL_OPCODE = 0x80


def torch_file_problem(path: str | os.PathLike, error: BaseException) -> str:
    """Why ``torch.load(path, weights_only=True)`` failed with ``error``, for people: what the
    file is (empty, text such as a CSV or TOML, a bare pickle, a damaged archive, an archive
    holding Python objects). Never advises ``weights_only=False``: that would run code from
    the file."""
    try:
        with open(path, "rb") as handle:
            head = handle.read(64)
    except OSError as exc:
        return f"cannot be read ({exc.strerror or exc})"
    if not head:
        return "is empty (0 bytes): a write that was cut short; restore it or use another file"
    if head.startswith(_ZIP_MAGIC):
        if "weights only" in str(error).lower():
            return ("holds Python objects other than tensors, numbers and strings: msr loads "
                    "torch files with weights_only=True and runs no code from them; it was not "
                    "written by msr")
        first = str(error).splitlines()[0].split(". ")[0][:160] if str(error) else "cut short"
        return f"is a damaged or truncated torch file ({type(error).__name__}: {first})"
    if head[0] == _PICKLE_PROTOCOL_OPCODE:
        return "is a bare Python pickle, not a torch file written by msr (torch.save)"
    try:
        text = codecs.getincrementaldecoder("utf-8")().decode(head)  # a cut last character is fine
    except UnicodeDecodeError:
        text = "\x00"
    if not text.strip() or not all(c.isprintable() or c in "\t\r\n" for c in text):
        return "is not a torch file (it does not begin as torch.save's zip archive does)"
    text = text.strip().splitlines()[0][:40]
    return f"is a text file (it begins {text!r}), not a torch file: was another file given here?"


def state_to_tensors(obj: Any) -> Any:
    """numpy arrays -> CPU tensors, recursively (checkpoints load with ``weights_only=True``)."""
    if isinstance(obj, np.ndarray):
        return torch.from_numpy(obj.copy())
    if isinstance(obj, dict):
        return {k: state_to_tensors(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return type(obj)(state_to_tensors(v) for v in obj)
    return obj


def state_to_numpy(obj: Any) -> Any:
    """Inverse of :func:`state_to_tensors`."""
    if isinstance(obj, torch.Tensor):
        return obj.numpy().copy()
    if isinstance(obj, dict):
        return {k: state_to_numpy(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return type(obj)(state_to_numpy(v) for v in obj)
    return obj



def save_checkpoint(path: str | os.PathLike, checkpoint: dict[str, Any]) -> None:
    """Write ``checkpoint`` atomically: to a temporary file in the same directory, then rename.

    The previous checkpoint stays until the new one is complete: on any failure (a full disk) or
    interruption the temporary file is removed and ``path`` is left as it was; an ``OSError``
    becomes :class:`~elastica_magnetic.io.OutputPathError` naming the file."""
    from elastica_magnetic.io import OutputPathError

    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    try:
        with open(tmp, "wb") as f:
            writer = _Writer(f)
            try:
                torch.save(checkpoint, writer)
            except RuntimeError:
                # torch's writer turns the file's own error (a full disk) into "unexpected pos"
                if writer.error is not None:
                    raise writer.error from None
                raise
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException as exc:
        tmp.unlink(missing_ok=True)
        if isinstance(exc, OSError) and not isinstance(exc, OutputPathError):
            kept = ("the previous checkpoint is kept; --resume continues from it" if path.exists()
                    else "no checkpoint was written yet, so there is nothing to resume: free space "
                    "and run the same command again without --resume")
            raise OutputPathError(f"{path}: cannot write the checkpoint: {exc.strerror or exc} "
                                  f"({kept})") from exc
        raise


class _Writer:
    """The file ``torch.save`` writes to, keeping the ``OSError`` a write raised (``error``)."""

    def __init__(self, handle: Any) -> None:
        self.handle = handle
        self.error: OSError | None = None

    def write(self, data: Any) -> int:
        try:
            return self.handle.write(data)
        except OSError as exc:
            self.error = exc
            raise

    def flush(self) -> None:
        self.handle.flush()


def load_checkpoint(path: str | os.PathLike, with_buffer: bool = True) -> dict[str, Any]:
    """Load a checkpoint (a run directory or the file itself), the replay buffer's contents
    included unless ``with_buffer`` is false (a quick check that it is readable). Raises
    ``ValueError`` naming the file when it is not a readable TD3 checkpoint."""
    path = Path(path)
    if path.is_dir():
        if not RunDir(path).has_checkpoint():
            hint = being_written_hint(path) or seed_runs_hint(path)
            raise FileNotFoundError(f"{path}: no {RunDir.CHECKPOINT}: "
                                    + (hint or "expected a run directory or a checkpoint"))
        path = RunDir(path).checkpoint
    try:
        ckpt = torch.load(path, map_location="cpu", weights_only=True)
    except FileNotFoundError:
        raise
    except Exception as err:  # truncated, empty or foreign files
        raise ValueError(f"{path}: cannot be read as a checkpoint: {torch_file_problem(path, err)}") \
            from None
    if not isinstance(ckpt, dict) or ckpt.get("format") not in (CHECKPOINT_FORMAT, *LEGACY_FORMATS):
        shipped = (path.parent / "policy.json").is_file()  # a shipped policy's actor.pt or critic.pt
        raise ValueError(f"{path} is not a TD3 checkpoint ({CHECKPOINT_FORMAT})"
                         + (f": a file of the shipped policy {path.parent}, played by naming that folder "
                            f"as the policy (msr policy generate {path.parent}), not as a checkpoint of a run"
                            if shipped else ""))
    buffer = ckpt.get("buffer")
    if with_buffer and isinstance(buffer, dict) and "file" in buffer:
        ckpt["buffer"] = {**buffer, **read_replay_rows(path.parent / buffer["file"], buffer)}
    return ckpt


def checkpoint_metadata(ckpt: dict[str, Any], path: str | os.PathLike) -> dict[str, Any]:
    """The case and settings of a checkpoint (loaded from ``path``): its own metadata, else
    ``run.json`` next to it. Raises ``ValueError`` naming ``path`` when neither names a case."""
    meta = dict(ckpt.get("metadata") or {})
    run_json = RunDir.of_checkpoint(path).run_json
    if "case" not in meta and run_json.is_file():
        meta = {**read_json(run_json), **meta}
    if "case" not in meta:
        raise ValueError(f"{path}: the checkpoint names no case (no metadata, no {RunDir.RUN_JSON})")
    return meta


def refuse_networks_only(ckpt: dict[str, Any], path: str | os.PathLike) -> None:
    """Raise if ``ckpt`` cannot be a starting point for training (``best.pt``, or an older format)."""
    if ckpt.get("kind") == "best":
        raise ValueError(f"{path} holds only the networks of the best evaluation (no optimisers, "
                         f"buffer or RNG states): training can only continue from a run's "
                         f"{RunDir.CHECKPOINT}")
    if ckpt.get("format") != CHECKPOINT_FORMAT:
        raise ValueError(f"{path} is a {ckpt.get('format')} checkpoint: its policy can be used "
                         f"(generate, export, ship) but training cannot continue from it "
                         f"(needs {CHECKPOINT_FORMAT})")


# ----------------------------------------------------------------------------------------------
# The replay buffer's append-only file
# ----------------------------------------------------------------------------------------------
def replay_row_width(obs_dim: int, act_dim: int, labelled: bool = False) -> int:
    """float32 values per transition (a row of ``replay.bin``, and of a replay buffer in memory):
    ``obs``, ``action``, ``reward``, ``next_obs``, ``terminated`` (and a ``labelled`` buffer's
    ``label``, ``act_dim`` more)."""
    return 2 * obs_dim + act_dim + 2 + (act_dim if labelled else 0)


def _row_width(state: dict[str, Any]) -> int:
    """The row width of the replay file a buffer's checkpoint entry ``state`` refers to."""
    return replay_row_width(int(state["obs_dim"]), int(state["act_dim"]), bool(state.get("labelled")))


#: What to do about a replay file that does not hold what its checkpoint needs.
_REPLAY_FIX = ("restore it (e.g. from a backup), or train the seed afresh without --resume (another "
               "--out)")


def replay_problem(path: Path, state: dict[str, Any]) -> str | None:
    """Why the replay file ``path`` cannot give the ``state["rows"]`` transitions its checkpoint
    needs (missing, or cut short: judged by its size, nothing read), with the fix; ``None``: it can."""
    rows = int(state["rows"])
    width = _row_width(state)
    if not rows:
        return None
    if not path.is_file():
        return f"{path} is missing: the checkpoint needs its {rows} transitions; {_REPLAY_FIX}"
    held = path.stat().st_size // (4 * width)
    if held < rows:
        return (f"{path}: holds {held} transitions, the checkpoint needs {rows} (the file was cut "
                f"short: a partial copy, a full disk?); {_REPLAY_FIX}")
    return None


def read_replay_rows(path: Path, state: dict[str, Any]) -> dict[str, torch.Tensor]:
    """The first ``state["rows"]`` transitions of ``path`` as the tensors of a buffer state."""
    obs_dim, act_dim, rows = int(state["obs_dim"]), int(state["act_dim"]), int(state["rows"])
    width = _row_width(state)
    if (problem := replay_problem(path, state)) is not None:
        raise ValueError(problem)
    data = np.fromfile(path, dtype=np.float32, count=rows * width) if rows else np.zeros(0, np.float32)
    if data.size != rows * width:
        raise ValueError(f"{path}: holds {data.size // width} transitions, the checkpoint needs {rows}")
    data = data.reshape(rows, width)
    cuts = np.cumsum([obs_dim, act_dim, 1, obs_dim, 1])
    obs, actions, rewards, next_obs, terminated, labels = np.split(data, cuts, axis=1)
    columns = dict(zip(_BUFFER_KEYS, (obs, actions, rewards[:, 0], next_obs, terminated[:, 0]), strict=True))
    if state.get("labelled"):
        columns["labels"] = labels
    return {k: torch.from_numpy(np.ascontiguousarray(v)) for k, v in columns.items()}


class ReplayFile:
    """Appends a replay buffer's new transitions to ``run_dir/replay.bin`` at each checkpoint.

    ``rows``: transitions already in the file (and referenced by the last checkpoint). On resume
    the file is cut to the checkpoint's row count first, so a crash between an append and the
    checkpoint's rename leaves no stray rows behind.
    """

    def __init__(self, run_dir: Path, rows: int = 0) -> None:
        self.path = RunDir(run_dir).replay
        self.rows = int(rows)

    def truncate(self, obs_dim: int, act_dim: int, labelled: bool = False) -> None:
        """Cut the file to the checkpoint's rows (of a buffer of ``obs_dim`` observations and
        ``act_dim`` actions, ``labelled`` or not)."""
        width = replay_row_width(obs_dim, act_dim, labelled)
        if self.path.exists():
            os.truncate(self.path, self.rows * width * 4)
        elif self.rows:
            raise ValueError(f"{self.path} is missing: the checkpoint needs its {self.rows} transitions")

    def state(self, buffer: Any) -> dict[str, Any]:
        """Append the transitions added since the last call; returns the buffer's checkpoint entry
        (the whole buffer inline if it has wrapped around)."""
        meta = {k: getattr(buffer, k) for k in ("capacity", "obs_dim", "act_dim", "ptr", "size")}
        labelled = buffer.labels is not None
        if labelled:
            meta["labelled"] = True
        if buffer.total_added != buffer.size:  # wrapped: rows were overwritten, store it whole
            return buffer.state_dict()
        width = replay_row_width(buffer.obs_dim, buffer.act_dim, labelled)
        if self.rows == 0:
            self.path.unlink(missing_ok=True)
        if buffer.size > self.rows:
            new = slice(self.rows, buffer.size)
            columns = [buffer.obs[new], buffer.actions[new], buffer.rewards[new, None],
                       buffer.next_obs[new], buffer.terminated[new, None]]
            rows = np.concatenate(columns + ([buffer.labels[new]] if labelled else []), axis=1)
            assert rows.shape[1] == width
            try:
                with open(self.path, "ab") as f:
                    f.write(np.ascontiguousarray(rows, dtype=np.float32).tobytes())
                    f.flush()
                    os.fsync(f.fileno())
            except BaseException:  # a full disk: the rows the last checkpoint needs stay
                with contextlib.suppress(OSError):
                    os.truncate(self.path, self.rows * width * 4)
                raise
            self.rows = buffer.size
        return {**meta, "total_added": buffer.total_added, "file": RunDir.REPLAY, "rows": self.rows}
