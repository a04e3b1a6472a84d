"""Case ``gradient-beam``: a hard-magnetic cantilever bent by a constant field gradient.

The experiment of Yan, Abbasi and Reis (2022, *Int. J. Solids Struct.* 257, 111319;
arXiv:2106.14878), configuration B1 as Alkuino, Clemmer, Santangelo and Zhang (2026,
arXiv:2603.27279) set it up for their bonded-particle rods in LAMMPS and published it
(`gsalkuin/lammps-bpm-rods`, `docs/examples/magnetic-beam/config-B1.in`, commit ``efa6bba``):
a 25.8 x 1.21 x 0.49 mm beam, E = 1.16 MPa, nu = 0.49, 2010 kg/m^3, magnetized across its
thickness (+y, 94.1 kA/m), clamped at the origin along +x, no gravity, in the field
``B = b (-x/2, y, -z/2)`` centred at the clamp: the gradient pulls the beam along +y and the field
turns it (``m x B``). The load is ``b = l * 0.36 E I / (M A L^3)`` on their scale ``l`` (their
lambda_m^C; ``M A L^3 b / (E I) = 0.36 l``), and the deflection reported is the tip's
``y / L``.

Three answers are compared: this package's rod (``MagneticTorques`` with a
:class:`~elastica_magnetic.ConstantGradientField`, relaxed at ``n``, ``2n``, ``4n`` elements, the
clamp's ``1/n`` error removed by Richardson extrapolation); an independent boundary-value
solution of the planar Cosserat rod with the same stiffnesses (:mod:`.bvp_magnet`); and the
published LAMMPS input run with the released LAMMPS (``validation/data/gradient_beam_lammps.csv``,
how it was made in ``validation/data/gradient_beam_lammps.md``). The rod is the rectangle's exact
section (area ``W H``, in-plane ``I = W H^3 / 12``), not the paper's equivalent circular rod.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path

import elastica as ea
import numpy as np

from elastica_magnetic import (
    ConstantGradientField,
    MagneticRodSimulator,
    MagneticTorques,
    set_shear_coefficient,
    uniform_magnetization,
)
from elastica_magnetic.section import quiet_small_inertia_warning

from .bvp_magnet import linear_field_2d, solve_magnetic_cantilever
from .report import CaseResult, Comparison, Gate

LENGTH, WIDTH, THICKNESS = 25.8e-3, 1.21e-3, 0.49e-3  # m
YOUNGS_MODULUS, POISSON = 1.16e6, 0.49  # Pa, 1
DENSITY = 2010.0  # kg/m^3
MAGNETIZATION = 94.1e3  # A/m, along +y (across the thickness)
AREA = WIDTH * THICKNESS
BENDING = YOUNGS_MODULUS * WIDTH * THICKNESS**3 / 12.0  # N m^2, in the x-y plane
SHEAR_MODULUS = YOUNGS_MODULUS / (2.0 * (1.0 + POISSON))
#: T/m per unit of the published load scale l (lambda_m^C): 0.36 E I / (M A L^3).
GRADIENT_PER_LOAD = 0.36 * BENDING / (MAGNETIZATION * AREA * LENGTH**3)
LOADS = {"full": (5, 10, 15, 20, 25, 30, 35, 40, 45), "quick": (15, 30, 45)}
RESOLUTIONS = {"full": (20, 40, 80), "quick": (10, 20, 40)}
DAMPING = 36.0  # 1/s: twice the first bending mode's 18 rad/s, near-critical
STEP_TIME = 0.6  # s per load: 0.1 s ramp from the previous load, then held
RAMP_TIME = 0.1  # s
REFERENCE_CSV = Path(__file__).parent / "data" / "gradient_beam_lammps.csv"
#: Worst errors of y_tip / L (absolute), rounded up to two digits: the extrapolated rod against the
#: Cosserat BVP, against the LAMMPS run, and successive extrapolations.
ACHIEVED = {"full": {"bvp": 1.4e-4, "lammps": 6.9e-4, "extrapolation": 2.9e-4},
            "quick": {"bvp": 4.3e-4, "lammps": 3.6e-4, "extrapolation": 1.2e-3}}


def gates(quick: bool) -> dict[str, Gate]:
    mode = "quick" if quick else "full"
    return {"bvp": Gate.from_achieved("tip y/L vs Cosserat BVP (extrapolated)", ACHIEVED[mode]["bvp"]),
            "lammps": Gate.from_achieved("tip y/L vs LAMMPS bonded particles (published input)",
                                         ACHIEVED[mode]["lammps"]),
            "extrapolation": Gate.from_achieved("tip y/L, successive extrapolations",
                                                ACHIEVED[mode]["extrapolation"])}


def gradient(load: float) -> np.ndarray:
    """``dB_i/dx_j`` (T/m) of configuration B1 at the published load ``l``."""
    b = GRADIENT_PER_LOAD * load
    return np.diag([-0.5 * b, b, -0.5 * b])


@dataclass
class Staircase:
    """The load ``l`` as a function of time: ramped from each load to the next, then held."""

    loads: tuple[float, ...]

    def __call__(self, time: float) -> float:
        k = min(int(time // STEP_TIME), len(self.loads) - 1)
        start = self.loads[k - 1] if k > 0 else 0.0
        w = min((time - k * STEP_TIME) / RAMP_TIME, 1.0)
        return start + (self.loads[k] - start) * (0.5 - 0.5 * math.cos(math.pi * w))


@dataclass
class Deflections:
    n_elements: int
    tip_y: np.ndarray  # (loads,) y / L at the end of each hold
    tip_x: np.ndarray  # (loads,) x / L - 1
    residual_speed: float  # m/s, largest node speed at the end of any hold
    shape: np.ndarray  # (3, n + 1) m, at the last load


def _rod(n_elements: int) -> ea.CosseratRod:
    """A straight rod with the rectangle's area (mass, magnetic volume) and its exact stiffnesses."""
    radius = math.sqrt(AREA / math.pi)
    with quiet_small_inertia_warning():  # PyElastica's absolute tolerance: a false alarm at this size
        rod = ea.CosseratRod.straight_rod(
            n_elements, np.zeros(3), np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), LENGTH, radius,
            DENSITY, youngs_modulus=YOUNGS_MODULUS, shear_modulus=SHEAR_MODULUS)
    circle = math.pi * radius**4 / 4.0
    # d1 = y, d2 = z, d3 = x: bending in the x-y plane turns about d2.
    rod.bend_matrix[0, 0] *= YOUNGS_MODULUS * THICKNESS * WIDTH**3 / 12.0 / (YOUNGS_MODULUS * circle)
    rod.bend_matrix[1, 1] *= BENDING / (YOUNGS_MODULUS * circle)
    set_shear_coefficient(rod, 1.0)  # the BVP's: G A (slender, L / H = 53: a 1e-4 effect at most)
    return rod


