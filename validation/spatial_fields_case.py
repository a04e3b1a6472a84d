"""Case ``spatial-fields``: the magnetic force and position-dependent torque of
:class:`~elastica_magnetic.MagneticTorques` with sources that vary in space, against closed forms,
conservation laws and a numerical Biot-Savart integration.

1. *Two point dipoles.* A one-element rod carrying the moment ``m2`` sits at ``x2`` in the field of
   a :class:`~elastica_magnetic.PointDipoleField` ``m1`` at ``x1``; the force on its two nodes and its
   torque (lab frame) are compared with the textbook dipole-dipole force
   ``F = 3 mu0 / (4 pi r^4) [(m1.n) m2 + (m2.n) m1 + (m1.m2) n - 5 (m1.n)(m2.n) n]`` and torque
   ``m2 x B1`` (e.g. Jackson, *Classical Electrodynamics*, 3rd ed., sec. 5.6-5.7; Yung, Landecker
   and Villani 1998, *Magn. Electr. Sep.* 9, 39), written here independently of the package.
2. *F = -grad U.* On a bent, twisted rod, the node forces equal minus the central finite
   differences (step 1e-7 m) of the energy ``U = -sum_e m_e . B(x_e)``.
3. *Uniform field.* A uniform field given as a spatial source: zero net force, and the total
   moment about the origin equals ``(sum m_e) x B``.
4. *Newton's third law.* The rod's elements, as point dipoles, push on the source dipole with
   minus the force the source exerts on the rod, and the moments about the origin balance.
5. *Coil pairs.* Helmholtz and Maxwell pairs (field and gradient) against the Biot-Savart law
   integrated numerically (trapezoidal rule on 4096 points per loop, spectrally accurate for a
   smooth periodic integrand) inside the coils.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import elastica as ea
import numpy as np

from elastica_magnetic import (
    ConstantField,
    FieldSum,
    HelmholtzCoils,
    MagneticTorques,
    MaxwellCoils,
    PointDipoleField,
)

from .report import CaseResult, Comparison, Gate

MU0 = 4e-7 * math.pi
#: Worst error achieved (the run is the same in full and quick): recorded rounded up to two
#: digits; the tolerance is MARGIN x it. Round-off checks use a fixed bound instead.
ACHIEVED = {"energy": 1.4e-10}
ROUND_OFF = 1e-12
#: The trapezoidal rule on a loop converges spectrally: the coil pairs' errors are the same 1e-15
#: (field) and 1e-14 (gradient) from 256 to 8192 points, so they are round-off (which differs
#: between machines and numpy builds, 1.1e-14 to 1.8e-14 measured), gated by the round-off bound.
BIOT_SAVART_POINTS = 4096


def gates() -> dict[str, Gate]:
    return {
        "dipole pair": Gate("dipole pair (force, torque)", 0.0, ROUND_OFF,
                            "round-off bound (closed form against closed form)", relative=True),
        "energy": Gate.from_achieved("F = -grad U (finite differences)", ACHIEVED["energy"], relative=True),
        "uniform": Gate("uniform field (net force, moment)", 0.0, ROUND_OFF,
                        "round-off bound (exact answer)", relative=True),
        "newton": Gate("Newton's third law", 0.0, ROUND_OFF, "round-off bound (exact balance)",
                       relative=True),
        "biot-savart field": Gate("coil pair B vs Biot-Savart", 0.0, ROUND_OFF,
                                  "round-off bound (converged quadrature)", relative=True),
        "biot-savart gradient": Gate("coil pair grad B vs Biot-Savart", 0.0, ROUND_OFF,
                                     "round-off bound (converged quadrature)", relative=True),
    }


def dipole_force_closed_form(m1, m2, x1, x2):
    """Force on dipole 2 (at x2) from dipole 1 (at x1), N, and the field of 1 at x2, T."""
    r = x2 - x1
    d = np.linalg.norm(r)
    n = r / d
    force = 3 * MU0 / (4 * np.pi * d**4) * (
        (m1 @ n) * m2 + (m2 @ n) * m1 + (m1 @ m2) * n - 5 * (m1 @ n) * (m2 @ n) * n)
    field = MU0 / (4 * np.pi * d**3) * (3 * n * (m1 @ n) - m1)
    return force, field


def _rod(n_elements, start, direction, length, radius=1e-3):
    normal = np.cross(direction, [0.0, 0.0, 1.0])
    if np.linalg.norm(normal) < 1e-6:
        normal = np.array([1.0, 0.0, 0.0])
    normal /= np.linalg.norm(normal)
    return ea.CosseratRod.straight_rod(n_elements, np.asarray(start, float), np.asarray(direction, float),
                                       normal, length, radius, 1000.0, youngs_modulus=1e6,
                                       shear_modulus=1e6 / 3)


def _loads(forcing, rod, t=0.0):
    rod.external_forces[:] = 0.0
    rod.external_torques[:] = 0.0
    forcing.apply_forces(rod, t)
    forcing.apply_torques(rod, t)
    torques_lab = np.einsum("jik,jk->ik", rod.director_collection, rod.external_torques)
    return rod.external_forces.copy(), torques_lab


def _relative(a, b):
    return float(np.abs(np.asarray(a) - np.asarray(b)).max() / np.abs(np.asarray(b)).max())


def dipole_pairs(case: CaseResult, gate: Gate) -> None:
    m1 = np.array([0.0, 0.0, 0.5])
    x1 = np.zeros(3)
    orientations = {"coaxial": ([0, 0, 1.0], [0, 0, 0.02]), "side by side": ([0, 0, 1.0], [1.0, 0, 0]),
                    "oblique": ([0.6, -0.3, 0.74], [0.5, 0.7, -0.3]), "crossed": ([1.0, 0, 0], [0, 1.0, 0.4])}
    for separation in (0.01, 0.03, 0.1):
        for name, (moment_dir, where) in orientations.items():
            direction = np.asarray(where, float) / np.linalg.norm(where)
            x2 = x1 + separation * direction
            # A two-element rod along y (PyElastica's smallest) whose first element, centred at
            # x2, carries m2; the second is not magnetized.
            length = 0.02  # only the element centre matters
            rod = _rod(2, x2 - [0, 0.25 * length, 0], [0, 1.0, 0], length, radius=2e-3)
            volume = float(rod.volume[0])
            m2 = 0.01 * np.asarray(moment_dir, float) / np.linalg.norm(moment_dir)
            magnetization = np.zeros((3, 2))
            magnetization[:, 0] = m2 / volume
            forcing = MagneticTorques(field=PointDipoleField(m1, x1), magnetization=magnetization)
            forces, torques = _loads(forcing, rod)
            force_ref, field_ref = dipole_force_closed_form(m1, m2, x1, x2)
            torque_ref = np.cross(m2, field_ref)
            label = f"{name}, r = {1e3 * separation:g} mm"
            f_sim = forces.sum(axis=1)
            # errors relative to the scales 3 |m1| |m2| mu0 / (4 pi r^4) and |m2| |B1| (the torque
            # of the coaxial and side-by-side pairs is zero)
            f_scale = 3 * MU0 / (4 * np.pi) * np.linalg.norm(m1) * np.linalg.norm(m2) / separation**4
            t_scale = np.linalg.norm(m2) * np.linalg.norm(field_ref)
            case.comparisons.append(Comparison.gated(
                f"force, {label} (|F| N)", float(np.linalg.norm(f_sim)), float(np.linalg.norm(force_ref)),
                float(np.abs(f_sim - force_ref).max() / f_scale), gate))
            case.comparisons.append(Comparison.gated(
                f"torque, {label} (|tau| N m)", float(np.linalg.norm(torques[:, 0])),
                float(np.linalg.norm(torque_ref)), float(np.abs(torques[:, 0] - torque_ref).max() / t_scale),
                gate))


def _bent_rod(n=24, seed=5):
    rod = _rod(n, [0.0, 0.0, 0.0], [1.0, 0, 0], 0.06)
    rng = np.random.default_rng(seed)
    rod.position_collection[1] += 0.012 * np.sin(np.linspace(0, np.pi, n + 1))
    rod.position_collection[2] += 0.004 * np.sin(np.linspace(0, 2 * np.pi, n + 1))
    for e, a in enumerate(0.4 * rng.normal(size=n)):
        c, s = math.cos(a), math.sin(a)
        rod.director_collection[:, :, e] = rod.director_collection[:, :, e] @ np.array(
            [[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
    magnetization = np.vstack([np.full(n, 8e4), np.linspace(-4e4, 4e4, n), np.full(n, 1e4)])
    return rod, magnetization


def energy_gradient(case: CaseResult, gate: Gate) -> None:
    sources = {"point dipole": PointDipoleField([0.1, 0.3, 0.2], [0.03, -0.02, 0.01]),
               "Helmholtz pair": HelmholtzCoils(0.04, 500.0, centre=[0.02, 0.0, 0.0], axis=[0, 1, 1]),
               "Maxwell pair": MaxwellCoils(0.04, 500.0, centre=[0.03, 0.01, 0.0], axis=[1, 0, 0.3])}
    for name, source in sources.items():
        rod, magnetization = _bent_rod()
        forcing = MagneticTorques(field=source, magnetization=magnetization)
        forces, _ = _loads(forcing, rod)
        moment_lab = np.einsum("jik,jk->ik", rod.director_collection, forcing.moment_in_material_frame(rod))

        def energy(positions, moment_lab=moment_lab, source=source):
            centres = 0.5 * (positions[:, :-1] + positions[:, 1:])
            return -float(np.sum(moment_lab * source.at(centres)))

        fd = np.zeros_like(forces)
        h = 1e-7
        for axis in range(3):
            for node in range(forces.shape[1]):
                plus, minus = rod.position_collection.copy(), rod.position_collection.copy()
                plus[axis, node] += h
                minus[axis, node] -= h
                fd[axis, node] = -(energy(plus) - energy(minus)) / (2 * h)
        case.comparisons.append(Comparison.gated(
            f"node forces vs -dU/dx, {name} (max |F| N)", float(np.abs(forces).max()),
            float(np.abs(fd).max()), _relative(forces, fd), gate))


def uniform_field(case: CaseResult, gate: Gate) -> None:
    rod, magnetization = _bent_rod()
    b = np.array([2e-3, -1e-3, 3e-3])
    forcing = MagneticTorques(field=FieldSum(ConstantField(b)), magnetization=magnetization)
    forces, torques = _loads(forcing, rod)
    moment_lab = np.einsum("jik,jk->ik", rod.director_collection, forcing.moment_in_material_frame(rod))
    couple = np.cross(moment_lab.sum(axis=1), b)
    total_moment = np.cross(rod.position_collection, forces, axis=0).sum(axis=1) + torques.sum(axis=1)
    scale = float(np.linalg.norm(moment_lab.sum(axis=1)) * np.linalg.norm(b) / 0.06)  # N
    case.comparisons.append(Comparison.gated(
        "net force in a uniform field (|F| / (|m| |B| / L))", float(np.linalg.norm(forces.sum(axis=1))), 0.0,
        float(np.abs(forces.sum(axis=1)).max() / scale), gate))
    case.comparisons.append(Comparison.gated(
        "total moment = (sum m) x B (|M| N m)", float(np.linalg.norm(total_moment)),
        float(np.linalg.norm(couple)), _relative(total_moment, couple), gate))


def newton(case: CaseResult, gate: Gate) -> None:
    rod, magnetization = _bent_rod()
    m_source, x_source = np.array([0.05, -0.02, 0.1]), np.array([0.035, -0.02, 0.015])
    forcing = MagneticTorques(field=PointDipoleField(m_source, x_source), magnetization=magnetization)
    forces, torques = _loads(forcing, rod)
    positions = rod.position_collection
    centres = 0.5 * (positions[:, :-1] + positions[:, 1:])
    moment_lab = np.einsum("jik,jk->ik", rod.director_collection, forcing.moment_in_material_frame(rod))
    f_source = np.zeros(3)
    tau_source = np.zeros(3)
    for e in range(centres.shape[1]):
        f, b = dipole_force_closed_form(moment_lab[:, e], m_source, centres[:, e], x_source)
        f_source += f
        tau_source += np.cross(m_source, b)
    f_rod = forces.sum(axis=1)
    moment_rod = np.cross(positions, forces, axis=0).sum(axis=1) + torques.sum(axis=1)
    moment_source = tau_source + np.cross(x_source, f_source)
    case.comparisons.append(Comparison.gated(
        "force on rod + force on source (|sum| / |F|)", float(np.linalg.norm(f_rod)),
        float(np.linalg.norm(f_source)), float(np.abs(f_rod + f_source).max() / np.abs(f_source).max()),
        gate))
    case.comparisons.append(Comparison.gated(
        "moment on rod + moment on source, about the origin", float(np.linalg.norm(moment_rod)),
        float(np.linalg.norm(moment_source)),
        float(np.abs(moment_rod + moment_source).max() / np.abs(moment_source).max()), gate))


def biot_savart(centres, axis, radii, currents, points, n_quad=BIOT_SAVART_POINTS):
    """B (3, n) and grad B (3, 3, n) of circular loops by the trapezoidal rule on the Biot-Savart law
    ``dB = mu0 I / (4 pi) dl x r / |r|^3``, written here in numpy."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    e1 = np.cross([1.0, 0, 0] if abs(axis[0]) < 0.9 else [0, 1.0, 0], axis)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    phi = 2 * np.pi * np.arange(n_quad) / n_quad
    b = np.zeros(points.shape)
    g = np.zeros((3, 3, points.shape[1]))
    for centre, radius, current in zip(centres, radii, currents, strict=True):
        y = centre[:, None] + radius * (np.outer(e1, np.cos(phi)) + np.outer(e2, np.sin(phi)))  # (3, q)
        dl = radius * (2 * np.pi / n_quad) * (-np.outer(e1, np.sin(phi)) + np.outer(e2, np.cos(phi)))
        r = points[:, :, None] - y[:, None, :]  # (3, n, q)
        d = np.sqrt((r**2).sum(axis=0))
        c = MU0 * current / (4 * np.pi)
        cross = np.cross(dl[:, None, :], r, axis=0)  # (3, n, q)
        b += c * (cross / d**3).sum(axis=2)
        for j in range(3):
            ej = np.zeros(3)
            ej[j] = 1.0
            dl_x_ej = np.cross(dl, ej, axis=0)  # (3, q)
            g[:, j, :] += c * ((dl_x_ej[:, None, :] / d**3) - 3 * cross * r[j] / d**5).sum(axis=2)
    return b, g


