"""The ``msr`` console script. It lives outside the packages because importing them (PyElastica,
numba, numpy) takes seconds, and a Ctrl-C in those seconds must end the command with one line,
not a traceback through the import machinery."""

from __future__ import annotations

import sys

#: The exit status of a command ended by SIGINT (128 + 2), as the command line's own.
_INTERRUPTED_STATUS = 130


def main() -> int:
    try:
        from elastica_magnetic.cli.app import main as run
    except KeyboardInterrupt:
        print("msr: interrupted (SIGINT) while starting up: nothing was done", file=sys.stderr)
        return _INTERRUPTED_STATUS
    return run()


if __name__ == "__main__":
    sys.exit(main())