def simulate(n_elements: int, loads: tuple[float, ...]) -> Deflections:
    rod = _rod(n_elements)
    simulator = MagneticRodSimulator()
    simulator.append(rod)
    simulator.constrain(rod).using(ea.OneEndFixedBC, constrained_position_idx=(0,),
                                   constrained_director_idx=(0,))
    staircase = Staircase(tuple(float(v) for v in loads))
    field = ConstantGradientField(gradient(1.0), scale=staircase)
    simulator.add_forcing_to(rod).using(
        MagneticTorques, field=field,
        magnetization=uniform_magnetization(n_elements, MAGNETIZATION, (0.0, 1.0, 0.0)))
    # 0.3 of the wave-crossing time of an element, or of the section when elements are longer than
    # it is thick: shearing an element against its rotational inertia then sets the limit.
    dt = 0.3 * min(float(rod.rest_lengths.min()), 2.0 * float(rod.radius[0])) / math.sqrt(
        YOUNGS_MODULUS / DENSITY)
    simulator.dampen(rod).using(ea.AnalyticalLinearDamper, uniform_damping_constant=DAMPING, time_step=dt)
    simulator.finalize()
    stepper = ea.PositionVerlet()
    tip_y, tip_x, speeds = [], [], []
    steps_per_load = int(round(STEP_TIME / dt))
    k = 0
    for _ in loads:
        for _ in range(steps_per_load):
            stepper.step(simulator, k * dt, dt)
            k += 1
        tip = rod.position_collection[:, -1]
        tip_y.append(tip[1] / LENGTH)
        tip_x.append(tip[0] / LENGTH - 1.0)
        speeds.append(float(np.abs(rod.velocity_collection).max()))
    return Deflections(n_elements, np.array(tip_y), np.array(tip_x), max(speeds),
                       rod.position_collection.copy())


