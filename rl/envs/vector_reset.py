"""The reset arguments of the package's vector environments (``SAME_STEP`` autoreset, one generator
per sub-environment), in one place: which sub-environments a reset resets and the seed of each."""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium.utils import seeding
from numpy.typing import NDArray

__all__ = ["reseed"]


def reseed(rngs: list[np.random.Generator | None], seed: int | list[int | None] | None,
           options: dict[str, Any], *, first: bool = False) -> NDArray[np.bool_]:
    """Pop ``options["reset_mask"]`` (bool ``(N,)``, default all) and reseed the generators
    ``rngs`` of the sub-environments it selects: ``seed`` ``s`` seeds sub-environment ``i`` with
    ``s + i`` (the Gymnasium convention, as ``SyncVectorEnv``), a list one each (``None``: keep),
    ``None`` none. ``first``: the environment's first reset, which builds its simulator and so
    must reset every sub-environment. Returns the mask."""
    n = len(rngs)
    mask = np.asarray(options.pop("reset_mask", np.ones(n, dtype=bool)), dtype=bool)
    if mask.shape != (n,):
        raise ValueError(f"reset_mask must have shape ({n},), got {mask.shape}")
    if first and not mask.all():
        raise RuntimeError("the first reset must reset every sub-environment")
    if seed is None:
        seeds: list[int | None] = [None] * n
    elif isinstance(seed, (int, np.integer)):
        seeds = [int(seed) + i for i in range(n)]
    else:
        seeds = list(seed)
        if len(seeds) != n:
            raise ValueError(f"seed list must have {n} entries, got {len(seeds)}")
    for i in np.flatnonzero(mask):
        if seeds[i] is not None:
            rngs[i], _ = seeding.np_random(int(seeds[i]))
    return mask
