"""Whether this PyTorch can put the networks on a device (``RunSettings.device``): asked before
any work, so that ``--device cuda`` on a CPU build of PyTorch is refused by name instead of
failing deep inside the first ``.to(device)`` after a run folder was written (issue 48)."""

from __future__ import annotations

__all__ = ["device_problem"]


def device_problem(device: str) -> str | None:
    """Why the networks cannot live on ``device`` (``"cpu"``, ``"cuda"``, ``"cuda:1"``, ...) in
    this PyTorch, as a phrase (``"this PyTorch has no CUDA (CPU build)"``), or ``None`` when they
    can. Imports torch."""
    import torch

    try:
        kind = torch.device(device)
    except (RuntimeError, TypeError) as err:
        return f"not a device PyTorch knows ({err})"
    if kind.type != "cuda":
        return None
    if torch.version.cuda is None:
        return "this PyTorch has no CUDA (CPU build)"
    if not torch.cuda.is_available():
        return (f"this PyTorch (CUDA {torch.version.cuda}) sees no CUDA device (no GPU, its driver "
                "not loaded, or CUDA_VISIBLE_DEVICES empty)")
    count = torch.cuda.device_count()
    if kind.index is not None and kind.index >= count:
        return f"this machine has {count} CUDA device(s), numbered from 0"
    return None
