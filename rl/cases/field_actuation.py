"""The ``[actuation]`` table of a case driven by a uniform field (the paper's coils): the field
the policy controls (:class:`Actuation`), read and checked from a spec (SI units: T, T per action,
Hz). The other actuations: :mod:`~elastica_magnetic_rl.cases.arm_actuation` (a magnet on a robot
arm) and :mod:`~elastica_magnetic_rl.cases.coil_actuation` (coil currents)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from elastica_magnetic.plausibility import mistake_hint
from elastica_magnetic.robot_spec import ACTION_PERIOD
from elastica_magnetic.specfile import SpecError, SpecTable

__all__ = [
    "ACTUATION_AXES", "ACTUATION_OBSERVATION", "CONTROL_RATE", "Actuation", "field_actuation_from_table",
]

#: Control rates the environments play, Hz.
CONTROL_RATE = 1.0 / ACTION_PERIOD

#: The field components a policy controls: ``"xy"``, the paper's two coil pairs (the field in
#: the robot's vertical plane), or ``"xyz"`` with the third pair (z: across the robot, in the
#: floor plane).
ACTUATION_AXES = ("xy", "xyz")
#: Blocks the observation gains per actuation (name, size), after the paper's field blocks.
ACTUATION_OBSERVATION: dict[str, tuple[tuple[str, int], ...]] = {"xy": (), "xyz": (("field_z", 1),)}


@dataclass(frozen=True)
class Actuation:
    """The field the policy controls: limit (T: the amplitude limit, the largest axis limit),
    increment per action (T: the largest axis increment), rate (Hz), initial field of training
    episodes, the controlled ``axes`` (:data:`ACTUATION_AXES`) and, where the coil pairs differ,
    one limit and one increment per controlled axis (``axis_limits``, ``axis_increments``, T;
    empty: ``field_limit`` and ``max_increment`` on every axis)."""

    field_limit: float
    max_increment: float = 0.3e-3
    control_rate: float = CONTROL_RATE
    initial_field: str = "random"
    axes: str = "xy"
    axis_limits: tuple[float, ...] = ()
    axis_increments: tuple[float, ...] = ()

    @property
    def n_axes(self) -> int:
        """The action's size: one field increment per controlled axis."""
        return len(self.axes)

    @property
    def limits(self) -> tuple[float, float, float]:
        """The limit of each lab axis (x, y, z), T (as :class:`~elastica_magnetic.ControlledField`
        takes it); an axis not controlled keeps the amplitude limit (its component stays 0)."""
        given = self.axis_limits or (self.field_limit,) * self.n_axes
        return (*given, *(self.field_limit,) * (3 - len(given)))  # type: ignore[return-value]

    @property
    def increments(self) -> tuple[float, float, float]:
        """The largest increment of each lab axis (x, y, z) per unit action, T."""
        given = self.axis_increments or (self.max_increment,) * self.n_axes
        return (*given, *(self.max_increment,) * (3 - len(given)))  # type: ignore[return-value]

    @property
    def observation_blocks(self) -> tuple[tuple[str, int], ...]:
        """The observation's blocks for this actuation beyond the paper's (``field_z`` for xyz)."""
        return ACTUATION_OBSERVATION[self.axes]

    def to_dict(self) -> dict[str, Any]:
        """The ``[actuation]`` table: per-axis values as lists, ``axes`` only when not the
        paper's (so a planar case's table is as it always was)."""
        out: dict[str, Any] = {
            "field_limit": list(self.axis_limits) if self.axis_limits else self.field_limit,
            "max_increment": list(self.axis_increments) if self.axis_increments else self.max_increment,
            "control_rate": self.control_rate, "initial_field": self.initial_field}
        if self.axes != "xy":
            out["axes"] = self.axes
        return out


def field_actuation_from_table(t: SpecTable) -> Actuation:
    """The checked ``[actuation]`` table of a field-driven case (``kind = "field"``, the default):
    one limit and increment for every axis or a list of one per controlled axis, the rate the
    environments play, the training episodes' initial field."""
    d = Actuation(field_limit=0.0)
    axes = t.string("axes", d.axes, choices=ACTUATION_AXES)
    limits = _per_axis(t, "field_limit", "T", axes, None, high=1.0, plausible="coil field")
    increments = _per_axis(t, "max_increment", "T per action", axes, d.max_increment)
    out = Actuation(
        field_limit=max(limits),
        max_increment=max(increments),
        control_rate=t.number("control_rate", "Hz", d.control_rate, low=0.0, low_open=True),
        initial_field=t.string("initial_field", d.initial_field, choices=("random", "zero")),
        axes=axes,
        axis_limits=tuple(limits) if len(set(limits)) > 1 else (),
        axis_increments=tuple(increments) if len(set(increments)) > 1 else (),
    )
    if t.has("max_increment"):
        for limit, increment in zip(out.limits, out.increments, strict=True):
            _check_increment(t, increment, limit, d.max_increment)
    if not math.isclose(out.control_rate, CONTROL_RATE):
        raise t.error("control_rate", f"only {CONTROL_RATE:g} Hz is supported (the environments' "
                                      f"0.01 s step and the firmware's playback rate), got "
                                      f"{out.control_rate:g}")
    t.finish()
    return out


def _per_axis(t: SpecTable, key: str, unit: str, axes: str, default: float | None,
              **checks: Any) -> list[float]:
    """``key`` of ``[actuation]``: one number for every controlled axis, or a list of one per
    axis (``axes``' order); each checked as :meth:`SpecTable.number` checks one (positive, below
    ``high``, plausible)."""
    value = t.raw(key, default) if default is not None or t.has(key) else t.number(key, unit)
    if not isinstance(value, list):
        return [t.number(key, unit, default, low=0.0, low_open=True, **checks)] * len(axes)
    if len(value) != len(axes):
        raise t.error(key, f"expected one number ({unit}) or a list of {len(axes)}, one per axis of "
                           f"axes = {axes!r} ({', '.join(axes)}), got {value!r}")
    out = []
    for axis, item in zip(axes, value, strict=True):
        item_table = SpecTable({key: item}, t.source, t.path, t.accept)
        try:
            out.append(item_table.number(key, unit, low=0.0, low_open=True, **checks))
        except SpecError as exc:
            raise t.error(key, f"{axis} axis: {str(exc).split(f'{key}: ', 1)[-1]}") from None
    return out


def _check_increment(t: SpecTable, increment: float, field_limit: float, papers: float) -> None:
    """Refuse an increment (T per action) above the field limit (T): one action could then jump
    the field from zero past the limit, so it limits no rate (mT written for T, most likely);
    judge it against the plausible increments otherwise (a warning where unusual)."""
    if increment > field_limit:
        raise t.error("max_increment", f"{increment:g} T per action is larger than the field limit "
                      f"{field_limit:g} T: it cannot act as a limit (one action may jump the field "
                      f"from zero past the limit){mistake_hint('field increment', increment)}; the "
                      f"paper's is {papers:g} T")
    t.check_plausible("max_increment", increment, "field increment")
