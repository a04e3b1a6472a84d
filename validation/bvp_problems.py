"""Named reference problems solved with :mod:`elastica_magnetic_validation.elastica_bvp`: the hard-magnetic
cantilever of Wang et al. 2020, the Hu et al. 2018 millirobot sheet (free-free), and the
first-order curvature model of Lum et al. 2016.

Like the solver, this module depends on numpy and scipy only (nothing from the simulator).
Units: SI (m, Pa, A/m, T, N m^2).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from .elastica_bvp import (
    ElasticaConvergenceError,
    ElasticaSolution,
    Equilibria,
    FloatArray,
    GuessLike,
    MagneticRod,
    continue_from,
    same_state,
    solve_elastica,
)

# Hu, Lum, Mastrangeli, Sitti, Nature 554, 81 (2018): the millirobot sheet.
HU2018_LENGTH = 3.7e-3  # m
HU2018_WIDTH = 1.5e-3  # m
HU2018_THICKNESS = 185e-6  # m
HU2018_MAGNETIZATION = 61.3e3  # A/m
HU2018_YOUNGS_MODULUS = 84.5e3  # Pa

def _add_unique(found: list[ElasticaSolution], sol: ElasticaSolution, atol: float) -> None:
    """Append ``sol`` to ``found`` unless it is the same state as one already there."""
    if not any(same_state(sol, f, atol) for f in found):
        found.append(sol)


# --------------------------------------------------------------------------------------
# Wang et al. 2020: hard-magnetic cantilever
# --------------------------------------------------------------------------------------


@dataclass
class CantileverResult:
    """Nondimensional hard-magnetic cantilever (Wang et al. 2020).

    Attributes
    ----------
    q : float
        Load ``M B A L^2 / (E I)`` (dimensionless).
    phi : float
        Field angle from the clamped tangent (rad).
    tip_angle : float
        ``theta(1)`` (rad).
    delta_y : float
        ``delta_y / L = int_0^1 sin(theta) d xi`` (tip deflection across the clamp axis).
    delta_x : float
        ``delta_x / L = 1 - int_0^1 cos(theta) d xi`` (tip shortening along it, >= 0).
    solution : ElasticaSolution
        The full solution, for a rod with ``L = EI = A = |B| = 1`` and ``|M| = q``.
    """

    q: float
    phi: float
    tip_angle: float
    delta_y: float
    delta_x: float
    solution: ElasticaSolution


def cantilever(
    q: float,
    phi: float,
    *,
    degrees: bool = False,
    tol: float = 1e-7,
    ramp_steps: int = 10,
    initial_guess: GuessLike | None = None,
) -> CantileverResult:
    """Hard-magnetic cantilever: ``theta'' = -q sin(phi - theta)``, clamped at ``xi = 0``.

    Boundary conditions ``theta(0) = 0`` and ``theta'(1) = 0``.

    Uniform magnetization along the rod (``alpha_m = 0``), uniform field at ``phi`` from
    the clamp direction, ``xi = s / L``.  Small ``q``: ``theta(1) = q sin(phi)/2 -
    (5/24) q^2 sin(phi) cos(phi) + O(q^3)`` and ``delta_y/L = q sin(phi)/3 - (2/15) q^2
    sin(phi) cos(phi) + O(q^3)``.

    The load is ramped from zero (the quasi-static branch), and the stable branch is
    returned: when the field is aligned with the rod (``sin(phi) = 0``) the straight
    rod solves the problem exactly for every ``q``, and the ramp stays on it; past the
    buckling load (``phi = 180`` deg, ``q > pi^2/4``) it is unstable and the solver
    leaves it along the buckling mode (``seek_stable`` of :func:`solve_elastica`), to
    the buckled branch with a positive tip angle.  No critical load is hard-coded.

    Parameters
    ----------
    q : float
        Dimensionless load ``M B A L^2 / (E I)`` (>= 0).
    phi : float
        Field angle (rad, or degrees if ``degrees``).
    degrees : bool
        Read ``phi`` in degrees.
    tol : float
        ``solve_bvp`` tolerance.
    ramp_steps : int
        Initial number of continuation steps.
    initial_guess : optional
        Start Newton at full load from this ``theta(xi)`` instead of ramping (no
        stability search then).

    Returns
    -------
    CantileverResult
    """
    phi_rad = math.radians(phi) if degrees else float(phi)
    rod = MagneticRod(
        length=1.0, bending_stiffness=1.0, area=1.0, magnetization=float(q), alpha_m=0.0
    )
    if initial_guess is not None:
        sol = solve_elastica(
            rod, 1.0, phi_rad, "clamped-free", initial_guess=initial_guess, tol=tol
        )
    else:
        sol = solve_elastica(
            rod, 1.0, phi_rad, "clamped-free", tol=tol, ramp_steps=ramp_steps, seek_stable=True
        )
    return CantileverResult(
        q=float(q),
        phi=phi_rad,
        tip_angle=sol.tip_angle,
        delta_y=sol.tip_deflection,
        delta_x=sol.tip_shortening,
        solution=sol,
    )


# --------------------------------------------------------------------------------------
# Hu et al. 2018 robot, free-free; Lum et al. 2016 first-order model
# --------------------------------------------------------------------------------------


def hu2018_rod(
    phi0: float = 0.0,
    *,
    EI: float | None = None,
    area: float | None = None,
    length: float = HU2018_LENGTH,
    width: float = HU2018_WIDTH,
    thickness: float = HU2018_THICKNESS,
    magnetization: float = HU2018_MAGNETIZATION,
    youngs_modulus: float = HU2018_YOUNGS_MODULUS,
) -> MagneticRod:
    """The Hu et al. 2018 sheet as a :class:`MagneticRod`.

    ``alpha_m(s) = 2 pi s / L + phi0`` (one full turn along the length), ``|M| = 61.3``
    kA/m.  Defaults: ``EI = E w h^3 / 12`` (N m^2) and ``A = w h`` (m^2) for the
    3.7 mm x 1.5 mm x 185 um band with ``E = 84.5`` kPa.  Only ``A/EI`` matters for the
    shape (energies scale with ``EI``); the equivalent circular rod of radius
    ``r = h / sqrt(3)`` has the same ratio ``A/(E I) = 12/(E h^2)``.

    Parameters
    ----------
    phi0 : float
        Magnetization angle at ``s = 0`` relative to the tangent (rad).
    EI : float, optional
        Bending stiffness (N m^2).
    area : float, optional
        Cross-section area (m^2).
    length, width, thickness : float
        Sheet dimensions (m).
    magnetization : float
        ``|M|`` (A/m).
    youngs_modulus : float
        ``E`` (Pa).

    Returns
    -------
    MagneticRod
    """
    if EI is None:
        EI = youngs_modulus * width * thickness**3 / 12.0
    if area is None:
        area = width * thickness
    two_pi_over_l = 2.0 * math.pi / length
    return MagneticRod(
        length=length,
        bending_stiffness=EI,
        area=area,
        magnetization=magnetization,
        alpha_m=lambda s: two_pi_over_l * np.asarray(s) + phi0,
    )


def hu2018_free_free(
    B: float,
    beta: float,
    phi0: float = 0.0,
    *,
    EI: float | None = None,
    area: float | None = None,
    length: float = HU2018_LENGTH,
    magnetization: float = HU2018_MAGNETIZATION,
    initial_guesses: Sequence[GuessLike] = (),
    n_orientations: int = 8,
    first_order_guesses: bool = True,
    tol: float = 1e-7,
    ramp_steps: int = 8,
    n_out: int = 1001,
    dedup_atol: float = 1e-3,
) -> Equilibria:
    """Free-free equilibria of the Hu et al. 2018 robot in a uniform field.

    Several starting points are tried and the distinct converged equilibria returned,
    sorted by energy:

    * each of ``initial_guesses`` (e.g. a simulated shape), solved directly at full load;
    * the four first-order (Lum et al.) equilibria ``c in {0, pi/2, pi, 3 pi/2}`` at the
      load where ``K L^2 = 1``, continued to the full load along their branch;
    * straight rods at ``n_orientations`` equally spaced orientations, load ramped from
      zero (snap-through allowed, as in a quasi-static experiment).

    Parameters
    ----------
    B : float
        Field magnitude (T).
    beta : float
        Field angle in the bending plane (rad, lab frame).
    phi0 : float
        Magnetization offset (rad); equivalent to rotating the field by ``-phi0``.
    EI, area, length, magnetization : float, optional
        See :func:`hu2018_rod` (SI units).
    initial_guesses : sequence
        Extra starting shapes (see :func:`solve_elastica`).
    n_orientations : int
        Number of straight starting orientations for the ramps.
    first_order_guesses : bool
        Use the first-order branches as starting points.
    tol : float
        ``solve_bvp`` tolerance.
    ramp_steps : int
        Initial number of continuation steps.
    n_out : int
        Output grid size.
    dedup_atol : float
        Two solutions whose ``theta`` differ by less (rad, modulo 2 pi) are the same.

    Returns
    -------
    Equilibria

    Raises
    ------
    ElasticaConvergenceError
        If no starting point converged.
    """
    rod = hu2018_rod(phi0, EI=EI, area=area, length=length, magnetization=magnetization)
    found: list[ElasticaSolution] = []
    attempts = failed = 0
    kw = dict(tol=tol, n_out=n_out)
    for g in initial_guesses:
        attempts += 1
        try:
            _add_unique(
                found, solve_elastica(rod, B, beta, "free-free", initial_guess=g, **kw), dedup_atol
            )
        except ElasticaConvergenceError:
            failed += 1
    if B == 0.0:
        attempts += 1
        _add_unique(found, solve_elastica(rod, 0.0, beta, "free-free", **kw), dedup_atol)
        return Equilibria(sorted(found, key=lambda s: s.energy), attempts, failed)
    k_full = rod.area * magnetization * abs(B) / rod.bending_stiffness  # 1/m^2
    frac = min(1.0, 1.0 / (k_full * length**2))
    if first_order_guesses:
        for c in (0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi):
            attempts += 1
            theta_start = beta - phi0 - c
            k_small = frac * k_full * (1.0 if B > 0 else -1.0)

            def guess(s: FloatArray, c=c, th=theta_start, k=k_small) -> FloatArray:
                return th + lum2016_theta(s, k, c, length)

            try:
                sol = continue_from(
                    rod, B, beta, "free-free", guess, frac, ramp_steps=ramp_steps, **kw
                )
                _add_unique(found, sol, dedup_atol)
            except ElasticaConvergenceError:
                failed += 1
    for j in range(n_orientations):
        attempts += 1
        try:
            sol = solve_elastica(
                rod,
                B,
                beta,
                "free-free",
                theta0=2.0 * math.pi * j / n_orientations,
                ramp_steps=ramp_steps,
                **kw,
            )
            _add_unique(found, sol, dedup_atol)
        except ElasticaConvergenceError:
            failed += 1
    if not found:
        raise ElasticaConvergenceError("no starting guess converged")
    return Equilibria(sorted(found, key=lambda s: s.energy), attempts, failed)


def lum2016_curvature(s: ArrayLike, K: float, c: float, length: float) -> FloatArray:
    """First-order curvature of the harmonic-magnetization robot (Lum et al. 2016).

    ``kappa(s) = K (L / 2 pi) [cos c - cos(c - 2 pi s / L)]`` with ``K = A |M| |B| / EI``
    (1/m^2) and ``c = beta - theta0 - phi0`` (rad), ``theta0 = theta(0)`` the tangent
    angle at the ``s = 0`` end.  This is the exact first-order solution of this module's
    equation with ``alpha_m = 2 pi s / L + phi0`` (magnetization turning counter-
    clockwise along ``s``) and ``kappa = theta'`` (counter-clockwise positive): it
    integrates ``theta'' = -K sin(c - 2 pi s / L)`` with ``theta'(0) = 0`` and satisfies
    ``theta'(L) = 0`` automatically.  At first order the net torque vanishes for every
    ``c``; at second order it is proportional to ``sin 2c``, so the equilibria are
    ``c = 0, pi`` (C shapes, stable) and ``c = pi/2, 3 pi/2`` (S shapes, unstable).

    Parameters
    ----------
    s : array_like, shape (n,)
        Arc length (m).
    K : float
        ``A |M| |B| / EI`` (1/m^2).
    c : float
        Phase (rad).
    length : float
        ``L`` (m).

    Returns
    -------
    ndarray, shape (n,)
        Curvature (1/m).
    """
    s = np.asarray(s, dtype=float)
    k = 2.0 * math.pi / length
    return K / k * (math.cos(c) - np.cos(c - k * s))


def lum2016_theta(s: ArrayLike, K: float, c: float, length: float) -> FloatArray:
    """First-order ``theta(s) - theta(0)`` (rad), the integral of :func:`lum2016_curvature`.

    Parameters and shapes as in :func:`lum2016_curvature`.
    """
    s = np.asarray(s, dtype=float)
    k = 2.0 * math.pi / length
    return K / k * (s * math.cos(c) + (np.sin(c - k * s) - math.sin(c)) / k)
