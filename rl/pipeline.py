"""Train, refine, generate, ship and export crawling policies (the library behind ``msr``).

Workflow (paper "Miscellaneous training tips"):

1. :func:`train_case`: TD3 on one case (``m1-4mT``, ``m2-4mT``, ``m1-10mT``, ``m2-10mT``) for several
   seeds in parallel processes or Ray tasks (:mod:`rl.backends`), in the mass-scaled *training*
   physics, random initial fields, 20 s episodes (truncated, not terminal). Each seed writes
   ``OUT/<case>/seed<k>/`` (``episodes.csv``, TensorBoard scalars, ``checkpoint.pt``,
   ``run.json``); a ``summary.json`` per case collects each seed's final mean episode return.
2. :func:`refine`: load a run's agent *and replay buffer* and keep training (~1000 steps) in the
   *accurate* physics (12.5x more substeps per step). Written to ``RUN/refined/``.
3. :func:`generate`: run the deterministic policy in the accurate physics with the field starting at
   zero; write the field CSV (mT, 100 Hz), ``trajectory.csv``, ``rollout.npz``, figures and a GIF.
4. :func:`ship`: pack a run into the shipped-policy format ``rl/policies/<name>/`` (``actor.pt``
   state dict, ``critic.pt``, ``policy.json``, ``MODEL_CARD.md``, and the generated
   ``fields.csv``).
5. :func:`export_policy`: the actor as TorchScript plus a JSON of the observation layout and
   scaling and the action scaling, to run without this package.

A *policy* argument is a run directory (holding ``checkpoint.pt``), a checkpoint file, a
shipped-format directory (``actor.pt`` + ``policy.json``), or the name of a shipped policy in
``rl/policies/`` (see :func:`resolve_policy`).
"""

from __future__ import annotations

import functools
import json
import math
import os
import platform
import sys
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from elastica_magnetic.io import atomic_save, atomic_write, atomic_write_text, prepare_output_dir
from elastica_magnetic.openloop import check_duration

from .backends import BACKENDS, run_jobs
from .baselines import RotatingFieldPolicy
from .env import CASES, MAX_FIELD_INCREMENT, MagneticCrawlerEnv, observation_spec
from .recipes import CRAWLER_TD3_OVERRIDES, DEFAULT_RECIPE, RECIPES

__all__ = [
    "AUTHORS_DISTANCE_10S",
    "LoadedPolicy",
    "POLICIES_DIR",
    "PolicyFileError",
    "PolicyNotFoundError",
    "crawler_config",
    "demo",
    "evaluate_seeds",
    "export_policy",
    "export_seeds",
    "generate",
    "make_env",
    "refine",
    "resolve_policy",
    "ship",
    "summarize_run",
    "train_case",
    "train_cases",
    "weights_sha256",
]

#: Folder of the shipped policies (``rl/policies/<name>/``).
POLICIES_DIR = Path(__file__).resolve().parent / "policies"
RUN_JSON = "run.json"
POLICY_JSON = "policy.json"
POLICY_FORMAT = "msr-policy-v1"
EXPORT_FORMAT = "msr-exported-policy-v1"

#: Distance of the middle of the robot in 10 s, accurate physics, field from zero, of the authors'
#: released policies (m): the targets of the shipped ones (from the authors' released trajectories).
AUTHORS_DISTANCE_10S = {"m1-4mT": 20.5e-3, "m2-4mT": 20.1e-3, "m1-10mT": 137e-3, "m2-10mT": 137e-3}


#: The evaluation during training: the shipping criterion's episode (field from zero,
#: deterministic actions, 10 s) in the physics the run trains in.
EVAL_DURATION = 10.0


class PolicyNotFoundError(FileNotFoundError):
    """A policy argument that names no run, checkpoint or shipped policy."""


class PolicyFileError(ValueError):
    """A policy file that is corrupted, truncated or does not match its ``policy.json``; the
    message names the file."""


def weights_sha256(state_dict: dict[str, Any]) -> str:
    """SHA-256 of a network's weights (names, dtypes, shapes and values, in name order): stored in
    ``policy.json`` to check that ``actor.pt`` is the actor it describes."""
    import hashlib

    digest = hashlib.sha256()
    for name in sorted(state_dict):
        tensor = state_dict[name].detach().cpu().contiguous()
        digest.update(f"{name}|{tensor.dtype}|{tuple(tensor.shape)}|".encode())
        digest.update(tensor.numpy().tobytes())
    return digest.hexdigest()


# ----------------------------------------------------------------------------------------------
# Environments and configuration
# ----------------------------------------------------------------------------------------------
def _case(case: str):
    if case not in CASES:
        raise ValueError(f"unknown case {case!r}; choose one of {', '.join(CASES)}")
    return CASES[case]


def make_env(
    case: str,
    physics: str = "training",
    initial_field: str = "random",
    duration: float = 20.0,
    render_mode: str | None = None,
) -> MagneticCrawlerEnv:
    """The environment of a case (module-level so that ``functools.partial`` of it pickles)."""
    return MagneticCrawlerEnv(
        **_case(case).env_kwargs, physics=physics, initial_field=initial_field, duration=duration,
        render_mode=render_mode,
    )


def crawler_config(seed: int = 0, recipe: str = DEFAULT_RECIPE, **overrides: Any):
    """The crawler's TD3 configuration: the paper's settings (:data:`CRAWLER_TD3_OVERRIDES` on
    :class:`~rl.td3.TD3Config`), then the ``recipe``'s changes (:data:`RECIPES`), then
    ``overrides`` (e.g. ``learning_starts`` for smoke runs)."""
    from .td3 import TD3Config

    if recipe not in RECIPES:
        raise ValueError(f"unknown recipe {recipe!r}; choose one of {', '.join(RECIPES)}")
    return TD3Config(**{**CRAWLER_TD3_OVERRIDES, **RECIPES[recipe], **overrides, "seed": int(seed)})


def _versions() -> dict[str, str]:
    import elastica
    import gymnasium
    import torch

    return {"python": platform.python_version(), "torch": torch.__version__,
            "gymnasium": gymnasium.__version__, "pyelastica": getattr(elastica, "__version__", "?"),
            "numpy": np.__version__}


def _write_json(path: Path, data: dict[str, Any]) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    return atomic_write_text(path, json.dumps(data, indent=2, default=str) + "\n")


# ----------------------------------------------------------------------------------------------
# Training
# ----------------------------------------------------------------------------------------------
def summarize_run(run_dir: str | Path, last: int = 5) -> dict[str, Any]:
    """Episodes, steps and the mean return of the last ``last`` episodes of a run (``nan`` if it has
    no finished episode). ``final_mean_distance_m`` is that return / 1e4 (m per episode). With
    evaluations during training: ``best_eval_step`` and ``best_eval_return`` (the evaluation that
    ``best.pt`` holds; its return / 1e4 is the 10 s distance from a zero field, m), else ``None``."""
    import csv

    run_dir = Path(run_dir)
    rows, evals = [], []
    if (run_dir / "episodes.csv").is_file():
        with open(run_dir / "episodes.csv", newline="") as f:
            rows = list(csv.DictReader(f))
    if (run_dir / "evaluations.csv").is_file():
        with open(run_dir / "evaluations.csv", newline="") as f:
            evals = list(csv.DictReader(f))
    best_eval = max(evals, key=lambda r: float(r["mean_return"])) if evals else None
    returns = [float(r["return"]) for r in rows]
    tail = returns[-last:]
    mean = float(np.mean(tail)) if tail else float("nan")
    return {
        "run_dir": str(run_dir),
        "episodes": len(rows),
        "global_step": int(rows[-1]["global_step"]) if rows else 0,
        "final_mean_return": mean,
        "final_mean_distance_m": mean / 1e4,
        "best_return": max(returns) if returns else float("nan"),
        "terminated_episodes": sum(int(r["terminated"]) for r in rows),
        "best_eval_step": int(best_eval["global_step"]) if best_eval else None,
        "best_eval_return": float(best_eval["mean_return"]) if best_eval else None,
    }


