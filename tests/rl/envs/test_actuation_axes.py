"""Three-axis actuation (issue 51): ``[actuation] axes = "xyz"`` and per-axis limits and
increments, from the spec through the field rule, both environments and the policy files; the
paper's planar cases exactly as before."""

from __future__ import annotations

import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.envs.env import MagneticCrawlerEnv, initial_field_value
from elastica_magnetic_rl.envs.vector_env import MagneticCrawlerVectorEnv
from elastica_magnetic_rl.shipping.policy_files import action_spec_of, observation_spec_of
from gymnasium.utils.env_checker import check_env

from elastica_magnetic import ControlledField
from elastica_magnetic.specfile import SpecError, spec_field_limit


def xyz_case(**actuation):
    spec = load_case("m1-4mT").to_dict()
    spec["actuation"].update({"axes": "xyz", **actuation})
    return load_case(spec)


def test_a_planar_case_is_as_it_was():
    case = load_case("m1-4mT")
    assert case.to_dict()["actuation"] == {"field_limit": 0.004, "max_increment": 0.0003,
                                           "control_rate": 100.0, "initial_field": "random"}
    assert case.obs_dim == 260 and case.actuation.n_axes == 2
    env = MagneticCrawlerEnv(case=case, duration=0.05)
    assert env.action_space.shape == (2,) and env.observation_space.shape == (260,)
    assert "field_z" not in env.layout
    assert action_spec_of(case)["shape"] == [2]
    assert "field_z" not in observation_spec_of(case)["scales"]


def test_the_spec_takes_axes_and_one_limit_per_axis():
    case = xyz_case(field_limit=[4e-3, 4e-3, 3e-3], max_increment=[3e-4, 3e-4, 2e-4])
    a = case.actuation
    assert (a.axes, a.field_limit, a.max_increment) == ("xyz", 4e-3, 3e-4)
    assert a.limits == (4e-3, 4e-3, 3e-3) and a.increments == (3e-4, 3e-4, 2e-4)
    assert case.obs_dim == 261
    assert load_case(case.to_dict()).to_dict() == case.to_dict()  # round trip
    assert case.to_dict()["actuation"]["field_limit"] == [4e-3, 4e-3, 3e-3]
    assert xyz_case().to_dict()["actuation"]["field_limit"] == 4e-3  # one number stays one
    assert spec_field_limit(case.to_dict(), "my.toml") == 4e-3
    action = action_spec_of(case)
    assert action["shape"] == [3] and action["field_limit_T_per_axis"] == [4e-3, 4e-3, 3e-3]
    assert action["field_increment_T_per_unit_per_axis"] == [3e-4, 3e-4, 2e-4]


@pytest.mark.parametrize("actuation, message", [
    ({"axes": "xz"}, r"\[actuation\] axes: expected one of xy, xyz; got 'xz'"),
    ({"field_limit": [4e-3, 4e-3]},
     r"\[actuation\] field_limit: expected one number \(T\) or a list of 3, one per axis of "
     r"axes = 'xyz'"),
    ({"field_limit": [4e-3, 4e-3, 3.0]}, r"\[actuation\] field_limit: z axis: must be <= 1 \(T\)"),
    ({"field_limit": [4e-3, "4", 4e-3]}, r"\[actuation\] field_limit: y axis: expected a number"),
    ({"field_limit": [4e-3, 4e-3, 0.0]}, r"\[actuation\] field_limit: z axis: must be > 0"),
    ({"max_increment": [3e-4, 3e-4, 5e-3], "field_limit": [4e-3, 4e-3, 3e-3]},
     r"\[actuation\] max_increment: 0.005 T per action is larger than the field limit 0.003 T"),
])
def test_bad_axes_and_per_axis_values_are_named(actuation, message):
    with pytest.raises(SpecError, match=message):
        xyz_case(**actuation)


def test_a_planar_case_takes_two_limits():
    spec = load_case("m1-4mT").to_dict()
    spec["actuation"]["field_limit"] = [4e-3, 3e-3]
    assert load_case(spec).actuation.limits == (4e-3, 3e-3, 4e-3)
    spec["actuation"]["field_limit"] = [4e-3, 3e-3, 3e-3]
    with pytest.raises(SpecError, match="a list of 2, one per axis of axes = 'xy'"):
        load_case(spec)


def _old_rule(value, delta, limit, increment):
    """The paper's rule as it was written before per-axis limits (one limit, one increment)."""
    value = value.copy()
    delta = np.clip(delta, -increment, increment)
    value[: delta.shape[0]] += delta
    np.clip(value, -limit, limit, out=value)
    amplitude = np.sqrt(float(value @ value))
    if amplitude > limit:
        value *= limit / amplitude
    return value


def test_one_limit_for_every_axis_is_the_paper_rule_bit_for_bit():
    rng = np.random.default_rng(3)
    field = ControlledField(4e-3, 3e-4)
    value = np.zeros(3)
    for _ in range(500):
        delta = rng.uniform(-5e-4, 5e-4, size=2)
        value = _old_rule(value, delta, 4e-3, 3e-4)
        field.apply_increment(delta)
        assert np.array_equal(field.value, value)


