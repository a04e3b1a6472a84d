"""Tests of the crawler environment (rl/envs/env.py): Gymnasium compliance, the observation layout and
scales on a constructed rod state, dtypes, truncation versus termination, seeding, the reward and
the action-to-field mapping."""

from __future__ import annotations

import dataclasses
import json
import math
import warnings

import elastica_magnetic_rl
import gymnasium as gym
import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import PAPER_CASES, load_case
from elastica_magnetic_rl.envs.env import (
    OBSERVATION_LAYOUT,
    OBSERVATION_SCALES,
    MagneticCrawlerEnv,
    observation_layout,
    observation_spec,
)
from gymnasium.utils.env_checker import check_env

from elastica_magnetic import yao2023_robot


def make(**kw) -> MagneticCrawlerEnv:
    kw.setdefault("duration", 0.1)
    return MagneticCrawlerEnv(**kw)


def test_check_env_passes_through_gym_make():
    env = gym.make(elastica_magnetic_rl.ENV_ID, duration=0.1, render_mode="rgb_array")
    with warnings.catch_warnings():
        # Unbounded blocks (angular velocity, contact) are honest infinities.
        warnings.filterwarnings("ignore", message=".*infinity.*")
        check_env(env.unwrapped)
    env.close()


@pytest.mark.parametrize("case", PAPER_CASES)
def test_registered_cases(case):
    """``gym.make(..., case=NAME)`` gives the paper's robot of the case's pattern and limit, and
    the same observations as the environment built from pattern and limit."""
    env = gym.make(elastica_magnetic_rl.ENV_ID, case=case, duration=0.05)
    obs, info = env.reset(seed=1)
    assert obs.shape == (260,) and env.observation_space.shape == (260,)
    limit = {"4mT": 4e-3, "10mT": 10e-3}[case.split("-")[1]]
    assert env.unwrapped.field_limit == limit == load_case(case).field_limit
    assert env.unwrapped.robot_spec.name == f"yao2023-m{case[1]}"
    old = MagneticCrawlerEnv(pattern=int(case[1]), field_limit=limit, duration=0.05)
    obs_old, _ = old.reset(seed=1)
    for _ in range(3):
        action = np.array([0.7, -0.4], dtype=np.float32)
        a, ra, *_ = env.step(action)
        b, rb, *_ = old.step(action)
        assert np.array_equal(a, b) and ra == rb
    assert np.array_equal(obs, obs_old)
    env.close()


def test_layout_sizes_and_spec_json():
    sizes = {k: s.stop - s.start for k, s in OBSERVATION_LAYOUT.items()}
    assert sizes == {"angular_velocity": 64, "orientation": 64, "height": 65, "contact": 65,
                     "field_amplitude": 1, "field_angle": 1}
    assert OBSERVATION_LAYOUT["field_angle"].stop == 260
    starts = [s.start for s in OBSERVATION_LAYOUT.values()]
    assert starts == sorted(starts) and starts[0] == 0
    assert observation_layout(10)["field_angle"].stop == 44
    spec = json.loads(json.dumps(observation_spec()))
    assert spec["size"] == 260 and spec["scales"]["height"] == 100.0
    assert [b["name"] for b in spec["blocks"]] == list(OBSERVATION_LAYOUT)


def _rotate_about_z(directors: np.ndarray, k: int, angle: float, flip: bool = False) -> None:
    """Directors (rows d1, d2, d3 in lab components) of element k rotated by ``angle`` about z;
    ``flip`` also turns the rod upside down about its axis (d1 -> -d1, d2 -> -z)."""
    c, s = math.cos(angle), math.sin(angle)
    d1 = np.array([-s, c, 0.0])
    d2 = np.array([0.0, 0.0, 1.0])
    if flip:
        d1, d2 = -d1, -d2
    directors[:, :, k] = np.stack([d1, d2, np.array([c, s, 0.0])])