def _run_metadata(case: str, physics: str, duration: float, seed: int, **extra: Any) -> dict:
    spec = _case(case)
    return {"case": case, "pattern": spec.pattern, "field_limit_T": spec.field_limit,
            "physics": physics, "episode_duration_s": duration, "seed": int(seed), **extra}


#: Settings of a run that a resume must not change (they are the run's, in ``run.json``).
_RUN_SETTINGS = ("case", "physics", "episode_duration_s", "recipe")


def _check_resume_settings(run_dir: Path, metadata: dict[str, Any]) -> None:
    """A resumed run keeps its case, physics and episode length: refuse other values, naming the
    option and the run's value."""
    run_json = run_dir / RUN_JSON
    if not run_json.is_file():
        return
    try:
        record = json.loads(run_json.read_text())
    except ValueError as err:
        raise ValueError(f"{run_json}: not readable JSON ({err})") from None
    options = {"case": "--case", "physics": "--physics", "episode_duration_s": "--episode-duration",
               "recipe": "--recipe"}
    for key in _RUN_SETTINGS:
        if key in record and record[key] != metadata[key]:
            raise ValueError(f"{options[key]} {metadata[key]} differs from the run's {record[key]} "
                             f"({run_json}): a resumed run keeps its settings")


def _write_run_json(run_dir: Path, config, metadata: dict[str, Any], steps: int, threads: int,
                    resumed_now: bool) -> None:
    """``run.json``: the run's settings, the steps it has reached and how often it was resumed
    (written when a new run starts, with 0 steps, and when a training call has finished)."""
    record = {}
    if (run_dir / RUN_JSON).is_file():
        record = json.loads((run_dir / RUN_JSON).read_text())
    _write_json(run_dir / RUN_JSON, {
        **record, **metadata, "steps": int(steps), "config": config.to_dict(),
        "torch_threads": int(threads), "versions": _versions(),
        "resumed": int(record.get("resumed", 0)) + int(resumed_now)})


def _train_group(job: dict[str, Any]) -> dict[str, Any]:
    """Train a group of seeds of one case side by side in one worker process: their crawlers in
    one batched simulator (``job["envs"]`` each), their networks updated as one computation
    (:func:`~rl.runner.train_seeds`). ``job`` holds plain data only (picklable). Returns
    ``{"group": [one result per seed]}``."""
    import torch

    from .checkpoint import load_checkpoint
    from .runner import train_seeds
    from .td3 import TD3Config, resolve_precision
    from .vector_env import make_vector_env

    torch.set_num_threads(int(job["threads"]))
    configs = [TD3Config.from_dict(c) for c in job["configs"]]
    run_dirs = [Path(d) for d in job["run_dirs"]]
    envs = int(job["envs"])
    metadata = [_run_metadata(job["case"], job["physics"], job["duration"], c.seed, command="train",
                              envs=envs, shared_simulator_seeds=len(configs),
                              precision=resolve_precision(c.precision, c.device),
                              recipe=job.get("recipe", DEFAULT_RECIPE))
                for c in configs]
    for config, run_dir, meta in zip(configs, run_dirs, metadata, strict=True):
        if not job["resume"]:
            run_dir.mkdir(parents=True, exist_ok=True)
            (run_dir / RUN_JSON).unlink(missing_ok=True)  # a stale record of a run without checkpoint
            _write_run_json(run_dir, config, meta, 0, job["threads"], resumed_now=False)
    start = time.perf_counter()
    train_seeds(functools.partial(make_vector_env, job["case"], physics=job["physics"],
                                  initial_field="random", duration=job["duration"]),
                configs, job["steps"], run_dirs, envs_per_seed=envs, resume=job["resume"],
                progress=job["progress"], metadata=metadata,
                eval_env_fn=functools.partial(make_env, job["case"], job["physics"], "zero",
                                              EVAL_DURATION),
                progress_position=job["position"], progress_desc=job["case"])
    wall, peak = time.perf_counter() - start, _peak_rss_bytes()
    results = []
    for run_dir, meta in zip(run_dirs, metadata, strict=True):
        ckpt = load_checkpoint(run_dir)  # what was actually done, with the settings actually used
        _write_run_json(run_dir, TD3Config.from_dict(ckpt["config"]), meta,
                        int(ckpt["global_step"]), job["threads"], resumed_now=job["resume"])
        results.append({"seed": int(ckpt["config"]["seed"]), **summarize_run(run_dir),
                        "wall_s": wall, "peak_rss_bytes": peak,
                        "group_seeds": [c.seed for c in configs],
                        "group_timing_s": ckpt.get("timing")})
    return {"group": results}


