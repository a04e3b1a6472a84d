"""Reports on the physics the paper left out: the fig. S2 question and the Kelvin-Voigt damping.

Run (each writes a JSON summary and a small PNG into ``--out``)::

    python -m elastica_magnetic_validation.extra_physics s2 --duration 3 --out docs/figures/physics
    python -m elastica_magnetic_validation.extra_physics damping --duration 1.5 --out docs/figures/physics

``s2``: pattern 2 under the shipped ``m2-10mT`` waveform with and without the magnetic interaction
between the robot's elements (plus self-contact), and pattern 1 under its shipped ``m1-10mT``
waveform, end-to-end distance over time. ``damping``: the first bending mode of the free crawler
under the paper's dampings, the Kelvin-Voigt viscosity that matches it, its explicit stability limit,
and the time of the first maximum height in the published pattern-1 4 mT replay.
"""

from __future__ import annotations

import argparse
import json
import time as wallclock
from dataclasses import replace
from pathlib import Path

import elastica as ea
import numpy as np

from elastica_magnetic import (
    DampingSpec,
    InteractionSpec,
    MagneticRodSimulator,
    TabulatedField,
    read_field_csv,
    run_open_loop,
    yao2023_robot,
)
from elastica_magnetic.cli import output_path
from elastica_magnetic.filesets import replace_files
from elastica_magnetic.reference import reference_field_csv
from elastica_magnetic.simulation import register_robot_forcing, robot_rod

ROOT = Path(__file__).resolve().parents[1]
#: RodSelfContact for the crawler: k resists ~1 mN of end attraction with ~5% of the radius of
#: overlap; nu is about half the critical damping of one node on that spring (node mass 0.39 mg).
SELF_CONTACT = {"self_contact_k": 40.0, "self_contact_nu": 4e-3}


def end_to_end(trajectory) -> np.ndarray:
    """Distance between the centres of the first and last elements, m, per row."""
    return np.hypot(
        trajectory.front_x_m - trajectory.back_x_m, trajectory.front_y_m - trajectory.back_y_m
    ).to_numpy()


def s2_cases(duration: float) -> dict[str, dict]:
    """Run the S2 cases; return their end-to-end distances and summaries."""
    m2_field = TabulatedField(read_field_csv(ROOT / "rl/policies/m2-10mT/fields.csv"))
    m1_field = TabulatedField(read_field_csv(ROOT / "rl/policies/m1-10mT/fields.csv"))
    band = InteractionSpec(band_source=True, **SELF_CONTACT)
    rod_source = InteractionSpec(band_source=False, **SELF_CONTACT)
    cases = {
        "m2 paper model": (yao2023_robot(2), m2_field),
        "m2 + interaction (band source) + self-contact": (
            replace(yao2023_robot(2), interaction=band),
            m2_field,
        ),
        "m2 + interaction (rod source) + self-contact": (
            replace(yao2023_robot(2), interaction=rod_source),
            m2_field,
        ),
        "m1 paper model": (yao2023_robot(1), m1_field),
        "m1 + interaction (band source) + self-contact": (
            replace(yao2023_robot(1), interaction=band),
            m1_field,
        ),
    }
    out = {}
    for name, (spec, field) in cases.items():
        try:
            result = run_open_loop(spec, field, duration)
        except Exception as error:  # a diverged case is a result too: report it
            out[name] = {"error": str(error)}
            print(f"{name}: {error}", flush=True)
            continue
        distance = end_to_end(result.trajectory)
        t = result.trajectory.t_s.to_numpy()
        close = distance < 3e-3
        out[name] = {
            "t_s": t.tolist(),
            "end_to_end_m": distance.tolist(),
            "min_end_to_end_mm": 1e3 * float(distance.min()),
            "final_end_to_end_mm": 1e3 * float(distance[-1]),
            "time_below_3mm_s": float(close.sum() * 0.01),
            "longest_stay_below_3mm_s": 0.01 * _longest_run(close),
            "mid_dx_mm": 1e3 * result.mid_dx,
            "step_us": result.step_us,
        }
        print(
            f"{name}: {json.dumps({k: v for k, v in out[name].items() if k[0] != 't' and k[0] != 'e'})}",
            flush=True,
        )
    return out


def _longest_run(mask: np.ndarray) -> int:
    best = run = 0
    for value in mask:
        run = run + 1 if value else 0
        best = max(best, run)
    return best


