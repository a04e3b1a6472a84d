"""Step cost of the paper's robot under fields that vary in space, next to the uniform field,
and the cost per call of the field sources against Magpylib (issue 33).

Run: ``python benchmarks/spatial_step_cost.py [--steps N] [--repeats R] [--json]``.
Target: a step with a point dipole or a coil pair costs at most 2x the uniform field's.
The Magpylib comparison needs ``pip install magpylib`` (skipped without it).
"""

import argparse
import json
import statistics
import time

import numpy as np

from elastica_magnetic import CurrentLoopField, PointDipoleField
from elastica_magnetic.bench import spatial_step_cost


def per_call_us(function, repeats: int = 7, calls: int = 200) -> float:
    """Median over ``repeats`` of the mean wall time of ``calls`` calls, microseconds."""
    function()
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(calls):
            function()
        samples.append((time.perf_counter() - start) / calls * 1e6)
    return statistics.median(samples)


def field_call_cost(n_points: int = 64) -> dict[str, float]:
    """Cost per call (us) of B (and B with its gradient) at ``n_points`` points: ours and Magpylib's."""
    points = np.random.default_rng(0).uniform(-0.02, 0.02, size=(3, n_points))
    points += np.array([[0.0], [0.0], [0.05]])
    dipole = PointDipoleField([0.0, 0.0, 1.0], [0.0, 0.0, 0.0])
    loop = CurrentLoopField(0.03, 10.0)
    out = {
        "ours_dipole_B_us": per_call_us(lambda: dipole.at(points)),
        "ours_dipole_B_and_gradient_us": per_call_us(lambda: dipole.evaluate(points)),
        "ours_loop_B_us": per_call_us(lambda: loop.at(points)),
        "ours_loop_B_and_gradient_us": per_call_us(lambda: loop.evaluate(points)),
    }
    try:
        import magpylib as magpy
    except ImportError:
        return out
    from elastica_magnetic.magnet_fields import CuboidMagnetField

    m_dipole = magpy.misc.Dipole(moment=(0.0, 0.0, 1.0))
    m_loop = magpy.current.Circle(current=10.0, diameter=0.06)
    observers = np.ascontiguousarray(points.T)
    cuboid = CuboidMagnetField([0.01, 0.01, 0.01], [0, 0, 1.3])
    out.update({
        "magpylib_dipole_B_us": per_call_us(lambda: m_dipole.getB(observers)),
        "magpylib_loop_B_us": per_call_us(lambda: m_loop.getB(observers)),
        "magpylib_cuboid_B_us": per_call_us(lambda: cuboid.at(points)),
        "magpylib_cuboid_B_and_fd_gradient_us": per_call_us(lambda: cuboid.evaluate(points)),
    })
    return out


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    result = {"field_calls_64_points": field_call_cost(),
              "training": spatial_step_cost("training", args.steps, args.repeats),
              "accurate": spatial_step_cost("accurate", args.steps, args.repeats)}
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        for key, value in result["field_calls_64_points"].items():
            print(f"{key:40s} {value:9.2f} us")
        for physics in ("training", "accurate"):
            r = result[physics]
            print(physics, " | ".join(f"{k} {v:.1f} us ({r['ratio_to_uniform'][k]:.2f}x)"
                                      for k, v in r["step_us"].items()))
