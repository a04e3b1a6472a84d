"""Replay of ``msr train --stop-when`` on committed seeds: how much of their step budget the seeds
would have run had the rule been on.

Run: ``python benchmarks/stop_rule_replay.py [--recipe pink-ln] [--consecutive 2 3] [--json]``.

For each paper case (``m1-4mT``, ``m1-10mT``, ``m2-4mT``, ``m2-10mT``) and each committed seed of the
recipe (``rl/policies/<case>/seeds/<recipe>/seed*/evaluations.csv``: the periodic evaluations of
the training run, 10 s from a zero field in the training physics), the ``target`` rule with ``k``
consecutive evaluations (:class:`~elastica_magnetic_rl.runner.stopping.StopRule`, the threshold
the case's :func:`~elastica_magnetic_rl.sweep.stop_settings.target_return`) is replayed on the
seed's evaluation history: the seed would have stopped at the first evaluation step where the rule
fires, else run its whole budget (``--steps``). Printed per case: the mean over the seeds of that
step divided by the budget (the fraction of the compute the seeds would have run), the seeds that
stopped, and each seed's stop step. A replay says nothing of whether the stopped actors are as good
as the final ones (``msr policy export-seeds`` judges that, on the actor at the stop step).
"""

from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path

from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.runner.stopping import StopRule
from elastica_magnetic_rl.sweep.stop_settings import target_return

PAPER_CASES = ("m1-4mT", "m1-10mT", "m2-4mT", "m2-10mT")
POLICIES = Path(__file__).resolve().parent.parent / "rl" / "policies"


def stop_step(rows: list[dict[str, str]], rule: StopRule) -> int | None:
    """The first evaluation step at which ``rule`` fires on the history ``rows`` (in order)."""
    returns: list[float] = []
    for row in rows:
        returns.append(float(row["mean_return"]))
        if rule.decide(returns):
            return int(row["global_step"])
    return None


def replay(case: str, recipe: str, consecutive: int, steps: int) -> dict:
    """One case: each committed seed's stop step under the ``target`` rule, and the mean fraction
    of the budget run."""
    rule = StopRule("target", threshold=target_return(load_case(case)), consecutive=consecutive)
    seeds = {}
    for csv_path in sorted((POLICIES / case / "seeds" / recipe).glob("seed*/evaluations.csv")):
        with open(csv_path, newline="") as f:
            rows = sorted(csv.DictReader(f), key=lambda r: int(r["global_step"]))
        seeds[csv_path.parent.name] = stop_step(rows, rule)
    if not seeds:
        raise SystemExit(f"no evaluations.csv under {POLICIES / case / 'seeds' / recipe}")
    fraction = sum(steps if s is None else s for s in seeds.values()) / (len(seeds) * steps)
    return {"case": case, "recipe": recipe, "consecutive": consecutive, "threshold": rule.threshold,
            "seeds": seeds, "stopped": sum(s is not None for s in seeds.values()),
            "steps_run_fraction": fraction}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--recipe", default="pink-ln")
    p.add_argument("--consecutive", type=int, nargs="+", default=[2, 3])
    p.add_argument("--steps", type=int, default=100_000, help="the seeds' step budget")
    p.add_argument("--json", action="store_true")
    args = p.parse_args(argv)
    results = [replay(case, args.recipe, k, args.steps) for k in args.consecutive for case in PAPER_CASES]
    if args.json:
        print(json.dumps(results, indent=2))
        return 0
    print(f"target rule replayed on the committed {args.recipe} seeds (budget {args.steps} steps)")
    print(f"{'k':>2} {'case':<8} {'threshold':>9} {'stopped':>8} {'steps run':>9}  stop step per seed")
    for r in results:
        steps = " ".join("-" if s is None else str(s) for s in r["seeds"].values())
        print(f"{r['consecutive']:>2} {r['case']:<8} {r['threshold']:>9.4g} "
              f"{r['stopped']:>4}/{len(r['seeds']):<3} {r['steps_run_fraction']:>9.2f}  {steps}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
