"""The ``msr`` console script. It lives outside the packages because importing them (PyElastica,
numba, numpy) takes seconds, and a Ctrl-C in those seconds must end the command with one line,
not a traceback through the import machinery."""

from __future__ import annotations

import signal
import sys

#: SIGTERM and SIGHUP end msr's start-up as Ctrl-C does (the command line takes them as Ctrl-C once
#: it runs); their default action would end the process without a word.
_STARTUP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name))


def main() -> int:
    # a Ctrl-C that lands in a callback of the import machinery (a module lock's weakref callback)
    # cannot be raised there: Python prints it as "ignored" and goes on; it is kept and obeyed here
    swallowed: list[BaseException] = []
    previous = sys.unraisablehook

    def hook(unraisable) -> None:
        if isinstance(unraisable.exc_value, KeyboardInterrupt):
            swallowed.append(unraisable.exc_value)
        else:
            previous(unraisable)

    received: list[int] = []

    def on_signal(signum: int, frame: object) -> None:
        received.append(signum)
        raise KeyboardInterrupt

    defaults = {s: signal.signal(s, on_signal) for s in _STARTUP_SIGNALS
                if signal.getsignal(s) == signal.SIG_DFL}
    sys.unraisablehook = hook
    try:
        from elastica_magnetic.cli.app import main as run
    except KeyboardInterrupt:
        swallowed.append(KeyboardInterrupt())
    except ImportError as error:  # a Ctrl-C inside a module that turns what it meets into an ImportError
        if not _caused_by_interrupt(error):  # (numba's import of its C extensions does)
            raise
        swallowed.append(KeyboardInterrupt())
    finally:
        sys.unraisablehook = previous
        for signum, default in defaults.items():  # the command line installs its own
            signal.signal(signum, default)
    if swallowed or received:
        signum = received[-1] if received else signal.SIGINT
        print(f"msr: interrupted ({signal.Signals(signum).name}) while starting up: nothing was done",
              file=sys.stderr)
        return 128 + signum  # as the command line's own (130 for Ctrl-C)
    return run()


def _caused_by_interrupt(error: BaseException) -> bool:
    """Whether a KeyboardInterrupt is among ``error``'s causes or the exceptions it was raised in."""
    seen: set[int] = set()
    todo: list[BaseException | None] = [error]
    while todo:
        current = todo.pop()
        if current is None or id(current) in seen:
            continue
        if isinstance(current, KeyboardInterrupt):
            return True
        seen.add(id(current))
        todo += [current.__cause__, current.__context__]
    return False


if __name__ == "__main__":
    sys.exit(main())
