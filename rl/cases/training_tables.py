"""The ``[training]`` table of a spec: the recipe, the steps per seed, TD3 settings on top of the
recipe (``[training.td3]``) and the robot's values randomized in training episodes
(``[training.randomize]``), read and checked (:func:`training_from_table`)."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from elastica_magnetic.specfile import (
    RobotDescription,
    SpecError,
    SpecTable,
    describe_robot,
    robot_tables_spec,
)

from .recipes import DEFAULT_RECIPE, RECIPES
from .variations import (
    Variation,
    VariationError,
    apply_variant,
    default_variations,
    design,
    parse_variation,
    resolve_variations,
)

__all__ = ["MAX_TRAIN_STEPS", "Training", "randomize_table", "training_from_table"]


@dataclass(frozen=True)
class Training:
    """The training recipe: its name, the steps per seed, TD3 settings on top of it, and the
    robot's values randomized in training episodes (``randomize``: variations of the spec's
    ``[robot]`` values, drawn per episode and per crawler; empty: the nominal robot only)."""

    recipe: str = DEFAULT_RECIPE
    steps: int = 100_000
    td3: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    randomize: tuple[Variation, ...] = ()



#: The most environment steps per seed a training takes (``[training] steps``, ``--steps``; the
#: recipes' are 2e4 to 2e5): beyond, months of training, a count written with extra digits.
MAX_TRAIN_STEPS = 100_000_000


def training_from_table(t: SpecTable | None, source: str, robot: RobotDescription) -> Training:
    """``[training]`` of the spec ``source``: the recipe, the steps per seed, ``[training.td3]``
    settings (each checked as ``msr train --set`` checks it) and ``[training.randomize]`` ranges
    (checked against ``robot``'s values, each end as a spec's own value)."""
    if t is None:
        return Training()
    d = Training()
    recipe = t.string("recipe", d.recipe, choices=tuple(RECIPES))
    steps = t.number("steps", "environment steps per seed", d.steps, low=1, high=MAX_TRAIN_STEPS,
                     integer=True)
    randomize = _randomize(t, robot)
    td3 = t.table("td3", required=False)
    overrides: dict[str, Any] = {}
    if td3 is not None:
        from ..td3.config import TD3Config

        fields = {f.name: f for f in dataclasses.fields(TD3Config)}
        for key in td3.data:
            if key not in fields or key == "seed":
                raise td3.error(key, "not a TD3 setting (see TD3Config; the seed is set per run)")
            default = getattr(TD3Config(), key)
            value = td3.raw(key)
            if isinstance(default, bool) or isinstance(value, bool):
                ok = isinstance(value, bool) and isinstance(default, bool)
            elif isinstance(default, (int, float)):
                ok = isinstance(value, (int, float)) and (isinstance(value, int) or
                                                          isinstance(default, float))
            elif isinstance(default, tuple) or (default is None and isinstance(value, list | tuple)):
                # a list of layer sizes (a TOML array; a tuple when the spec comes from a Case);
                # None-defaulted sizes (actor_hidden_sizes: "as hidden_sizes") take one too
                ok = isinstance(value, list | tuple) and all(
                    isinstance(v, int) and not isinstance(v, bool) for v in value)
                value = tuple(value)
            else:
                ok = isinstance(value, type(default))
            if not ok and isinstance(td3.raw(key), str) and key in TD3Config.settable():
                try:  # the spelling of msr train --set: "256,256", "1e6", "true"
                    value, ok = TD3Config.parse_setting(key, td3.raw(key)), True
                except ValueError as exc:
                    raise td3.error(key, str(exc)) from None
            if not ok:
                shown = list(default) if isinstance(default, tuple) else default
                raw = td3.raw(key)
                integer = isinstance(default, int) and not isinstance(default, bool)
                hint = (f": an integer; TOML reads {raw!r} as a decimal number, write {int(raw)} (no "
                        "exponent, no decimal point)" if integer and isinstance(raw, float)
                        and raw.is_integer() else "")
                raise td3.error(key, f"expected a value like {shown!r}, got {raw!r}{hint}")
            overrides[key] = value
        try:  # each value in range, checked now, naming the key
            config = TD3Config(**overrides)
        except ValueError as exc:
            named = [k for k in overrides if str(exc).startswith(k)] or list(overrides)
            raise td3.error(named[0], str(exc)) from None
        if config.yardstick_regularization and config.buffer_size < steps:
            key = "buffer_size" if "buffer_size" in overrides else "yardstick_regularization"
            raise td3.error(key, f"yardstick_regularization {config.yardstick_regularization:g} holds the "
                            "actor near the warm-up's transitions for the whole run, and buffer_size "
                            f"{config.buffer_size} holds fewer than the [training] steps = {steps}: the ring "
                            f"would overwrite them; give buffer_size of at least {steps}")
        td3.finish()
    t.finish()
    return Training(recipe, steps, overrides, randomize)


def _randomize(t: SpecTable, robot: RobotDescription) -> tuple[Variation, ...]:
    """``[training.randomize]``: ``KEY = "LOW:HIGH"`` (factors of the nominal value) or
    ``"abs:LOW:HIGH"`` (SI), KEY a dotted ``[robot]`` key, keys joined by ``+`` or a group name
    (:data:`~elastica_magnetic_rl.cases.variations.GROUPS`), as ``msr real robustness --vary``; or
    ``randomize = "default"`` for the default set (magnetization +-15 %, modulus +-20 %, friction
    +-25 %, density +-10 %)."""
    t.takes("randomize")
    if not t.has("randomize"):
        return ()
    value = t.raw("randomize")
    where = t.where("randomize")
    if isinstance(value, str):
        if value != "default":
            raise t.error("randomize", f"expected \"default\" or a table of KEY = \"LOW:HIGH\" "
                                       f"ranges, got {value!r}")
        return tuple(default_variations(robot.tables))
    if not isinstance(value, Mapping):
        raise t.error("randomize", "expected a table of KEY = \"LOW:HIGH\" ranges (or \"default\")")
    variations = []
    try:
        for key, text in _dotted(value).items():
            if not isinstance(text, str):
                raise VariationError(f"{where}: {key} = {text!r}: expected a string \"LOW:HIGH\" "
                                     "(factors) or \"abs:LOW:HIGH\" (SI)")
            variations.append(parse_variation(f"{key}={text}"))
        variations = resolve_variations(variations, robot.tables, option=where)
    except VariationError as err:
        raise SpecError(str(err).replace("--vary ", f"{where}: ", 1)) from None
    for v in variations:
        if v.low == v.high:  # a range of one value: nothing is randomized
            raise SpecError(f"{where}: {v.name} = \"{randomize_table((v,))[v.name]}\" varies "
                            "nothing (its ends are equal): give a range, or leave the key out")
    _check_randomize_ends(variations, robot, where)
    return tuple(variations)


def _dotted(table: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """A ``[training.randomize]`` table with its keys as written: TOML reads an unquoted dotted key
    (``robot.ground.kinetic_mu = "0.8:1.2"``) as nested tables, which are joined back here."""
    out: dict[str, Any] = {}
    for key, value in table.items():
        if isinstance(value, Mapping) and value:
            out.update(_dotted(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


def _check_randomize_ends(variations: list[Variation], robot: RobotDescription, where: str) -> None:
    """Each range's ends, one at a time, checked as a spec's own values are (units, physical
    ranges): a range in kPa for Pa or percent for factors is refused here, naming the range,
    not by the first training episode that draws a value from it."""
    import warnings

    from elastica_magnetic.plausibility import ImplausibleValueWarning

    label = "<range end>"

    def unusual(tables: Mapping[str, Any]) -> dict[str, str]:
        """The plausibility warnings of a robot (by message without the label), not shown."""
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ImplausibleValueWarning)
            describe_robot(robot_tables_spec(tables), label)
        return {str(w.message).replace(f"{label}: ", "", 1): getattr(w.message, "key", "")
                for w in caught if issubclass(w.category, ImplausibleValueWarning)}

    nominal = unusual(robot.tables)  # the spec's own unusual values warn once, elsewhere
    for variant in design(variations, robot.tables, one_at_a_time=True, corners=False)[1:]:
        try:
            found = unusual(apply_variant(robot.tables, variations, variant))
        except SpecError as err:
            message = str(err).replace(f"{label}: ", "", 1)
            raise SpecError(f"{where}: the range's end {variant.label} gives a robot the spec "
                            f"refuses: {message}") from None
        for message, key in found.items():  # unusual only at this end: a unit mistake in the range?
            if message not in nominal:
                warnings.warn(ImplausibleValueWarning(
                    f"{where}: the range's end {variant.label} gives an unusual robot: {message}",
                    key), stacklevel=2)


def randomize_table(variations: tuple[Variation, ...]) -> dict[str, str]:
    """``[training.randomize]`` as plain data: variation name -> ``"LOW:HIGH"`` / ``"abs:LOW:HIGH"``."""
    return {v.name: f"{'abs:' if v.absolute else ''}{v.low!r}:{v.high!r}" for v in variations}