def default_layout(seeds: int, cases: int = 1, cpus: int | None = None) -> dict[str, int]:
    """The fastest layout known for ``seeds`` seeds of each of ``cases`` cases on ``cpus`` cores:
    one worker process per core, each training its share of a case's seeds side by side (one
    batched simulator, one stacked update; measured in ``docs/performance.md``), one torch thread
    each. Returns ``workers``, ``seeds_per_simulator`` and ``threads``."""
    cpus = max(1, cpus if cpus is not None else (os.cpu_count() or 1))
    workers_per_case = max(1, cpus // max(1, cases))
    per_group = -(-seeds // min(seeds, workers_per_case))
    groups = -(-seeds // per_group) * cases
    workers = min(cpus, groups)
    return {"workers": workers, "seeds_per_simulator": per_group,
            "threads": max(1, cpus // workers)}


def _peak_rss_bytes() -> int | None:
    """Peak resident memory of this process so far (bytes; ``None`` where unavailable)."""
    try:
        import resource
    except ImportError:  # not on Windows
        return None
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return int(peak if sys.platform == "darwin" else peak * 1024)  # macOS: bytes; Linux: KiB


def _earlier_seeds(case_dir: Path, exclude: list[int]) -> list[dict[str, Any]]:
    """Seeds of ``case_dir`` trained by earlier ``msr train`` calls (``--seed-offset``), so that
    ``summary.json`` covers every seed of the case. Their entries from the previous summary are
    kept (wall time, memory) and their episode statistics re-read from ``episodes.csv``."""
    previous: dict[int, dict[str, Any]] = {}
    if (case_dir / "summary.json").is_file():
        try:
            old = json.loads((case_dir / "summary.json").read_text())
            previous = {int(r["seed"]): r for r in old.get("seeds", []) if "seed" in r}
        except (ValueError, KeyError, TypeError):
            previous = {}  # an unreadable summary is rebuilt from the run folders
    found = []
    for path in sorted(case_dir.glob("seed*")):
        tail = path.name[len("seed"):]
        if not tail.isdigit() or int(tail) in exclude or not (path / "episodes.csv").is_file():
            continue
        entry = {k: v for k, v in previous.get(int(tail), {}).items() if k != "succeeded"}
        found.append({**entry, "seed": int(tail), **summarize_run(path), "run_dir": str(path)})
    return found


def train_case(case: str, seeds: int = 8, **kwargs: Any) -> dict[str, Any]:
    """Train seeds of one case: :func:`train_cases` with ``[case]``; returns its summary."""
    return train_cases([case], seeds, **kwargs)[case]


def train_cases(
    cases: Sequence[str],
    seeds: int = 8,
    steps: int = 100_000,
    workers: int | None = None,
    out: str | Path = "runs",
    resume: bool = False,
    seed_offset: int = 0,
    config_overrides: dict[str, Any] | None = None,
    physics: str = "training",
    episode_duration: float = 20.0,
    progress: bool = True,
    threads: int | None = None,
    success_fraction: float = 0.5,
    envs: int = 1,
    backend: str = "process",
    address: str | None = None,
    seeds_per_simulator: int | None = None,
    recipe: str = DEFAULT_RECIPE,
) -> dict[str, dict[str, Any]]:
    """Train seeds ``seed_offset .. seed_offset + seeds - 1`` of every case in ``cases`` for
    ``steps`` environment steps each, in groups of seeds of one case that train side by side in
    one worker (:func:`_train_group`), ``workers`` groups at a time in separate processes
    (``spawn``, one progress bar per seed) or Ray tasks.

    The layout (``workers``, ``seeds_per_simulator``, ``threads``) defaults to
    :func:`default_layout`, the fastest one known for this machine; the results do not depend on
    it (a seed trained in a group is bit-identical to the same seed trained alone).

    Writes ``out/<case>/seed<k>/`` per seed and ``out/<case>/summary.json`` per case; returns the
    summaries by case. A summary covers every seed folder of its case, also those of earlier calls
    (trained with another ``seed_offset``), so success counts and the best seed are over all of
    them. A seed counts as *succeeded* when its final mean episode return reaches
    ``success_fraction`` of the authors' distance rate (their 10 s distance, scaled to the episode
    length, x 1e4): a heuristic to count working seeds, reported with its threshold.

    Args:
        config_overrides: :class:`~rl.td3.TD3Config` fields on top of :func:`crawler_config`
            (e.g. ``precision="bf16"``, ``device="cuda"``).
        workers: groups trained at a time (processes or Ray tasks in flight).
        threads: torch threads per worker. Exact resume needs the same thread count.
        envs: crawlers per seed (``envs`` transitions and updates per vector step); resume with
            the same value.
        backend: ``"process"`` (default: worker processes on this machine) or ``"ray"`` (one Ray
            task per group; see :mod:`rl.backends`). Same run directories and summaries.
        address: Ray cluster to run on (``backend="ray"`` only; default: a local Ray instance with
            ``workers x threads`` CPUs, started and shut down here). The output folder must then be
            on a filesystem every node sees at the same path.
        seeds_per_simulator: seeds of a case per group (one batched simulator, one stacked
            update).
        recipe: the training recipe (:data:`RECIPES`), recorded in ``run.json`` and the summary.
    """
    cases = list(dict.fromkeys(cases))  # in order, once each
    if not cases:
        raise ValueError("no case to train")
    for case in cases:
        _case(case)
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; choose one of {', '.join(BACKENDS)}")
    if address is not None and backend != "ray":
        raise ValueError("--address is for the ray backend (--backend ray)")
    for name, value in (("seeds", seeds), ("steps", steps), ("envs", envs), ("workers", workers),
                        ("seeds_per_simulator", seeds_per_simulator), ("threads", threads)):
        if value is not None and value < 1:
            raise ValueError(f"{name} must be >= 1, got {value}")
    if seed_offset < 0:
        raise ValueError(f"seed_offset must be >= 0, got {seed_offset}")
    layout = default_layout(seeds, len(cases), None if not address else seeds * len(cases))
    manual = {k for k, v in (("workers", workers), ("seeds_per_simulator", seeds_per_simulator),
                             ("threads", threads)) if v is not None}
    seeds_per_simulator = min(seeds, seeds_per_simulator or layout["seeds_per_simulator"])
    seed_list = [seed_offset + k for k in range(seeds)]
    groups = [seed_list[i:i + seeds_per_simulator] for i in range(0, seeds, seeds_per_simulator)]
    workers = min(workers or layout["workers"], len(groups) * len(cases))
    if threads is None:  # on a Ray cluster this machine's CPU count says nothing: one per worker
        threads = 1 if address else max(1, (os.cpu_count() or 1) // workers)
    configs = {s: crawler_config(s, recipe, **(config_overrides or {})) for s in seed_list}
    if not resume:
        existing = [str(Path(out) / case / f"seed{s}") for case in cases for s in seed_list
                    if (Path(out) / case / f"seed{s}" / "checkpoint.pt").exists()]
        if existing:
            raise FileExistsError(f"runs already exist: {', '.join(existing)} (use --resume, another "
                                  "--out, or --seed-offset)")
    else:
        missing = [str(Path(out) / case / f"seed{s}" / "checkpoint.pt") for case in cases
                   for s in seed_list if not (Path(out) / case / f"seed{s}" / "checkpoint.pt").exists()]
        if missing:
            raise FileNotFoundError(f"cannot resume: no checkpoint {', '.join(missing)} (train those "
                                    "seeds without --resume, or choose --seeds/--seed-offset)")
        from .checkpoint import load_checkpoint, refuse_networks_only

        for case in cases:  # a resumed run keeps its settings: checked before any work
            for s in seed_list:
                path = Path(out) / case / f"seed{s}" / "checkpoint.pt"
                refuse_networks_only(load_checkpoint(path, with_buffer=False), path)
                _check_resume_settings(Path(out) / case / f"seed{s}", {
                    "case": case, "physics": physics, "episode_duration_s": float(episode_duration),
                    "recipe": recipe})

    from elastica_magnetic.io import prepare_output_dir

    for case in cases:  # every seed's folder can be written, before any work
        for s in seed_list:
            prepare_output_dir(Path(out) / case / f"seed{s}", "--out")

    def run_dir(case: str, seed: int) -> str:
        # Ray workers may run elsewhere (another cwd, another node): give them absolute paths
        path = Path(out) / case / f"seed{seed}"
        return str(path.resolve() if backend == "ray" else path)

    jobs = []
    position = 0
    for case in cases:
        for group in groups:
            jobs.append({
                "case": case, "physics": physics, "duration": float(episode_duration),
                "steps": int(steps), "resume": resume, "progress": progress, "position": position,
                "threads": threads, "envs": int(envs), "recipe": recipe,
                "configs": [configs[s].to_dict() for s in group],
                "run_dirs": [run_dir(case, s) for s in group],
                # for the backends' bookkeeping: the group's first seed and folder
                "config": configs[group[0]].to_dict(), "run_dir": run_dir(case, group[0]),
            })
            position += len(group)
    start = time.perf_counter()
    results = []
    for job, result in zip(jobs, run_jobs(_train_group, jobs, workers, backend=backend,
                                          address=address, progress=progress), strict=True):
        if "group" in result:
            results += [(job["case"], r) for r in result["group"]]
        else:  # the whole group failed: what its folders hold is still reported
            for c, d in zip(job["configs"], job["run_dirs"], strict=True):
                entry = summarize_run(d) if (Path(d) / "episodes.csv").is_file() else {}
                results.append((job["case"], {**entry, "seed": c["seed"], "error": result["error"]}))
    wall = time.perf_counter() - start

    summaries = {}
    for case in cases:
        case_dir = Path(out) / case
        mine = [r for c, r in results if c == case]
        for r in mine:
            if "run_dir" in r:
                r["run_dir"] = str(case_dir / f"seed{r['seed']}")
        threshold = success_fraction * AUTHORS_DISTANCE_10S[case] * (episode_duration / 10.0) * 1e4
        per_seed = sorted(mine + _earlier_seeds(case_dir, seed_list), key=lambda r: r["seed"])
        for r in per_seed:
            if "error" not in r:
                r["succeeded"] = bool(r["final_mean_return"] >= threshold)
        ok = [r for r in per_seed if "error" not in r and math.isfinite(r["final_mean_return"])]
        best = max(ok, key=lambda r: r["final_mean_return"]) if ok else None
        summary = {
            "case": case,
            "steps": int(steps),
            "physics": physics,
            "episode_duration_s": float(episode_duration),
            "workers": workers,
            "backend": backend,
            "envs_per_seed": int(envs),
            "seeds_per_simulator": int(seeds_per_simulator),
            "torch_threads_per_worker": threads,
            "layout": "default" if not manual else f"set: {', '.join(sorted(manual))}",
            "recipe": recipe,
            "precision": configs[seed_list[0]].precision,
            "device": configs[seed_list[0]].device,
            "success_threshold_return": threshold,
            "succeeded": sum(bool(r.get("succeeded")) for r in per_seed),
            "best_seed": best["seed"] if best else None,
            "best_run_dir": best["run_dir"] if best else None,
            "wall_s": wall,
            "seeds": per_seed,
            "failed": [r["seed"] for r in per_seed if "error" in r],
        }
        case_dir.mkdir(parents=True, exist_ok=True)
        _write_json(case_dir / "summary.json", summary)
        summary["summary_json"] = str(case_dir / "summary.json")
        summaries[case] = summary
    return summaries


def _checkpoint_path(run: str | Path) -> Path:
    run = Path(run)
    path = run / "checkpoint.pt" if run.is_dir() else run
    if not path.is_file():
        raise PolicyNotFoundError(f"{run}: no checkpoint.pt (expected a run directory or a checkpoint)")
    return path


def _checkpoint_metadata(ckpt: dict[str, Any], path: Path) -> dict[str, Any]:
    """The case and settings of a checkpoint: its own metadata, else ``run.json`` next to it."""
    meta = dict(ckpt.get("metadata") or {})
    if "case" not in meta and (path.parent / RUN_JSON).is_file():
        meta = {**json.loads((path.parent / RUN_JSON).read_text()), **meta}
    if "case" not in meta:
        raise ValueError(f"{path}: the checkpoint names no case (no metadata, no {RUN_JSON})")
    return meta


def refine(
    run: str | Path,
    steps: int = 1000,
    out: str | Path | None = None,
    resume: bool = False,
    progress: bool = True,
    episode_duration: float = 20.0,
    physics: str = "accurate",
    device: str | None = None,
) -> dict[str, Any]:
    """Continue training a run for ``steps`` more environment steps in the accurate physics
    (on ``device``, default the run's).

    The agent (networks, targets, optimisers), its replay buffer, RNG states and counters come from
    the run's checkpoint (``init_from``), so learning continues at once (the counters are past the
    warm-up) with the training-physics transitions still in the buffer, gradually displaced by
    accurate ones. Episodes keep the training setting (random initial field, 20 s). The refined
    run goes to ``out`` (default ``RUN/refined``) with its own ``episodes.csv``, TensorBoard scalars,
    ``checkpoint.pt`` and ``run.json``; ``resume`` continues an interrupted refinement.

    Cost: one accurate step is 1250 substeps (~0.1 s here), 12.5x a training step.
    """
    from .checkpoint import load_checkpoint, refuse_networks_only
    from .runner import train_seeds
    from .td3 import TD3Config
    from .vector_env import make_vector_env

    if steps < 1:
        raise ValueError("steps must be >= 1")
    source = _checkpoint_path(run)
    ckpt = load_checkpoint(source)
    refuse_networks_only(ckpt, source)
    meta = _checkpoint_metadata(ckpt, source)
    case = meta["case"]
    out = Path(out) if out is not None else source.parent / "refined"
    start_step = int(ckpt["global_step"])
    total = start_step + int(steps)
    config = TD3Config.from_dict(ckpt["config"])
    if device is not None:
        config.device = device
    metadata = _run_metadata(
        case, physics, episode_duration, config.seed, command="refine",
        refined_from=str(source), refine_start_step=start_step, refine_steps=int(steps),
        training_steps=int(meta.get("training_steps", start_step)),
    )
    if (out / "checkpoint.pt").exists() and not resume:
        raise FileExistsError(f"{out} already holds a refined checkpoint (use --resume or --out)")
    _write_json(out / RUN_JSON, {**metadata, "steps": total, "config": config.to_dict(),
                                 "versions": _versions()})
    begin = time.perf_counter()
    train_seeds(functools.partial(make_vector_env, case, physics=physics, initial_field="random",
                                  duration=episode_duration),
                [config], total, [out], resume=resume, progress=progress, init_from=[source],
                progress_desc=f"refine {case} seed{config.seed}", metadata=[metadata])
    summary = summarize_run(out)
    return {"case": case, "source": str(source), "run_dir": str(out),
            "checkpoint": str(out / "checkpoint.pt"), "start_step": start_step, "steps": int(steps),
            "physics": physics, **{k: summary[k] for k in ("episodes", "final_mean_return")},
            "wall_s": time.perf_counter() - begin}


# ----------------------------------------------------------------------------------------------
# Policies: loading, shipping, exporting
# ----------------------------------------------------------------------------------------------
@dataclass
class LoadedPolicy:
    """A policy ready to act: the actor (normalised actions), the critic if known, and its case."""

    actor: Any  # rl.td3.Actor in eval mode
    critic: Any | None  # rl.td3.TwinCritic or None
    case: str
    source: Path
    kind: str  # "checkpoint" or "shipped"
    meta: dict[str, Any] = field(default_factory=dict)
    obs_dim: int = 260
    act_dim: int = 2
    hidden_sizes: tuple[int, ...] = (256, 256)

    def act(self, obs: np.ndarray) -> np.ndarray:
        """Deterministic normalised action in [-1, 1]^2 for one observation (float32)."""
        import torch

        with torch.no_grad():
            x = torch.as_tensor(np.asarray(obs, dtype=np.float32).reshape(1, -1))
            return self.actor(x)[0].numpy().astype(np.float32)


def _build_networks(obs_dim: int, act_dim: int, hidden: tuple[int, ...], actor_state: dict,
                    critic_state: dict | None, source: Path | None = None):
    from .td3 import Actor, TwinCritic

    def load(network, state, what: str):
        try:
            network.load_state_dict(state)
        except (RuntimeError, KeyError, TypeError, AttributeError) as exc:
            first = str(exc).strip().splitlines()
            raise PolicyFileError(
                f"{source}: the {what} weights do not fit the architecture it declares "
                f"(observations {obs_dim}, actions {act_dim}, hidden sizes {list(hidden)}): "
                f"{' '.join(first[1:3] or first)[:300]}"
            ) from None
        return network.eval().requires_grad_(False)

    actor = load(Actor(obs_dim, act_dim, hidden), actor_state, "actor")
    critic = None
    if critic_state is not None:
        critic = load(TwinCritic(obs_dim, act_dim, hidden), critic_state, "critic")
    return actor, critic


def _torch_load(path: Path) -> Any:
    """``torch.load`` of a policy file; a truncated or corrupted file is a PolicyFileError naming it."""
    import torch

    try:
        return torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises EOFError, RuntimeError, UnpicklingError, ...
        raise PolicyFileError(
            f"{path}: cannot be read as a torch file ({type(exc).__name__}: "
            f"{str(exc).splitlines()[0][:200] if str(exc) else 'empty or truncated'}); "
            "restore it from the run or the repository"
        ) from None


def _policy_json(path: Path) -> dict[str, Any]:
    """``policy.json`` of a shipped-format folder, with the keys loading needs checked."""
    try:
        meta = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise PolicyFileError(f"{path}: not valid JSON ({exc})") from None
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
    if meta["case"] not in CASES:
        raise PolicyFileError(f"{path}: unknown case {meta['case']!r}; known: {', '.join(CASES)}")
    return meta


def resolve_policy(policy: str | Path, policies_dir: str | Path | None = None) -> LoadedPolicy:
    """Load a policy from a run directory, a checkpoint file, a shipped-format directory
    (``actor.pt`` + ``policy.json``), or a shipped name (``rl/policies/<name>``), in that order."""

    from .checkpoint import load_checkpoint

    policies_dir = Path(policies_dir) if policies_dir is not None else POLICIES_DIR
    path = Path(policy)
    if not path.exists() and (policies_dir / str(policy)).is_dir():
        path = policies_dir / str(policy)
    if path.is_dir() and (path / "checkpoint.pt").is_file():
        path = path / "checkpoint.pt"
    if path.is_file():
        try:
            ckpt = load_checkpoint(path)
        except ValueError:
            raise
        except Exception as exc:  # a truncated or corrupted file
            raise PolicyFileError(
                f"{path}: cannot be read as a checkpoint ({type(exc).__name__}: "
                f"{str(exc).splitlines()[0][:200] if str(exc) else 'empty or truncated'})"
            ) from None
        meta = _checkpoint_metadata(ckpt, path)
        try:
            hidden = tuple(ckpt["config"]["hidden_sizes"])
            actor_state, critic_state = ckpt["agent"]["actor"], ckpt["agent"]["critic"]
            obs_dim, act_dim = ckpt["obs_dim"], ckpt["act_dim"]
        except (KeyError, TypeError) as exc:
            raise PolicyFileError(f"{path}: incomplete checkpoint (no {exc})") from None
        actor, critic = _build_networks(obs_dim, act_dim, hidden, actor_state, critic_state, path)
        meta = {**meta, "global_step": int(ckpt["global_step"]), "config": ckpt["config"],
                "checkpoint_kind": ckpt.get("kind", "full")}
        return LoadedPolicy(actor, critic, meta["case"], path, "checkpoint", meta,
                            ckpt["obs_dim"], ckpt["act_dim"], hidden)
    if path.is_dir() and (path / POLICY_JSON).is_file() and (path / "actor.pt").is_file():
        meta = _policy_json(path / POLICY_JSON)
        arch = meta["architecture"]
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
        actor, critic = _build_networks(arch["obs_dim"], arch["act_dim"], hidden, actor_state,
                                        critic_state, path / "actor.pt")
        return LoadedPolicy(actor, critic, meta["case"], path, "shipped", meta, arch["obs_dim"],
                            arch["act_dim"], hidden)
    shipped = sorted(p.name for p in policies_dir.glob("*") if (p / POLICY_JSON).is_file()) \
        if policies_dir.is_dir() else []
    raise PolicyNotFoundError(
        f"{policy}: not a run directory, checkpoint, shipped-policy folder or shipped policy name "
        f"(shipped in {policies_dir}: {', '.join(shipped) or 'none'})"
    )


# ----------------------------------------------------------------------------------------------
# Generating fields
# ----------------------------------------------------------------------------------------------
def run_policy(
    policy: LoadedPolicy | RotatingFieldPolicy,
    duration: float = 10.0,
    physics: str = "accurate",
    initial_field: str = "zero",
    progress: bool = True,
):
    """Roll out ``policy`` deterministically for ``duration`` s; returns a :class:`~rl.rollout.Rollout`
    (stops early, with ``meta["diverged"]``, if the simulation blows up)."""
    import pandas as pd
    from tqdm.auto import tqdm

    from elastica_magnetic.simulation import TRAJECTORY_COLUMNS

    from .rollout import Rollout

    env = make_env(policy.case, physics, initial_field, duration)
    obs, _ = env.reset(seed=0)
    if obs.shape[0] != policy.obs_dim:
        raise ValueError(f"policy expects {policy.obs_dim} observations, the environment gives "
                         f"{obs.shape[0]}")
    sim = env.simulation
    n = env.max_episode_steps
    times, positions, observations = [0.0], [sim.rod.position_collection[:2].copy()], [obs]
    rows = [sim.markers()]
    fields, actions, rewards = [], [], []
    diverged = None
    start = time.perf_counter()
    with tqdm(total=n, desc=f"generate {policy.case}", unit="step", disable=not progress,
              leave=False) as bar:
        for _ in range(n):
            action = policy.act(obs)
            obs, reward, terminated, truncated, info = env.step(action)
            if terminated:
                diverged = info.get("divergence", "diverged")
                break
            fields.append(info["field_T"])
            actions.append(action)
            rewards.append(reward)
            times.append(sim.time)
            positions.append(sim.rod.position_collection[:2].copy())
            observations.append(obs)
            rows.append(sim.markers())
            bar.update(1)
            if truncated:
                break
    wall = time.perf_counter() - start
    spec = env.robot_spec
    env.close()
    meta = {
        "case": policy.case, "physics": physics, "initial_field": initial_field,
        "duration_s": float(times[-1]), "field_limit_T": env.field_limit,
        "max_increment_T": env.max_increment, "length_m": spec.length, "radius_m": spec.radius,
        "n_elements": spec.n_elements, "policy_source": str(policy.source),
        "policy_kind": policy.kind, "diverged": diverged, "wall_s": wall,
        "step_ms": 1e3 * wall / max(len(actions), 1),
    }
    return Rollout(
        times=np.asarray(times), positions=np.asarray(positions),
        fields=np.asarray(fields).reshape(-1, 3), actions=np.asarray(actions).reshape(-1, 2),
        rewards=np.asarray(rewards), observations=np.asarray(observations, dtype=np.float32),
        trajectory=pd.DataFrame(rows, columns=list(TRAJECTORY_COLUMNS)), meta=meta,
    )


def evaluate_seeds(
    case_dir: str | Path,
    duration: float = 10.0,
    progress: bool = True,
    workers: int = 1,
) -> list[dict[str, Any]]:
    """Distance in ``duration`` s of every seed of a case, by the shipping criterion: the final
    checkpoint of ``case_dir/seed<k>/``, and its ``best.pt`` (best evaluation during training) when
    there is one, run deterministically in the accurate physics from a zero field (as
    :func:`generate`).

    Each result is cached in the seed's folder (``evaluation.json``) and reused while the
    checkpoint's global step and the duration are the same. Returns one dict per seed, ordered by
    seed: ``seed``, ``global_step``, ``mid_dx_m`` (m), ``diverged``, ``meets_target`` (the
    authors' distance in 10 s reached; ``None`` for other durations) of the final checkpoint, and
    ``best``: the same keys for ``best.pt``, or ``None``.
    """

    case_dir = Path(case_dir)
    results = []
    seeds = sorted((int(p.name[4:]), p) for p in case_dir.glob("seed*")
                   if p.name[4:].isdigit() and (p / "checkpoint.pt").is_file())
    if not seeds:
        raise FileNotFoundError(f"{case_dir}: no seed<k>/checkpoint.pt to evaluate")
    jobs = [(seed, run_dir, duration, progress and workers == 1) for seed, run_dir in seeds]
    if workers > 1:  # each seed's rollouts in its own process
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        context = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
            results = list(pool.map(_evaluate_seed, jobs))
    else:
        results = [_evaluate_seed(job) for job in jobs]
    return results


def _evaluate_seed(job: tuple[int, Path, float, bool]) -> dict[str, Any]:
    """The final and ``best.pt`` evaluations of one seed folder (cached in ``evaluation.json``)."""
    from .checkpoint import BEST_NAME

    seed, run_dir, duration, progress = job
    cache_path = run_dir / "evaluation.json"
    cache = json.loads(cache_path.read_text()) if cache_path.is_file() else {}
    final = _evaluate_cached(run_dir / "checkpoint.pt", cache, duration, progress)
    best = None
    if (run_dir / BEST_NAME).is_file():
        best = _evaluate_cached(run_dir / BEST_NAME, cache.get("best") or {}, duration, progress)
    _write_json(cache_path, {"seed": seed, **final, "best": best})
    return {"seed": seed, **final, "best": best}


def export_seeds(
    case_dir: str | Path,
    dest: str | Path,
    duration: float = 10.0,
    progress: bool = True,
    workers: int = 1,
) -> dict[str, Any]:
    """Every seed of a case as a policy folder ``dest/seed<k>/`` (``actor.pt`` and
    ``policy.json``: what ``msr generate`` reads; no critic, no buffer) and ``dest/seeds.json``:
    one object per seed, ``{"seed", "steps", "distance_10s_m", "actor", "checkpoint",
    "meets_target"}``.

    Each seed's actor is the farther in ``duration`` s (accurate physics, zero field:
    :func:`evaluate_seeds`) of its final checkpoint and its ``best.pt``; ``checkpoint`` says which,
    ``steps`` is that actor's training step and ``distance_10s_m`` its distance (m). Returns
    ``{"seeds": [...], "meeting_target": n, "total": n}``.
    """
    from .checkpoint import BEST_NAME

    case_dir, dest = Path(case_dir), Path(dest)
    evaluations = evaluate_seeds(case_dir, duration, progress, workers)
    entries = []
    for ev in evaluations:
        best = ev.get("best")
        use_best = best is not None and not best["diverged"] and (
            ev["diverged"] or best["mid_dx_m"] > ev["mid_dx_m"])
        chosen = best if use_best else ev
        source = case_dir / f"seed{ev['seed']}" / (BEST_NAME if use_best else "checkpoint.pt")
        folder = f"seed{ev['seed']}"
        ship(source, folder, dest=dest, measure=False, progress=False, overwrite=True,
             with_critic=False, with_card=False)
        entries.append({"seed": ev["seed"], "steps": chosen["global_step"],
                        "distance_10s_m": chosen["mid_dx_m"], "actor": folder,
                        "checkpoint": "best" if use_best else "final",
                        "meets_target": chosen["meets_target"]})
    _write_json(dest / "seeds.json", entries)
    return {"seeds": entries, "total": len(entries),
            "meeting_target": sum(bool(e["meets_target"]) for e in entries)}


def _evaluate_cached(path: Path, cached: dict[str, Any], duration: float,
                     progress: bool) -> dict[str, Any]:
    """The accurate evaluation of one checkpoint file with its ``meets_target`` verdict, reusing
    ``cached`` when it is of the same global step and duration."""
    policy = resolve_policy(path)
    step = policy.meta.get("global_step")
    if cached.get("global_step") == step and cached.get("duration_s") == float(duration):
        entry = {k: cached[k] for k in ("global_step", "duration_s", "physics", "initial_field",
                                        "mid_dx_m", "diverged")}
    else:
        rollout = run_policy(policy, duration, "accurate", "zero", progress)
        entry = {"global_step": step, "duration_s": float(duration), "physics": "accurate",
                 "initial_field": "zero", "mid_dx_m": rollout.mid_dx,
                 "diverged": rollout.meta["diverged"]}
    target = AUTHORS_DISTANCE_10S[policy.case]
    entry["meets_target"] = (entry["mid_dx_m"] >= target and not entry["diverged"]
                             if abs(duration - 10.0) < 1e-9 else None)
    return entry


def generate(
    policy: str | Path | LoadedPolicy | RotatingFieldPolicy,
    duration: float = 10.0,
    out: str | Path = "out/generate",
    physics: str = "accurate",
    progress: bool = True,
    figures: bool = True,
    gif: bool = True,
) -> dict[str, Any]:
    """Generate a field waveform with a policy: accurate physics, field from zero, deterministic.

    ``policy`` is anything :func:`resolve_policy` accepts, a loaded policy, or a hand-designed
    baseline such as :class:`~rl.baselines.RotatingFieldPolicy`.

    Writes into ``out``: ``fields.csv`` (paper format: index, mag_x, mag_y, mag_z in mT; row ``i``
    is the field held on ``[i/100, (i+1)/100)`` s), ``trajectory.csv`` (the columns of
    ``msr replay``, 100 Hz, first row t = 0), ``gait.csv`` (height, span and the contact strength
    of the back and front nodes, 100 Hz), ``rollout.npz`` (every node position, observation, action
    and field), ``generate.json`` (this result), the figures and ``gait.gif``.

    Returns a dict with at least ``mid_dx_m`` (x displacement of the middle, mean of the two central
    element centres as in ``trajectory.csv``, m), ``node32_dx_m`` (of the reward's middle node),
    ``fields_csv`` and ``trajectory_csv``.
    """
    import pandas as pd

    from elastica_magnetic import write_field_csv, write_trajectory_csv

    from .figures import rollout_figures

    check_duration(duration)
    loaded = resolve_policy(policy) if isinstance(policy, (str, Path)) else policy
    out = prepare_output_dir(out)
    rollout = run_policy(loaded, duration, physics, "zero", progress)
    fields_csv = write_field_csv(out / "fields.csv", rollout.fields) if rollout.n_steps else None
    trajectory_csv = write_trajectory_csv(rollout.trajectory, out / "trajectory.csv")
    rollout_npz = rollout.save(out)
    traj = rollout.trajectory
    contact = rollout.contact()
    gait_csv = out / "gait.csv"
    with atomic_write(gait_csv, "w", newline="") as handle:
        pd.DataFrame({
            "t_s": traj.t_s, "height_max_m": traj.height_max_m, "span_m": traj.span_m,
            "contact_back": contact[:, 0], "contact_front": contact[:, -1],
        }).to_csv(handle, index=False, float_format="%.9g")
    mid = rollout.positions.shape[2] // 2
    result: dict[str, Any] = {
        "case": loaded.case,
        "policy": str(loaded.source),
        "policy_kind": loaded.kind,
        "physics": physics,
        "duration_s": float(rollout.times[-1]),
        "mid_dx_m": rollout.mid_dx,
        "node32_dx_m": float(rollout.positions[-1, 0, mid] - rollout.positions[0, 0, mid]),
        "return": float(np.sum(rollout.rewards)),
        "max_height_m": float(traj.height_max_m.max()),
        "max_field_T": float(np.max(np.hypot(rollout.fields[:, 0], rollout.fields[:, 1])))
        if rollout.n_steps else 0.0,
        "authors_mid_dx_10s_m": AUTHORS_DISTANCE_10S.get(loaded.case),
        "diverged": rollout.meta["diverged"],
        "fields_csv": str(fields_csv) if fields_csv else None,
        "trajectory_csv": str(trajectory_csv),
        "rollout_npz": str(rollout_npz),
        "gait_csv": str(gait_csv),
        "step_ms": rollout.meta["step_ms"],
    }
    if figures and rollout.n_steps:
        result["figures"] = rollout_figures(rollout, out, loaded.critic, loaded.actor, gif=gif)
    _write_json(out / "generate.json", result)
    return result


def ship(
    run: str | Path,
    name: str,
    dest: str | Path | None = None,
    measure: bool = True,
    duration: float = 10.0,
    progress: bool = True,
    overwrite: bool = False,
    evaluate_all_seeds: bool = False,
    notes: str | None = None,
    with_critic: bool = True,
    with_card: bool = True,
) -> dict[str, Any]:
    """Pack a run's checkpoint into the shipped-policy format ``dest/<name>/`` (default
    ``rl/policies/<name>/``): ``actor.pt`` and ``critic.pt`` (state dicts of
    :class:`~rl.td3.Actor` / :class:`~rl.td3.TwinCritic`), ``policy.json`` (case, observation
    layout and scaling, action scaling, architecture, provenance) and ``MODEL_CARD.md``.

    With ``measure`` the policy is run for ``duration`` s in the accurate physics from a zero field
    (as :func:`generate`); the distance goes into the card and the waveform into ``fields.csv``.
    The success count over seeds comes from the case's ``summary.json`` when it is found; with
    ``evaluate_all_seeds`` every seed of the case is also run like this (:func:`evaluate_seeds`)
    and the card lists each seed's distance and how many reach the authors' distance. ``notes``
    (Markdown) becomes the card's "Notes" section: what the numbers do not say. ``with_critic`` /
    ``with_card``: also write ``critic.pt`` / ``MODEL_CARD.md``.
    """
    import torch

    from elastica_magnetic import write_field_csv

    policy = resolve_policy(run)
    if policy.kind != "checkpoint":
        raise ValueError(f"{run}: ship takes a run directory or checkpoint, not a shipped policy")
    target = (Path(dest) if dest is not None else POLICIES_DIR) / name
    if (target / POLICY_JSON).exists() and not overwrite:
        raise FileExistsError(f"{target} already holds a policy (pass overwrite / --force)")
    target.mkdir(parents=True, exist_ok=True)
    torch.save(policy.actor.state_dict(), target / "actor.pt")
    if policy.critic is not None and with_critic:
        torch.save(policy.critic.state_dict(), target / "critic.pt")
    meta = policy.meta
    summary = _find_summary(policy.source, policy.case)
    measured = None
    if measure:
        rollout = run_policy(policy, duration, "accurate", "zero", progress)
        measured = {"duration_s": float(rollout.times[-1]), "mid_dx_m": rollout.mid_dx,
                    "diverged": rollout.meta["diverged"]}
        if rollout.n_steps:
            write_field_csv(target / "fields.csv", rollout.fields)
    seed_evaluations = None
    if evaluate_all_seeds:
        if summary is None:
            raise FileNotFoundError(f"{policy.source}: no summary.json of case {policy.case} found "
                                    "above the run, so its seeds cannot be evaluated")
        seed_evaluations = evaluate_seeds(_find_case_dir(policy.source, policy.case), duration,
                                          progress)
    case = _case(policy.case)
    refined = meta.get("command") == "refine"
    info = {
        "format": POLICY_FORMAT,
        "name": name,
        "case": policy.case,
        "pattern": case.pattern,
        "field_limit_T": case.field_limit,
        "actor_sha256": weights_sha256(policy.actor.state_dict()),
        "architecture": {"type": "mlp", "obs_dim": policy.obs_dim, "act_dim": policy.act_dim,
                         "hidden_sizes": list(policy.hidden_sizes), "activation": "relu",
                         "output": "tanh", "module": "rl.td3.Actor (net = Sequential of Linear/ReLU)"},
        "observation": observation_spec(),
        "action": _action_spec(case.field_limit),
        "training": {
            "seed": meta.get("seed"),
            "training_steps": meta.get("training_steps", meta.get("global_step")),
            "refine_steps": meta.get("refine_steps", 0) if refined else 0,
            "global_step": meta.get("global_step"),
            "config": meta.get("config"),
            "source": _portable_source(policy.source, policy.case),
            "best_evaluation": meta.get("checkpoint_kind") == "best",
        },
        "seeds": {"succeeded": summary.get("succeeded"), "total": len(summary.get("seeds", [])),
                  "success_threshold_return": summary.get("success_threshold_return"),
                  "evaluations": seed_evaluations,
                  "meeting_target": None if seed_evaluations is None
                  else sum(_seed_meets_target(e) for e in seed_evaluations)}
        if summary else None,
        "evaluation": measured,
        "authors_mid_dx_10s_m": AUTHORS_DISTANCE_10S[policy.case],
        "notes": notes,
    }
    _write_json(target / POLICY_JSON, info)
    if with_card:
        (target / "MODEL_CARD.md").write_text(_model_card(info, summary))
    return {"name": name, "dir": str(target), "case": policy.case,
            "evaluation": measured, "files": sorted(p.name for p in target.iterdir())}


def _portable_source(path: Path, case: str) -> str:
    """Where a shipped policy came from, without this machine's folders: the path from the case's
    training folder on (``m1-4mT/seed3/refined/checkpoint.pt``), else the file's name."""
    parts = Path(path).parts
    if case in parts:
        return "/".join(parts[len(parts) - 1 - parts[::-1].index(case):])
    return Path(path).name


def _seed_meets_target(evaluation: dict[str, Any]) -> bool:
    """A seed succeeds when its final actor or its best evaluated one reaches the target."""
    best = evaluation.get("best") or {}
    return bool(evaluation["meets_target"]) or bool(best.get("meets_target"))


def _find_case_dir(source: Path, case: str) -> Path | None:
    """The case folder of a run (``<case>/seed<k>[/refined]/checkpoint.pt``): the nearest parent
    holding the ``summary.json`` of ``case``."""
    for parent in list(source.parents)[:4]:
        if (parent / "summary.json").is_file():
            summary = json.loads((parent / "summary.json").read_text())
            if summary.get("case") == case:
                return parent
    return None


def _find_summary(source: Path, case: str) -> dict[str, Any] | None:
    """``summary.json`` of the case folder of a run, if there is one."""
    case_dir = _find_case_dir(source, case)
    return json.loads((case_dir / "summary.json").read_text()) if case_dir else None


def _action_spec(field_limit: float) -> dict[str, Any]:
    return {
        "shape": [2],
        "low": -1.0,
        "high": 1.0,
        "meaning": "field increment (dB_x, dB_y) = field_increment_T_per_unit * action",
        "field_increment_T_per_unit": MAX_FIELD_INCREMENT,
        "field_increment_mT_per_unit": MAX_FIELD_INCREMENT * 1e3,
        "field_limit_T": field_limit,
        "field_rule": "B += clip(dB, -0.3 mT, 0.3 mT); clip each component to +-limit; if |B| > limit "
                      "scale B to |B| = limit; hold for 0.01 s (100 Hz)",
        "control_period_s": 0.01,
    }


def _model_card(info: dict[str, Any], summary: dict[str, Any] | None) -> str:
    tr, ev = info["training"], info["evaluation"]
    target = info["authors_mid_dx_10s_m"]
    lines = [
        f"# Model card: `{info['name']}`",
        "",
        f"TD3 actor that drives the crawling robot of Yao et al. 2023, magnetization pattern "
        f"{info['pattern']}, field limit {1e3 * info['field_limit_T']:g} mT (case `{info['case']}`).",
        "",
        "## Use",
        "",
        f"- `msr generate {info['name']} --duration 10 --out DIR`: field CSV (mT, 100 Hz) from a "
        "zero field in the accurate physics, trajectory, figures, GIF.",
        f"- `msr export {info['name']} --out DIR`: TorchScript + observation/action JSON.",
        "- Input: 260 float32 observations (layout and scales in `policy.json`); output: 2 actions in "
        "[-1, 1], x 0.3 mT = field increment per 0.01 s.",
        "",
        "## Training",
        "",
        f"- seed: {tr['seed']}",
        f"- training steps (mass-scaled training physics, dt 1e-4 s): {tr['training_steps']}",
        f"- refinement steps (accurate physics, dt 8e-6 s): {tr['refine_steps']}",
        f"- checkpoint: `{tr['source']}` (global step {tr['global_step']}"
        + ("; the best of the evaluations during training" if tr.get("best_evaluation") else "")
        + ")",
    ]
    if summary:
        lines.append(
            f"- seeds that succeeded: {summary.get('succeeded')} of {len(summary.get('seeds', []))} "
            f"(final mean episode return >= {summary.get('success_threshold_return', float('nan')):.0f}, "
            "half the authors' distance rate)"
        )
    else:
        lines.append("- seeds that succeeded: unknown (no summary.json found next to the run)")
    evaluations = (info.get("seeds") or {}).get("evaluations")
    if evaluations:
        lines += [
            "",
            "## Every seed of the case (accurate physics, field from zero)",
            "",
            f"{info['seeds']['meeting_target']} of {len(evaluations)} seeds move the robot at least "
            f"as far as the authors' policy ({1e3 * target:+.1f} mm in 10 s) with their final "
            "actor or with the best actor of their evaluations during training (`best.pt`, where "
            "the run has one).",
            "",
            "| seed | training steps | distance, final actor (mm) | best.pt: step, distance (mm) "
            "| meets the target |",
            "|---|---|---|---|---|",
        ]
        for e in evaluations:
            best = e.get("best")
            verdict = "n/a" if e["meets_target"] is None else \
                ("yes" if _seed_meets_target(e) else "no")
            for entry in (e, best):
                if entry and entry["diverged"]:
                    verdict += f" (diverged: {entry['diverged']})"
            best_cell = (f"{best['global_step']}, {1e3 * best['mid_dx_m']:+.1f}" if best else "-")
            lines.append(f"| {e['seed']} | {e['global_step']} | {1e3 * e['mid_dx_m']:+.1f} "
                         f"(in {e['duration_s']:g} s) | {best_cell} | {verdict} |")
    lines += ["", "## Evaluation (accurate physics, field from zero, deterministic)", ""]
    if ev:
        if abs(ev["duration_s"] - 10.0) < 1e-6:
            verdict = "meets the target" if ev["mid_dx_m"] >= target else "falls short of the target"
        else:
            verdict = "not comparable: the target is for 10 s"
        lines.append(
            f"- middle of the robot moved {1e3 * ev['mid_dx_m']:+.1f} mm in {ev['duration_s']:g} s; "
            f"the authors' policy: {1e3 * target:+.1f} mm in 10 s ({verdict})"
            + (f"; DIVERGED: {ev['diverged']}" if ev["diverged"] else "")
        )
    else:
        lines.append(f"- not measured (the authors' policy: {1e3 * target:+.1f} mm in 10 s)")
    if info.get("notes"):
        lines += ["", "## Notes", "", info["notes"].strip()]
    lines += [
        "",
        "## Limitations",
        "",
        "- Simulation only: the model's rotational over-damping makes the simulated robot respond "
        "~0.3 s slower than the real one (paper); check the waveform on hardware at low amplitude "
        "first.",
        "- Trained for one robot (20 x 8 x 0.8 mm, 84.5 kPa, 61.3 kA/m) on a flat ground with "
        "friction 0.8/0.6; other robots need retraining.",
        "",
    ]
    return "\n".join(lines)


def export_policy(policy: str | Path, out: str | Path = "out/export") -> dict[str, Any]:
    """Export the actor as TorchScript (``policy.ts.pt``, traced: float32 ``(N, 260)`` observations
    -> ``(N, 2)`` actions in [-1, 1]), as a ``torch.export`` program (``policy.pt2``, dynamic batch;
    torch 2.13 deprecates TorchScript), and ``policy.json`` (observation layout and scaling, action
    scaling and field rule, case). Both files are checked by reloading them with plain torch
    (``torch.jit.load``, ``torch.export.load``).

    Returns the paths, ``max_abs_diff`` / ``max_abs_diff_pt2`` between the reloaded modules and the
    agent's actor on a batch of observations, and the sizes.
    """
    import torch

    from .td3 import ScaledPolicy

    loaded = resolve_policy(policy)
    out = prepare_output_dir(out)
    module = ScaledPolicy(loaded.actor, np.full(loaded.act_dim, -1.0), np.full(loaded.act_dim, 1.0))
    module.eval().requires_grad_(False)
    example = torch.zeros(2, loaded.obs_dim)
    ts_path = out / "policy.ts.pt"
    pt2_path = out / "policy.pt2"
    with warnings.catch_warnings():
        # torch 2.13 deprecates torch.jit (trace, save, load) in favour of torch.export; TorchScript
        # is still what C++/LibTorch and older runtimes load, so both formats are written.
        warnings.simplefilter("ignore", DeprecationWarning)
        with torch.no_grad():
            traced = torch.jit.trace(module, example, check_trace=True)
        atomic_save(ts_path, lambda tmp: traced.save(str(tmp)))
        reloaded = torch.jit.load(str(ts_path))
    batch_dim = torch.export.Dim("batch", min=1)
    exported = torch.export.export(module, (example,), dynamic_shapes=({0: batch_dim},))
    atomic_save(pt2_path, lambda tmp: torch.export.save(exported, str(tmp)))
    reloaded_pt2 = torch.export.load(str(pt2_path)).module()

    # Check: the reloaded modules give the agent's actions on real and random observations.
    env = make_env(loaded.case, "training", "random", 0.05)
    obs, _ = env.reset(seed=0)
    batch = [obs]
    for _ in range(3):
        obs, *_ = env.step(env.action_space.sample())
        batch.append(obs)
    env.close()
    rng = np.random.default_rng(0)
    batch = np.concatenate([np.asarray(batch, dtype=np.float32),
                            rng.normal(0.0, 1.0, (12, loaded.obs_dim)).astype(np.float32)])
    with torch.no_grad():
        x = torch.from_numpy(batch)
        reference = loaded.actor(x)
        diff = float((reloaded(x) - reference).abs().max())
        diff_pt2 = float((reloaded_pt2(x) - reference).abs().max())
    case = _case(loaded.case)
    info = {
        "format": EXPORT_FORMAT,
        "case": loaded.case,
        "pattern": case.pattern,
        "torchscript": ts_path.name,
        "torch_export": pt2_path.name,
        "input": {"shape": ["N", loaded.obs_dim], "dtype": "float32"},
        "output": {"shape": ["N", loaded.act_dim], "dtype": "float32", "range": [-1.0, 1.0]},
        "observation": observation_spec(),
        "action": _action_spec(case.field_limit),
        "usage": "m = torch.jit.load('policy.ts.pt')  # or torch.export.load('policy.pt2').module(); "
                 "a = m(torch.tensor(obs[None], dtype=torch.float32))[0]; dB_T = 3e-4 * a",
        "source": str(loaded.source),
    }
    json_path = _write_json(out / "policy.json", info)
    return {"torchscript": str(ts_path), "torch_export": str(pt2_path), "json": str(json_path),
            "case": loaded.case, "max_abs_diff": diff, "max_abs_diff_pt2": diff_pt2,
            "obs_dim": loaded.obs_dim, "act_dim": loaded.act_dim}


def demo(out: str | Path = "out/demo", duration: float = 10.0, progress: bool = True,
         name: str = "m1-4mT") -> dict[str, Any]:
    """``msr demo``: generate with the shipped pattern-1 4 mT policy ``m1-4mT``."""
    folder = POLICIES_DIR / name
    missing = [f for f in ("actor.pt", POLICY_JSON) if not (folder / f).is_file()]
    if missing:
        raise PolicyNotFoundError(
            f"no shipped policy {name!r}: {folder} lacks {', '.join(missing)}. Train and ship it "
            f"first: `msr train --case {name} --seeds 8 --steps 100000 --out runs`, "
            f"`msr refine runs/{name}/seed<best>`, `msr ship runs/{name}/seed<best>/refined "
            f"--name {name}`"
        )
    return generate(name, duration=duration, out=out, progress=progress)

