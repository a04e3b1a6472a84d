"""Policy files: where shipped policies live, how a policy argument (a run directory, a checkpoint,
a shipped-format folder or a shipped name) is loaded, and the errors that name a bad file.

A shipped-format folder holds ``actor.pt`` (state dict of :class:`~elastica_magnetic_rl.td3.algorithm.Actor`),
optionally ``critic.pt``, and ``policy.json`` (format ``msr-policy-v1``: case and ``case_spec``,
architecture, observation and action layout, provenance, ``actor_sha256``).
"""

from __future__ import annotations

import hashlib
import json
import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from elastica_magnetic.io import (
    DamagedFileError,
    UnverifiedFileWarning,
    canonical_sha256,
    missing_folder_hint,
    read_json,
)
from elastica_magnetic.result_markers import describe_result, read_marker

from ..cases.case import Case, case_from_metadata

__all__ = [
    "LoadedPolicy",
    "POLICIES_DIR",
    "POLICY_FORMAT",
    "POLICY_JSON",
    "PolicyFileError",
    "PolicyNotFoundError",
    "SEEDS_FOLDER",
    "SHIPPED_FILES",
    "check_policy_case",
    "figure_cases",
    "TIP_PATHS_PNG",
    "RING_PNG",
    "policy_holder",
    "shipped_policy_holding",
    "OLD_POLICY_KEYS",
    "finish_interrupted_ship",
    "read_policy_json",
    "case_spec_sha256",
    "resolve_policy",
    "weights_sha256",
]

#: Folder of the shipped policies (``rl/policies/<name>/``).
POLICIES_DIR = Path(__file__).resolve().parents[1] / "policies"
POLICY_JSON = "policy.json"
#: The tip's paths to a tip-reach policy's held-out targets, its own and its yardstick's (the card shows it).
TIP_PATHS_PNG = "tip_paths.png"
#: The top view of a goto policy's paths to its ring of targets, beside its yardstick's (the card shows it).
RING_PNG = "ring.png"
#: The files of a shipped policy (``actor.pt`` and ``policy.json`` always, the others optional).
SHIPPED_FILES = ("actor.pt", POLICY_JSON, "critic.pt", "fields.csv", TIP_PATHS_PNG, RING_PNG, "MODEL_CARD.md")
POLICY_FORMAT = "msr-policy-v1"


#: The subfolder of a shipped policy where the seed campaigns of its case go (``msr policy
#: export-seeds --out POLICY/seeds/<recipe>``): the one place in a policy's folder for other results.
SEEDS_FOLDER = "seeds"


def policy_holder(case: str) -> str:
    """What holds a shipped policy's folder whole, as its record of files
    (:data:`elastica_magnetic.result_markers.MANIFEST`) says: no other command puts a file there."""
    return f"a shipped policy of case {case!r} (msr policy ship)"


def shipped_policy_holding(folder: Path) -> tuple[str, tuple[str, ...]] | None:
    """The holder and open subfolders of ``folder`` when it holds a shipped policy (its
    ``policy.json`` of :data:`POLICY_FORMAT`), whatever its record says (one written before records
    named a holder, or none: a policy copied file by file); else ``None``."""
    try:
        data = json.loads((folder / POLICY_JSON).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict) or data.get("format") != POLICY_FORMAT:
        return None
    return policy_holder(str(data.get("case", "?"))), (SEEDS_FOLDER,)

#: The actor's hidden activation and output squashing (``td3.algorithm.Actor``), as policy.json
#: records them.
ACTOR_ACTIVATION, ACTOR_OUTPUT = "relu", "tanh"
#: ``policy.json`` keys older files used -> today's (:func:`read_policy_json` maps them):
#: the yardstick was named for the paper's robot, whichever case it was.
OLD_POLICY_KEYS = {"authors_mid_dx_10s_m": "yardstick_10s_m"}


class PolicyNotFoundError(FileNotFoundError):
    """A policy argument that names no run, checkpoint or shipped policy."""


