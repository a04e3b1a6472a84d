"""How each ``msr`` command is written (one home, read by the command line and by the messages of
the lower layers, such as a result folder naming the command that wrote it).

Commands are grouped by noun (``msr policy generate``); each is registered, and recorded in result
markers, under its plain name (``generate``). This module imports nothing: every layer may read it.
"""

from __future__ import annotations

__all__ = ["COMMAND_HOMES", "spelling"]

#: Commands registered under a plain name that live in a group: plain name -> (group, name there).
#: The plain name stays a hidden top-level alias (scripts written for earlier releases run).
COMMAND_HOMES: dict[str, tuple[str, str]] = {
    "replay": ("field", "replay"), "simulate": ("field", "simulate"), "baseline": ("field", "baseline"),
    "generate": ("policy", "generate"), "demo": ("policy", "demo"), "figures": ("policy", "figures"),
    "export-seeds": ("policy", "export-seeds"), "seeds": ("policy", "seeds"),
    "ship": ("policy", "ship"), "notes": ("policy", "notes"), "export": ("policy", "export"),
    "diagnose": ("policy", "diagnose"),
    "robustness": ("real", "robustness"), "identify": ("real", "identify"),
    "stream": ("hw", "stream"), "export-firmware": ("hw", "firmware"), "calibrate": ("hw", "calibrate"),
}


def spelling(plain: str) -> str:
    """How a command is written today: ``"policy generate"`` for ``"generate"``."""
    return " ".join(COMMAND_HOMES.get(plain, (plain,)))
