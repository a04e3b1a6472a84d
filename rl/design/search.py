"""The search of ``msr design``: CMA-ES over a :class:`~elastica_magnetic_rl.design.space.DesignSpace`,
each generation one batched simulation of all its candidates, checkpointed after every generation.

Why CMA-ES (the ``cma`` package, Hansen's reference implementation): the objective is a noisy-free
but rugged black box of 6-40 continuous coordinates (directions are angles, magnitudes and
lengths bounded), each evaluation a simulation of seconds, a few hundred evaluations in the
budget; CMA-ES is the standard for that regime (no gradients, invariant to the coordinates'
scale, handles bounds), and the package is well kept and pure Python.

A candidate's objective (m, larger is better):

- ``yardstick``: the farther of the two senses of a rotating field of the candidate's own period
  (the search vector's last coordinate: the period is searched with the design, so one candidate
  costs two simulations instead of a whole sweep);
- ``robust``: for each sense, the worst over the variation set (the nominal robot and each group
  of the default fabrication errors at its low and high end), the better sense.

Determinism: the candidates of a generation depend only on the seed and the objectives before
them (CMA-ES draws from numpy's global generator, whose state the checkpoint keeps), and every
simulation is deterministic, so a search resumed after a kill goes on exactly as it would have.
"""

from __future__ import annotations

import math
import pickle
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic.io import atomic_write

from ..cases.case import Case
from ..cases.design_space import DesignSpace
from .evaluate import Trial, run_trials

__all__ = ["OBJECTIVES", "SearchState", "evaluate_candidates", "new_search", "run_generation"]

#: The objectives ``--objective`` takes.
OBJECTIVES = ("yardstick", "robust")
#: Variations and the variants of them a robust objective judges a candidate on.
VariationSet = tuple[list[Any], list[Any]]
#: What a candidate whose every simulation diverged scores, m (worse than any distance).
DIVERGED_SCORE = -1.0


@dataclass
class SearchState:
    """What a checkpoint holds: the CMA-ES object, numpy's generator state, the generations done,
    the best candidate so far (vector, objective in m) and the wall time spent (s)."""

    es: Any
    rng_state: Any
    generation: int = 0
    best_x: NDArray[np.float64] | None = None
    best_objective: float = -math.inf
    elapsed_s: float = 0.0
    history: list[dict[str, Any]] = field(default_factory=list)

    def save(self, path: Path) -> None:
        """Write the checkpoint atomically (a kill leaves the previous one)."""
        with atomic_write(path, "wb") as f:
            pickle.dump(self, f, protocol=pickle.HIGHEST_PROTOCOL)

    @classmethod
    def load(cls, path: Path) -> SearchState:
        """The checkpoint at ``path``; ``ValueError`` naming the file when it is damaged."""
        try:
            with open(path, "rb") as f:
                state = pickle.load(f)
        except (OSError, EOFError, pickle.UnpicklingError, AttributeError, ImportError,
                IndexError, TypeError, ValueError) as exc:
            raise ValueError(f"{path}: damaged design checkpoint ({type(exc).__name__}: {exc}); "
                             "start the design afresh with --force") from None
        if not isinstance(state, cls):
            raise ValueError(f"{path}: not a design checkpoint; start afresh with --force")
        return state


def new_search(space: DesignSpace, x0: NDArray[np.float64], seed: int, popsize: int | None,
               sigma0: float) -> SearchState:
    """A CMA-ES search from ``x0`` (step ``sigma0`` in the vector's units), seeded; its first
    generation holds, besides its draws, the two designs whose direction turns once along the
    body (:meth:`~elastica_magnetic_rl.cases.design_space.DesignSpace.turning_vectors`)."""
    import cma

    low, high = space.bounds()
    options = {"seed": int(seed) + 1,  # cma treats seed 0 as "draw one"
               "bounds": [low, high], "verbose": -9, "CMA_diagonal": False}
    if popsize is not None:
        options["popsize"] = int(popsize)
    es = cma.CMAEvolutionStrategy(np.asarray(x0, dtype=float), float(sigma0), options)
    if es.popsize > 2:  # keep at least one draw of CMA-ES's own in the generation
        for x in space.turning_vectors(x0)[: es.popsize - 1]:
            es.inject([es.gp.geno(x, from_bounds=es.boundary_handler.inverse)], force=True)
    return SearchState(es=es, rng_state=np.random.get_state())