def bvp_reference(loads: tuple[float, ...]) -> np.ndarray:
    """Tip ``y / L`` of the planar Cosserat rod with the same stiffnesses (shear coefficient 1) at
    each load, continued from zero in load steps of at most 2.5 of ``l``."""
    settings = {"nodes": 200, "tol": 1e-9, "axial_stiffness": YOUNGS_MODULUS * AREA,
                "shear_stiffness": SHEAR_MODULUS * AREA}
    tips, guess, done = [], None, 0.0
    for load in loads:
        steps = max(1, math.ceil((load - done) / 2.5))
        if guess is None:  # the solver's own continuation from zero
            field = linear_field_2d(gradient(load)[:2, :2])
            sol = solve_magnetic_cantilever(LENGTH, BENDING, AREA, MAGNETIZATION, field, math.pi / 2,
                                            steps=steps, **settings)
        else:
            for j in range(1, steps + 1):
                field = linear_field_2d(gradient(done + (load - done) * j / steps)[:2, :2])
                sol = solve_magnetic_cantilever(LENGTH, BENDING, AREA, MAGNETIZATION, field, math.pi / 2,
                                                guess=guess, **settings)
                guess = (sol.s, sol.x, sol.y, sol.theta)
        guess = (sol.s, sol.x, sol.y, sol.theta)
        tips.append(sol.tip[1] / LENGTH)
        done = load
    return np.array(tips)


def lammps_reference() -> dict[float, tuple[float, float]]:
    """Load ``l`` -> ``(x_tip / L - 1, y_tip / L)`` of the LAMMPS run (``REFERENCE_CSV``)."""
    table = np.loadtxt(REFERENCE_CSV, delimiter=",", comments="#", skiprows=1, ndmin=2)
    return {float(row[0]): (float(row[1]), float(row[2])) for row in table}


def run(out: Path, quick: bool = False) -> CaseResult:
    start = time.perf_counter()
    mode = "quick" if quick else "full"
    loads, resolutions = LOADS[mode], RESOLUTIONS[mode]
    case = CaseResult(name="gradient-beam", title=(
        "Hard-magnetic cantilever in a constant gradient (Yan et al. 2022, configuration B1)"),
        description=_description(loads, resolutions), quick=quick)
    gate = gates(quick)
    case.gates = list(gate.values())
    runs = [simulate(n, loads) for n in resolutions]
    extrapolated = 2.0 * runs[-1].tip_y - runs[-2].tip_y
    previous = 2.0 * runs[-2].tip_y - runs[-3].tip_y
    bvp = bvp_reference(loads)
    lammps = lammps_reference()
    case.tables.append(_table(loads, runs, extrapolated, bvp, lammps))
    for i, load in enumerate(loads):
        case.comparisons.append(Comparison.gated(
            f"tip y/L at l = {load}, extrapolated, vs the Cosserat BVP", extrapolated[i], bvp[i],
            extrapolated[i] - bvp[i], gate["bvp"]))
        if float(load) in lammps:
            ref = lammps[float(load)][1]
            case.comparisons.append(Comparison.gated(
                f"tip y/L at l = {load}, extrapolated, vs LAMMPS", extrapolated[i], ref,
                extrapolated[i] - ref, gate["lammps"]))
    shared = [i for i, load in enumerate(loads) if float(load) in lammps]
    if shared:
        far = max(shared, key=lambda i: abs(lammps[float(loads[i])][1] - bvp[i]))
        ref = lammps[float(loads[far])][1]
        case.comparisons.append(Comparison.informational(
            f"tip y/L at l = {loads[far]}: LAMMPS vs the Cosserat BVP (largest difference)", ref, bvp[far],
            ref - bvp[far], "", "the two references' own difference: the bonded-particle discretization "
            "(259 particles, a whole particle's dipole at the tip) against the continuum rod"))
    worst = int(np.argmax(np.abs(extrapolated - previous)))
    case.comparisons.append(Comparison.gated(
        f"tip y/L at l = {loads[worst]}, extrapolated from n = {resolutions[-2]}, {resolutions[-1]} vs "
        f"{resolutions[-3]}, {resolutions[-2]}", extrapolated[worst], previous[worst],
        extrapolated[worst] - previous[worst], gate["extrapolation"]))
    case.notes.append(f"largest node speed at the end of any hold: "
                      f"{max(r.residual_speed for r in runs):.1e} m/s")
    out.mkdir(parents=True, exist_ok=True)
    case.figures.append(_figure(loads, runs, extrapolated, bvp, lammps, out / "gradient_beam.png"))
    case.wall_s = time.perf_counter() - start
    return case


