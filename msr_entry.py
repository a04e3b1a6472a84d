"""The ``msr`` console script. It lives outside the packages because importing them (PyElastica,
numba, numpy) takes seconds, and a Ctrl-C in those seconds must end the command with one line,
not a traceback through the import machinery."""

from __future__ import annotations

import sys

#: The exit status of a command ended by SIGINT (128 + 2), as the command line's own.
_INTERRUPTED_STATUS = 130


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
    if swallowed:
        print("msr: interrupted (SIGINT) while starting up: nothing was done", file=sys.stderr)
        return _INTERRUPTED_STATUS
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
