"""Per-robot step cost of batched robots (one forcing kernel per step) against the per-rod path.

Run: ``python benchmarks/batched_step_cost.py [--n 1 4 16 64] [--robot-steps S] [--repeats R] [--json]``.

For each N, in one process and one run:

- ``batched``: :class:`~elastica_magnetic.batch.BatchedRobots` with N robots, stepped with
  ``robots.step(100)`` (one health check per 0.01 s, as an environment does);
- ``per_rod``: N rods in one PyElastica simulator (one memory block), each with the forcing and
  contact objects :func:`~elastica_magnetic.build_simulation` registers (five Python-level forcing
  calls per rod and step), stepped with ``PositionVerlet`` directly (no health check);
- ``independent``: one :func:`~elastica_magnetic.build_simulation` robot, stepped with
  ``sim.step`` (N separate simulators cost N times this per step).

Costs are medians over ``--repeats`` of wall time / (steps x N), in microseconds per robot-step
(the repeats of the three paths are interleaved so that they share the load's fluctuations),
with the paper's robot (64 elements) in training physics (dt = 1e-4 s) driven by 4-10 mT fields so
that contact, lift-off and friction are all active. Then a profile of the batched step at N = 16:
each part of ``PositionVerlet.step`` timed on its own (internal forces, our kernel, kinematic and
dynamic updates, ...), the remainder (Python overhead plus timing noise), and the Python overhead
measured directly (the same step with every numba call replaced by a no-op).

The measurement itself (:func:`elastica_magnetic.bench.measure_batched`) is shared with ``msr bench``.

Timings depend on the machine and its load: compare the ratios measured in the same run.
Target (issue 5): <= 12 us per robot-step at N = 16.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import numpy as np
from numba import njit

from elastica_magnetic import yao2023_robot
from elastica_magnetic.batch import BatchedRobots
from elastica_magnetic.bench import batched_fields as _fields
from elastica_magnetic.bench import measure_batched, per_rod_simulator  # noqa: F401  (re-exported)
from elastica_magnetic.robot_spec import RobotSpec


@njit(cache=True)
def _empty_call(*args) -> None:  # only the call overhead is measured
    pass


def profile_batched(spec: RobotSpec, n: int, calls: int, repeats: int) -> dict[str, float]:
    """Time each part of the batched step separately, us per step (whole block) and per robot."""
    robots = BatchedRobots(spec, n, fields=_fields(n))
    robots.step(200)
    block, simulator = robots.block, robots.simulator
    t, dt, zero = np.float64(0.0), np.float64(spec.dt), np.float64(0.0)
    args = robots.kernel_arguments

    def timed(fn) -> float:
        fn()
        samples = []
        for _ in range(repeats):
            start = time.perf_counter()
            for _ in range(calls):
                fn()
            samples.append((time.perf_counter() - start) / calls * 1e6)
        return statistics.median(samples)

    parts = {
        # PositionVerlet: 2 kinematic half steps, internal forces, synchronize (our kernel via
        # PyElastica's forcing call), accelerations + dynamics, constraint/callback groups, zeroing.
        "full_step": timed(lambda: robots.stepper.step(simulator, t, dt)),
        "internal_forces": timed(lambda: block.compute_internal_forces_and_torques(t)),
        "kernel_direct": timed(robots.apply_forcing),
        "synchronize": timed(lambda: simulator.synchronize(t)),
        "kinematic_update_x2": 2.0 * timed(lambda: block.update_kinematics(t, zero)),
        "dynamic_update": timed(lambda: (block.update_accelerations(t, dt), block.update_dynamics(t, zero))),
        "zero_loads": timed(lambda: block.zeroed_out_external_forces_and_torques(t)),
        "numba_dispatch_21_arrays": timed(lambda: _empty_call(*args)),
    }
    block.zeroed_out_external_forces_and_torques(t)
    # Share of elements touching the ground in the state the kernel was timed in (lifted elements
    # cost almost nothing), and the kernel with every element on the ground (zero field, at rest).
    parts["contact_fraction"] = robots.contact_fraction()  # of the last robot
    flat = BatchedRobots(spec, n)
    flat.step(200)
    parts["kernel_all_in_contact"] = timed(flat.apply_forcing)
    accounted = (
        parts["internal_forces"]
        + parts["synchronize"]
        + parts["kinematic_update_x2"]
        + parts["dynamic_update"]
        + parts["zero_loads"]
    )
    parts["python_overhead_residual"] = parts["full_step"] - accounted
    parts["python_overhead_measured"] = _python_overhead(spec, n, timed)
    contact_fraction = parts.pop("contact_fraction")
    return (
        {name: round(value, 2) for name, value in parts.items()}
        | {f"{name}_per_robot": round(value / n, 3) for name, value in parts.items()}
        | {"contact_fraction": round(contact_fraction, 3)}
    )


def _python_overhead(spec: RobotSpec, n: int, timed) -> float:
    """``PositionVerlet.step`` with every numba call replaced by a no-op: pure Python cost, us."""
    robots = BatchedRobots(spec, n)
    block = robots.block

    def noop(*args, **kwargs) -> None:
        pass

    for name in (
        "update_kinematics",
        "update_dynamics",
        "update_accelerations",
        "compute_internal_forces_and_torques",
        "zeroed_out_external_forces_and_torques",
    ):
        setattr(block, name, noop)  # instance attributes shadow the methods
    robots.apply_forcing = noop  # the block kernel's call, shadowed on this instance
    t, dt = np.float64(0.0), np.float64(spec.dt)
    return timed(lambda: robots.stepper.step(robots.simulator, t, dt))


def run_benchmark(
    ns: tuple[int, ...] = (1, 4, 16, 64), robot_steps: int = 6400, repeats: int = 5, profile_n: int = 16
) -> dict:
    spec = yao2023_robot(1, "training")
    batched, per_rod, independent = {}, {}, {}
    for n in ns:
        steps = max(100, (robot_steps // n) // 100 * 100)
        result = measure_batched(spec, n, steps, repeats)
        batched[str(n)] = round(result["batched"], 2)
        per_rod[str(n)] = round(result["per_rod"], 2)
        independent[str(n)] = round(result["independent"], 2)
    return {
        "robot": spec.name,
        "physics": "training",
        "dt_s": spec.dt,
        "n_elements": spec.n_elements,
        "per_robot_step_us": batched,
        "per_rod_per_robot_step_us": per_rod,
        "independent_per_robot_step_us": independent,
        "speedup_vs_per_rod": {n: round(per_rod[n] / batched[n], 2) for n in batched},
        "speedup_vs_independent": {n: round(independent[n] / batched[n], 2) for n in batched},
        f"profile_n{profile_n}_us_per_step": profile_batched(spec, profile_n, 500, repeats),
        "target_us_at_16": 12.0,
        "note": "wall-clock medians in one run on this machine and its current load; compare ratios",
    }


def _print_report(result: dict) -> None:
    head = f"{result['robot']} {result['physics']} physics, {result['n_elements']} elements"
    print(f"{head}, us per robot-step")
    print(f"{'N':>4} {'batched':>9} {'per-rod':>9} {'indep.':>9} {'vs per-rod':>11} {'vs indep.':>10}")
    for n, value in result["per_robot_step_us"].items():
        print(
            f"{n:>4} {value:9.2f} {result['per_rod_per_robot_step_us'][n]:9.2f} "
            f"{result['independent_per_robot_step_us'][n]:9.2f} "
            f"{result['speedup_vs_per_rod'][n]:10.2f}x {result['speedup_vs_independent'][n]:9.2f}x"
        )
    key = next(k for k in result if k.startswith("profile_"))
    print(f"{key}:")
    for name, value in result[key].items():
        if name == "contact_fraction":
            print(f"  share of elements on the ground while timing: {value:.2f}")
        elif not name.endswith("_per_robot"):
            print(f"  {name:26s} {value:9.2f} us  ({result[key][name + '_per_robot']:.3f} per robot)")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--n", type=int, nargs="+", default=[1, 4, 16, 64])
    parser.add_argument("--robot-steps", type=int, default=6400, help="robot-steps per repeat")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    result = run_benchmark(tuple(args.n), args.robot_steps, args.repeats)
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        _print_report(result)
