"""A stand-in for a worker's training of a group of seeds (``_train_group``), for the tests of
the pool's rebalancing (tests/rl/sweep/test_rebalance.py): runs in spawned worker processes, so
it lives in a module they can import."""

from __future__ import annotations

import os
import time

#: How long a group with several seeds waits to be asked to hand them back, s.
WAIT_S = 60.0


def fake_group(job) -> dict:
    """A group of one seed that is not a continuation finishes at once; a group of several waits
    for the request to hand them back and does (all its folders); a continuation finishes, except
    for ``job.case == "fail-3"`` when it holds seed 3 (it raises). Each seed's result says which
    group it finished in (``ran_in``)."""
    if job.continued and job.case == "fail-3" and 3 in job.seeds:
        raise RuntimeError("seed 3's worker failed")
    if len(job.seeds) > 1 and not job.continued:
        deadline = time.monotonic() + WAIT_S
        while time.monotonic() < deadline:
            if job.hand_back_file and os.path.exists(job.hand_back_file):
                return {"group": [], "handed_back": list(job.run_dirs)}
            time.sleep(0.05)
    return {"group": [{"seed": s, "ran_in": job.seeds} for s in job.seeds]}