class PolicyFileError(ValueError):
    """A policy file that is corrupted, truncated or does not match its ``policy.json``; the
    message names the file."""


def weights_sha256(state_dict: dict[str, Any]) -> str:
    """SHA-256 of a network's weights (names, dtypes, shapes and values, in name order): stored in
    ``policy.json`` to check that ``actor.pt`` is the actor it describes."""

    digest = hashlib.sha256()
    for name in sorted(state_dict):
        tensor = state_dict[name].detach().cpu().contiguous()
        digest.update(f"{name}|{tensor.dtype}|{tuple(tensor.shape)}|".encode())
        digest.update(tensor.numpy().tobytes())
    return digest.hexdigest()


@dataclass
class LoadedPolicy:
    """A policy ready to act: the actor (normalised actions), the critic if known, and its case."""

    actor: Any  # elastica_magnetic_rl.td3.algorithm.Actor in eval mode
    critic: Any | None  # elastica_magnetic_rl.td3.algorithm.TwinCritic or None
    case: Case
    source: Path
    kind: str  # "checkpoint" or "shipped"
    meta: dict[str, Any] = field(default_factory=dict)
    obs_dim: int = 260  # the case's (checked against it on loading)
    act_dim: int = 2
    hidden_sizes: tuple[int, ...] = (256, 256)
    _controller: Any = field(default=None, repr=False, compare=False)

    @property
    def residual(self) -> float:
        """The weight of the actor's correction on the case's yardstick for a residual policy
        (:attr:`~elastica_magnetic_rl.td3.config.TD3Config.residual`); 0: the actor is the policy."""
        if self.kind == "shipped":
            return float(self.meta["architecture"].get("residual", 0.0))
        return float((self.meta.get("config") or {}).get("residual", 0.0))

    def correction(self, obs: np.ndarray) -> np.ndarray:
        """The actor's output ``(N, act_dim)`` float32 in [-1, 1] for observations ``(N, obs_dim)``:
        the action of a plain policy, the correction of a residual one."""
        import torch

        with torch.no_grad():
            return self.actor(torch.as_tensor(np.asarray(obs, dtype=np.float32))).numpy()

    def residual_controller(self) -> Any:
        """A new :class:`~elastica_magnetic_rl.envs.residual.ResidualController` of a residual
        policy: the case's yardstick (one per sub-environment) corrected by the actor."""
        from ..envs.residual import ResidualController, residual_base

        return ResidualController(self.correction, residual_base(self.case), self.residual)

    def __getstate__(self) -> dict[str, Any]:
        """Pickled without a residual policy's controller (the ring's worker processes make their
        own: its yardsticks' memories belong to the episodes played here)."""
        return {**self.__dict__, "_controller": None}

    def reset(self) -> None:
        """A new episode: a residual policy's yardstick forgets its manoeuvre (a plain policy has
        no memory)."""
        if self._controller is not None:
            self._controller.reset()

    def act(self, obs: np.ndarray) -> np.ndarray:
        """Deterministic normalised action in [-1, 1]^k for one observation: the actor's (float32),
        or a residual policy's yardstick command corrected by it (float64, as its environments play
        it; :meth:`reset` at each episode)."""
        if self.residual:
            if self._controller is None:
                self._controller = self.residual_controller()
            return self._controller.act(np.asarray(obs, dtype=np.float32).reshape(-1))
        return self.correction(np.asarray(obs, dtype=np.float32).reshape(1, -1))[0].astype(np.float32)


def build_networks(obs_dim: int, act_dim: int, hidden: tuple[int, ...], actor_state: dict,
                   critic_state: dict | None, source: Path | None = None,
                   critic_layer_norm: bool = False, critic_hidden: tuple[int, ...] | None = None):
    """The actor (and the twin critic when ``critic_state`` is given) of a checkpoint or policy
    file (:func:`~elastica_magnetic_rl.td3.algorithm.networks_from_state`). Weights that do not fit
    the declared architecture raise a :class:`PolicyFileError` naming ``source``."""
    from ..td3.networks import networks_from_state

    try:
        return networks_from_state(obs_dim, act_dim, hidden, actor_state, critic_state, source,
                                   critic_layer_norm, critic_hidden)
    except ValueError as exc:
        raise PolicyFileError(str(exc)) from None


