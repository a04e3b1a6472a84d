"""Keep freed memory in the process (glibc), so the TD3 update stops paying for page faults.

A TD3 update of the paper's networks allocates and frees tensors of 0.25-2 MB dozens of times
(activations, their gradients, the weights' gradients). glibc's ``malloc`` serves blocks above
its mmap threshold with a fresh ``mmap`` and returns them to the kernel on ``free``, so every
such tensor is page-faulted in again on first touch: ~600-850 minor faults per update of 4
stacked seeds, measured at roughly 10 % of the update's time on a 2-core virtual machine.
Raising the mmap and trim thresholds keeps those blocks in the heap and reuses them; the numbers
computed are unchanged (only where the memory comes from changes).

Only glibc has ``mallopt``; elsewhere (macOS, musl) :func:`retain_freed_memory` does nothing.
"""

from __future__ import annotations

import ctypes
import ctypes.util

#: ``mallopt`` parameter numbers (glibc ``malloc.h``).
_M_TRIM_THRESHOLD, _M_TOP_PAD, _M_MMAP_THRESHOLD = -1, -2, -3
#: Blocks up to this size come from the heap (glibc's largest allowed mmap threshold on 64-bit).
MMAP_THRESHOLD_BYTES = 32 * 1024 * 1024
#: Free memory at the top of the heap is returned to the kernel only above this.
TRIM_THRESHOLD_BYTES = 256 * 1024 * 1024
#: Extra memory requested from the kernel each time the heap grows.
TOP_PAD_BYTES = 64 * 1024 * 1024


def retain_freed_memory() -> bool:
    """Set this process's glibc ``malloc`` to keep freed blocks up to
    :data:`MMAP_THRESHOLD_BYTES` for reuse. Returns whether it took effect (``False`` without
    glibc). Idempotent; call it once in each process that trains."""
    name = ctypes.util.find_library("c")
    if name is None:
        return False
    try:
        libc = ctypes.CDLL(name)
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    settings = ((_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES), (_M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES),
                (_M_TOP_PAD, TOP_PAD_BYTES))
    return all(mallopt(param, value) == 1 for param, value in settings)
