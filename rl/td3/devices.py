"""Where the networks compute: whether this PyTorch can put them on a device
(``RunSettings.device``), asked before any work, so that ``--device cuda`` on a CPU build of
PyTorch is refused by name instead of failing deep inside the first ``.to(device)`` after a run
folder was written (issue 48); and the CPU threads a computation takes (:func:`torch_threads`)."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

__all__ = ["device_problem", "torch_threads"]


@contextlib.contextmanager
def torch_threads(n: int) -> Iterator[None]:
    """PyTorch's intra-op threads set to ``n`` inside the block and restored after it: a worker's
    setting run in the caller's own process (one worker) must not stay there (measured: the TD3
    update of small networks at 2 threads beside another busy process on 2 cores, 50x slower than
    at 1: the threads wait on each other)."""
    import torch

    previous = torch.get_num_threads()
    torch.set_num_threads(int(n))
    try:
        yield
    finally:
        torch.set_num_threads(previous)


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
