"""Recorded files several tests write (a helper module, imported with ``tests/`` on ``sys.path`` for
its ``conftest.py``), in the formats of docs/sim_to_real.md: times in s, currents in A, lengths in m.

- :func:`write_coil_currents`: the coils' currents of a catheter's drive (``t_s``, ``current_K_A``,
  ``insertion_m``), each coil a sine of its own frequency.
"""

from __future__ import annotations

import math
from pathlib import Path


def write_coil_currents(path: Path, n_coils: int = 8, n_rows: int = 31, dt_s: float = 0.01) -> Path:
    """Write ``n_rows`` rows of ``n_coils`` currents (A, coil K a sine of 0.1 (K + 1) per row) every
    ``dt_s`` seconds, the insertion held at 0 m, to ``path``; returns ``path``."""
    header = "t_s," + ",".join(f"current_{k}_A" for k in range(n_coils)) + ",insertion_m"
    rows = [f"{dt_s * i:.2f}," + ",".join(f"{math.sin(0.1 * i * (k + 1)):.6f}" for k in range(n_coils)) + ",0"
            for i in range(n_rows)]
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path