def test_per_axis_limits_and_increments_hold():
    field = ControlledField([4e-3, 4e-3, 1e-3], [3e-4, 3e-4, 1e-4])
    assert field.limit == 4e-3 and field.max_increment == 3e-4
    field.apply_increment([0.0, 0.0, 1.0])
    assert field.value[2] == pytest.approx(1e-4)  # the z increment, not the largest
    for _ in range(40):
        field.apply_increment([1.0, 0.0, 1.0])
    assert field.value[2] <= 1e-3 + 1e-15 and field.value[0] <= 4e-3
    assert np.linalg.norm(field.value) <= 4e-3 * (1 + 1e-12)
    with pytest.raises(ValueError, match="limit must be a field in tesla or one per axis"):
        ControlledField([4e-3, 4e-3])


def test_the_three_axis_environment_moves_bz_and_observes_it():
    case = xyz_case(field_limit=[4e-3, 4e-3, 3e-3])
    env = MagneticCrawlerEnv(case=case, initial_field="zero", duration=0.2)
    assert env.action_space.shape == (3,) and env.observation_space.shape == (261,)
    obs, _ = env.reset(seed=0)
    for _ in range(5):
        obs, _, _, _, info = env.step(np.array([0.0, 0.0, 1.0], dtype=np.float32))
    assert info["field_T"][:2].tolist() == [0.0, 0.0]
    assert info["field_T"][2] == pytest.approx(1.5e-3)
    assert obs[env.layout["field_z"]][0] == pytest.approx(200 * 1.5e-3, rel=1e-6)
    assert obs[env.layout["field_amplitude"]][0] == 0.0  # the x-y part, as the planar block
    for _ in range(20):
        _, _, _, _, info = env.step(np.array([0.0, 0.0, -1.0], dtype=np.float32))
    assert info["field_T"][2] == pytest.approx(-3e-3)  # the z limit, not the amplitude limit
    with pytest.raises(ValueError, match=r"3 components \(normalised dB_x, dB_y, dB_z\)"):
        env.step(np.zeros(2, dtype=np.float32))
    check_env(MagneticCrawlerEnv(case=case, duration=0.05), skip_render_check=True)


def test_random_initial_fields_draw_every_controlled_axis():
    limits = np.array([4e-3, 4e-3, 1e-3])
    draws = np.array([initial_field_value("random", limits, np.random.default_rng(k), "xyz")
                      for k in range(200)])
    assert np.all(np.abs(draws) <= 0.7 * limits) and np.abs(draws[:, 2]).max() > 0.5e-3
    # planar: the same two draws as ever, B_z = 0
    rng, reference = np.random.default_rng(7), np.random.default_rng(7)
    planar = initial_field_value("random", np.full(3, 4e-3), rng)
    expected = reference.uniform(-0.7 * 4e-3, 0.7 * 4e-3, size=2)
    assert planar == (expected[0], expected[1], 0.0)


def test_the_vector_environment_equals_the_single_one_in_three_axes():
    case = xyz_case(field_limit=[4e-3, 4e-3, 3e-3])
    vector = MagneticCrawlerVectorEnv(2, case=case, initial_field="random", duration=0.2)
    single = MagneticCrawlerEnv(case=case, initial_field="random", duration=0.2)
    assert vector.single_action_space.shape == (3,) and vector.action_space.shape == (2, 3)
    obs, _ = vector.reset(seed=5)
    one, _ = single.reset(seed=5)
    assert np.array_equal(obs[0], one)
    rng = np.random.default_rng(0)
    for _ in range(8):
        actions = rng.uniform(-1, 1, size=(2, 3)).astype(np.float32)
        obs, *_ = vector.step(actions)
        one, *_ = single.step(actions[0])
        assert np.array_equal(obs[0], one)


def test_the_case_summary_names_the_axes_and_per_axis_limits():
    from elastica_magnetic_rl.cases.check import case_summary

    text = case_summary(xyz_case(field_limit=[4e-3, 4e-3, 3e-3], max_increment=[3e-4, 3e-4, 2e-4]))
    assert ("actuation    axes xyz (the third coil pair too), field limits x 4, y 4, z 3 mT "
            "(amplitude 4 mT), at most x 0.3, y 0.3, z 0.2 mT per 10 ms") in text
    assert "axes xy (the paper's two coil pairs), field limit 4 mT" in case_summary(load_case("m1-4mT"))


def test_the_rotating_field_yardstick_drives_a_three_axis_case():
    """Round 7, N20/N21: msr field baseline (and msr loop's yardstick) on an xyz case stopped with
    "action must have 3 components"; the yardstick now holds B_z at zero with the third pair."""
    from elastica_magnetic_rl.envs.yardsticks import RotatingFieldPolicy

    case = xyz_case(field_limit=[4e-3, 4e-3, 3e-3])
    policy = RotatingFieldPolicy(case, 1.0)
    env = MagneticCrawlerEnv(case=case, initial_field="zero", duration=0.1)
    obs, _ = env.reset(seed=0, options={"initial_field": (1e-3, 1e-3, 1e-3)})
    assert policy.act_dim == 3
    for _ in range(10):
        obs, _, _, _, info = env.step(policy.act(obs))
    assert abs(info["field_T"][2]) < 1e-12 and np.hypot(*info["field_T"][:2]) > 3e-3