def _torch_load(path: Path) -> Any:
    """``torch.load`` of a policy file; a truncated or corrupted file is a PolicyFileError naming it."""
    import torch

    from ..runfiles.checkpoint import torch_file_problem

    try:
        return torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises EOFError, RuntimeError, UnpicklingError, ...
        raise PolicyFileError(f"{path}: cannot be read as a torch file: "
                              f"{torch_file_problem(path, exc)}; restore it from the run or the "
                              "repository") from None


def read_policy_json(path: str | Path) -> dict[str, Any]:
    """``policy.json`` of a shipped-format folder, with the keys loading needs checked and older
    files' key names mapped to today's (:data:`OLD_POLICY_KEYS`; an old yardstick of ``None``, a
    case without one, is dropped)."""
    path = Path(path)
    try:
        meta = read_json(path, fix="restore it (e.g. from git) or ship the policy again")
    except DamagedFileError as exc:
        raise PolicyFileError(str(exc)) from None
    if isinstance(meta, dict):
        for old, new in OLD_POLICY_KEYS.items():
            value = meta.pop(old, None)
            if value is not None and new not in meta:
                meta[new] = value
    fmt = meta.get("format") if isinstance(meta, dict) else None
    if fmt is not None and fmt != POLICY_FORMAT:  # files from before the format key have none
        raise PolicyFileError(f"{path}: format {fmt!r} is not one this msr reads ({POLICY_FORMAT}): "
                              "written by another version of msr? Use that version, or ship the "
                              "policy again with this one")
    arch = meta.get("architecture") if isinstance(meta, dict) else None
    if not isinstance(arch, dict) or not isinstance(meta.get("case"), str):
        raise PolicyFileError(f"{path}: lacks 'case' or 'architecture' (not a {POLICY_FORMAT} file)")
    missing = [k for k in ("obs_dim", "act_dim", "hidden_sizes") if k not in arch]
    if missing:
        raise PolicyFileError(f"{path}: architecture lacks {', '.join(missing)}")
    try:
        arch["hidden_sizes"] = [int(h) for h in arch["hidden_sizes"]]
        arch["obs_dim"], arch["act_dim"] = int(arch["obs_dim"]), int(arch["act_dim"])
    except (TypeError, ValueError):
        raise PolicyFileError(f"{path}: architecture sizes must be integers, got {arch}") from None
    sizes = [("obs_dim", arch["obs_dim"]), ("act_dim", arch["act_dim"]),
             *(("hidden_sizes", h) for h in arch["hidden_sizes"])]
    if (bad := next(((k, v) for k, v in sizes if v < 1), None)) is not None:
        raise PolicyFileError(f"{path}: architecture.{bad[0]}: {bad[1]} is not a size (a layer or "
                              "vector of at least 1); the file was edited or damaged: ship the policy "
                              "again with msr policy ship")
    return meta


def _policy_case(meta: dict[str, Any], path: Path) -> Case:
    """The case of a policy's metadata; an unknown or invalid one is a PolicyFileError naming it."""
    from elastica_magnetic.specfile import SpecError

    try:
        return case_from_metadata(meta, str(path))
    except SpecError as exc:
        raise PolicyFileError(str(exc)) from None


