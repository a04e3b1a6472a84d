"""Varied robots: spec values changed by dotted keys, ranges and the designs that sample them.

A *variation* is a group of spec keys varied together over a range, written
``KEY[+KEY...]=LOW:HIGH``:

- keys are dotted paths into the spec, e.g. ``robot.magnetization.magnitude``,
  ``robot.ground.kinetic_mu``, ``robot.magnetization.segments.2.magnitude`` (a list's items by
  their index from 0), ``robot.magnetization.values`` (a per-element table, scaled as a whole:
  only by a factor) (only the real-valued keys of the ``[robot]`` tables: see
  :func:`variable_keys`); keys joined by ``+`` are varied together, by the same factor;
- ``LOW:HIGH`` is relative (factors of the spec's nominal value, both > 0), ``abs:LOW:HIGH`` is
  absolute (in the key's SI unit; one key only);
- a group name stands for its keys *in the spec at hand* (:func:`group_keys`), so it means the
  same on every spec: ``magnetization`` (the magnitude of a named pattern, every segment's
  magnitude, or a per-element table), ``modulus`` (Young's and shear modulus together, or Young's
  modulus alone where the spec gives a Poisson ratio, which is then kept, so the shear modulus
  follows), ``friction`` (static and kinetic friction), ``density``. A spec's own key that its
  complete form stores elsewhere is accepted as written: ``robot.magnetization.magnitude`` of a
  ``segments`` magnetization (the default magnitude of its segments) stands for every segment's.

The default set (:data:`DEFAULT_RANGES`, what a silicone-NdFeB robot on a lab surface varies by):
magnetization magnitude +-15 %, Young's and shear modulus +-20 % together, static and kinetic
friction +-25 % together, density +-10 %; and for a catheter steered by a magnet on an arm, the
magnet's moment +-10 % (:data:`SOURCE_RANGES`).

A *variant* sets every variation to one value (a factor, or an absolute value); :func:`design`
lists the nominal robot, the one-at-a-time variants (each variation at its low and high end, the
others nominal), all corners (every combination of ends) and Latin-hypercube samples (seeded).
:func:`apply_variant` writes a variant into a copy of a spec; the caller passes that copy through
the normal spec parser, so an invalid variant gets the parser's named error.
"""

from __future__ import annotations

import copy
import difflib
import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from elastica_magnetic.field_csv import is_number

__all__ = [
    "DEFAULT_RANGES",
    "SOURCE_RANGES",
    "GROUPS",
    "Variant",
    "Variation",
    "VariationError",
    "apply_variant",
    "apply_values",
    "default_variations",
    "design",
    "get_value",
    "group_keys",
    "parse_group",
    "parse_variation",
    "physical_differences",
    "resolve_variations",
    "scaled",
    "magnitude_of",
    "variable_keys",
    "variant_values",
]

#: Named groups of keys varied together (a name may stand for its keys on the command line).
GROUPS: dict[str, tuple[str, ...]] = {
    "magnetization": ("robot.magnetization.magnitude",),
    "modulus": ("robot.youngs_modulus", "robot.shear_modulus"),
    "friction": ("robot.ground.static_mu", "robot.ground.kinetic_mu"),
    "density": ("robot.density",),
    "magnet": ("actuation.moment",),
    "coils": ("actuation.coils.K.turns",),  # every coil's, K = 0, 1, ... (group_keys)
}
#: The name of a unit vector in a spec (a magnetization's, a clamp's): never varied, a factor leaves it.
DIRECTION_KEY = "direction"
#: The default variation set: group -> (low, high) factors of the nominal values.
DEFAULT_RANGES: dict[str, tuple[float, float]] = {
    "magnetization": (0.85, 1.15),
    "modulus": (0.8, 1.2),
    "friction": (0.75, 1.25),
    "density": (0.9, 1.1),
}
#: The default set's variations of a steering source, for the cases that have one: a magnet arm's
#: moment +-10 % (an NdFeB grade's remanence spread and the magnet's size tolerance); fixed coils'
#: gains (field per ampere: their ``turns``) +-5 % together (a winding's count and a current
#: sensor's scale).
SOURCE_RANGES: dict[str, tuple[float, float]] = {
    "magnet": (0.9, 1.1),
    "coils": (0.95, 1.05),
}
#: Most variations whose corners are listed (2 ** 8 = 256 variants).
MAX_CORNER_VARIATIONS = 8


