"""Export a policy to run without this package (``msr policy export``): the actor as TorchScript and as a
``torch.export`` program, and a ``policy.json`` of the observation layout and scaling and the action
scaling.
"""

from __future__ import annotations

import io
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from elastica_magnetic.io import atomic_write_bytes, atomic_write_json
from elastica_magnetic.results import result_folder

from ..envs.env import make_env
from .policy_files import (
    action_spec_of,
    check_policy_case,
    observation_spec_of,
    resolve_policy,
)

__all__ = ["EXPORT_FILES", "EXPORT_FORMAT", "export_policy"]

#: The files ``msr policy export`` writes.
EXPORT_FILES = ("policy.ts.pt", "policy.pt2", "policy.json")

#: Format of ``msr policy export``'s ``policy.json``.
EXPORT_FORMAT = "msr-exported-policy-v1"


def refuse_residual_export(loaded: Any) -> None:
    """A residual policy is its case's yardstick (a controller with a memory) corrected by its actor:
    the actor alone exported would not be the policy (``ValueError`` naming it)."""
    if loaded.residual:
        raise ValueError(f"{loaded.source}: a residual policy (residual {loaded.residual:g}) acts as the "
                         "case's yardstick corrected by its actor, and the yardstick (a controller with a "
                         "memory) is not a network: the actor alone exported would not be the policy. Play "
                         "it with msr policy generate, or in Python through resolve_policy(...).act")


def export_policy(policy: str | Path, out: str | Path = "out/export",
                  force: bool = False) -> dict[str, Any]:
    """Export the actor as TorchScript (``policy.ts.pt``, traced: float32 ``(N, 260)`` observations
    -> ``(N, 2)`` actions in [-1, 1]), as a ``torch.export`` program (``policy.pt2``, dynamic batch;
    torch 2.13 deprecates TorchScript), and ``policy.json`` (observation layout and scaling, action
    scaling and field rule, case). Both files are checked by reloading them with plain torch
    (``torch.jit.load``, ``torch.export.load``).

    ``out`` is written whole or not at all (:func:`elastica_magnetic.results.result_folder`): an
    earlier export of the same case is replaced only with ``force``, anything else is refused.

    Returns the paths, ``max_abs_diff`` / ``max_abs_diff_pt2`` between the reloaded modules and the
    agent's actor on a batch of observations, and the sizes.
    """
    import torch

    from ..td3.networks import ScaledPolicy

    loaded = resolve_policy(policy)
    refuse_residual_export(loaded)
    check_policy_case(out, loaded.case)
    with result_folder(out, kind="export", subject=f"case {loaded.case.name}", force=force,
                       known_files=EXPORT_FILES) as folder:
        out = folder.path
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
            atomic_write_bytes(ts_path, _saved(lambda buffer: torch.jit.save(traced, buffer)))
            reloaded = torch.jit.load(str(ts_path))
        batch_dim = torch.export.Dim("batch", min=1)
        exported = torch.export.export(module, (example,), dynamic_shapes=({0: batch_dim},))
        atomic_write_bytes(pt2_path, _saved(lambda buffer: torch.export.save(exported, buffer)))
        reloaded_pt2 = torch.export.load(str(pt2_path)).module()

        # Check: the reloaded modules give the agent's actions on real and random observations.
        env = make_env(loaded.case, "training", "random", 0.05)  # a few real observations
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
        case = loaded.case
        info = {
            "format": EXPORT_FORMAT,
            "case": case.name,
            "case_spec": case.to_dict(),
            "torchscript": ts_path.name,
            "torch_export": pt2_path.name,
            "input": {"shape": ["N", loaded.obs_dim], "dtype": "float32"},
            "output": {"shape": ["N", loaded.act_dim], "dtype": "float32", "range": [-1.0, 1.0]},
            "observation": observation_spec_of(case),
            "action": action_spec_of(case),
            "usage": "m = torch.jit.load('policy.ts.pt')  # or torch.export.load('policy.pt2').module(); "
                     "a = m(torch.tensor(obs[None], dtype=torch.float32))[0]; "
                     f"dB_T = {case.actuation.max_increment:g} * a",
            "source": str(loaded.source),
        }
        json_path = atomic_write_json(out / "policy.json", info)
    ts_path, pt2_path, json_path = (folder.final_path(p) for p in (ts_path, pt2_path, json_path))
    return {"torchscript": str(ts_path), "torch_export": str(pt2_path), "json": str(json_path),
            "case": case.name, "max_abs_diff": diff, "max_abs_diff_pt2": diff_pt2,
            "obs_dim": loaded.obs_dim, "act_dim": loaded.act_dim, "notes": folder.notes}


def _saved(save: Callable[[io.BytesIO], Any]) -> bytes:
    """The bytes ``save(buffer)`` writes to an in-memory file. torch's C++ writer, given a path,
    aborts the process on a full disk (``unexpected pos`` in its destructor); the bytes are written
    with Python's I/O instead (a TorchScript actor is a few hundred kB)."""
    buffer = io.BytesIO()
    save(buffer)
    return buffer.getvalue()