def resolve_policy(policy: str | Path, policies_dir: str | Path | None = None) -> LoadedPolicy:
    """Load a policy from a run directory, a checkpoint file, a shipped-format directory
    (``actor.pt`` + ``policy.json``), or a shipped name (``rl/policies/<name>``), in that order."""

    from ..runfiles.checkpoint import checkpoint_metadata, load_checkpoint, torch_file_problem
    from ..runfiles.rundir import RunDir

    policies_dir = Path(policies_dir) if policies_dir is not None else POLICIES_DIR
    path = Path(policy)
    if not path.exists() and (policies_dir / str(policy)).is_dir():
        path = policies_dir / str(policy)
    if path.is_dir() and RunDir(path).has_checkpoint():
        path = RunDir(path).checkpoint
    if path.is_dir():
        finish_interrupted_ship(path)
    if (path.is_file() and path.suffix != ".pt" and path.name in SHIPPED_FILES
            and (path.parent / POLICY_JSON).is_file()):
        raise PolicyFileError(f"{path}: a file of the shipped policy {path.parent}, not a policy: give "
                              f"its folder ({path.parent})")
    if path.is_file():
        try:  # the networks only: a checkpoint copied away from its replay file still plays
            ckpt = load_checkpoint(path, with_buffer=False)
        except ValueError as exc:  # unreadable, or not a checkpoint: named by load_checkpoint
            raise PolicyFileError(str(exc)) from None
        except Exception as exc:  # a truncated or corrupted file
            raise PolicyFileError(f"{path}: cannot be read as a checkpoint: "
                                  f"{torch_file_problem(path, exc)}") from None
        meta = checkpoint_metadata(ckpt, path)
        try:
            critic_hidden = tuple(ckpt["config"]["hidden_sizes"])
            hidden = tuple(ckpt["config"].get("actor_hidden_sizes") or critic_hidden)  # the actor's
            actor_state, critic_state = ckpt["agent"]["actor"], ckpt["agent"]["critic"]
            obs_dim, act_dim = ckpt["obs_dim"], ckpt["act_dim"]
        except (KeyError, TypeError) as exc:
            raise PolicyFileError(f"{path}: incomplete checkpoint (no {exc})") from None
        actor, critic = build_networks(obs_dim, act_dim, hidden, actor_state, critic_state, path,
                                        bool(ckpt["config"].get("critic_layer_norm", False)),
                                        critic_hidden)
        meta = {**meta, "global_step": int(ckpt["global_step"]), "config": ckpt["config"],
                "checkpoint_kind": ckpt.get("kind", "full")}
        case = _policy_case(meta, path)
        _check_obs_dim(case, obs_dim, path)
        return LoadedPolicy(actor, critic, case, path, "checkpoint", meta,
                            ckpt["obs_dim"], ckpt["act_dim"], hidden)
    if path.is_dir() and (path / POLICY_JSON).is_file() and (path / "actor.pt").is_file():
        meta = read_policy_json(path / POLICY_JSON)
        case = _policy_case(meta, path / POLICY_JSON)
        _check_recorded_limits(case, meta, path / POLICY_JSON)
        _check_recorded_case(case, meta, path / POLICY_JSON)
        _check_case_spec_hash(meta, path / POLICY_JSON)  # any other edit (the named ones first)
        arch = meta["architecture"]
        _check_obs_dim(case, arch["obs_dim"], path / POLICY_JSON)
        hidden = tuple(arch["hidden_sizes"])
        actor_state = _torch_load(path / "actor.pt")
        expected = meta.get("actor_sha256")
        if expected is not None and weights_sha256(actor_state) != expected:
            raise PolicyFileError(
                f"{path / 'actor.pt'}: its weights do not match the actor_sha256 of {path / POLICY_JSON} "
                f"(case {meta['case']}): the files come from different policies"
            )
        critic_state = None
        if (path / "critic.pt").is_file():
            critic_state = _torch_load(path / "critic.pt")
        actor, critic = build_networks(arch["obs_dim"], arch["act_dim"], hidden, actor_state,
                                        critic_state, path / "actor.pt",
                                        bool(arch.get("critic_layer_norm", False)),
                                        tuple(arch.get("critic_hidden_sizes") or hidden))
        return LoadedPolicy(actor, critic, case, path, "shipped", meta, arch["obs_dim"],
                            arch["act_dim"], hidden)
    raise PolicyNotFoundError(_not_a_policy(policy, path, policies_dir))


