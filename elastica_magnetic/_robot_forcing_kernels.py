"""Numba kernels of the force and torque a field in space exerts on a robot (private): the spatial
branch of :class:`~elastica_magnetic.MagneticTorques` for one rod, and its batched twins for many
robots in one memory block, each under its own source (a moved magnet, a field map, coils with their
own currents, a dipole on a path), with the same operations in the same order as the per-rod
forcing. SI units: m, T, T/m, A m^2, N, N m, s. The fields: :mod:`elastica_magnetic._spatial_kernels`.
"""

from __future__ import annotations

from numba import njit

from ._spatial_kernels import (
    coil_currents_at,
    dipole_field,
    first_nonfinite,
    grid_field,
    loops_field,
    moved_dipole_field,
    moved_map_field_into,
    path_value,
    posed_grid_field,
)


@njit(cache=True)
def element_centres(positions, out):
    """Midpoints of consecutive nodes: ``positions`` (3, n + 1) -> ``out`` (3, n)."""
    for k in range(out.shape[1]):
        for d in range(3):
            out[d, k] = 0.5 * (positions[d, k] + positions[d, k + 1])


@njit(cache=True)
def magnetic_forces(moment_material, directors, gradients, external_forces):
    """Add ``F_e = (grad B)^T m_e`` (``m_e = Q_e^T m_material``, lab frame) half to node ``e`` and
    half to node ``e + 1``. Shapes ``(3, n)``, ``(3, 3, n)``, ``(3, 3, n)``, ``(3, n + 1)``."""
    for e in range(moment_material.shape[1]):
        # Lab-frame moment: m_lab = Q^T m (rows of Q are d1, d2, d3).
        ml0 = (directors[0, 0, e] * moment_material[0, e] + directors[1, 0, e] * moment_material[1, e]
               + directors[2, 0, e] * moment_material[2, e])
        ml1 = (directors[0, 1, e] * moment_material[0, e] + directors[1, 1, e] * moment_material[1, e]
               + directors[2, 1, e] * moment_material[2, e])
        ml2 = (directors[0, 2, e] * moment_material[0, e] + directors[1, 2, e] * moment_material[1, e]
               + directors[2, 2, e] * moment_material[2, e])
        for j in range(3):
            f = 0.5 * (gradients[0, j, e] * ml0 + gradients[1, j, e] * ml1 + gradients[2, j, e] * ml2)
            external_forces[j, e] += f
            external_forces[j, e + 1] += f


@njit(cache=True)
def magnetic_torques_at_elements(moment_material, fields_lab, directors, external_torques):
    """Add ``m x (Q_e B_e)`` to the material-frame torques; ``B_e`` is element ``e``'s own field.
    Shapes ``(3, n)``, ``(3, n)``, ``(3, 3, n)``, ``(3, n)``."""
    for e in range(moment_material.shape[1]):
        f0 = fields_lab[0, e]
        f1 = fields_lab[1, e]
        f2 = fields_lab[2, e]
        b0 = directors[0, 0, e] * f0 + directors[0, 1, e] * f1 + directors[0, 2, e] * f2
        b1 = directors[1, 0, e] * f0 + directors[1, 1, e] * f1 + directors[1, 2, e] * f2
        b2 = directors[2, 0, e] * f0 + directors[2, 1, e] * f1 + directors[2, 2, e] * f2
        m0 = moment_material[0, e]
        m1 = moment_material[1, e]
        m2 = moment_material[2, e]
        external_torques[0, e] += m1 * b2 - m2 * b1
        external_torques[1, e] += m2 * b0 - m0 * b2
        external_torques[2, e] += m0 * b1 - m1 * b0


@njit(cache=True)
def start_robot_field(positions, n0, centres, b, g):
    """The element centres ``centres`` ``(3, n)`` (m) of the robot whose nodes start at block node
    ``n0``, and its ``B`` ``(3, n)`` and ``grad B`` ``(3, 3, n)`` zeroed, for a source to add into."""
    element_centres(positions[:, n0:n0 + centres.shape[1] + 1], centres)
    b[...] = 0.0
    g[...] = 0.0