class VariationError(ValueError):
    """A variation that cannot be applied: the message names the option text, the key and the
    expected syntax or range."""


@dataclass(frozen=True)
class Variation:
    """Keys varied together over ``[low, high]``: factors of the nominal values (relative) or
    values in the keys' SI unit (``absolute``, one key). ``name``: a group name or the keys
    joined by ``+``."""

    name: str
    keys: tuple[str, ...]
    low: float
    high: float
    absolute: bool = False

    @property
    def nominal_setting(self) -> float | None:
        """The setting of the nominal robot: factor 1 (relative); ``None`` (absolute: the spec's
        value, see :meth:`nominal_value`)."""
        return None if self.absolute else 1.0

    def nominal_value(self, spec: Mapping[str, Any]) -> float:
        """The nominal setting in ``spec``: 1 (relative) or the key's value (absolute)."""
        return get_value(spec, self.keys[0]) if self.absolute else 1.0

    def label(self, setting: float) -> str:
        """``"magnetization x0.85"`` or ``"robot.ground.kinetic_mu = 0.4"``."""
        return f"{self.name} = {setting:.6g}" if self.absolute else f"{self.name} x{setting:.6g}"

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "keys": list(self.keys), "low": self.low, "high": self.high,
                "absolute": self.absolute}


@dataclass(frozen=True)
class Variant:
    """One varied robot: ``settings`` maps each variation's name to its factor (relative) or value
    (absolute); ``kind`` is ``"nominal"``, ``"one-at-a-time"``, ``"corner"`` or ``"sample"``."""

    label: str
    kind: str
    settings: dict[str, float] = field(default_factory=dict)


# -- keys of a spec -------------------------------------------------------------------------------


def _is_array(value: Any) -> bool:
    """A (nested) list of numbers with at least one float: a table varied as a whole."""
    if not isinstance(value, list) or not value:
        return False
    leaves = np.asarray(value, dtype=object).ravel()
    return (all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in leaves)
            and any(isinstance(v, float) for v in leaves))


def variable_keys(spec: Mapping[str, Any]) -> list[str]:
    """The dotted keys that can be varied in ``spec`` (a complete spec, every default written out,
    e.g. ``Case.to_dict()``): every real-valued (float) value under ``robot``, the items of its
    lists of tables by index (``robot.magnetization.segments.0.magnitude``) and its tables of
    numbers as a whole (``robot.magnetization.values``), a magnet arm's ``actuation.moment`` and
    fixed coils' ``actuation.coils.K.turns`` (each coil's gain), sorted."""
    found: list[str] = []

    def walk(table: Any, path: str) -> None:
        if isinstance(table, Mapping):
            for key, value in table.items():
                if key != DIRECTION_KEY:  # a unit vector: normalized when read, a factor leaves it
                    walk(value, f"{path}.{key}")
        elif _is_array(table):
            found.append(path)
        elif isinstance(table, list):
            for index, value in enumerate(table):
                if isinstance(value, Mapping):
                    walk(value, f"{path}.{index}")
        elif isinstance(table, float):
            found.append(path)

    walk(spec.get("robot", {}), "robot")
    actuation = spec.get("actuation", {})
    if isinstance(actuation, Mapping) and isinstance(actuation.get("moment"), float):
        found.append("actuation.moment")  # a magnet arm's magnet: its strength
    if isinstance(actuation, Mapping) and actuation.get("kind") == "coil-currents":
        found += [f"actuation.coils.{k}.turns" for k, coil in enumerate(actuation.get("coils", ()))
                  if isinstance(coil, Mapping) and isinstance(coil.get("turns"), int | float)]  # gains
    return sorted(found)


def _child(table: Any, part: str, key: str) -> Any:
    if isinstance(table, Mapping) and part in table:
        return table[part]
    if isinstance(table, list) and part.isdigit() and int(part) < len(table):
        return table[int(part)]
    raise KeyError(key)


def get_value(spec: Mapping[str, Any], key: str) -> Any:
    """The value at a dotted key: a float, or a (nested) list of numbers for a table (KeyError if
    absent)."""
    table: Any = spec
    for part in key.split("."):
        table = _child(table, part, key)
    return table