def _not_a_policy(policy: str | Path, path: Path, policies_dir: Path) -> str:
    """Why ``policy`` (found at ``path``, or not) is no policy :func:`resolve_policy` can load,
    naming what it is where that is known."""
    from ..runfiles.rundir import being_written_hint, seed_runs_hint

    _check_policy_folder_whole(path)
    if hint := being_written_hint(path):
        return f"{policy}: no checkpoint yet: {hint}"
    if hint := seed_runs_hint(path):
        return f"{policy}: not a run directory: {hint}"
    if (refusal := other_result_refusal(path)) is not None:
        return refusal
    shipped = sorted(p.name for p in policies_dir.glob("*") if (p / POLICY_JSON).is_file()) \
        if policies_dir.is_dir() else []
    return (f"{policy}: not a run directory, checkpoint, shipped-policy folder or shipped policy name "
            f"(shipped in {policies_dir}: {', '.join(shipped) or 'none'}){missing_folder_hint(policy)}")


#: What a command reading a policy takes (:func:`other_result_refusal`'s default).
POLICY_WANTED = "a policy: give a run folder, a checkpoint or a shipped policy"


def other_result_refusal(path: Path, wanted: str = POLICY_WANTED) -> str | None:
    """Where ``path`` holds another command's result (a marker of any kind but a training's: a
    generate, replay, ring, robustness or export result), the refusal naming it and ``wanted``
    (what the command takes instead); else ``None``."""
    marker = read_marker(path) if path.is_dir() else None
    if marker is None or marker.get("kind") in ("train", "refine"):
        return None
    waveform = path / "fields.csv"
    also = f"; its waveform, where a field CSV goes, is {waveform}" if waveform.is_file() else ""
    return f"{path}: holds {describe_result(marker)}, not {wanted}{also}"


def _check_policy_folder_whole(path: Path) -> None:
    """A folder holding some of a shipped policy's files but not both it needs (``actor.pt``,
    ``policy.json``): name the missing ones (deleted or not copied), not "not a policy"."""

    if not path.is_dir():
        return
    present = [name for name in SHIPPED_FILES if (path / name).is_file()]
    missing = [name for name in ("actor.pt", POLICY_JSON) if not (path / name).is_file()]
    if present and missing and (refusal := other_result_refusal(path)) is not None:
        raise PolicyNotFoundError(refusal)  # a generate or robustness result: named, not "broken"
    if present and missing:
        raise PolicyNotFoundError(
            f"{path}: a shipped-policy folder (it holds {', '.join(present)}) without "
            f"{' and '.join(missing)}: a shipped policy needs actor.pt and {POLICY_JSON} "
            "(deleted or not copied? ship it again with msr policy ship)")


def finish_interrupted_ship(folder: Path) -> list[str]:
    """Before a shipped-policy folder is read: when an ``msr policy ship --force`` (or ``msr policy notes
    --file``) was killed while it replaced the folder's files, finish that replacement (its new
    files were complete: roll forward) or drop the unfinished one, so the folder holds one whole
    policy, never the new ``actor.pt`` beside the old ``policy.json``
    (:func:`elastica_magnetic.filesets.recover_files`). What was done is printed on stderr
    (``note: ...``) and returned. Raises
    :class:`~elastica_magnetic.locks.FolderLockedError` naming the process when a live one is
    writing the folder now."""
    import sys

    from elastica_magnetic.filesets import interrupted_replacements, recover_files

    if not interrupted_replacements(folder):
        return []
    notes = recover_files(folder, option="policy")
    for note in notes:
        print(f"note: {note}", file=sys.stderr)
    return notes


def case_spec_sha256(spec: Mapping[str, Any]) -> str:
    """The SHA-256 of a ``case_spec`` in a canonical JSON form: ``policy.json`` records it, so a
    case_spec edited by hand (a longer robot, another field limit) is refused, not run."""
    return canonical_sha256(spec)