@njit(cache=True)
def robot_field_forcing(moments, directors, n0, e0, e1, b, g, external_forces, external_torques):
    """The force and torque of the field ``b``, ``g`` on the robot of block nodes ``n0 ..`` and
    elements ``e0:e1``, as :class:`~elastica_magnetic.MagneticTorques` adds them (forces, then
    torques); returns the first element whose field is not finite (nothing added), else -1."""
    bad = first_nonfinite(b, g, True)
    if bad >= 0:
        return bad
    moment, rotation = moments[:, e0:e1], directors[:, :, e0:e1]
    magnetic_forces(moment, rotation, g, external_forces[:, n0:n0 + (e1 - e0) + 1])
    magnetic_torques_at_elements(moment, b, rotation, external_torques[:, e0:e1])
    return -1


@njit(cache=True)
def moved_dipoles_forcing(motions, robots, times, moments, node_start, elem_start, elem_end,
                          positions, directors, external_forces, external_torques, centres, b, g):
    """The force and torque of each robot ``robots[k]``'s own moved magnet ``motions[k]`` on it, as
    :class:`~elastica_magnetic.MagneticTorques` applies a spatial source (the same operations in the
    same order), for robots of a memory block: element centres, ``B`` and ``grad B`` there at the
    robot's own time ``times[k]`` (s), then the forces and the torques. ``moments``
    ``(3, n_block_elements)`` A m^2 in the material frame; ``centres``, ``b``, ``g`` scratch of one
    robot's elements. Returns ``k * n + e`` of the first non-finite field (robot ``k``, element
    ``e``; a magnet on an element), else -1."""
    n = centres.shape[1]
    for k in range(robots.shape[0]):
        i = robots[k]
        n0, e0, e1 = node_start[i], elem_start[i], elem_end[i]
        start_robot_field(positions, n0, centres, b, g)
        moved_dipole_field(motions[k], times[k], centres, b, g, True)
        bad = robot_field_forcing(moments, directors, n0, e0, e1, b, g, external_forces, external_torques)
        if bad >= 0:
            return k * n + bad
    return -1


@njit(cache=True)
def moved_maps_forcing(motions, robots, times, origin, spacing, shape, samples, gradients, reference_moment,
                       moments, node_start, elem_start, elem_end, positions, directors, external_forces,
                       external_torques, centres, b, g, rotation, local, b_local, g_local):
    """As :func:`moved_dipoles_forcing`, each robot under its arm's magnet given by one field map in
    the magnet's frame (:func:`moved_map_field_into`). Returns ``k * n + e`` of the first element
    outside the map or whose field is not finite (robot ``k``, element ``e``), else -1."""
    n = centres.shape[1]
    for k in range(robots.shape[0]):
        i = robots[k]
        n0, e0, e1 = node_start[i], elem_start[i], elem_end[i]
        start_robot_field(positions, n0, centres, b, g)
        outside = moved_map_field_into(motions[k], times[k], origin, spacing, shape, samples, gradients,
                                       reference_moment, centres, b, g, True, rotation, local, b_local,
                                       g_local)
        if outside >= 0:
            return k * n + outside
        bad = robot_field_forcing(moments, directors, n0, e0, e1, b, g, external_forces, external_torques)
        if bad >= 0:
            return k * n + bad
    return -1


@njit(cache=True)
def fixed_maps_forcing(robots, posed, position, rotation, scale, origin, spacing, shape, samples,
                       gradients, moments, node_start, elem_start, elem_end, positions, directors,
                       external_forces, external_torques, centres, b, g, local, b_local, g_local):
    """As :func:`moved_dipoles_forcing`, robots ``robots`` under one field map fixed in the lab
    (``posed``: at ``position`` turned by ``rotation``, :func:`posed_grid_field`; else in the lab's
    frame, :func:`grid_field`), times ``scale``, the same operations as
    :class:`~elastica_magnetic.FieldMap` per robot (the map does not change: no robot's clock
    needed). Returns ``k * n + e`` of the first element
    outside the map or whose field is not finite (robot ``k``, element ``e``), else -1."""
    n = centres.shape[1]
    for k in range(robots.shape[0]):
        i = robots[k]
        n0, e0, e1 = node_start[i], elem_start[i], elem_end[i]
        start_robot_field(positions, n0, centres, b, g)
        if posed:
            outside = posed_grid_field(position, rotation, scale, origin, spacing, shape, samples, gradients,
                                       centres, b, g, True, local, b_local, g_local)
        else:
            outside = grid_field(origin, spacing, shape, samples, gradients, scale, centres, b, g, True)
        if outside >= 0:
            return k * n + outside
        bad = robot_field_forcing(moments, directors, n0, e0, e1, b, g, external_forces, external_torques)
        if bad >= 0:
            return k * n + bad
    return -1


