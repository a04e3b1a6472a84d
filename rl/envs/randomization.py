"""Domain randomization: a robot drawn anew for each training episode of each crawler.

A case's ``[training.randomize]`` lists variations of its ``[robot]`` values (dotted keys, ranges;
:mod:`~elastica_magnetic_rl.cases.variations`). :class:`RobotRandomizer` draws one setting per
variation, uniformly in its range (a factor of the nominal value, or an absolute value in SI),
and builds that robot in the run's physics through the spec parser, so a drawn robot is checked
like any spec. The vector environment gives each crawler its own draw at each reset
(:meth:`~elastica_magnetic.batch.BatchedRobots.set_robot`); the observation is unchanged (the
policy is not told the robot's values), and evaluations stay on the nominal robot.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from elastica_magnetic import RobotSpec
from elastica_magnetic.plausibility import ImplausibleValueWarning
from elastica_magnetic.specfile import describe_robot, robot_tables_spec

from ..cases.variations import Variant, Variation, apply_variant

__all__ = ["RobotRandomizer"]


class RobotRandomizer:
    """Draws robots of ``tables`` (a complete ``{"robot": ..., "physics": ...}``, e.g.
    ``Case.robot.tables``) varied by ``variations``, built in ``physics``.

    Examples
    --------
    >>> randomizer = RobotRandomizer(case.robot.tables, case.training.randomize, "training")
    >>> settings = randomizer.draw(np.random.default_rng(0))   # {"magnetization": 0.93, ...}
    >>> spec = randomizer.robot(settings)                        # a RobotSpec
    """

    def __init__(self, tables: Mapping[str, Any], variations: Sequence[Variation],
                 physics: str) -> None:
        if not variations:
            raise ValueError("RobotRandomizer needs at least one variation")
        self.tables = {"robot": tables["robot"], "physics": tables["physics"]}
        self.variations = tuple(variations)
        self.physics = physics

    @property
    def names(self) -> tuple[str, ...]:
        """The variations' names, in the order :meth:`as_array` uses."""
        return tuple(v.name for v in self.variations)

    def nominal(self) -> dict[str, float]:
        """The nominal robot's settings (factor 1, or the spec's value)."""
        return {v.name: v.nominal_value(self.tables) for v in self.variations}

    def draw(self, rng: np.random.Generator) -> dict[str, float]:
        """One setting per variation, uniform in ``[low, high]`` (one ``rng.random()`` each, in
        the variations' order)."""
        return {v.name: float(v.low + rng.random() * (v.high - v.low)) for v in self.variations}

    def robot(self, settings: Mapping[str, float]) -> RobotSpec:
        """The robot of ``settings`` in the randomizer's physics (the spec parser checks it)."""
        variant = Variant("randomized", "sample", dict(settings))
        spec = robot_tables_spec(apply_variant(self.tables, self.variations, variant))
        with warnings.catch_warnings():  # the nominal robot's unusual values were reported once
            warnings.simplefilter("ignore", ImplausibleValueWarning)
            return describe_robot(spec, "[training.randomize]").robot(self.physics)

    def as_array(self, settings: Mapping[str, float]) -> np.ndarray:
        """``settings`` as a float64 array in :attr:`names` order (for saved states)."""
        return np.array([settings[name] for name in self.names], dtype=np.float64)

    def from_array(self, values: Sequence[float]) -> dict[str, float]:
        """The inverse of :meth:`as_array`."""
        if len(values) != len(self.variations):
            raise ValueError(f"expected {len(self.variations)} settings ({', '.join(self.names)}), "
                             f"got {len(values)}")
        return {name: float(v) for name, v in zip(self.names, values, strict=True)}