def _check_case_spec_hash(meta: dict[str, Any], path: Path) -> None:
    """A ``policy.json`` whose ``case_spec`` no longer matches its ``case_spec_sha256`` was edited:
    the policy would run on a robot or in a setting it was not trained for."""
    expected = meta.get("case_spec_sha256")
    if "case_spec" not in meta:
        return
    if expected is None:  # shipped before the hash was recorded, or the key was removed
        warnings.warn(f"{path}: records no case_spec_sha256 (shipped before msr recorded it, or the "
                      "key was removed): an edit of its case_spec (the robot, the field limit) "
                      "cannot be told from the original; ship the policy again to record it",
                      UnverifiedFileWarning, stacklevel=2)
        return
    if case_spec_sha256(meta["case_spec"]) != expected:
        raise PolicyFileError(f"{path}: its case_spec was edited (it no longer matches "
                              "case_spec_sha256): the policy would run on a robot or with limits it "
                              "was not trained for; restore the file (e.g. from git), or train "
                              "and ship a policy for the new case")


def _check_recorded_limits(case: Case, meta: dict[str, Any], path: Path) -> None:
    """A policy.json whose ``case_spec`` disagrees with the limits it records (``field_limit_T``,
    the action's scaling) was edited by hand: the policy would run with limits it was not trained
    for. Refused naming the value."""
    if not case.field_actuated:  # its limits are the source's, read from the case_spec alone
        return
    action = meta.get("action") if isinstance(meta.get("action"), dict) else {}
    recorded = {"field_limit_T": meta.get("field_limit_T", action.get("field_limit_T")),
                "action.field_limit_T": action.get("field_limit_T"),
                "action.field_increment_T_per_unit": action.get("field_increment_T_per_unit")}
    spec = {"field_limit_T": case.field_limit, "action.field_limit_T": case.field_limit,
            "action.field_increment_T_per_unit": case.actuation.max_increment}
    for key, value in recorded.items():
        if value is not None and not (isinstance(value, int | float)
                                      and abs(float(value) - spec[key]) <= 1e-9 * max(1.0, abs(spec[key]))):
            raise PolicyFileError(f"{path}: {key} = {value!r} but its case_spec gives {spec[key]:g}: "
                                  "the file contradicts itself (edited by hand?); restore it (e.g. "
                                  "from git) or ship the policy again")


def _check_recorded_case(case: Case, meta: dict[str, Any], path: Path) -> None:
    """The other entries of a ``policy.json`` that repeat its ``case_spec`` (the robot, its
    magnetization, the task, the observation's scales, the actor's activations) must agree with it:
    the policy runs on the case_spec, so an edit of the copies would be ignored without a word."""
    arch = meta.get("architecture") or {}
    expected = observation_spec_of(case)["scales"]
    scales = (meta.get("observation") or {}).get("scales")
    checks = [
        ("robot", meta.get("robot"), case.robot.name),
        ("magnetization", meta.get("magnetization"),
         case.robot.tables["robot"]["magnetization"]["kind"]),
        ("task", meta.get("task"), case.task.kind),
        ("architecture.activation", arch.get("activation"), ACTOR_ACTIVATION),
        ("architecture.output", arch.get("output"), ACTOR_OUTPUT),
    ]
    for key, value, want in checks:
        if value is not None and value != want:
            raise PolicyFileError(f"{path}: {key} = {value!r} but its case_spec (or the actor this "
                                  f"package runs) gives {want!r}: the file contradicts itself (edited "
                                  "by hand?); restore it (e.g. from git) or ship the policy again")
    if isinstance(scales, dict):
        for key, value in scales.items():
            want = expected.get(key)
            same = (isinstance(value, int | float) and isinstance(want, int | float)
                    and math.isfinite(value) and abs(value - want) <= 1e-9 * max(1.0, abs(want)))
            if want is not None and not same and value != want:
                raise PolicyFileError(f"{path}: observation.scales.{key} = {value!r} but its case_spec "
                                      f"gives {want!r}: the file contradicts itself (edited by "
                                      "hand?); restore it (e.g. from git) or ship the policy again")