def test_observation_entries_on_a_constructed_state():
    env = make(initial_field="zero")
    env.reset(seed=0)
    rod = env.simulation.rod
    lay = OBSERVATION_LAYOUT
    # a known state: rotated elements, spinning elements, lifted / pressed nodes, a set field
    _rotate_about_z(rod.director_collection, 5, 0.7)
    _rotate_about_z(rod.director_collection, 6, 2.5)
    _rotate_about_z(rod.director_collection, 8, -1.2, flip=True)
    rod.omega_collection[:, :] = 0.0
    rod.omega_collection[1, 7] = 3.0  # about d2 = +z: counter-clockwise
    rod.omega_collection[1, 8] = 3.0  # about d2 = -z (flipped element): clockwise
    y = rod.position_collection[1]
    y[:] = 0.0
    y[10] = 2e-3  # lifted 2 mm
    y[20] = -3e-5  # pressed 30 um into the ground
    y[30] = 5e-8  # within the 1e-7 m contact tolerance
    y[40] = 2e-7  # just above it
    env.field.set((3e-3, -2e-3, 0.0))
    obs = env.observation()

    assert obs.dtype == np.float32 and obs.shape == (260,)
    ang = obs[lay["orientation"]]
    assert ang[5] == pytest.approx(0.7, abs=1e-6)
    assert ang[6] == pytest.approx(2.5, abs=1e-6)
    assert ang[8] == pytest.approx(-1.2, abs=1e-6)
    assert np.all(ang[[0, 4, 7, 63]] == 0.0)
    w = obs[lay["angular_velocity"]]
    assert w[7] == pytest.approx(0.25 * 3.0) and w[8] == pytest.approx(-0.25 * 3.0)
    assert np.count_nonzero(w) == 2
    h = obs[lay["height"]]
    assert h[10] == pytest.approx(100.0 * 2e-3)
    assert h[30] == pytest.approx(100.0 * 5e-8) and h[40] == pytest.approx(100.0 * 2e-7)
    assert h[20] == 0.0 and h[0] == 0.0
    c = obs[lay["contact"]]
    assert c[20] == pytest.approx(1.0 + 1e4 * 3e-5)
    assert c[0] == 1.0 and c[30] == 1.0  # touching, no penetration
    assert c[10] == 0.0 and c[40] == 0.0  # off the ground
    assert obs[lay["field_amplitude"]][0] == pytest.approx(200.0 * math.hypot(3e-3, 2e-3))
    assert obs[lay["field_angle"]][0] == pytest.approx(math.atan2(-2.0, 3.0))
    assert OBSERVATION_SCALES["field_amplitude"] * 4e-3 == pytest.approx(0.8)


def test_rest_state_and_zero_field_observation():
    env = make(initial_field="zero")
    obs, info = env.reset(seed=0)
    lay = OBSERVATION_LAYOUT
    assert np.all(obs[lay["orientation"]] == 0.0) and np.all(obs[lay["angular_velocity"]] == 0.0)
    assert np.all(obs[lay["height"]] == 0.0) and np.all(obs[lay["contact"]] == 1.0)
    assert obs[lay["field_amplitude"]][0] == 0.0 and obs[lay["field_angle"]][0] == 0.0
    assert np.all(info["field_T"] == 0.0)


def test_counter_clockwise_bending_is_positive():
    """Pattern 1 (front half magnetized +x) in a +y field: the front end turns counter-clockwise,
    so its angle and its angular velocity are positive (the back end mirrors it)."""
    env = make(initial_field="zero", field_limit=4e-3)
    env.reset(seed=0, options={"initial_field": (0.0, 3.9e-3)})
    obs, *_ = env.step(np.zeros(2, np.float32))
    lay = OBSERVATION_LAYOUT
    assert obs[lay["orientation"]][63] > 0.01 and obs[lay["angular_velocity"]][63] > 0.1
    assert obs[lay["orientation"]][0] < -0.01 and obs[lay["angular_velocity"]][0] < -0.1
    omega_material = env.simulation.rod.omega_collection
    assert obs[lay["angular_velocity"]][63] == pytest.approx(0.25 * omega_material[1, 63], rel=1e-6)


def test_dtypes_and_spaces():
    env = make()
    assert env.observation_space.dtype == np.float32 and env.action_space.dtype == np.float32
    assert env.action_space.shape == (2,)
    assert np.all(env.action_space.low == -1.0) and np.all(env.action_space.high == 1.0)
    obs, _ = env.reset(seed=0)
    assert obs.dtype == np.float32 and env.observation_space.contains(obs)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
    assert obs.dtype == np.float32 and isinstance(reward, float)
    assert isinstance(terminated, bool) and isinstance(truncated, bool)


def test_action_is_a_field_increment_with_clipping():
    env = make(initial_field="zero", field_limit=4e-3)
    env.reset(seed=0)
    *_, info = env.step(np.array([1.0, -0.5], np.float32))
    np.testing.assert_allclose(info["field_T"], [0.3e-3, -0.15e-3, 0.0], rtol=1e-6)
    *_, info = env.step(np.array([7.0, -7.0], np.float32))  # clipped to +-1
    np.testing.assert_allclose(info["field_T"], [0.6e-3, -0.45e-3, 0.0], rtol=1e-6)
    env.reset(seed=0, options={"initial_field": (3.9e-3, 3.9e-3)})
    *_, info = env.step(np.array([1.0, 1.0], np.float32))
    assert np.hypot(*info["field_T"][:2]) == pytest.approx(4e-3)  # amplitude limit


def test_bad_action_is_named():
    env = make(initial_field="zero", field_limit=4e-3)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"action must have 2 components .* got shape \(3,\)"):
        env.step(np.zeros(3, np.float32))
    with pytest.raises(ValueError, match="action must be finite"):
        env.step(np.array([np.nan, 0.0], np.float32))


def test_random_initial_field_within_0p7_limit():
    env = make(field_limit=10e-3)
    fields = []
    for seed in range(20):
        _, info = env.reset(seed=seed)
        fields.append(info["field_T"])
    fields = np.array(fields)
    assert np.all(np.abs(fields[:, :2]) <= 0.7 * 10e-3) and np.all(fields[:, 2] == 0.0)
    assert np.std(fields[:, 0]) > 1e-3  # actually random


