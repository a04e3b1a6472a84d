"""Spec texts several tests write (a helper module, imported with ``tests/`` on ``sys.path`` for its
``conftest.py``). SI units (m, kg/m^3, Pa, A/m, s).

- :data:`CATHETER`: a small magnetic catheter, 50 mm long, 0.5 mm radius, 10 elements, no gravity,
  magnetized uniformly (100 kA/m), with its time steps; :data:`CATHETER_ON_GROUND` on a ground;
  :data:`CATHETER_MAGNET_REACH` a tip-reach case of it steered by a magnet on an arm.
- :func:`quick_catheter`: a shipped catheter case made quicker to simulate, as a case dict.
- :data:`SMALL_BAND`: the ``[robot]`` table of the paper's 20 x 8 x 0.8 mm band with 8 elements,
  its moduli given by a Poisson ratio; a test adds its own ``[robot.magnetization]``.
"""

from __future__ import annotations

_ROBOT = """
[robot]
length = 0.05
radius = 0.0005
n_elements = 10
density = 1100.0
youngs_modulus = 3.0e6
poisson_ratio = 0.45
gravity = 0.0
[robot.magnetization]
kind = "uniform"
magnitude = 1.0e5
"""
_REST = """[robot.damping]
relative = 0.0
legacy_force = 0.03
legacy_torque = 1e-9
[physics.accurate]
dt = 1e-5
[physics.training]
dt = 1e-5
"""

#: The catheter's spec text, free of any ground.
CATHETER = _ROBOT + _REST

#: The same catheter on a ground (static and kinetic friction 0.8 and 0.6).
CATHETER_ON_GROUND = _ROBOT + "[robot.ground]\nstatic_mu = 0.8\nkinetic_mu = 0.6\n" + _REST

#: The paper's band, 8 elements, Poisson ratio 0.48: the ``[robot]`` table without magnetization.
SMALL_BAND = """
[robot]
length = 0.02
n_elements = 8
width = 0.008
thickness = 0.0008
density = 1860.0
youngs_modulus = 84500.0
poisson_ratio = 0.48
"""

#: The catheter steered by a magnet on an arm to targets in front of its tip: a tip-reach case
#: (the training physics scales the mass by 100 for a 5x longer time step).
CATHETER_MAGNET_REACH = _ROBOT + _REST.replace(
    "[physics.training]\ndt = 1e-5", "[physics.training]\nmass_scale = 100.0\ndt = 5e-5") + """
[actuation]
kind = "magnet-pose"
moment = 1.0
position = [0.09, 0.0, 0.0]
direction = [1.0, 0.0, 0.0]
workspace = [[-0.1, -0.1, -0.1], [0.15, 0.1, 0.1]]
max_speed = 0.1
max_turn_rate = 3.0
min_clearance = 0.01
[task]
kind = "tip-reach"
target_box = [[0.04, 0.0, -0.01], [0.045, 0.015, 0.01]]
tolerance = 0.001
episode_duration = 2.0
"""


def quick_catheter(case_name: str, name: str) -> dict:
    """The shipped catheter case ``case_name`` with 6 elements and a 4e-5 s training step (a fit
    runs ~40 simulations: ~3x faster than the shipped 10 elements at 2e-5 s), named ``name``, as
    a complete case dict."""
    import copy

    from elastica_magnetic_rl.cases.case import load_case

    spec = copy.deepcopy(load_case(case_name).to_dict())
    spec["name"] = name
    spec["robot"]["n_elements"] = 6
    spec["physics"]["training"]["dt"] = 4e-5
    return spec
