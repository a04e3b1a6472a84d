"""Step cost of the paper's robot: our numba forcing vs a naive per-element loop vs no forcing.

Run: ``python benchmarks/step_cost.py [--steps N] [--repeats R] [--json]`` (same as ``msr bench``).
Targets (issue 2): at least 20x faster than the naive loops, within 1.5x of the bare robot.
"""

import argparse
import json

from elastica_magnetic.bench import benchmark_step_cost

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    result = benchmark_step_cost(steps=args.steps, repeats=args.repeats)
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        for physics in ("training", "accurate"):
            r = result[physics]
            print(
                f"{physics:9s} ours {r['step_us']:7.1f} us/step | naive {r['naive_step_us']:8.1f} "
                f"({r['speedup_vs_naive']:.1f}x slower) | bare {r['bare_step_us']:6.1f} "
                f"(ours/bare {r['overhead_vs_bare']:.2f}) | {r['action_ms']:.2f} ms per 0.01 s action"
            )