def plot_s2(results: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 3.4), dpi=90)
    for name, r in results.items():
        if "t_s" in r:
            ax.plot(r["t_s"], 1e3 * np.asarray(r["end_to_end_m"]), lw=1.2, label=name)
    ax.axhline(2 * 0.8e-3 / np.sqrt(3) * 1e3, color="k", lw=0.6, ls=":", label="touching (2 radii)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("end-to-end distance (mm)")
    ax.legend(fontsize=6.5, loc="upper right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def free_crawler_mode_decay(damping: DampingSpec, duration: float = 0.08, dt: float = 8e-6) -> dict:
    """First free-free bending mode of the crawler (no gravity, no ground) under ``damping``.

    Starts straight with the mode's velocity shape; returns the decay of the mode's amplitude
    (projection of y on the mode shape) as a damping ratio from successive peaks, or as an
    exponential decay rate when there are fewer than two peaks (overdamped).
    """
    spec = replace(yao2023_robot(1), gravity=0.0, ground=None, damping=damping, dt=dt)
    simulator = MagneticRodSimulator()
    rod = robot_rod(spec)
    simulator.append(rod)
    zero = TabulatedField(np.zeros((1, 3)))
    register_robot_forcing(simulator, rod, replace(spec, magnetization=0.0 * spec.magnetization), zero, None)
    simulator.finalize()
    length = spec.length
    x = rod.position_collection[0, :] / length
    beta = 4.730040744862704
    sigma = (np.cosh(beta) - np.cos(beta)) / (np.sinh(beta) - np.sin(beta))
    shape = np.cosh(beta * x) + np.cos(beta * x) - sigma * (np.sinh(beta * x) + np.sin(beta * x))
    rod.velocity_collection[1, :] = 1e-3 * shape
    rod.omega_collection[1, :] = np.diff(rod.velocity_collection[1, :]) / rod.rest_lengths
    stepper, t = ea.PositionVerlet(), 0.0
    n = int(round(duration / dt))
    amplitude = np.empty(n)
    weight = shape / np.dot(shape, shape)
    for k in range(n):
        t = stepper.step(simulator, t, dt)
        amplitude[k] = np.dot(weight, rod.position_collection[1, :] - rod.position_collection[1, :].mean())
    peaks = [k for k in range(1, n - 1) if amplitude[k - 1] < amplitude[k] >= amplitude[k + 1]]
    peaks = [k for k in peaks if amplitude[k] > 0]
    result: dict = {"first_peak_s": (peaks[0] + 1) * dt if peaks else None}
    if len(peaks) >= 2:
        decrement = np.log(amplitude[peaks[0]] / amplitude[peaks[1]])
        result["zeta"] = float(decrement / np.sqrt(4 * np.pi**2 + decrement**2))
        result["omega_d"] = float(2 * np.pi / ((peaks[1] - peaks[0]) * dt))
    else:
        result["zeta"] = None
    result["amplitude_peak_m"] = float(amplitude.max())
    # Overdamped (one peak): the modal velocity v0 = 1e-3 m/s dies within tau = 1 / (2 zeta omega),
    # long before the spring acts, so the peak is about v0 tau: zeta ~ v0 / (2 omega x_peak).
    omega_1 = 22.3733 * np.sqrt(spec.youngs_modulus * spec.radius**2 / 4 / spec.density) / length**2
    result["zeta_from_peak"] = float(1e-3 / (2 * omega_1 * amplitude.max()))
    return result


def first_max_height_time(trajectory, window: float = 1.5) -> tuple[float, float]:
    """Time and value of the first local maximum of the largest element height (within ``window`` s)."""
    t = trajectory.t_s.to_numpy()
    h = trajectory.height_max_m.to_numpy()
    h = h[t <= window]
    for k in range(1, len(h) - 1):
        if h[k] >= h[k - 1] and h[k] > h[k + 1] and h[k] > 0.5 * h.max():
            return float(t[k]), float(h[k])
    k = int(np.argmax(h))
    return float(t[k]), float(h[k])


def damping_report(duration: float) -> dict:
    paper = DampingSpec()
    youngs = yao2023_robot(1).youngs_modulus
    paper_mode = free_crawler_mode_decay(paper)
    # A Kelvin-Voigt solid damps a mode of angular frequency omega with zeta = eta omega / (2 E).
    omega_1 = 22.3733 * np.sqrt(youngs * (0.8e-3 / np.sqrt(3)) ** 2 / 4 / 1860.0) / 20e-3**2
    out: dict = {"paper_mode": paper_mode, "omega_1_rad_s": float(omega_1)}
    zeta = paper_mode["zeta"] if paper_mode["zeta"] is not None else paper_mode["zeta_from_peak"]
    if zeta is not None:
        out["eta_match_Pa_s"] = float(2 * youngs * zeta / omega_1)
    # Explicit stability of the viscous term: find the largest stable eta at dt = 8e-6 by trying.
    stable = []
    for eta in (1.0, 2.0, 4.0, 8.0, 16.0):
        kv = DampingSpec(0.0, 4, 0.0, 0.0, kelvin_voigt=eta)
        mode = free_crawler_mode_decay(kv, duration=0.02)
        ok = np.isfinite(mode["amplitude_peak_m"]) and mode["amplitude_peak_m"] < 1e-3
        stable.append(
            {"eta_Pa_s": eta, "stable": bool(ok), "zeta_predicted": float(eta * omega_1 / 2 / youngs)}
        )
    out["stability_dt_8e-6"] = stable
    eta_stable = max([s["eta_Pa_s"] for s in stable if s["stable"]], default=None)
    out["eta_used_Pa_s"] = eta_stable
    field = TabulatedField(read_field_csv(reference_field_csv()))
    runs = {}
    variants = {
        "paper dampings": DampingSpec(),
        f"Kelvin-Voigt eta = {eta_stable:g} Pa s only": DampingSpec(
            0.0, 4, 0.0, 0.0, kelvin_voigt=eta_stable
        ),
        f"Kelvin-Voigt eta = {eta_stable:g} Pa s + relative damper": DampingSpec(
            20.0, 4, 0.0, 0.0, kelvin_voigt=eta_stable
        ),
    }
    for name, damping in variants.items():
        start = wallclock.perf_counter()
        try:
            result = run_open_loop(replace(yao2023_robot(1), damping=damping), field, duration)
        except Exception as error:
            runs[name] = {"error": str(error)}
            continue
        t_max, h_max = first_max_height_time(result.trajectory)
        runs[name] = {
            "first_max_height_s": t_max,
            "first_max_height_mm": 1e3 * h_max,
            "mid_dx_mm": 1e3 * result.mid_dx,
            "t_s": result.trajectory.t_s.tolist(),
            "height_max_m": result.trajectory.height_max_m.tolist(),
            "wall_s": wallclock.perf_counter() - start,
        }
        print(name, {k: v for k, v in runs[name].items() if k not in ("t_s", "height_max_m")}, flush=True)
    out["replays"] = runs
    return out


def plot_damping(report: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 3.2), dpi=90)
    for name, r in report["replays"].items():
        if "t_s" in r:
            ax.plot(r["t_s"], 1e3 * np.asarray(r["height_max_m"]), lw=1.2, label=name)
            ax.plot([r["first_max_height_s"]], [r["first_max_height_mm"]], "k.", ms=5)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("largest element height (mm)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def write_report(report: str, duration: float, out: Path) -> None:
    """Run the ``s2`` or ``damping`` cases for ``duration`` s and write the figure and JSON."""
    if report == "s2":
        results = s2_cases(duration)
        plot_s2(results, out / "s2_end_to_end.png")
        summary = {
            k: {kk: vv for kk, vv in v.items() if kk not in ("t_s", "end_to_end_m")}
            for k, v in results.items()
        }
        (out / "s2.json").write_text(json.dumps({"duration_s": duration, "cases": summary}, indent=1))
    else:
        damping = damping_report(duration)
        plot_damping(damping, out / "damping_first_max.png")
        summary = dict(damping)
        summary["replays"] = {
            k: {kk: vv for kk, vv in v.items() if kk not in ("t_s", "height_max_m")}
            for k, v in damping["replays"].items()
        }
        (out / "damping.json").write_text(json.dumps({"duration_s": duration, **summary}, indent=1))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("report", choices=("s2", "damping"))
    parser.add_argument("--duration", type=float, default=3.0, help="simulated time per case, s")
    parser.add_argument("--out", type=output_path, default="docs/figures/physics")
    args = parser.parse_args(argv)
    names = (("s2_end_to_end.png", "s2.json") if args.report == "s2"
             else ("damping_first_max.png", "damping.json"))
    # Both files go in together or neither changes; earlier ones are replaced, nothing else is.
    with replace_files(args.out, names, force=True) as files:
        write_report(args.report, args.duration, files.path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
