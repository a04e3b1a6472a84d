"""How much memory training processes hold: one home for the memory probes.

:func:`peak_rss_bytes` is the peak resident memory of this process (each training worker reports its
own in ``summary.json``: ``peak_rss_bytes``); :func:`process_tree_rss` is the current resident
memory of a process and all its descendants (``msr bench --memory-seeds``, sampled while a
multi-process training runs).
"""

from __future__ import annotations

import os
import sys

__all__ = ["peak_rss_bytes", "process_tree_rss"]


def peak_rss_bytes() -> int | None:
    """Peak resident memory of this process so far (bytes; ``None`` where unavailable)."""
    try:
        import resource
    except ImportError:  # not on Windows
        return None
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return int(peak if sys.platform == "darwin" else peak * 1024)  # macOS: bytes; Linux: KiB


def process_tree_rss(root: int) -> int:
    """Resident memory (bytes) of process ``root`` and all its descendants, from ``/proc`` (Linux;
    0 where ``/proc`` is missing)."""
    children: dict[int, list[int]] = {}
    rss: dict[int, int] = {}
    try:
        entries = os.listdir("/proc")
    except OSError:
        return 0
    for entry in entries:
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/status") as f:
                fields = dict(line.split(":", 1) for line in f if ":" in line)
        except OSError:  # the process ended while we looked
            continue
        pid = int(entry)
        children.setdefault(int(fields["PPid"]), []).append(pid)
        rss[pid] = int(fields.get("VmRSS", "0 kB").split()[0]) * 1024
    total, stack = 0, [root]
    while stack:
        pid = stack.pop()
        total += rss.get(pid, 0)
        stack.extend(children.get(pid, []))
    return total
