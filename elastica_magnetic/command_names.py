"""How each ``msr`` command is written (one home, read by the command line and by the messages of
the lower layers, such as a result folder naming the command that wrote it).

Commands are grouped by noun (``msr policy generate``); each is registered, and recorded in result
markers, under its plain name (``generate``). This module imports nothing: every layer may read it.
"""

from __future__ import annotations

__all__ = ["COMMAND_HOMES", "FORMER_GROUPS", "spelling"]

#: Commands registered under a plain name that live in a group: plain name -> (group, name there).
#: The plain name stays a hidden top-level alias (scripts written for earlier releases run).
COMMAND_HOMES: dict[str, tuple[str, str]] = {
    "replay": ("field", "replay"), "simulate": ("field", "simulate"), "baseline": ("field", "baseline"),
    "generate": ("policy", "generate"), "demo": ("policy", "demo"), "figures": ("policy", "figures"),
    "export-seeds": ("policy", "export-seeds"), "seeds": ("policy", "seeds"),
    "ship": ("policy", "ship"), "notes": ("policy", "notes"), "export": ("policy", "export"),
    "diagnose": ("policy", "diagnose"),
    "robustness": ("real", "robustness"), "identify": ("real", "identify"),
    "stream": ("real", "stream"), "export-firmware": ("real", "firmware"),
    "calibrate": ("real", "calibrate"),
}

#: Groups of earlier releases merged into another: old group -> (its group now, the commands it
#: had, as spelled in both). ``msr real stream`` stays a hidden spelling of ``msr real stream``.
FORMER_GROUPS: dict[str, tuple[str, tuple[str, ...]]] = {
    "hw": ("real", ("stream", "firmware", "calibrate")),
}


def spelling(plain: str) -> str:
    """How a command is written today: ``"policy generate"`` for ``"generate"``, ``"real stream"``
    for ``"hw stream"``."""
    group, _, name = plain.partition(" ")
    if group in FORMER_GROUPS and name:
        return f"{FORMER_GROUPS[group][0]} {name}"
    return " ".join(COMMAND_HOMES.get(plain, (plain,)))