def coil_pairs(case: CaseResult, gate_b: Gate, gate_g: Gate) -> None:
    rng = np.random.default_rng(11)
    radius, current, turns = 0.08, 2.0, 100
    centre, axis = np.array([0.01, -0.02, 0.03]), np.array([0.2, 1.0, 0.4])
    for cls in (HelmholtzCoils, MaxwellCoils):
        source = cls(radius, current=current, centre=centre, axis=axis, turns=turns)
        # points inside the coils: rho up to 0.7 R, along the axis up to 0.6 R either side
        local = np.vstack([rng.uniform(-0.5, 0.5, 40) * radius, rng.uniform(-0.5, 0.5, 40) * radius,
                           rng.uniform(-0.6, 0.6, 40) * radius])
        points = centre[:, None] + source.frame @ local
        b, g = source.evaluate(points)
        loop_centres = [centre + o * source.axis for o in source.offsets]
        b_ref, g_ref = biot_savart(loop_centres, source.axis, source.radii, current * source.weights, points)
        name = cls.__name__
        case.comparisons.append(Comparison.gated(
            f"{name}: B at 40 points inside (max |B| T)", float(np.abs(b).max()), float(np.abs(b_ref).max()),
            _relative(b, b_ref), gate_b))
        case.comparisons.append(Comparison.gated(
            f"{name}: grad B at 40 points inside (max T/m)", float(np.abs(g).max()),
            float(np.abs(g_ref).max()), _relative(g, g_ref), gate_g))


