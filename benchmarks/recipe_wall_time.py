"""The wall time of 8 seeds x 1e5 steps of a paper case with a recipe, on this machine, without
its stop rule: the reference a ``fast`` campaign is timed against when the reference recipe's own
runs were on another machine.

Run: ``python benchmarks/recipe_wall_time.py [--case m2-10mT] [--recipe pink-ln] [--seeds 8]
[--window 1000] [--json]``.

A real run in the default layout (:func:`~elastica_magnetic_rl.reports.bench.training_time`):
the recipe's warm-up (uniform random actions, no updates), then ``--window`` steps of learning
resumed from it, each group's time split by the training loop; the 1e5 steps are projected from
the window's per-step cost plus the evaluation and checkpoint rounds at their measured costs. A
few minutes for the default window. Machines here are noisy: run it next to the campaign it is
compared with, nothing else running.
"""

from __future__ import annotations

import argparse
import json

from elastica_magnetic_rl.reports.bench import training_time


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--case", default="m2-10mT", help="a shipped case or a spec file")
    parser.add_argument("--recipe", default="pink-ln", help="training recipe (msr train --recipe)")
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--window", type=int, default=1000,
                        help="environment steps of learning measured after the warm-up")
    parser.add_argument("--json", action="store_true", help="print the whole result as JSON")
    args = parser.parse_args(argv)
    if args.seeds < 1 or args.window < 1:
        parser.error("--seeds and --window must be >= 1")
    result = training_time(args.seeds, args.case, window=args.window, recipe=args.recipe)
    if args.json:
        print(json.dumps(result, indent=1))
    else:
        print(f"{args.case}, {args.recipe}, {args.seeds} seeds x {result['full_steps']} steps: "
              f"{result['projected_s'] / 60:.1f} min projected ({result['workers']} workers x "
              f"{result['seeds_per_simulator']} seeds; the measured run took "
              f"{result['measured_wall_s']:.0f} s)")
        for k, group in enumerate(result["groups"]):
            print(f"  group {k}: warm-up {group['warmup_s']:.0f} s, "
                  f"{group['update_per_step_s'] * 1e3:.1f} ms of updates and "
                  f"{group['env_per_step_s'] * 1e3:.1f} ms of physics per step, "
                  f"evaluation round {group['evaluation_round_s']:.1f} s")
    return result


if __name__ == "__main__":
    main()