def test_truncation_at_time_limit_is_not_termination():
    env = make(duration=0.05)
    env.reset(seed=0)
    flags = [env.step(np.zeros(2, np.float32))[2:4] for _ in range(5)]
    assert flags[:-1] == [(False, False)] * 4
    assert flags[-1] == (False, True)
    assert env.max_episode_steps == 5 and env.time == pytest.approx(0.05)


def test_nan_blow_up_terminates_with_penalty_and_finite_obs():
    env = make(divergence_penalty=-10.0)
    env.reset(seed=0)
    last, *_ = env.step(np.zeros(2, np.float32))
    env.simulation.rod.velocity_collection[:, 10] = np.nan
    obs, reward, terminated, truncated, info = env.step(np.zeros(2, np.float32))
    assert terminated and not truncated and reward == -10.0
    assert np.all(np.isfinite(obs)) and np.array_equal(obs, last)
    assert info["diverged"] and "NaN" in info["divergence"]
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(2, np.float32))
    env.reset(seed=0)  # usable again
    assert not env.step(np.zeros(2, np.float32))[2]


def test_huge_time_step_blows_up_and_terminates():
    spec = dataclasses.replace(yao2023_robot(1, "training"), dt=2e-3)
    env = MagneticCrawlerEnv(spec=spec, initial_field="zero", duration=1.0)
    obs0, _ = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(np.ones(2, np.float32))
    assert terminated and not truncated and reward == env.divergence_penalty
    assert np.array_equal(obs, obs0)


def test_reset_seed_reproducible():
    actions = np.random.default_rng(0).uniform(-1, 1, (3, 2)).astype(np.float32)

    def run(env, seed):
        obs, _ = env.reset(seed=seed)
        out = [obs]
        for a in actions:
            out.append(env.step(a)[0])
        return np.array(out)

    env_a, env_b = make(), make()
    first = run(env_a, 3)
    np.testing.assert_array_equal(first, run(env_b, 3))
    np.testing.assert_array_equal(first, run(env_a, 3))  # same env, reset again
    other, _ = env_a.reset(seed=4)
    field = slice(OBSERVATION_LAYOUT["field_amplitude"].start, 260)
    assert not np.array_equal(other[field], first[0][field])


def test_reward_is_1e4_times_middle_node_displacement():
    env = make(initial_field="zero")
    _, info = env.reset(seed=0)
    x_prev = info["mid_x_m"]
    assert x_prev == env.simulation.rod.position_collection[0, 32]
    rewards = []
    for a in ([1.0, 1.0], [1.0, 0.5], [-1.0, 1.0], [0.3, -1.0]):
        _, reward, _, _, info = env.step(np.array(a, np.float32))
        assert info["mid_x_m"] == env.simulation.rod.position_collection[0, 32]
        assert reward == pytest.approx(1e4 * (info["mid_x_m"] - x_prev), rel=1e-12, abs=1e-15)
        rewards.append(reward)
        x_prev = info["mid_x_m"]
    assert any(r != 0.0 for r in rewards)


def test_render_rgb_array():
    env = make(render_mode="rgb_array")
    env.reset(seed=0)
    env.step(np.ones(2, np.float32))
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert frame.std() > 0
    env.close()
    with pytest.warns(UserWarning, match="render_mode"):
        assert make().render() is None  # no render_mode: warns, returns None


def test_pattern_2_is_pattern_1_with_the_field_turned_a_quarter_turn():
    """Pattern 2's magnetization is pattern 1's turned by +90 degrees about z (the authors' code), and the
    motion is planar (rotations about z commute), so pattern 2 under the field turned by +90 degrees
    must move exactly as pattern 1: the two cases are the same control problem. A sign or index
    slip in either pattern, the torque or the field clipping breaks this."""
    rng = np.random.default_rng(3)
    # Field swung towards -x -y, then turned: the robot folds up (as the 10 mT agents start).
    ramp = np.repeat([[-1.0, -1.0], [-1.0, 1.0]], 15, axis=0)
    actions = np.clip(ramp + rng.normal(0.0, 0.3, ramp.shape), -1, 1).astype(np.float32)
    envs = [make(pattern=p, field_limit=10e-3, initial_field="zero", duration=0.3) for p in (1, 2)]
    for env in envs:
        env.reset(seed=0)
    for a in actions:
        _, r1, *_ = envs[0].step(a)
        _, r2, *_ = envs[1].step(np.array([-a[1], a[0]], dtype=np.float32))
        b1, b2 = envs[0].field.value, envs[1].field.value
        np.testing.assert_allclose(b2[:2], [-b1[1], b1[0]], rtol=0, atol=1e-15)
        assert r2 == pytest.approx(r1, rel=1e-9, abs=1e-12)
    x1 = envs[0].simulation.rod.position_collection
    x2 = envs[1].simulation.rod.position_collection
    np.testing.assert_allclose(x2, x1, rtol=0, atol=1e-12)
    assert np.ptp(x1[1]) > 5e-4  # not trivially: the rod lifted by more than 0.5 mm