def _description(loads, resolutions) -> str:
    return (
        "Yan, Abbasi and Reis (2022, Int. J. Solids Struct. 257, 111319) configuration B1 as published "
        "for LAMMPS by Alkuino et al. (2026, arXiv:2603.27279; gsalkuin/lammps-bpm-rods, config-B1.in, "
        f"commit efa6bba): beam {LENGTH * 1e3:g} x {WIDTH * 1e3:g} x {THICKNESS * 1e3:g} mm, E = "
        f"{YOUNGS_MODULUS / 1e6:g} MPa, nu = {POISSON:g}, {DENSITY:g} kg/m^3, magnetized across its "
        f"thickness ({MAGNETIZATION / 1e3:g} kA/m, +y), clamped along +x, no gravity, field B = b (-x/2, "
        f"y, -z/2), b = {GRADIENT_PER_LOAD * 1e3:.4g} mT/m per unit of the published load l (M A L^3 b / "
        f"EI = 0.36 l), l = {', '.join(map(str, loads))}, each load ramped from the previous one and "
        "held. Compared: the tip's y/L of this package's rod (the rectangle's exact area and "
        f"stiffnesses, n = {', '.join(map(str, resolutions))}, Richardson-extrapolated from the two "
        "finest), an independent planar Cosserat BVP (validation/bvp_magnet.py), and the published "
        "LAMMPS input run with LAMMPS 2025.7.22 (validation/data/gradient_beam_lammps.md says how; the "
        "paper's own numbers are in figures only).")


def _table(loads, runs, extrapolated, bvp, lammps) -> str:
    rows = ["| l | " + " | ".join(f"n = {r.n_elements}" for r in runs)
            + " | extrapolated | Cosserat BVP | LAMMPS (published input) |",
            "|---" * (len(runs) + 4) + "|"]
    for i, load in enumerate(loads):
        cells = " | ".join(f"{r.tip_y[i]:.5f}" for r in runs)
        lmp = lammps.get(float(load))
        rows.append(f"| {load} | {cells} | {extrapolated[i]:.5f} | {bvp[i]:.5f} | "
                    f"{'' if lmp is None else f'{lmp[1]:.5f}'} |")
    return "\n".join(rows)


def _figure(loads, runs, extrapolated, bvp, lammps, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax_s, ax_c) = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    finest = runs[-1].shape
    ax_s.plot(1e3 * finest[0], 1e3 * finest[1], "-", label=f"n = {runs[-1].n_elements}, l = {loads[-1]}")
    ax_s.set_aspect("equal")
    ax_s.set_xlabel("x (mm)")
    ax_s.set_ylabel("y (mm)")
    ax_s.legend(fontsize=7)
    ax_c.plot(loads, extrapolated, "o-", label="PyElastica + MagneticTorques (extrapolated)")
    ax_c.plot(loads, bvp, "k--", label="Cosserat BVP")
    known = sorted(lammps)
    ax_c.plot(known, [lammps[v][1] for v in known], "s", mfc="none", label="LAMMPS, published input")
    ax_c.set_xlabel("load l (lambda_m^C; M A L^3 b / EI = 0.36 l)")
    ax_c.set_ylabel("tip y / L")
    ax_c.legend(fontsize=7)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
