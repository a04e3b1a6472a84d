"""Physical ranges: the one table of what a value can be in a magnetic soft robot lab.

Every door of the package (spec files, the fields in space they build, field CSVs, calibrations)
judges a number against :data:`QUANTITIES`: a value outside a quantity's *refuse* range cannot be
physical for a magnetic soft robot, its coils or its magnets, and is refused with the door's own
error; a value inside it but outside the narrower *warn* range is merely unusual and gets an
:class:`ImplausibleValueWarning` (a spec silences it with ``[checks] accept = ["robot.key"]``).
Both messages name the unit mistake the value most likely comes from (mm for m, kPa for Pa, mT for
T, ...): the mistakes of each quantity whose conversion lands the value in the warn range.

Every value is SI (the unit is :attr:`Quantity.unit`); a door that reads another unit (a field CSV
in mT) passes its unit and scale to :func:`judge`. This module imports nothing but the standard
library: every layer may read it.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

__all__ = [
    "NAMED_CHECKS",
    "Bound",
    "Finding",
    "ImplausibleValueWarning",
    "Quantity",
    "QUANTITIES",
    "MIN_STEPS_PER_PERIOD",
    "SettingNotAppliedWarning",
    "MAX_RELATIVE_CHANGE_PER_ELEMENT",
    "judge",
    "mistake_hint",
    "too_few_steps",
    "warn_implausible",
]

#: Fewer time steps than this per period of a field's oscillation: the integrator samples the
#: waveform too coarsely (a cosine sampled 20 times a period is within 1.2 % of its peak).
MIN_STEPS_PER_PERIOD = 20
#: Largest change of the field along the rod over one element, relative to the strongest field on
#: the rod: the forcing samples the field once per element, so a field that changes by more than
#: half its strength within an element is not resolved by the rod (add elements).
MAX_RELATIVE_CHANGE_PER_ELEMENT = 0.5


#: Warnings about no single key, by the name ``[checks] accept`` gives them.
NAMED_CHECKS: dict[str, str] = {
    "field.resolution": "the field changes by more than half its strength over one element",
    "field.strength": "the largest field on the rod at t = 0 is unusually strong",
}


class SettingNotAppliedWarning(UserWarning):
    """A default setting (a recipe's, a spec's) that cannot act on this input and is left off,
    the run going on without it (a setting asked for by name is refused instead)."""


class ImplausibleValueWarning(UserWarning):
    """A value that is physical but unusual (outside a quantity's warn range); ``key`` is the
    dotted spec key (``"robot.youngs_modulus"``) that ``[checks] accept`` silences, or ``""``."""

    def __init__(self, message: str, key: str = "") -> None:
        super().__init__(message)
        self.key = key


@dataclass(frozen=True)
class Bound:
    """One end of a range (SI) and why it is there, for the message."""

    value: float
    why: str


@dataclass(frozen=True)
class Quantity:
    """A physical quantity: its SI ``unit``, the ``refuse`` and ``warn`` ranges (``None``: no bound
    on that side; bounds inclusive) and the ``mistakes`` it commonly comes from: units written by
    mistake where ``unit`` is expected, each with its size in ``unit``."""

    name: str
    unit: str
    refuse: tuple[Bound | None, Bound | None]
    warn: tuple[Bound | None, Bound | None]
    mistakes: tuple[tuple[str, float], ...] = ()
    signed: bool = False  # judge the value itself, not its magnitude


@dataclass(frozen=True)
class Finding:
    """What :func:`judge` found: ``refuse`` (True: cannot be physical) and the text
    ``"84.5 Pa is below 100 Pa, ...; it looks like kPa written where Pa is expected (...)"``."""

    refuse: bool
    text: str
    high: bool  # above the range (False: below it)


_MM_CM = (("mm", 1e-3), ("cm", 1e-2))


def _q(name: str, unit: str, refuse: tuple, warn: tuple, mistakes: tuple = (),
       signed: bool = False) -> Quantity:
    return Quantity(name, unit, tuple(None if b is None else Bound(*b) for b in refuse),  # type: ignore[arg-type]
                    tuple(None if b is None else Bound(*b) for b in warn), mistakes,  # type: ignore[arg-type]
                    signed)


#: The table: quantity name -> :class:`Quantity` (SI). Why each bound, in its text.
QUANTITIES: dict[str, Quantity] = {q.name: q for q in (
    _q("rod length", "m",
       ((1e-5, "smaller than any magnetic soft robot made"),
        (5.0, "longer than any magnetic soft robot or catheter")),
       ((1e-4, "the smallest magnetic soft robots"),
        (1.0, "the longest magnetic catheters")), _MM_CM),
    _q("section", "m",  # width, thickness, radius of the rod
       ((1e-7, "thinner than any film a robot is made of"),
        (0.5, "thicker than any soft rod")),
       ((1e-5, "the thinnest magnetic films"),
        (0.05, "the thickest soft robot bodies")), _MM_CM),
    _q("density", "kg/m^3",
       ((50.0, "lighter than any magnetizable solid (polymer foams)"),
        (25000.0, "denser than osmium (22590 kg/m^3), the densest element")),
       ((500.0, "lighter than elastomers and hydrogels (900-1300 kg/m^3)"),
        (8000.0, "denser than steel and sintered NdFeB (7500-7900 kg/m^3)")),
       (("g/cm^3", 1e3),)),
    _q("youngs modulus", "Pa",
       ((100.0, "the softest hydrogels (~100 Pa)"),
        (1.2e12, "diamond (1.2e12 Pa), the stiffest solid")),
       ((1e3, "the softest soft robots (hydrogels)"),
        (1e10, "stiffer than soft robot materials (rigid plastics ~3 GPa)")),
       (("kPa", 1e3), ("MPa", 1e6))),
    _q("shear modulus", "Pa",  # G = E / (2 (1 + nu)): about a third of E's bounds
       ((30.0, "a third of the softest hydrogels' E (~100 Pa)"),
        (6e11, "half diamond's E (1.2e12 Pa)")),
       ((300.0, "a third of 1 kPa, the softest soft robots' E"),
        (4e9, "a third of 10 GPa, stiffer than soft robot materials")),
       (("kPa", 1e3), ("MPa", 1e6))),
    _q("shear coefficient", "1",  # alpha_c, the shear stiffness's factor (PyElastica's 4/3, the paper's 1)
       ((0.1, "a tenth of any cross-section's (Timoshenko's 5/6 to PyElastica's 4/3)"),
        (10.0, "ten times any cross-section's (Timoshenko's 5/6 to PyElastica's 4/3)")),
       ((0.5, "below any cross-section's (5/6 for a rectangle)"),
        (2.0, "above any cross-section's (4/3, PyElastica's default)")),
       (("percent", 1e-2),)),
    _q("poisson ratio", "1", (None, None),
       ((0.0, "a negative Poisson ratio is an auxetic material"), None),
       (("percent", 1e-2),), signed=True),
    _q("magnetization", "A/m",
       # any weak magnetization is physical (merely useless): only the top is refused
       (None, (2e6, "above the saturation of any magnet material (NdFeB ~1.1e6 A/m)")),
       ((1e3, "weaker than magnetic soft robots (weakly loaded composites are a few kA/m)"),
        (1.2e6, "solid NdFeB")),
       # a remanence B_r written where M = B_r / mu0 is expected
       (("kA/m", 1e3), ("T", 1.0 / (4e-7 * math.pi)))),
    _q("polarization", "T",  # a permanent magnet's J = mu0 M (remanence)
       (None, (2.0, "above the remanence of any permanent magnet (NdFeB ~1.45 T)")),
       ((0.1, "weaker than bonded ferrite magnets (~0.2 T)"),
        (1.5, "the strongest NdFeB grades")),
       (("mT", 1e-3),)),
    _q("magnetic moment", "A m^2",
       (None, (1e4, "more than a 20 cm NdFeB cube (~8e3 A m^2)")),
       (None, (1e3, "a 10 cm NdFeB cube")),
       (("mA m^2", 1e-3),)),
    _q("magnet dimension", "m",
       ((1e-5, "smaller than any magnet placed by hand"),
        (1.0, "larger than any permanent magnet block")),
       ((2e-4, "the smallest magnets sold"),
        (0.2, "the largest magnets used to steer robots")), _MM_CM),
    _q("position", "m",  # |position| of a magnet, coil, grid point, path point from the origin
       (None, (10.0, "farther than any lab setup (the field there is nil)")),
       (None, (1.0, "far for a lab setup")), _MM_CM),
    _q("coil field", "T",  # fields coils make at the robot: limits, waveforms, measurements
       ((5e-5, "the Earth's field: a coil field below it moves no robot"),
        (1.0, "beyond electromagnetic coils around a robot")),
       ((5e-4, "weak for moving a robot"), (0.1, "the strongest coil systems")),
       (("mT", 1e-3), ("T", 1.0), ("uT", 1e-6), ("G", 1e-4))),
    _q("field increment", "T",  # the largest change of a field component per 0.01 s action
       # (a case also refuses one above its own field limit: it would limit nothing)
       (None, (1.0, "above the largest field limit (1 T): it would limit nothing")),
       ((1e-5, "10 uT per 0.01 s step (1 mT/s), a field of a few mT takes seconds to build"),
        (0.01, "10 mT per 0.01 s step (1 T/s), faster than lab coil drivers slew")),
       (("mT", 1e-3), ("uT", 1e-6))),
    _q("field in space", "T",  # a field map's or a source's largest field on the robot
       ((5e-5, "the Earth's field"),
        (3.0, "beyond any permanent magnet's surface field (~1.5 T) or lab electromagnet")),
       ((5e-4, "weak for moving a robot"), (1.0, "a magnet's surface field")),
       (("mT", 1e-3), ("T", 1.0), ("uT", 1e-6), ("G", 1e-4))),
    _q("gradient", "T/m",  # a uniform gradient made by coils
       (None, (20.0, "beyond any coil system (MRI ~0.1 T/m, magnetic navigation ~2 T/m)")),
       (None, (2.0, "the strongest gradient coil systems")),
       (("mT/m", 1e-3), ("G/cm", 1e-2))),
    _q("coil current", "A",
       (None, (1e4, "beyond any lab coil (superconducting magnets run ~1 kA)")),
       (None, (200.0, "beyond water-cooled lab coils")),
       (("mA", 1e-3),)),
    _q("coil radius", "m",
       ((1e-4, "smaller than any wound coil"),
        (5.0, "larger than any coil around a robot")),
       ((5e-3, "the smallest coils"), (1.0, "the largest lab coils")), _MM_CM),
    _q("coil constant", "T/A",  # |actuation matrix entry| of Helmholtz-type coils
       # B/I = (4/5)^(3/2) mu0 N / R at the centre of a pair of radius R with N turns per coil:
       # about 10 uT/A (a metre-sized pair with a few turns) to 50 mT/A (centimetres, ~1000 turns)
       ((1e-5, "a metre-sized pair with a few turns"), (5e-2, "a centimetre-sized pair with "
                                                            "~1000 turns")),
       ((1e-5, ""), (5e-2, "")),
       (("mT/A", 1e-3), ("G/A", 1e-4), ("uT/A", 1e-6))),
    _q("friction coefficient", "1",
       (None, (10.0, "beyond any dry friction (rubber on rough ground ~1-2)")),
       (None, (2.0, "rubber on rough ground")),
       (("%", 1e-2),)),
    _q("gravity", "m/s^2",  # judged when not 0 (0: no gravity, e.g. a free rod's statics)
       (None, (1000.0, "100 g: no robot moves on such a ground")),
       ((9.7, "below the Earth's 9.78 m/s^2: a robot in a buoyant liquid, or 1 g written as 1"),
        (9.9, "above the Earth's 9.83 m/s^2")),
       (("g", 9.80665), ("cm/s^2", 1e-2))),
    _q("episode duration", "s",  # a training episode
       (None, (86400.0, "a day of simulated time per episode")),
       (None, (600.0, "10 minutes of simulated time per episode (the paper's: 20 s)")),
       (("ms", 1e-3),)),
    _q("simulated time", "s",  # a run's --duration
       (None, None),
       (None, (600.0, "10 minutes of simulated time (the paper's runs: 10 to 20 s; a minute of "
                      "the accurate physics is about an hour of computing)")),
       (("ms", 1e-3),)),
    _q("field time", "s",  # a field's ramp, a magnet path's times
       (None, (86400.0, "a day")),
       (None, (60.0, "a minute of simulated time (every shipped run is 10 s or less; a minute "
                     "of the accurate physics is an hour of computing)")),
       (("ms", 1e-3),)),
    _q("rotation period", "s",  # one turn of a rotating field
       (None, (86400.0, "a turn per day: a static field")),
       (None, (60.0, "a turn per minute: over the 10 s that judge a gait, a nearly static field "
                     "(the paper's robots walk at 1 to 3 s per turn)")),
       (("ms", 1e-3),)),
    _q("phase angle", "rad",  # a magnetization's or a field's phase
       (None, None),
       (None, (2.0 * math.pi + 1e-9, "a full turn (2 pi rad)")),
       (("deg", math.pi / 180.0),)),
    _q("mass scale", "1",  # density x s, gravity / s: the paper's training physics is 10.5
       (None, (1e4, "a robot 10,000 times heavier in inertia: its dynamics are no longer the "
                    "robot's")),
       ((0.01, "a robot 100 times lighter in inertia than it is"),
        (100.0, "ten times the paper's 10.5 (1000/95): the gait of a heavier robot is learned"))),
    _q("time step", "s",
       ((1e-10, "1e8 steps per 0.01 s: a run that never ends"),
        (0.01, "the 0.01 s control period")),
       ((1e-8, "finer than any soft robot needs"), (1e-3, "coarser than any stable soft robot step")),
       (("us", 1e-6), ("ms", 1e-3))),
)}


def _shown(value: float, unit: str) -> str:
    """``"84.5 Pa"``; a dimensionless value without its ``"1"``."""
    return f"{value:g}" if unit == "1" else f"{value:g} {unit}"


def _in(value: float, bounds: tuple[Bound | None, Bound | None]) -> bool:
    low, high = bounds
    return (low is None or value >= low.value) and (high is None or value <= high.value)


def mistake_hint(name: str, value: float, unit: str | None = None, scale: float = 1.0) -> str:
    """``"; it looks like mT written where T is expected (4 mT is 0.004 T)"`` for a value of
    quantity ``name`` (in ``unit`` of ``scale`` SI units each), or a reminder of the unit."""
    quantity = QUANTITIES[name]
    return _mistakes(quantity, abs(value), quantity.unit if unit is None else unit, scale)


def _mistakes(quantity: Quantity, value: float, unit: str, scale: float) -> str:
    """``"; it looks like kPa written where Pa is expected (84.5 kPa is 84500 Pa)"`` for the
    mistakes that bring ``value`` (in ``unit``, ``scale`` SI per unit) into the warn range."""
    # a fraction written in percent is a number of at least 1 (0.55 is no 0.55 %)
    found = [(name, size) for name, size in quantity.mistakes
             if name != unit and _in(value * size, quantity.warn) and not (name == "percent" and value < 1.0)]
    if not found:
        return "" if unit == "1" else f"; check the unit: {unit} is expected"
    names = " or ".join(name for name, _ in found)
    examples = "; ".join(f"{value:g} {name} is {_shown(value * size / scale, unit)}"
                         for name, size in found)
    expected = "a plain number" if unit == "1" else unit
    return f"; it looks like {names} written where {expected} is expected ({examples})"


def judge(name: str, value: float, unit: str | None = None, scale: float = 1.0, *,
          hint: bool = True) -> Finding | None:
    """Judge ``value`` of quantity ``name`` (a key of :data:`QUANTITIES`): ``None`` when usual,
    else a :class:`Finding`. ``value`` is in ``unit`` (default the quantity's SI unit) of
    ``scale`` SI units each (a field CSV: ``"mT"``, ``1e-3``); magnitudes are judged (``|value|``),
    and 0 (nothing: no field, no magnetization) is not judged. ``hint=False``: no unit mistake
    is named (a value computed, not written)."""
    quantity = QUANTITIES[name]
    unit = quantity.unit if unit is None else unit
    si = (value if quantity.signed else abs(value)) * scale
    if si == 0.0 or not math.isfinite(si):
        return None
    for refuse, bounds in ((True, quantity.refuse), (False, quantity.warn)):
        low, high = bounds
        if low is not None and si < low.value:
            above, bound = False, low
        elif high is not None and si > high.value:
            above, bound = True, high
        else:
            continue
        text = (f"{_shown(value, unit)} is {'above' if above else 'below'} "
                f"{_shown(bound.value / scale, unit)}, {bound.why}")
        if not refuse:
            text += ": unusual for a magnetic soft robot lab"
        if hint:
            text += _mistakes(quantity, value if quantity.signed else abs(value), unit, scale)
        return Finding(refuse, text, above)
    return None


def too_few_steps(frequency: float, dt: float) -> str | None:
    """What is wrong with a field oscillating at ``frequency`` (Hz) simulated with steps of ``dt``
    (s), when there are fewer than :data:`MIN_STEPS_PER_PERIOD` steps per period; else ``None``."""
    if frequency == 0.0:
        return None
    steps = 1.0 / (abs(frequency) * dt)
    if steps >= MIN_STEPS_PER_PERIOD:
        return None
    return (f"{steps:.3g} time steps per period, fewer than {MIN_STEPS_PER_PERIOD}: the simulation "
            "samples the waveform too coarsely (lower dt, or check that the frequency is in Hz, not "
            "rad/s)")


def warn_implausible(message: str, key: str = "", stacklevel: int = 3) -> None:
    """Issue an :class:`ImplausibleValueWarning` (printed once on stderr by ``msr``)."""
    warnings.warn(ImplausibleValueWarning(message, key), stacklevel=stacklevel)
