"""Figures for docs/performance.md: step cost against the number of robots and of elements.

Run: ``python benchmarks/performance_figures.py [--out docs/figures] [--json]``. A few minutes.
Writes ``perf_vs_robots.png``, ``perf_vs_elements.png`` and ``performance.json``, all three
together or none (:func:`elastica_magnetic.filesets.replace_files`; it replaces its own earlier
ones and touches nothing else in the folder).
"""

import argparse
import json
import statistics
import time
from dataclasses import replace
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from elastica_magnetic import ConstantField, build_simulation, yao2023_magnetization, yao2023_robot  # noqa: E402
from elastica_magnetic.bench import per_robot_step_cost  # noqa: E402
from elastica_magnetic.filesets import replace_files  # noqa: E402

ROBOTS = (1, 2, 4, 8, 16, 32, 64)
ELEMENTS = (16, 32, 64, 128, 256)


def cost_vs_elements(repeats: int = 5, steps: int = 500) -> dict[str, float]:
    """Median us per step of one robot (per-rod path, accurate physics) for each element count."""
    out = {}
    for n in ELEMENTS:
        spec = replace(yao2023_robot(1, "accurate"), n_elements=n, magnetization=yao2023_magnetization(1, n),
                       dt=8e-6 * min(1.0, 64 / n))
        sim = build_simulation(spec, ConstantField([1e-3, 2e-3, 0.0]))
        sim.step(100)
        samples = []
        for _ in range(repeats):
            start = time.perf_counter()
            sim.step(steps)
            samples.append((time.perf_counter() - start) / steps * 1e6)
        out[str(n)] = statistics.median(samples)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", type=Path, default=Path("docs/figures"))
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    names = ("performance.json", "perf_vs_robots.png", "perf_vs_elements.png")
    with replace_files(args.out, names, force=True, adopt=True) as files:  # the repo's own figures
        result = write_figures(files.path)
    print(json.dumps(result, indent=2) if args.json else f"figures in {args.out}")


def write_figures(out: Path) -> dict:
    """Measure, then write the JSON and the two figures into ``out``; returns the measurements."""
    robots = per_robot_step_cost(ROBOTS, robot_steps=6400, repeats=3, paths=("batched", "per_rod"))
    elements = cost_vs_elements()
    result = {"per_robot_step_us": robots, "step_us_vs_elements": elements}
    (out / "performance.json").write_text(json.dumps(result, indent=2))

    fig, ax = plt.subplots(figsize=(5.5, 3.8), constrained_layout=True)
    for path, label in (("batched", "BatchedRobots (one numba call)"), ("per_rod", "per-rod forcing")):
        ax.plot(ROBOTS, [robots[path][str(n)] for n in ROBOTS], "o-", label=label)
    ax.axhline(12.0, color="gray", ls="--", lw=1, label="target at N = 16 (12 us)")
    ax.set_xscale("log", base=2)
    ax.set_xlabel("robots in one simulator N")
    ax.set_ylabel("us per robot-step")
    ax.set_ylim(bottom=0)
    ax.set_title("paper robot, 64 elements, training physics")
    ax.legend()
    fig.savefig(out / "perf_vs_robots.png", dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(5.5, 3.8), constrained_layout=True)
    ax.plot(ELEMENTS, [elements[str(n)] for n in ELEMENTS], "o-")
    ax.set_xscale("log", base=2)
    ax.set_xlabel("elements")
    ax.set_ylabel("us per step (one robot)")
    ax.set_ylim(bottom=0)
    ax.set_title("one robot, per-rod path, accurate physics")
    fig.savefig(out / "perf_vs_elements.png", dpi=110)
    plt.close(fig)
    return result


if __name__ == "__main__":
    main()
