"""Signals as exceptions, so that a command's ``finally`` blocks run when it is stopped.

While :func:`signals_as_exceptions` is entered (in the main thread, where the handler was Python's
default), SIGINT raises :class:`KeyboardInterrupt` and SIGTERM or SIGHUP raise :class:`Interrupted`
(a subclass), so that a result folder being written is removed and the old one kept
(:mod:`elastica_magnetic.results`). :func:`signals_held` holds them back during a step that must
not be cut in two (the two renames of a swap) and raises the first one after it.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from typing import Any

__all__ = ["Interrupted", "signals_as_exceptions", "signals_held"]


class Interrupted(KeyboardInterrupt):
    """SIGTERM or SIGHUP received while a result folder was being written (``signum``)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


_SIGNALS = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, n))
_signal_state: dict[str, Any] = {"depth": 0, "previous": {}, "deferring": 0, "pending": None}


def _raise_for(signum: int) -> None:
    if signum == signal.SIGINT:
        raise KeyboardInterrupt
    raise Interrupted(signum)


def _handler(signum: int, frame: object) -> None:
    if _signal_state["deferring"]:
        _signal_state["pending"] = _signal_state["pending"] or signum
        return
    _raise_for(signum)


@contextlib.contextmanager
def signals_as_exceptions() -> Iterator[None]:
    """SIGINT, SIGTERM and SIGHUP raise in the main thread while this is entered (where their
    handler was Python's default: SIGINT :class:`KeyboardInterrupt`, the others
    :class:`Interrupted`), so ``finally`` blocks run; nested uses share one installation."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    state = _signal_state
    if state["depth"] == 0:
        for signum in _SIGNALS:
            current = signal.getsignal(signum)
            if current in (signal.SIG_DFL, signal.default_int_handler):
                state["previous"][signum] = current
                signal.signal(signum, _handler)
    state["depth"] += 1
    try:
        yield
    finally:
        state["depth"] -= 1
        if state["depth"] == 0:
            for signum, previous in state["previous"].items():
                signal.signal(signum, previous)
            state["previous"] = {}


@contextlib.contextmanager
def signals_held() -> Iterator[None]:
    """Hold SIGINT/SIGTERM/SIGHUP back (when our handler is installed) until the block is over."""
    _signal_state["deferring"] += 1
    try:
        yield
    finally:
        _signal_state["deferring"] -= 1
        pending = _signal_state["pending"]
        if not _signal_state["deferring"] and pending is not None:
            _signal_state["pending"] = None
            _raise_for(pending)