def scaled(value: Any, factor: float) -> Any:
    """``value`` (a number, or a nested list of numbers) times ``factor``, in the same form."""
    if isinstance(value, list):
        return np.multiply(np.asarray(value, dtype=np.float64), factor).tolist()
    return float(value) * factor


def magnitude_of(value: Any) -> float:
    """One number for a value in reports: the value itself, or for a table of vectors (3, n) the
    largest vector length (for a per-element magnetization: the strongest element's magnitude)."""
    if isinstance(value, list):
        array = np.asarray(value, dtype=np.float64)
        return float(np.linalg.norm(array, axis=0).max()) if array.ndim == 2 else \
            float(np.abs(array).max())
    return float(value)


def apply_values(spec: Mapping[str, Any], values: Mapping[str, Any]) -> dict[str, Any]:
    """A deep copy of ``spec`` with ``values`` (dotted key -> value: a number, or a nested list
    for a table key) written in; the keys must exist (see :func:`variable_keys`). The copy is not
    checked: parse it (``case_from_dict``, ``describe_robot``) to get the spec parser's errors."""
    out = copy.deepcopy(dict(spec))
    for key, value in values.items():
        *tables, last = key.split(".")
        table: Any = out
        for part in tables:
            table = _child(table, part, key)
        _child(table, last, key)  # must exist
        item = int(last) if isinstance(table, list) else last
        table[item] = (np.asarray(value, dtype=np.float64).tolist() if isinstance(value, list)
                       else float(value))
    return out


#: Top-level tables of a spec that say nothing about the robot or its task (a robot varied in its
#: physical values may differ there freely; ``checks`` only silences plausibility warnings).
NON_ROBOT_TABLES = ("name", "description", "yardstick", "training", "checks")


def _flatten(table: Any, path: str = "") -> dict[str, Any]:
    """Dotted key -> value, lists of tables by index (as :func:`variable_keys` names them)."""
    if isinstance(table, Mapping):
        out: dict[str, Any] = {}
        for key, value in table.items():
            out.update(_flatten(value, f"{path}.{key}" if path else str(key)))
        return out
    if isinstance(table, list) and table and all(isinstance(v, Mapping) for v in table):
        out = {f"{path}.length": len(table)}  # a different count of items is another robot
        for index, value in enumerate(table):
            out.update(_flatten(value, f"{path}.{index}"))
        return out
    return {path: table}


def physical_differences(base: Mapping[str, Any], other: Mapping[str, Any]) -> dict[str, tuple[Any, Any]]:
    """Dotted key -> ``(base value, other value)`` of every physical value (a variable key, see
    :func:`variable_keys`; a table's values as nested lists) in which two complete specs differ.
    Raises :class:`VariationError` naming the first other difference (elements, magnetization
    pattern, task, actuation, physics settings: what makes ``other`` another robot or task, not
    the same robot with other values); ``name``, ``description``, ``yardstick`` and ``training``
    may differ."""
    variable = set(variable_keys(base))
    a, b = _flatten(base), _flatten(other)
    physical: dict[str, tuple[float, float]] = {}
    for key in sorted(set(a) | set(b)):
        if a.get(key) == b.get(key) or key.split(".")[0] in NON_ROBOT_TABLES:
            continue
        if key in variable and isinstance(b.get(key), float):
            physical[key] = (float(a[key]), float(b[key]))
            continue
        if key in variable and _is_array(b.get(key)) and \
                np.shape(a[key]) == np.shape(b[key]):
            physical[key] = (a[key], b[key])
            continue
        raise VariationError(f"{key}: {a.get(key, '(absent)')!r} in the run's spec, "
                             f"{b.get(key, '(absent)')!r} in the new one: only physical values "
                             f"({', '.join(sorted(variable))}) may differ")
    return physical


def _unknown_key(key: str, valid: Sequence[str], where: str) -> VariationError:
    close = difflib.get_close_matches(key, valid, n=2, cutoff=0.8)
    hint = f"; did you mean {' or '.join(close)}?" if close else ""
    groups = ", ".join(f"{name} = {'+'.join(keys)}" for name, keys in GROUPS.items())
    return VariationError(
        f"{where}: unknown key {key!r}{hint} (variable keys of this spec: {', '.join(valid)}; "
        f"groups: {groups})"
    )


