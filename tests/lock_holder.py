"""A folder's lock held by another process, for tests of a second writer: a lock is re-entrant
within one process (a command's pre-check and its write share it), so "someone else is writing"
needs a real second process."""

from __future__ import annotations

import contextlib
import subprocess
import sys
import textwrap
from collections.abc import Iterator
from pathlib import Path

HOLDER = textwrap.dedent("""
    import sys
    from elastica_magnetic.locks import FolderLock
    lock = FolderLock(sys.argv[1]).acquire()
    print("held", flush=True)
    sys.stdin.readline()
    lock.release()
""")


def start_holder(folder: Path) -> subprocess.Popen:
    """A process holding the lock of ``folder`` until a line is written to its stdin."""
    process = subprocess.Popen([sys.executable, "-c", HOLDER, str(folder)], stdin=subprocess.PIPE,
                               stdout=subprocess.PIPE, text=True)
    assert process.stdout.readline().strip() == "held"
    return process


@contextlib.contextmanager
def held_elsewhere(folder: Path) -> Iterator[int]:
    """``with held_elsewhere(folder) as pid:`` another process holds ``folder``'s lock."""
    process = start_holder(folder)
    try:
        yield process.pid
    finally:
        with contextlib.suppress(OSError, ValueError):
            process.communicate("\n", timeout=30)
        process.kill()
        process.wait()
