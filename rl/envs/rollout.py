"""A recorded closed-loop run of a policy (what ``msr policy generate`` produces), saved as
``rollout.npz``."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from elastica_magnetic.io import DamagedFileError, atomic_save, display_path
from elastica_magnetic.simulation import PLANAR_TRAJECTORY_COLUMNS, TRAJECTORY_COLUMNS

from .crawler_observation import observation_layout

__all__ = ["Rollout", "ROLLOUT_NPZ"]

ROLLOUT_NPZ = "rollout.npz"


@dataclass
class Rollout:
    """Arrays of one run of ``n`` control steps (0.01 s each), SI units.

    Attributes
    ----------
    times : ndarray (n+1,)
        s; entry 0 is the initial state.
    positions : ndarray (n+1, 3, n_nodes)
        x, y and z of every node, m (files written before z: ``(n+1, 2, n_nodes)``).
    fields : ndarray (n, 3)
        Field held during step ``i`` (after that step's increment), T: row ``i`` of the field CSV.
    actions : ndarray (n, k)
        Normalised actions in [-1, 1] (x 0.3 mT = field increment), one per controlled axis
        (``k = 2``: x, y; ``3`` for a three-axis case).
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
        """Read a ``rollout.npz`` (or the one in a folder); a damaged file (cut short, an array
        missing, of the wrong shape or not finite) is a
        :class:`~elastica_magnetic.io.DamagedFileError` naming it and what is wrong."""
        import zipfile

        path = Path(directory_or_file)
        if path.is_dir():
            path = path / ROLLOUT_NPZ
        try:
            with np.load(path, allow_pickle=False) as data:
                missing = [k for k in _ROLLOUT_ARRAYS if k not in data.files]
                if missing:
                    raise _damaged(path, f"lacks {', '.join(missing)}")
                arrays = {k: data[k] for k in _ROLLOUT_ARRAYS}
        except (zipfile.BadZipFile, EOFError, ValueError, OSError) as exc:
            if isinstance(exc, DamagedFileError) or isinstance(exc, FileNotFoundError):
                raise
            raise _damaged(path, f"not a readable .npz ({exc})") from None
        _check_shapes(path, arrays)
        try:
            meta = json.loads(str(arrays["meta"]))
        except ValueError as exc:
            raise _damaged(path, f"its meta is not JSON ({exc})") from None
        return cls(
            times=arrays["times"],
            positions=arrays["positions"].astype(np.float64),
            fields=arrays["fields"],
            actions=arrays["actions"],
            rewards=arrays["rewards"],
            observations=arrays["observations"],
            trajectory=_trajectory_frame(arrays["trajectory"]),
            meta=meta,
        )


def _trajectory_frame(rows: NDArray[np.float64]) -> pd.DataFrame:
    """The trajectory of a rollout file; one written before the sideways columns (a planar run:
    its markers never left z = 0) gets them as zeros."""
    if rows.shape[1] == len(TRAJECTORY_COLUMNS):
        return pd.DataFrame(rows, columns=list(TRAJECTORY_COLUMNS))
    frame = pd.DataFrame(rows, columns=list(PLANAR_TRAJECTORY_COLUMNS))
    for column in TRAJECTORY_COLUMNS[len(PLANAR_TRAJECTORY_COLUMNS):]:
        frame[column] = 0.0
    return frame


#: The arrays of a ``rollout.npz``.
_ROLLOUT_ARRAYS = ("times", "positions", "fields", "actions", "rewards", "observations",
                   "trajectory", "meta")


def _damaged(path: Path, what: str) -> DamagedFileError:
    return DamagedFileError(f"{display_path(path)}: damaged rollout ({what}); generate it again "
                            "(msr policy generate POLICY --out FOLDER --force)")


def _check_shapes(path: Path, a: dict[str, np.ndarray]) -> None:
    """The arrays of one run of ``n`` steps agree (see :class:`Rollout`) and are finite."""
    if a["times"].ndim != 1 or a["times"].shape[0] < 1:
        raise _damaged(path, f"times has shape {a['times'].shape}, expected (n + 1,)")
    n = a["times"].shape[0] - 1  # steps
    expected = {"fields": (n, 3), "rewards": (n,)}
    for key, shape in expected.items():
        if a[key].shape != shape:
            raise _damaged(path, f"{key} has shape {a[key].shape}, expected {shape} for the "
                                 f"{n} steps of times")
    for key, rows in (("positions", n + 1), ("actions", n), ("observations", n + 1),
                      ("trajectory", n + 1)):
        if a[key].ndim < 2 or a[key].shape[0] != rows:
            raise _damaged(path, f"{key} has shape {a[key].shape}, expected {rows} rows")
    if a["trajectory"].shape[1] not in (len(TRAJECTORY_COLUMNS), len(PLANAR_TRAJECTORY_COLUMNS)):
        raise _damaged(path, f"trajectory has {a['trajectory'].shape[1]} columns, expected "
                             f"{len(TRAJECTORY_COLUMNS)}")
    for key in ("times", "fields", "actions"):  # positions may end in a blow-up (diverged)
        if not np.all(np.isfinite(a[key])):
            raise _damaged(path, f"{key} holds NaN or infinite values")
