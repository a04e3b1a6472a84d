"""The columns that mark the recorded drives of a steered catheter, so that a reader of another
format names such a file for what it is: the coils' currents (``current_<K>_A``, A) and a magnet
arm's path (``magnet_x_m``, ... m). Their readers are in ``elastica_magnetic_rl.sim2real``."""

from __future__ import annotations

import re
from collections.abc import Sequence

#: A coil's current column: ``current_<K>_A``, K its index among the spec's coils (from 0), A.
CURRENT_COLUMN = re.compile(r"^current_(\d+)_A$")
#: The column that marks a magnet arm's path (its first position column, m).
MAGNET_COLUMN = "magnet_x_m"


def drive_described(names: Sequence[str]) -> str | None:
    """What a CSV whose header holds ``names`` is, when it is a catheter's recorded drive (as a
    person reads it: ``"the currents of 8 coils (current_0_A, ..., A)"``), else None."""
    currents = [n for n in names if CURRENT_COLUMN.match(n)]
    if currents:
        return (f"the currents of {len(currents)} coil{'s' if len(currents) != 1 else ''} "
                f"({currents[0]}, ..., A), a catheter's drive by coil currents")
    if MAGNET_COLUMN in names:
        return f"a magnet arm's path ({MAGNET_COLUMN}, ..., m), a catheter's drive by a magnet"
    return None