def _check_obs_dim(case: Case, obs_dim: int, path: Path) -> None:
    if int(obs_dim) != case.obs_dim:
        raise PolicyFileError(f"{path}: the policy takes {obs_dim} observations, its case "
                              f"{case.name!r} gives {case.obs_dim}")


#: The tables of a case spec that make it the same case (the robot, its physics, what moves it and
#: its task); a training recipe or a yardstick measured since may differ between runs of one case.
SAME_CASE_TABLES = ("robot", "physics", "actuation", "task")


def case_spec_difference(recorded: Any, spec: Mapping[str, Any]) -> str | None:
    """Where ``spec`` (a case's :meth:`~elastica_magnetic_rl.cases.case.Case.to_dict`) differs from
    a policy's ``recorded`` ``case_spec`` in :data:`SAME_CASE_TABLES` (``"[table] key"``), or
    ``None``: the same case (or nothing recorded to compare)."""
    from ..sweep.run_records import first_difference

    if not isinstance(recorded, dict):
        return None
    mine, theirs = ({table: part.get(table) for table in SAME_CASE_TABLES} for part in (spec, recorded))
    return None if mine == theirs else first_difference(theirs, mine)


def check_policy_case(dest: str | Path, case: Case | str, *, option: str = "--out",
                      what: str = "this result is") -> None:
    """A result of ``case`` (a case, or only its name) written into a shipped policy's folder (its
    ``seeds/``, the one place there open to other results) must be of that policy's case: another
    case's, or one of the same name with another spec (a user's file named as the shipped case),
    is refused (:class:`~elastica_magnetic.io.OutputPathError`), or the policy's folder would hold,
    and ``msr policy seeds`` count, a result that is not its own. ``option`` names the path given
    (``--out``, ``--figure``...), ``what`` the thing written, with its verb (``"these figures are"``)."""
    from elastica_magnetic.io import OutputPathError, display_path, normalized_path

    name = case if isinstance(case, str) else case.name
    dest = normalized_path(dest)
    for parent in dest.parents:
        if not (parent / POLICY_JSON).is_file():
            continue
        try:
            meta = json.loads((parent / POLICY_JSON).read_text(encoding="utf-8"))
            theirs = meta.get("case")
        except (OSError, ValueError, AttributeError):
            meta, theirs = {}, None
        if theirs is not None and theirs != name:
            raise OutputPathError(f"{option} {display_path(dest)}: lies in the shipped policy "
                                  f"{display_path(parent)} of case {theirs!r}, and {what} of case "
                                  f"{name!r}: a policy's seeds/ holds its own case's results; choose another "
                                  f"{option}")
        recorded = meta.get("case_spec")
        differ = None if isinstance(case, str) else case_spec_difference(recorded, case.to_dict())
        if theirs is not None and differ is not None:
            raise OutputPathError(f"{option} {display_path(dest)}: lies in the shipped policy "
                                  f"{display_path(parent)} of case {theirs!r}, and {what} of a case "
                                  f"of the same name with another spec (they differ at {differ}): a "
                                  f"policy's seeds/ holds its own case's results; choose another {option}")
        return


def figure_cases(path: str | Path) -> list[str]:
    """The names of the cases whose figures ``msr policy figures`` draws for ``path``: a generate
    output's case, or the case of every training run found there (its ``run.json``; an exported
    seed's ``policy.json``). What records no case is left out (``make_figures`` names a fault)."""
    from ..envs.rollout import ROLLOUT_NPZ, Rollout
    from ..reports.figures import find_runs
    from ..runfiles.rundir import RunDir

    path = Path(path)
    if (path / ROLLOUT_NPZ).is_file():
        try:
            records = [Rollout.load(path).meta]
        except (OSError, ValueError, KeyError):
            return []
    else:
        records = []
        for run in (run for runs in find_runs(path).values() for run in runs):
            for record in (RunDir(run).run_json, Path(run) / POLICY_JSON):
                try:
                    records.append(json.loads(record.read_text(encoding="utf-8")))
                    break
                except (OSError, ValueError):
                    continue
    cases = (r.get("case") for r in records if isinstance(r, dict))
    return sorted({case for case in cases if isinstance(case, str)})


