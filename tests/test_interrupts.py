"""Signals as exceptions (elastica_magnetic.interrupts), in this process's main thread."""

from __future__ import annotations

import os
import signal

import pytest

from elastica_magnetic.interrupts import Interrupted, signals_as_exceptions, signals_held


@pytest.fixture
def default_handlers():
    saved = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    yield
    for s, handler in saved.items():
        signal.signal(s, handler)


def test_sigterm_raises_interrupted_and_the_handler_is_restored(default_handlers):
    with pytest.raises(Interrupted) as caught, signals_as_exceptions():
        os.kill(os.getpid(), signal.SIGTERM)
    assert caught.value.signum == signal.SIGTERM
    assert signal.getsignal(signal.SIGTERM) == signal.SIG_DFL


def test_a_held_signal_comes_after_the_block(default_handlers):
    done = []
    with pytest.raises(KeyboardInterrupt), signals_as_exceptions():
        with signals_held():
            os.kill(os.getpid(), signal.SIGINT)
            done.append("the held step ran to its end")
        done.append("never reached")
    assert done == ["the held step ran to its end"]
