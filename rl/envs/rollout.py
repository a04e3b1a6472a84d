"""A recorded closed-loop run of a policy (what ``msr generate`` produces), saved as ``rollout.npz``."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from elastica_magnetic.io import atomic_save
from elastica_magnetic.simulation import TRAJECTORY_COLUMNS

from .env import observation_layout

__all__ = ["Rollout", "ROLLOUT_NPZ"]

ROLLOUT_NPZ = "rollout.npz"


@dataclass
class Rollout:
    """Arrays of one run of ``n`` control steps (0.01 s each), SI units.

    Attributes
    ----------
    times : ndarray (n+1,)
        s; entry 0 is the initial state.
    positions : ndarray (n+1, 2, n_nodes)
        x and y of every node, m.
    fields : ndarray (n, 3)
        Field held during step ``i`` (after that step's increment), T: row ``i`` of the field CSV.
    actions : ndarray (n, 2)
        Normalised actions in [-1, 1] (x 0.3 mT = field increment).
    rewards : ndarray (n,)
    observations : ndarray (n+1, obs_dim), float32
        Observation before each step (and the final one).
    trajectory : pandas.DataFrame
        n+1 rows with :data:`~elastica_magnetic.simulation.TRAJECTORY_COLUMNS`.
    meta : dict
        ``case``, ``field_limit_T``, ``length_m``, ``radius_m``, ``n_elements``, policy source, ...
    """

    times: NDArray[np.float64]
    positions: NDArray[np.float64]
    fields: NDArray[np.float64]
    actions: NDArray[np.float64]
    rewards: NDArray[np.float64]
    observations: NDArray[np.float32]
    trajectory: pd.DataFrame
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def n_steps(self) -> int:
        return int(self.fields.shape[0])

    @property
    def mid_dx(self) -> float:
        """Displacement of the middle along x over the run (``mid_x_m`` of the trajectory), m."""
        return float(self.trajectory.mid_x_m.iloc[-1] - self.trajectory.mid_x_m.iloc[0])

    def contact(self) -> NDArray[np.float32]:
        """Contact indicator per node and time, ``(n+1, n_nodes)`` (observation ``contact`` block)."""
        layout = observation_layout(int(self.meta.get("n_elements", 64)))
        return self.observations[:, layout["contact"]]

    def save(self, directory: str | Path) -> Path:
        path = Path(directory) / ROLLOUT_NPZ
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_save(path, lambda tmp: np.savez_compressed(
            tmp,
            times=self.times,
            positions=self.positions.astype(np.float32),
            fields=self.fields,
            actions=self.actions,
            rewards=self.rewards,
            observations=self.observations,
            trajectory=self.trajectory[list(TRAJECTORY_COLUMNS)].to_numpy(),
            meta=np.array(json.dumps(self.meta, default=str)),
        ))
        return path

    @classmethod
    def load(cls, directory_or_file: str | Path) -> Rollout:
        path = Path(directory_or_file)
        if path.is_dir():
            path = path / ROLLOUT_NPZ
        with np.load(path, allow_pickle=False) as data:
            return cls(
                times=data["times"],
                positions=data["positions"].astype(np.float64),
                fields=data["fields"],
                actions=data["actions"],
                rewards=data["rewards"],
                observations=data["observations"],
                trajectory=pd.DataFrame(data["trajectory"], columns=list(TRAJECTORY_COLUMNS)),
                meta=json.loads(str(data["meta"])),
            )