def observation_spec_of(case: Case) -> dict[str, Any]:
    """The ``observation`` entry of a policy's ``policy.json``: the case's observation layout and
    scaling (:func:`~elastica_magnetic_rl.envs.crawler_observation.observation_spec`; a case
    steered by a source: the catheter's, :func:`_steered_observation_spec`)."""
    from ..envs.crawler_observation import observation_spec

    if not case.field_actuated:
        return _steered_observation_spec(case)
    ground = case.robot_spec("training").ground
    return observation_spec(case.n_elements, ground.surface_tolerance, case.task,
                            case.actuation.axes)


def _steered_observation_spec(case: Case) -> dict[str, Any]:
    """The observation of a case steered by a source (a magnet arm, coil currents): the blocks of
    :func:`~elastica_magnetic_rl.envs.catheter_env.catheter_observation_layout` and their scales
    (per m, per m/s, over the current limit; lengths relative to the clamped base)."""
    from ..envs.catheter_env import CATHETER_OBSERVATION_SCALES, catheter_observation_layout

    layout = catheter_observation_layout(case.n_elements, case.actuation.observation_blocks)
    return {"size": layout["target_offset"].stop, "dtype": "float32",
            "blocks": [{"name": name, "start": s.start, "stop": s.stop} for name, s in layout.items()],
            "scales": {name: CATHETER_OBSERVATION_SCALES[name] for name in layout},
            "frame": "the spec's: the clamped base at the origin at the start, the rod along +x; "
                     "lengths relative to the base"}


def _steered_action_spec(case: Case) -> dict[str, Any]:
    """The action of a case steered by a source: its components in [-1, 1] and what they command."""
    actuation = case.actuation
    return {"shape": [actuation.action_size], "low": -1.0, "high": 1.0, "meaning": actuation.action_words(),
            "control_period_s": 0.01}


def action_spec_of(case: Case) -> dict[str, Any]:
    """The ``action`` entry of a policy's ``policy.json``: the action's scaling to a field increment
    (T) and the field rule (a case steered by a source: :func:`_steered_action_spec`)."""
    if not case.field_actuated:
        return _steered_action_spec(case)
    actuation = case.actuation
    increment = actuation.max_increment
    components = ", ".join(f"dB_{axis}" for axis in actuation.axes)
    spec = {
        "shape": [actuation.n_axes],
        "low": -1.0,
        "high": 1.0,
        "meaning": f"field increment ({components}) = field_increment_T_per_unit * action",
        "field_increment_T_per_unit": increment,
        "field_increment_mT_per_unit": increment * 1e3,
        "field_limit_T": case.field_limit,
        "field_rule": f"B += clip(dB, -{1e3 * increment:g} mT, {1e3 * increment:g} mT); clip each "
                      "component to +-limit; if |B| > limit scale B to |B| = limit; hold for 0.01 s "
                      "(100 Hz)",
        "control_period_s": 0.01,
    }
    if actuation.axis_limits or actuation.axis_increments:  # coil pairs that differ
        spec["field_increment_T_per_unit_per_axis"] = list(actuation.increments[:actuation.n_axes])
        spec["field_limit_T_per_axis"] = list(actuation.limits[:actuation.n_axes])
        spec["field_rule"] = ("B += clip(dB, -increment, +increment) per axis; clip each component "
                              "to +-its axis limit; if |B| > field_limit_T (the largest axis limit) "
                              "scale B to |B| = field_limit_T; hold for 0.01 s (100 Hz)")
        spec["meaning"] = (f"field increment ({components}) = field_increment_T_per_unit_per_axis "
                           "* action, per component")
    return spec