def variant_specs(case: Case, spec: dict[str, Any], physics: str,
                  variations: VariationSet | None) -> list[Any]:
    """The robots (RobotSpec in ``physics``) a candidate's ``spec`` is judged on: itself, or each
    variant of ``variations``, the set made anew on this spec (its keys are where this spec keeps
    its values: a pattern's magnitude, each segment's), with or without corners as given."""
    import warnings

    from elastica_magnetic.plausibility import ImplausibleValueWarning

    from ..cases.case import case_from_dict
    from ..cases.variations import apply_variant

    if variations is not None:
        corners = any(v.kind == "corner" for v in variations[1])
        variations = variation_set(spec, "robust", corners)
    specs = [spec] if variations is None else [apply_variant(spec, variations[0], v)
                                               for v in variations[1]]
    with warnings.catch_warnings():  # a weak segment is a design, not a unit mistake
        warnings.simplefilter("ignore", ImplausibleValueWarning)
        return [case_from_dict(s, case.source, case.name).robot_spec(physics) for s in specs]


def variation_set(spec: dict[str, Any], objective: str, corners: bool) -> VariationSet | None:
    """The robust objective's variation set on a design's ``spec``: the default fabrication
    errors, each group at its ends (and every corner, with ``corners``: the final judgement);
    ``None`` for the yardstick objective."""
    if objective != "robust":
        return None
    from ..cases.variations import default_variations, design

    variations = default_variations(spec)
    return variations, design(variations, spec, corners=corners)


def evaluate_candidates(case: Case, specs: list[dict[str, Any]], periods: list[float],
                        physics: str, duration: float, workers: int,
                        variations: VariationSet | None = None) -> list[dict[str, Any]]:
    """Each candidate (a complete spec and its period, s) under a rotating field of that period in
    both senses, every robot of the variation set (``None``: the nominal robot only), in one
    batched simulation; one record per candidate: ``objective_m`` (see the module docstring),
    ``distance_cw_m``/``distance_ccw_m`` (the nominal robot's, or the worst variant's),
    ``clockwise`` (the better sense) and ``period_s``. A candidate the spec parser refuses (every
    segment unmagnetized: no robot to move) scores :data:`DIVERGED_SCORE` in both senses."""
    from elastica_magnetic.specfile import SpecError

    trials, owners = [], []
    for k, (spec, period) in enumerate(zip(specs, periods, strict=True)):
        try:
            robots = variant_specs(case, spec, physics, variations)
        except SpecError:
            robots = []
        for robot in robots:
            for clockwise in (True, False):
                trials.append(Trial(robot, period, clockwise))
                owners.append((k, clockwise))
    distances = run_trials(case, trials, duration, workers)
    records = []
    for k, period in enumerate(periods):
        by_sense = {}
        for clockwise in (True, False):
            values = [d for (owner, cw), d in zip(owners, distances, strict=True)
                      if owner == k and cw == clockwise]
            by_sense[clockwise] = _worst(values)
        clockwise = by_sense[True] >= by_sense[False]
        records.append({"objective_m": max(by_sense.values()), "period_s": period,
                        "clockwise": bool(clockwise), "distance_cw_m": by_sense[True],
                        "distance_ccw_m": by_sense[False]})
    return records


def _worst(values: list[float]) -> float:
    """The smallest distance (m); a diverged robot (nan), or none, counts as :data:`DIVERGED_SCORE`."""
    return min((DIVERGED_SCORE if math.isnan(v) else float(v) for v in values), default=DIVERGED_SCORE)


def run_generation(state: SearchState, space: DesignSpace,
                   evaluate: Callable[[list[NDArray[np.float64]]], list[dict[str, Any]]]
                   ) -> list[dict[str, Any]]:
    """One CMA-ES generation: ask, evaluate (``evaluate(vectors)`` -> a record per vector, see
    :func:`evaluate_candidates`), tell (CMA-ES minimises: the negated objective); the state
    updated (generation, best, history). Returns the generation's records."""
    np.random.set_state(state.rng_state)
    vectors = state.es.ask()
    records = evaluate([np.asarray(x, dtype=float) for x in vectors])
    state.es.tell(vectors, [-r["objective_m"] for r in records])
    state.rng_state = np.random.get_state()
    state.generation += 1
    for k, (x, record) in enumerate(zip(vectors, records, strict=True)):
        record.update({"generation": state.generation, "candidate": k,
                       "vector": [float(v) for v in x]})
        state.history.append(record)
        if record["objective_m"] > state.best_objective:
            state.best_objective = record["objective_m"]
            state.best_x = np.array(x, dtype=float)
    return records