def run(out: Path, quick: bool = False) -> CaseResult:
    start = time.perf_counter()
    case = CaseResult(
        name="spatial-fields",
        title="Magnetic forces and torques in fields that vary in space",
        description=(
            "MagneticTorques with a spatial source applies at each element centre the torque "
            "m x B(x) and the force (grad B)^T m, half on each node. Checked against the "
            "dipole-dipole closed form (Jackson, Classical Electrodynamics, 3rd ed., sec. 5.6-5.7) "
            "at separations of 10, 30 and 100 mm in four orientations, against finite differences "
            "of the magnetic energy on a bent and twisted rod (24 elements), against the exact "
            "answers of a uniform field and of Newton's third law between the rod and a dipole, "
            "and, for the Helmholtz and Maxwell coil pairs (closed form by elliptic integrals), "
            f"against the Biot-Savart law integrated on {BIOT_SAVART_POINTS} points per loop. "
            "The relative errors are the largest component difference over the largest component "
            "of the reference (dipole pairs: over 3 mu0 |m1| |m2| / (4 pi r^4) and |m2| |B1|). The "
            "same run in full and --quick."
        ),
        quick=quick,
    )
    gate = gates()
    case.gates = list(gate.values())
    dipole_pairs(case, gate["dipole pair"])
    energy_gradient(case, gate["energy"])
    uniform_field(case, gate["uniform"])
    newton(case, gate["newton"])
    coil_pairs(case, gate["biot-savart field"], gate["biot-savart gradient"])
    case.notes.append(
        "finite-difference step 1e-7 m on node positions with the directors fixed (the moments move "
        "with the directors, not with the nodes); its truncation and round-off set the energy gate")
    case.wall_s = time.perf_counter() - start
    return case
