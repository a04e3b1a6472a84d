"""Round 19 of held-out tries (issue 48), the findings read where a spec or a setting is read: each
test fails without its fix (docs/errors.md, "A nineteenth round of tries")."""

from __future__ import annotations

import copy
import tomllib
import warnings

import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import SPECS_DIR, load_case
from elastica_magnetic_rl.td3.config import TD3Config
from spec_texts import CATHETER_MAGNET_REACH

from elastica_magnetic import CylinderMagnetField, PointDipoleField
from elastica_magnetic.specfile import SpecError


def _quiet(data):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_case(data)


def _bodied(**magnet) -> dict:
    data = tomllib.loads(CATHETER_MAGNET_REACH)
    data["name"] = "catheter"
    data["actuation"]["magnet"] = {"shape": "cuboid", "dimension": [0.01, 0.01, 0.01], **magnet}
    return data


@pytest.mark.parametrize(("magnet", "message"), [
    # S1: a 100 mm grid about a 10 mm cube read ~0 mT where the cube makes 3-13 mT
    ({"map_spacing": 0.1}, r"map_spacing: 100 mm against the 10 mm \(min_clearance\).*cannot resolve"),
    # S2: a spacing as wide as the map (or mm written as m) passed, every use then failed unnamed
    ({"map_spacing": 1.0}, r"map_spacing: 1000 mm against.*mm written as m"),
    ({"map_spacing": 4}, r"map_spacing: 4000 mm against"),
    # S3: 300 mm written as m: a 6 m spacing by default
    ({"map_half_width": 300}, r"map_half_width: 300 m is more than 10 times the 0.2562 m the rod can reach"),
])
def test_a_magnet_map_that_cannot_resolve_the_field_near_the_rod_is_refused(magnet, message):
    with pytest.raises(SpecError, match=message):
        _quiet(_bodied(**magnet))


def test_a_map_coarse_against_min_clearance_is_warned_and_the_default_is_not():
    """Beyond half min_clearance the map's error near the magnet is tens of percent: warned; the
    default spacing is finer to half min_clearance (5 mm here, 101 nodes a side would be 5.12 mm)."""
    with pytest.warns(UserWarning, match=r"map_spacing: 8 mm against the 10 mm.*5 mm or finer"):
        load_case(_bodied(map_spacing=0.008))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        case = load_case(_bodied())
    assert case.actuation.magnet.map_spacing == pytest.approx(0.005)


def test_a_bodys_field_at_the_tip_is_the_bodys_not_a_dipoles():
    """S9: a 70 mm rod magnet whose pole starts 5 mm from the tip: case check stated the point
    dipole's 3.1 mT at the tip (and its bending number), the body makes ~50 mT there."""
    data = _bodied(shape="cylinder", dimension=[0.004, 0.07])
    data["actuation"]["min_clearance"] = 0.036
    case = _quiet(data)
    arm = case.actuation
    tip = np.array([[0.05], [0.0], [0.0]])
    body = CylinderMagnetField(0.004, 0.07, [0.0, 0.0, arm.magnet.polarization(1.0)], [0.09, 0.0, 0.0],
                               [1.0, 0.0, 0.0])
    dipole = PointDipoleField([1.0, 0.0, 0.0], [0.09, 0.0, 0.0])
    assert arm.field_at_tip(0.05) == pytest.approx(np.linalg.norm(body.at(tip)), rel=1e-12)
    assert arm.field_at_tip(0.05) > 10 * np.linalg.norm(dipole.at(tip))
    on_axis = body.at(np.array([[0.09 + 0.036], [0.0], [0.0]]))
    assert arm.reach_field(0.05) == pytest.approx(np.linalg.norm(on_axis), rel=1e-9)
    assert f"{1e3 * arm.field_at_tip(0.05):.3g} mT at the straight tip" in arm.describe(0.05)


@pytest.mark.parametrize(("key", "value", "message"), [
    # S: the clip on the noise's scale was unbounded while the noises are bounded at 1
    ("target_noise_clip", 50.0, r"target_noise_clip must be at most 2 .*a wider clip never acts"),
    # S: the spectrum's exponent beyond red was accepted silently
    ("noise_color", 5.0, r"noise_color must be at most 2 \(the exponent beta"),
])
def test_noise_settings_that_cannot_mean_what_they_say_are_refused(key, value, message):
    with pytest.raises(ValueError, match=message):
        TD3Config(**{key: value})
    assert TD3Config(**{key: 2.0}).to_dict()[key] == 2.0
    data = _m1()
    data["training"] = {**data.get("training", {}), "td3": {key: value}}
    with pytest.raises(SpecError, match=rf"\[training.td3\] {key}"):
        _quiet(data)


def test_a_coil_of_less_than_a_turn_is_refused_and_a_fraction_warned():
    """S: ``turns = 0.5`` passed (no winding has half a turn)."""
    coils = load_case("catheter-coils-reach").to_dict()
    data = copy.deepcopy(coils)
    data["actuation"]["coils"][0]["turns"] = 0.5
    with pytest.raises(SpecError, match=r"turns.*>= 1"):
        _quiet(data)
    data["actuation"]["coils"][0]["turns"] = 500.5
    with pytest.warns(UserWarning, match=r"turns: 500.5: a winding has a whole number of turns"):
        load_case(data)


def _m1() -> dict:
    data = tomllib.loads((SPECS_DIR / "m1-4mT.toml").read_text())
    data["name"] = "m1"
    return data


def test_a_shear_coefficient_no_section_has_is_refused():
    """V8: ``shear_coefficient = 100`` was answered with a time step, not with the value."""
    data = _m1()
    data["robot"]["shear_coefficient"] = 100.0
    with pytest.raises(SpecError, match=r"shear_coefficient.*ten times any cross-section's"):
        _quiet(data)


def test_a_damping_no_step_can_run_names_its_key_not_a_time_step():
    """V8: ``legacy_torque = 150`` (the paper's nu in its own units) advised dt = 2e-12 s."""
    data = _m1()
    data["robot"]["damping"]["legacy_torque"] = 150.0
    with pytest.raises(SpecError, match=r"\[robot.damping\] legacy_torque: this robot's legacy torque "
                                        r"damping alone needs a time step below .*other units") as info:
        _quiet(data)
    assert "Set dt" not in str(info.value)