@njit(cache=True)
def coil_loops_forcing(ramps, robots, times, loop_start, centres, frames, radii, unit_currents, moments,
                       node_start, elem_start, elem_end, positions, directors, external_forces,
                       external_torques, points, b, g, unit_b, unit_g, currents):
    """The force and torque of coils of circular loops on robots ``robots[k]`` of a memory block,
    each robot with its own currents (ramp row ``ramps[k]``, at the robot's own time ``times[k]``,
    s), as :class:`~elastica_magnetic.MagneticTorques` applies the coils' summed field (coil ``c``'s
    field at 1 A times its current, coil after coil; the same operations in the same order). Coil
    ``c`` is the loops ``loop_start[c]:loop_start[c + 1]`` (``centres`` (3, L) m, ``frames``
    (3, 3, L), ``radii`` (L,) m, ``unit_currents`` (L,) A turns at 1 A). ``points``, ``b``, ``g``,
    ``unit_b``, ``unit_g``: scratch of one robot's elements; ``currents`` (C,). Returns ``k * n + e``
    of the first non-finite field (robot ``k``, element ``e``), else -1; a point on a wire raises
    ZeroDivisionError."""
    n = points.shape[1]
    n_coils = currents.shape[0]
    for k in range(robots.shape[0]):
        i = robots[k]
        n0, e0, e1 = node_start[i], elem_start[i], elem_end[i]
        start_robot_field(positions, n0, points, b, g)
        coil_currents_at(ramps[k], times[k], currents)
        for c in range(n_coils):
            current = currents[c]
            if current == 0.0:
                continue
            unit_b[...] = 0.0
            unit_g[...] = 0.0
            l0, l1 = loop_start[c], loop_start[c + 1]
            loops_field(centres[:, l0:l1], frames[:, :, l0:l1], radii[l0:l1], unit_currents[l0:l1], points,
                        unit_b, unit_g, True)
            for e in range(n):
                for d in range(3):
                    b[d, e] += current * unit_b[d, e]
                    for j in range(3):
                        g[d, j, e] += current * unit_g[d, j, e]
        bad = robot_field_forcing(moments, directors, n0, e0, e1, b, g, external_forces, external_torques)
        if bad >= 0:
            return k * n + bad
    return -1


@njit(cache=True)
def dipole_paths_forcing(robots, times, path_start, path_times, path_values, moments, node_start,
                         elem_start, elem_end, positions, directors, external_forces, external_torques,
                         centres, b, g, moment, position):
    """The force and torque of each robot ``robots[k]``'s own point dipole, its moment (A m^2) and
    position (m) each a path (:func:`path_value`: paths ``2 k`` and ``2 k + 1`` of ``path_start``),
    as :class:`~elastica_magnetic.MagneticTorques` applies a
    :class:`~elastica_magnetic.PointDipoleField` (the same operations in the same order), at the
    robot's own time ``times[k]`` (s). ``moments`` ``(3, n_block_elements)`` A m^2 in the material
    frame; ``centres``, ``b``, ``g`` scratch of one robot's elements, ``moment``, ``position`` (3,).
    Returns ``k * n + e`` of the first non-finite field (robot ``k``, element ``e``), else -1."""
    n = centres.shape[1]
    for k in range(robots.shape[0]):
        i = robots[k]
        n0, e0, e1 = node_start[i], elem_start[i], elem_end[i]
        start_robot_field(positions, n0, centres, b, g)
        path_value(path_times, path_values, path_start[2 * k], path_start[2 * k + 1], times[k], moment)
        path_value(path_times, path_values, path_start[2 * k + 1], path_start[2 * k + 2], times[k], position)
        dipole_field(moment, position, centres, b, g, True)
        bad = robot_field_forcing(moments, directors, n0, e0, e1, b, g, external_forces, external_torques)
        if bad >= 0:
            return k * n + bad
    return -1