# -- parsing --------------------------------------------------------------------------------------


def parse_group(text: str, where: str | None = None) -> tuple[str, tuple[str, ...]]:
    """``KEY[+KEY...]`` or a group name -> ``(name, keys)``; keys are checked against a spec by
    :func:`resolve_variations`."""
    where = where or repr(text)
    text = text.strip()
    if text in GROUPS:
        return text, GROUPS[text]
    keys = tuple(k.strip() for k in text.split("+"))
    if not text or any(not k for k in keys):
        raise VariationError(f"{where}: expected KEY[+KEY...] (dotted spec keys such as "
                             f"robot.magnetization.magnitude) or a group ({', '.join(GROUPS)})")
    expanded: list[str] = []
    for key in keys:
        expanded.extend(GROUPS.get(key, (key,)))
    if len(set(expanded)) != len(expanded):
        raise VariationError(f"{where}: a key appears twice in the group")
    return text, tuple(expanded)


def _factors_meant(parts: list[str]) -> str | None:
    """The factors a range written otherwise means, as advice (``"0.9:1.1 for -10% to +10%"``): percents
    of the nominal value (``90%:110%``), signed changes (``-10%:10%``, ``+-10%``, one ``10%``: either
    way) or factors marked ``x`` (``x0.9:x1.1``); ``None`` for any other range."""
    texts = [p.strip().replace("±", "+-") for p in parts]
    if len(texts) == 1 and texts[0].endswith("%"):  # one percent: a change either way
        change = texts[0].removeprefix("+-")
        if is_number(change[:-1]):
            p = abs(float(change[:-1])) / 100
            return f"{1 - p:g}:{1 + p:g} for {texts[0]} either way"
    if len(texts) != 2:
        return None
    if all(t.lower().startswith("x") and is_number(t[1:]) for t in texts):
        return f"{texts[0][1:]}:{texts[1][1:]} (without the x)"
    if not all(t.endswith("%") and is_number(t[:-1]) for t in texts):
        return None
    percents = [float(t[:-1]) for t in texts]
    changes = any(t.startswith(("+", "-")) for t in texts)  # -10%:+10%: changes of the value
    low, high = ((1 + p / 100 for p in percents) if changes else (p / 100 for p in percents))
    return f"{low:g}:{high:g} for {texts[0]} to {texts[1]}"


