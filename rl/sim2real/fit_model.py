"""The simulated motion of measured points for given factors of fitted spec values
(:class:`FitModel`), and what drives it: a uniform field waveform (:class:`FieldDrive`) or a magnet
arm's recorded path (:class:`~elastica_magnetic_rl.sim2real.magnet_path.MagnetDrive`). The model
of :func:`~elastica_magnetic_rl.sim2real.identify.identify`'s fit."""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic.plausibility import ImplausibleValueWarning
from elastica_magnetic.robot_spec import ACTION_PERIOD
from elastica_magnetic.specfile import SpecError, describe_robot

from ..cases.variations import Variation, apply_values, get_value, scaled
from .tracking import MeasuredTrajectory, points_at_rows

__all__ = ["DIVERGED_RESIDUAL_M", "FieldDrive", "FitModel"]

#: Residual of every frame of a simulation that diverged, m.
DIVERGED_RESIDUAL_M = 1.0


@dataclass
class FieldDrive:
    """What played a robot's motion: a uniform field waveform, ``fields`` ``(n, 3)`` T at 100 Hz,
    played open loop on the robot of a spec (the drive of :func:`identify` for a crawler), as
    ``msr field replay`` plays it: with a spec's ``[field]`` in space added to it and its
    ``[boundary]`` clamp (``setup``: :func:`elastica_magnetic.field_spec.load_field` of the spec
    file; those tables are not fitted)."""

    fields: NDArray[np.float64]
    setup: Any = None  # elastica_magnetic.field_spec.FieldSetup

    @property
    def duration(self) -> float:
        """s, how long the waveform lasts."""
        return self.fields.shape[0] * ACTION_PERIOD

    def describe(self) -> str:
        return "the waveform"

    def check_spec(self, spec: Mapping[str, Any]) -> None:
        """A spec with a ``[field]`` or ``[boundary]`` table needs its ``setup`` (else the robot
        would be fitted free, under the waveform alone: a wrong fit; :func:`load_spec` refuses a
        case steered by a source)."""
        tables = [name for name in ("field", "boundary") if name in spec]
        if tables and self.setup is None:
            raise ValueError(f"the spec has {' and '.join(f'[{t}]' for t in tables)}: give the drive its "
                             "setup (FieldDrive(fields, load_field(SPEC_FILE))) so that the fit plays "
                             "them as msr field replay does")

    def check_measured(self, measured: MeasuredTrajectory, spec: Mapping[str, Any]) -> None:
        """Nothing beyond :func:`~.tracking.check_against_robot` (the crawler's points)."""

    def rows(self, spec: Mapping[str, Any], physics: str,
             measured: MeasuredTrajectory) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The measured points of the robot of ``spec`` in ``physics`` at every 0.01 s row of the
        waveform, ``(n_rows, k, 2)`` m, with the rows' times ``(n_rows,)`` s."""
        from elastica_magnetic.fields import TabulatedField
        from elastica_magnetic.openloop import run_open_loop
        from elastica_magnetic.spatial_fields import FieldSum

        robot = describe_robot(spec, "fitted spec").robot(physics)
        rows = max(int(np.ceil(measured.duration / ACTION_PERIOD - 1e-9)), 1)
        field = TabulatedField(self.fields)
        source = self.setup.source() if self.setup is not None else None
        if source is not None:  # the coils' uniform waveform plus the spec's field in space
            field = FieldSum(field, source)
        result = run_open_loop(robot, field, rows * ACTION_PERIOD, n_shapes=rows + 1,
                               clamp=self.setup is not None and self.setup.clamp)
        return result.trajectory.t_s.to_numpy(), points_at_rows(measured, result.trajectory, result.shapes)


@dataclass
class FitModel:
    """The simulated motion of the measured points for given factors of the fitted values."""

    spec: dict[str, Any]
    fits: list[Variation]
    drive: Any  # FieldDrive (or its waveform, (n, 3) T), or a magnet arm's path (.magnet_path.MagnetDrive)
    measured: MeasuredTrajectory
    physics: str = "training"
    evaluations: int = 0
    diverged: int = 0
    refused: int = 0  # factors whose spec the parser refused
    _cache: dict = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        if isinstance(self.drive, np.ndarray):  # a waveform, (n, 3) T at 100 Hz
            self.drive = FieldDrive(np.asarray(self.drive, dtype=np.float64))

    def values(self, factors: Sequence[float]) -> dict[str, Any]:
        """Dotted key -> value for one factor per fit (a table key's value: the scaled table)."""
        return {key: scaled(get_value(self.spec, key), float(f))
                for fit, f in zip(self.fits, factors, strict=True) for key in fit.keys}

    def displacements(self, factors: Sequence[float], physics: str | None = None) -> NDArray[np.float64]:
        """``(n_frames, k, d)`` simulated displacements (m) of the points from the first measured
        frame, at the measured frames' times (cached per factors and physics)."""
        key = (tuple(float(f) for f in factors), physics or self.physics)
        if key in self._cache:
            return self._cache[key]
        self.evaluations += 1
        spec = apply_values(self.spec, self.values(factors))
        with warnings.catch_warnings():  # the optimizer's trial values are nobody's spec: not judged
            warnings.simplefilter("ignore", ImplausibleValueWarning)
            t_rows, at_rows = self.drive.rows(spec, physics or self.physics, self.measured)
        sampled = np.empty((self.measured.times.shape[0], *at_rows.shape[1:]))
        for j in range(at_rows.shape[1]):
            for c in range(at_rows.shape[2]):
                sampled[:, j, c] = np.interp(self.measured.times, t_rows, at_rows[:, j, c])
        self._cache[key] = sampled - sampled[:1]
        return self._cache[key]

    def residuals(self, factors: Sequence[float], physics: str | None = None) -> NDArray[np.float64]:
        """Simulated minus measured displacements at every frame, each point's coordinates centred on
        its mean over the frames (the tracker's origin is free, and a centred residual does not
        carry the first frame's tracking error into every other frame), flattened (m)."""
        from elastica_magnetic.simulation import SimulationDivergedError

        measured = self.measured.displacements()
        try:
            simulated = self.displacements(factors, physics)
        except SimulationDivergedError:  # values far from the robot's: as bad as a residual can be
            self.diverged += 1
            return np.full(measured.size, DIVERGED_RESIDUAL_M)
        except SpecError:  # values no robot has (kinetic friction above static): as bad
            self.refused += 1
            return np.full(measured.size, DIVERGED_RESIDUAL_M)
        return ((simulated - simulated.mean(axis=0)) - (measured - measured.mean(axis=0))).ravel()
