"""Unit mistakes a second round of tries found silent (issue 48): gravity in g, an episode in ms,
a field's ramp and a magnet path's times in ms. Each is warned (a value that may be meant: a
robot in a buoyant liquid, a slow experiment), naming the key and the mistake; 0 gravity is a
choice and says nothing."""

from __future__ import annotations

from pathlib import Path

import pytest
from elastica_magnetic_rl.cases.case import case_from_dict, load_case

from elastica_magnetic.field_spec import describe_field
from elastica_magnetic.plausibility import ImplausibleValueWarning
from elastica_magnetic.specfile import read_spec

CATHETER = Path(__file__).resolve().parents[1] / "elastica_magnetic" / "data" / "examples" / "catheter.toml"


def _case(edit):
    spec = load_case("m1-4mT").to_dict()
    edit(spec)
    return case_from_dict(spec, "my.toml")


def test_gravity_in_g_is_warned_and_zero_gravity_is_not(recwarn):
    with pytest.warns(ImplausibleValueWarning, match=r"gravity = 1 m/s\^2 .*looks like g written"):
        _case(lambda s: s["robot"].update(gravity=1.0))
    recwarn.clear()
    _case(lambda s: s["robot"].update(gravity=0.0))
    assert not [w for w in recwarn if issubclass(w.category, ImplausibleValueWarning)]


def test_an_episode_in_ms_is_warned():
    with pytest.warns(ImplausibleValueWarning, match=r"episode_duration = 20000 s .*looks like ms"):
        _case(lambda s: s["task"].update(episode_duration=20000.0))


@pytest.mark.parametrize("key, value, match", [
    ("ramp", 300.0, r"ramp = 300 s .*looks like ms"),
    ("times", [0.0, 500.0, 3500.0, 4000.0], r"the last time = 4000 s .*looks like ms"),
])
def test_a_field_time_in_ms_is_warned(key, value, match):
    spec = read_spec(CATHETER)
    if key == "times":
        spec["field"]["path"]["times"] = value
    else:
        spec["field"][key] = value
    with pytest.warns(ImplausibleValueWarning, match=match):
        describe_field(spec, str(CATHETER))