def _number(text: str, what: str, where: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise VariationError(f"{where}: {what} {text!r} is not a number") from None
    if not math.isfinite(value):
        raise VariationError(f"{where}: {what} must be finite, got {text!r}")
    return value



def parse_variation(text: str) -> Variation:
    """Parse ``KEY[+KEY...]=LOW:HIGH`` (relative factors) or ``KEY=abs:LOW:HIGH`` (absolute, SI)
    (see the module docstring). Raises :class:`VariationError` naming the problem: no ``=``, a
    range that is not two numbers, ``LOW > HIGH``, a factor that is not > 0, an absolute range on
    several keys."""
    where = f"--vary {text!r}"
    if "=" not in text:
        raise VariationError(f"{where}: expected KEY=LOW:HIGH (factors of the nominal value, e.g. "
                             "robot.magnetization.magnitude=0.85:1.15) or KEY=abs:LOW:HIGH (SI)")
    group, _, spec_range = text.partition("=")
    name, keys = parse_group(group, where)
    absolute = spec_range.strip().startswith("abs:")
    parts = spec_range.strip()[4 if absolute else 0:].split(":")
    if not absolute and (factors := _factors_meant(parts)):
        raise VariationError(f"{where}: LOW:HIGH are factors of the nominal value (1 = nominal): "
                             f"{factors}")
    if len(parts) != 2:
        raise VariationError(f"{where}: the range must be LOW:HIGH or abs:LOW:HIGH, got "
                             f"{spec_range!r}")
    low = _number(parts[0], "LOW", where)
    high = _number(parts[1], "HIGH", where)
    if low > high:
        raise VariationError(f"{where}: LOW {low:g} is greater than HIGH {high:g}")
    if absolute and len(keys) > 1:
        raise VariationError(f"{where}: an absolute range (abs:) sets one key; the keys of a group "
                             f"({'+'.join(keys)}) are varied together by a factor (LOW:HIGH)")
    if not absolute and low <= 0.0:
        raise VariationError(f"{where}: relative factors must be > 0 (1 = the nominal value), got "
                             f"LOW {low:g}; for absolute values write abs:LOW:HIGH")
    if not absolute and low >= PERCENT_LIKE_FACTOR:
        percent = (f"{spec_range.strip()} looks like percent: {low / 100:g}:{high / 100:g} (for absolute "
                   "values write abs:LOW:HIGH)" if low / 100 <= 1.0 <= high / 100 else
                   f"no fabrication error makes a value x{low:g}: for absolute values (SI) write "
                   f"abs:{low:g}:{high:g}")
        raise VariationError(f"{where}: factors of the nominal value (1 = nominal) from x{low:g} to "
                             f"x{high:g}; {percent}")
    if not absolute and high <= 1.0 / PERCENT_LIKE_FACTOR:
        raise VariationError(f"{where}: factors of the nominal value (1 = nominal) from x{low:g} to "
                             f"x{high:g}: no fabrication error cuts a value tenfold; for absolute values "
                             f"(SI) write abs:{low:g}:{high:g}")
    return Variation(name, keys, low, high, absolute)


#: The smallest relative factor taken for a percentage (no fabrication error makes a value x10).
PERCENT_LIKE_FACTOR = 10.0


_MAGNETIZATION = "robot.magnetization"


def group_keys(name: str, spec: Mapping[str, Any]) -> tuple[str, ...]:
    """The keys the group ``name`` (:data:`GROUPS`) stands for in ``spec`` (complete): the
    magnetization wherever the spec keeps it (a pattern's ``magnitude``, every segment's
    ``magnitude``, a per-element ``values`` table); the group's other keys that the spec has (a
    spec with ``poisson_ratio`` has no ``shear_modulus``: it follows Young's modulus, the Poisson
    ratio kept). Empty when the spec has none of them."""
    valid = variable_keys(spec)
    if name == "magnetization":
        return tuple(k for k in valid if k.startswith(f"{_MAGNETIZATION}.")
                     and (k.endswith(".magnitude") or k == f"{_MAGNETIZATION}.values"))
    if name == "coils":  # in the coils' order
        return tuple(sorted((k for k in valid if k.startswith("actuation.coils.")),
                            key=lambda k: int(k.split(".")[2])))
    return tuple(k for k in GROUPS[name] if k in valid)


def _expand_key(key: str, spec: Mapping[str, Any], valid: Sequence[str], where: str) -> tuple[str, ...]:
    """A key as the user's spec writes it, in the keys of the complete spec: the default
    ``magnitude`` of a ``segments`` magnetization stands for every segment's; a key the spec
    computes (the shear modulus of a spec with a Poisson ratio) is named as such."""
    if key in valid:
        return (key,)
    if key.rsplit(".", 1)[-1] == DIRECTION_KEY and _has_key(spec, key):
        raise VariationError(f"{where}: {key} is a direction, made a unit vector when the spec is read, "
                             "so scaling it leaves every variant the nominal robot; a direction is not "
                             "varied (a magnetization's strength is its magnitude: vary that)")
    robot = spec.get("robot", {})
    if key == f"{_MAGNETIZATION}.magnitude" and robot.get("magnetization", {}).get("kind") == "segments":
        return group_keys("magnetization", spec)
    if key == "robot.shear_modulus" and "poisson_ratio" in robot:
        raise VariationError(f"{where}: this spec gives poisson_ratio, so its shear modulus is "
                             "E / (2 (1 + poisson_ratio)) and follows robot.youngs_modulus; vary "
                             "robot.youngs_modulus (or the group modulus), or robot.poisson_ratio")
    raise _unknown_key(key, valid, where)


def _has_key(spec: Mapping[str, Any], key: str) -> bool:
    """Whether the dotted ``key`` names a value of ``spec``."""
    try:
        get_value(spec, key)
    except (KeyError, IndexError, TypeError, ValueError, VariationError):
        return False
    return True


def resolve_variations(variations: Sequence[Variation], spec: Mapping[str, Any],
                       option: str = "--vary",
                       unmodelled: Mapping[str, str] | None = None) -> list[Variation]:
    """Check ``variations`` against a complete spec and return them with the keys they stand
    for in it: a group's keys in this spec (:func:`group_keys`), a key the user's spec writes
    in the keys of its complete form; every key variable, no key varied twice, a relative
    variation's nominal value not 0, a table varied only by a factor. ``unmodelled``: keys (and
    the keys under them) the study's simulator leaves out -> why, neither offered nor accepted.
    Errors name ``option``."""
    unmodelled = dict(unmodelled or {})

    def left_out(key: str) -> str | None:
        return next((why for prefix, why in unmodelled.items()
                     if key == prefix or key.startswith(f"{prefix}.")), None)

    valid = [key for key in variable_keys(spec) if left_out(key) is None]
    seen: dict[str, str] = {}
    resolved = []
    for variation in variations:
        where = f"{option} {variation.name}"
        if variation.name in GROUPS:
            keys = group_keys(variation.name, spec)
            if not keys:
                raise VariationError(f"{where}: this spec has none of the group's keys "
                                     f"({', '.join(GROUPS[variation.name])})")
        else:
            for key in variation.keys:
                if (why := left_out(key)) is not None:
                    raise VariationError(f"{where}: {key}: {why}; leave it out of {option}")
            keys = tuple(k for key in variation.keys for k in _expand_key(key, spec, valid, where))
        for key in keys:
            if key in seen:  # one key, one variation: which of two would it take?
                if seen[key] == variation.name:
                    raise VariationError(f"{where}: {key} is named twice; name it once")
                raise VariationError(f"{where}: {key} is already taken by {option} {seen[key]}; name it "
                                     "in one of them")
            seen[key] = variation.name
            value = get_value(spec, key)
            if isinstance(value, list) and variation.absolute:
                raise VariationError(f"{where}: {key} is a table; it is varied by a factor "
                                     "(LOW:HIGH), not set to an absolute value")
            _refuse_absolute_as_factors(variation, key, value, where)
            if not variation.absolute and not np.any(np.asarray(value, dtype=np.float64)):
                fix = ("a fit scales the spec's value by a factor: give the key a non-zero value "
                       "in the spec to fit it" if option == "--fit"
                       else "give an absolute range (abs:LOW:HIGH)")
                raise VariationError(f"{where}: {key} is 0 in this spec, so a factor leaves it 0; {fix}")
        if option in ("--vary", "--fit"):  # a spec's randomize refuses any equal ends itself
            _check_varies(variation, keys, spec, where, option)
        resolved.append(Variation(variation.name, keys, variation.low, variation.high,
                                  variation.absolute))
    return resolved


def _refuse_absolute_as_factors(variation: Variation, key: str, value: Any, where: str) -> None:
    """Refuse factors that leave out the nominal value (x1) while, read as values, they bracket the
    key's: ``robot.length=0.018:0.022`` around a 0.02 m robot is metres, not x0.018 to x0.022."""
    if variation.absolute or variation.low <= 1.0 <= variation.high:
        return
    values = np.asarray(value, dtype=np.float64).ravel()
    if values.size and np.all((variation.low <= values) & (values <= variation.high)):
        nominal = f"{values[0]:g}" if np.all(values == values[0]) else f"{values.min():g} to {values.max():g}"
        raise VariationError(
            f"{where}: factors of the nominal value (1 = nominal) from x{variation.low:g} to "
            f"x{variation.high:g}, which leave the nominal out, while {key} is {nominal} (SI), inside "
            f"{variation.low:g}:{variation.high:g}: for absolute values write {key}=abs:{variation.low:g}:"
            f"{variation.high:g}")


def _check_varies(variation: Variation, keys: Sequence[str], spec: Mapping[str, Any], where: str,
                  option: str) -> None:
    """Refuse a range that leaves every key at its nominal value: factors 1:1, or an absolute
    range whose two ends are the spec's value (a study of the nominal robot alone, or a fit with
    nothing to fit, said as if something varied)."""
    if variation.low != variation.high:
        return
    nominal = (variation.low == 1.0 if not variation.absolute
               else all(np.allclose(np.asarray(get_value(spec, key), dtype=np.float64), variation.low,
                                    rtol=0.0, atol=0.0) for key in keys))
    if nominal:
        shown = f"{'abs:' if variation.absolute else ''}{variation.low:g}:{variation.high:g}"
        what = "fits nothing" if option == "--fit" else "varies nothing"
        raise VariationError(f"{where}={shown} {what} (both ends are the nominal value): give a range "
                             "around it, e.g. 0.9:1.1")


def default_variations(spec: Mapping[str, Any]) -> list[Variation]:
    """The default set (:data:`DEFAULT_RANGES`, and :data:`SOURCE_RANGES` for a case steered by a
    source) for ``spec``, each group with its keys in this spec (:func:`group_keys`); a group
    without keys is dropped."""
    out = []
    for name, (low, high) in {**DEFAULT_RANGES, **SOURCE_RANGES}.items():
        keys = group_keys(name, spec)
        if keys:
            out.append(Variation(name, keys, low, high))
    return out


# -- designs --------------------------------------------------------------------------------------


def design(
    variations: Sequence[Variation],
    spec: Mapping[str, Any],
    *,
    one_at_a_time: bool = True,
    corners: bool = True,
    samples: int = 0,
    seed: int = 0,
) -> list[Variant]:
    """The variants to run: the nominal robot first, then each variation at its low and high end
    alone (``one_at_a_time``), every combination of ends (``corners``; at most
    :data:`MAX_CORNER_VARIATIONS` variations), and ``samples`` Latin-hypercube draws (each
    variation's range cut into ``samples`` equal strata, one draw in each, strata paired at
    random; uniform in the factor or value; ``seed`` fixes them). A variant equal to an earlier one
    (e.g. the corners of a single variation) is listed once."""
    if samples < 0:
        raise VariationError(f"--samples must be >= 0, got {samples}")
    if corners and len(variations) > MAX_CORNER_VARIATIONS:
        raise VariationError(f"{len(variations)} variations have {2 ** len(variations)} corners; "
                             f"at most {MAX_CORNER_VARIATIONS} variations take corners (leave "
                             "the corners out, or vary fewer groups)")
    nominal = {v.name: v.nominal_value(spec) for v in variations}
    variants = [Variant("nominal", "nominal", dict(nominal))]
    if one_at_a_time:
        for v in variations:
            for end in (v.low, v.high):
                variants.append(Variant(v.label(end), "one-at-a-time", {**nominal, v.name: end}))
    if corners and variations:
        for ends in itertools.product(*[(v.low, v.high) for v in variations]):
            settings = {v.name: end for v, end in zip(variations, ends, strict=True)}
            label = "corner: " + ", ".join(v.label(e) for v, e in zip(variations, ends, strict=True))
            variants.append(Variant(label, "corner", settings))
    if samples and variations:
        rng = np.random.default_rng(seed)
        strata = np.stack([(rng.permutation(samples) + rng.random(samples)) / samples
                           for _ in variations], axis=1)  # (samples, n_variations) in [0, 1)
        for k, row in enumerate(strata):
            settings = {v.name: float(v.low + u * (v.high - v.low))
                        for v, u in zip(variations, row, strict=True)}
            label = f"sample {k + 1}: " + ", ".join(v.label(settings[v.name]) for v in variations)
            variants.append(Variant(label, "sample", settings))
    unique: list[Variant] = []
    seen: set[tuple[float, ...]] = set()
    for variant in variants:
        signature = tuple(round(variant.settings[v.name], 12) for v in variations)
        if signature not in seen:
            seen.add(signature)
            unique.append(variant)
    return unique


def variant_values(variations: Sequence[Variation], variant: Variant,
                   spec: Mapping[str, Any]) -> dict[str, Any]:
    """Dotted key -> value of ``variant`` on ``spec`` (nominal value x factor, or the value; a
    table key's value is the scaled table)."""
    values = {}
    for v in variations:
        setting = variant.settings[v.name]
        for key in v.keys:
            values[key] = setting if v.absolute else scaled(get_value(spec, key), setting)
    return values


def apply_variant(spec: Mapping[str, Any], variations: Sequence[Variation],
                  variant: Variant) -> dict[str, Any]:
    """A copy of ``spec`` with ``variant`` written in (not yet checked by the spec parser)."""
    return apply_values(spec, variant_values(variations, variant, spec))
