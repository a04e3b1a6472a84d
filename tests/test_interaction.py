"""Dipole-dipole interaction between the elements of a rod: closed forms and conservation laws."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from elastica_magnetic import MagneticInteraction, rectangular_band_rod, yao2023_magnetization
from elastica_magnetic.interaction import MU0

L, W, H = 20e-3, 8e-3, 0.8e-3


def make_rod(n):
    return rectangular_band_rod(n, L, W, H, 1860.0, 84.5e3, 84.5e3 / 3)


def lab_torques(rod):
    return np.einsum("jik,jk->ik", rod.director_collection, rod.external_torques)


def centres(rod):
    return 0.5 * (rod.position_collection[:, :-1] + rod.position_collection[:, 1:])


def loads(forcing, rod):
    rod.external_forces[:] = 0.0
    rod.external_torques[:] = 0.0
    forcing.apply_forces(rod, 0.0)
    forcing.apply_torques(rod, 0.0)
    return rod.external_forces.copy(), lab_torques(rod)


def bend_randomly(rod, rng, amplitude=0.6):
    """A random smooth 3D bend: random curvature along the rod, integrated from node 0."""
    n = rod.n_elems
    rotations = Rotation.from_rotvec(rng.normal(scale=amplitude / np.sqrt(n), size=(n, 3)))
    frame = Rotation.identity()
    x = np.zeros(3)
    q0 = rod.director_collection[..., 0].copy()
    for e in range(n):
        frame = frame * rotations[e]
        matrix = frame.as_matrix()
        rod.director_collection[..., e] = q0 @ matrix.T  # rows d1 d2 d3 turned by the frame
        rod.position_collection[:, e] = x
        x = x + rod.rest_lengths[e] * rod.director_collection[2, :, e]
    rod.position_collection[:, n] = x


def test_two_coaxial_dipoles_attract_with_the_closed_form():
    rod = make_rod(2)
    m = np.array([61.3e3, 0.0, 0.0])  # along the rod (+x): head to tail
    forcing = MagneticInteraction(m, cutoff=0.0)
    forces, torques = loads(forcing, rod)
    moment = rod.volume[0] * 61.3e3
    d = L / 2
    attraction = 3 * MU0 * moment**2 / (2 * np.pi * d**4)
    # Element 0 is pulled towards element 1 (+x), half of it on each of its nodes.
    np.testing.assert_allclose(forces[:, 0], [attraction / 2, 0, 0], rtol=1e-12)
    np.testing.assert_allclose(forces[:, 2], [-attraction / 2, 0, 0], rtol=1e-12)
    np.testing.assert_allclose(forces[:, 1], 0.0, atol=1e-15 * attraction)
    np.testing.assert_allclose(torques, 0.0, atol=1e-30)


def test_two_side_by_side_dipoles_repel_and_the_source_area_scales_them():
    rod = make_rod(2)
    m = np.array([0.0, 61.3e3, 0.0])  # across the line joining the two centres
    forces, torques = loads(MagneticInteraction(m, cutoff=0.0), rod)
    moment = rod.volume[0] * 61.3e3
    repulsion = 3 * MU0 * moment**2 / (4 * np.pi * (L / 2) ** 4)
    np.testing.assert_allclose(forces[:, 0], [-repulsion / 2, 0, 0], rtol=1e-12)
    np.testing.assert_allclose(torques, 0.0, atol=1e-30)
    area = rod.volume[0] / rod.rest_lengths[0]
    scaled, _ = loads(MagneticInteraction(m, cutoff=0.0, source_area=W * H), rod)
    np.testing.assert_allclose(scaled, forces * (W * H / area), rtol=1e-12)


def test_perpendicular_dipoles_torque_closed_form():
    # m_0 along the line, m_1 across it: field of 1 at 0 is -mu0 m1 / (4 pi d^3), so
    # tau_0 = m0 x B1 = -mu0 m0 m1 / (4 pi d^3) (x cross y) and the field of 0 at 1 is
    # 2 mu0 m0 / (4 pi d^3) along x: tau_1 = m1 x B0 = -2 mu0 m0 m1 / (4 pi d^3) z.
    rod = make_rod(2)
    magnetization = np.array([[61.3e3, 0.0], [0.0, 61.3e3], [0.0, 0.0]])
    _, torques = loads(MagneticInteraction(magnetization, cutoff=0.0), rod)
    moment = rod.volume[0] * 61.3e3
    k = MU0 * moment**2 / (4 * np.pi * (L / 2) ** 3)
    np.testing.assert_allclose(torques[:, 0], [0, 0, -k], rtol=1e-12)
    np.testing.assert_allclose(torques[:, 1], [0, 0, -2 * k], rtol=1e-12)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_newton_third_law_and_balance_of_moments_for_random_bends(seed):
    rng = np.random.default_rng(seed)
    n = 32
    rod = make_rod(n)
    magnetization = yao2023_magnetization(1, n) + rng.normal(scale=2e4, size=(3, n))
    forcing = MagneticInteraction(magnetization, cutoff=1e-3)
    forcing.moment_in_material_frame(rod)  # fix the magnetization in the straight rod
    bend_randomly(rod, rng)
    forces, torques = loads(forcing, rod)
    scale_f = np.abs(forces).max()
    assert scale_f > 0
    np.testing.assert_allclose(forces.sum(axis=1), 0.0, atol=1e-12 * scale_f * n)
    moment = torques.sum(axis=1) + np.cross(rod.position_collection.T, forces.T).sum(axis=0)
    scale_m = np.abs(torques).max() + scale_f * L
    np.testing.assert_allclose(moment, 0.0, atol=1e-12 * scale_m * n)


def test_forces_and_torques_are_minus_the_gradient_of_the_energy():
    rng = np.random.default_rng(7)
    n = 12
    rod = make_rod(n)
    magnetization = yao2023_magnetization(2, n) + rng.normal(scale=3e4, size=(3, n))
    forcing = MagneticInteraction(magnetization, cutoff=0.0)
    forcing.moment_in_material_frame(rod)
    bend_randomly(rod, rng, amplitude=1.5)
    forces, torques = loads(forcing, rod)
    h = 1e-8  # m; the energy is smooth on the scale of the element length (3e-4 m here)
    numeric = np.zeros_like(forces)
    for node in range(n + 1):
        for a in range(3):
            saved = rod.position_collection[a, node]
            rod.position_collection[a, node] = saved + h
            up = forcing.potential_energy(rod)
            rod.position_collection[a, node] = saved - h
            down = forcing.potential_energy(rod)
            rod.position_collection[a, node] = saved
            numeric[a, node] = -(up - down) / (2 * h)
    np.testing.assert_allclose(forces, numeric, rtol=1e-6, atol=1e-6 * np.abs(forces).max())
    # Torque: turning element e by a small lab angle dtheta changes the energy by -tau . dtheta.
    angle = 1e-6
    numeric_t = np.zeros_like(torques)
    for e in range(n):
        saved = rod.director_collection[..., e].copy()
        for a in range(3):
            rotvec = np.zeros(3)
            rotvec[a] = angle
            energies = []
            for sign in (1, -1):
                rod.director_collection[..., e] = saved @ Rotation.from_rotvec(sign * rotvec).as_matrix().T
                energies.append(forcing.potential_energy(rod))
            rod.director_collection[..., e] = saved
            numeric_t[a, e] = -(energies[0] - energies[1]) / (2 * angle)
    np.testing.assert_allclose(torques, numeric_t, rtol=1e-6, atol=1e-6 * np.abs(torques).max())


@pytest.mark.parametrize("direction", [(1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.3, -0.5, 0.8)])
def test_uniformly_magnetized_straight_rod_feels_no_net_force_or_torque(direction):
    n = 64
    rod = make_rod(n)
    m = 61.3e3 * np.asarray(direction) / np.linalg.norm(direction)
    forces, torques = loads(MagneticInteraction(m), rod)
    scale = np.abs(forces).max()
    assert scale > 0  # the parts do act on each other ...
    np.testing.assert_allclose(forces.sum(axis=1), 0.0, atol=1e-12 * scale)  # ... but not on the whole
    moment = torques.sum(axis=1) + np.cross(rod.position_collection.T, forces.T).sum(axis=0)
    np.testing.assert_allclose(moment, 0.0, atol=1e-12 * (np.abs(torques).max() + scale * L))
    # By symmetry the load pattern is mirrored about the middle: F(s) = -F(L - s).
    np.testing.assert_allclose(forces, -forces[:, ::-1], atol=1e-12 * scale)


def test_cutoff_leaves_out_near_pairs():
    rod = make_rod(8)
    m = np.array([61.3e3, 0.0, 0.0])
    element = L / 8
    forcing = MagneticInteraction(m, cutoff=7 * element)  # only the two end elements interact
    forces, _ = loads(forcing, rod)
    moment = rod.volume[0] * 61.3e3
    attraction = 3 * MU0 * moment**2 / (2 * np.pi * (7 * element) ** 4)
    np.testing.assert_allclose(forces[:, 0], [attraction / 2, 0, 0], rtol=1e-12)
    np.testing.assert_allclose(forces[:, 2:7], 0.0, atol=1e-30)
    assert MagneticInteraction(m)._prepare(rod) is None
    default = MagneticInteraction(m)
    default.moment_in_material_frame(rod)
    assert default.cutoff_used == pytest.approx(4 * rod.radius.max())


def test_rejects_bad_arguments():
    with pytest.raises(ValueError):
        MagneticInteraction(np.zeros((2, 4)))
    with pytest.raises(ValueError):
        MagneticInteraction(np.zeros(3), cutoff=-1.0)
    with pytest.raises(ValueError):
        MagneticInteraction(np.zeros(3), source_area=0.0)
    with pytest.raises(ValueError):
        MagneticInteraction(np.zeros(3), frame="body")
    forcing = MagneticInteraction(np.zeros((3, 5)))
    with pytest.raises(ValueError, match="5 columns"):
        forcing.apply_forces(make_rod(4), 0.0)


def test_robot_spec_interaction_is_opt_in(monkeypatch):
    from dataclasses import replace

    from elastica_magnetic import ConstantField, InteractionSpec, build_simulation, yao2023_robot

    scales = []
    original = MagneticInteraction.apply_forces

    def counted(self, system, time=0.0):
        original(self, system, time)
        scales.append(self._source_scale)

    monkeypatch.setattr(MagneticInteraction, "apply_forces", counted)
    default = yao2023_robot(2)
    assert default.interaction is None
    build_simulation(default, ConstantField(np.zeros(3))).step(3)
    assert scales == []
    spec = replace(default, interaction=InteractionSpec(self_contact_k=1.0, self_contact_nu=1e-3))
    simulation = build_simulation(spec, ConstantField(np.array([0.0, 0.0, 10e-3])))
    simulation.step(3)
    band_over_rod = (W * H) / (np.pi * (H / np.sqrt(3)) ** 2)
    assert scales == pytest.approx([band_over_rod] * 3)
