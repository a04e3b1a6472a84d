"""The catheter tip-reach vector environment (issue 53): spaces, seeding, rewards, episode ends,
state save and restore, and a steering law driving it."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from elastica_magnetic_rl.cases.arm_actuation import MagnetArm
from elastica_magnetic_rl.cases.tasks import TipReachTask
from elastica_magnetic_rl.envs.catheter_env import CatheterReachVectorEnv, catheter_observation_layout
from spec_texts import CATHETER_MAGNET_REACH

from elastica_magnetic.spec_format import loads
from elastica_magnetic.specfile import describe_robot

ARM = MagnetArm(moment=1.0, position=(0.09, 0.0, 0.0), direction=(1.0, 0.0, 0.0),
                workspace=((-0.1, -0.1, -0.1), (0.15, 0.1, 0.1)), max_speed=0.1, max_turn_rate=3.0)


@pytest.fixture(scope="module")
def spec():
    return describe_robot(loads(CATHETER_MAGNET_REACH, "c.toml"), "c.toml").robot("training")


def make(spec, n=2, **task):
    return CatheterReachVectorEnv(n, spec, ARM, TipReachTask(**{"episode_duration": 0.05, **task}))


def test_spaces_seeding_and_the_first_observation(spec):
    env = make(spec, 3)
    layout = catheter_observation_layout(10)
    assert env.single_observation_space.shape == (3 * 11 + 12,) == (layout["target_offset"].stop,)
    assert env.action_space.shape == (3, 5) and env.observation_space.dtype == np.float32
    obs, info = env.reset(seed=7)
    assert obs.shape == (3, 45) and obs.dtype == np.float32
    low, high = np.asarray(env.task.target_box)
    assert np.all((info["target_m"] >= low) & (info["target_m"] <= high))
    assert len({tuple(t) for t in info["target_m"]}) == 3  # each sub-environment its own draw
    # the straight rod's shape, the arm's start and the offset to the target, scaled per m by 100
    np.testing.assert_allclose(obs[0, layout["node_positions"]].reshape(11, 3)[:, 0], np.linspace(0, 5, 11),
                               atol=1e-6)
    np.testing.assert_allclose(obs[0, layout["magnet_position"]], [9.0, 0.0, 0.0], atol=1e-6)
    np.testing.assert_allclose(obs[0, layout["target_offset"]], 100 * (info["target_m"][0] - [0.05, 0, 0]),
                               rtol=1e-6)
    again = make(spec, 3)
    assert np.array_equal(again.reset(seed=7)[0], obs)
    assert not np.array_equal(again.reset(seed=8)[0], obs)
    alone = make(spec, 1)
    assert np.array_equal(alone.reset(seed=8)[0][0], obs[1])  # sub-environment i is seeded s + i


def test_reward_is_the_distance_closed_and_episodes_truncate_with_autoreset(spec):
    env = make(spec, 2)
    obs, info = env.reset(seed=0, options={"target": (0.045, 0.015, 0.015)})
    turn = np.array([[0.0, 0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 0.0, -1.0]])
    total = np.zeros(2)
    for k in range(5):
        before = info["distance_m"].copy()
        obs, reward, terminated, truncated, info = env.step(turn)
        if k < 4:
            np.testing.assert_allclose(reward, 1e4 * (before - info["distance_m"]), rtol=1e-9, atol=1e-12)
            total += reward
            assert not truncated.any()
    assert truncated.all() and not terminated.any()  # 0.05 s: five steps
    assert set(info["final_info"]["ended_by"]) == {"time"}
    assert info["time_s"].tolist() == [0.0, 0.0] and env.steps.tolist() == [0, 0]  # same-step autoreset
    assert not np.array_equal(info["final_obs"][0], obs[0])
    assert total[0] * total[1] < 0  # the two senses of turning bend the tip opposite ways


def test_a_magnet_that_comes_near_the_rod_ends_the_episode(spec):
    near = dataclasses.replace(ARM, position=(0.065, 0.0, 0.0), min_clearance=0.012)
    env = CatheterReachVectorEnv(1, spec, near, TipReachTask(episode_duration=1.0))
    env.reset(seed=0)
    for _ in range(100):
        _, reward, terminated, truncated, info = env.step(np.array([[-1.0, 0.0, 0.0, 0.0, 0.0]]))
        if terminated[0]:
            break
    assert terminated[0] and not truncated[0] and reward[0] == -10.0
    assert info["final_info"]["ended_by"][0] == "collision"


def test_state_round_trip_reproduces_the_future(spec):
    env = make(spec, 2, episode_duration=0.2)
    env.reset(seed=3)
    rng = np.random.default_rng(0)
    for _ in range(3):
        env.step(rng.uniform(-1, 1, (2, 5)))
    state = env.get_state()
    actions = rng.uniform(-1, 1, (4, 2, 5))
    first = [env.step(a) for a in actions]
    other = make(spec, 2, episode_duration=0.2)
    other.set_state(state)
    second = [other.step(a) for a in actions]
    for a, b in zip(first, second, strict=True):
        assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    with pytest.raises(ValueError, match="not a state of this vector environment"):
        make(spec, 3).set_state(state)


def test_the_bearing_steering_law_closes_the_distance(spec):
    """The yardstick's law (elastica_magnetic.steering) through the environment: 1 s of it brings the
    tip nearer a target off the straight line."""
    from elastica_magnetic.steering import MagnetBearingSteering

    env = make(spec, 1, episode_duration=2.0)
    target = np.array([0.04, 0.02, 0.0])
    _, info = env.reset(seed=0, options={"target": target})
    law = MagnetBearingSteering(env.actuators[0], base=[0.0, 0.0, 0.0], distance=0.04)
    start = info["distance_m"][0]
    for _ in range(100):
        action = law.action(env.tip(0), target, env.robots.robot_time(0), 0.01)
        _, _, terminated, _, info = env.step(action[None])
        assert not terminated[0]
    assert info["distance_m"][0] < 0.5 * start


def test_the_tip_reach_task_checks_its_values():
    with pytest.raises(ValueError, match="target_box"):
        TipReachTask(target_box=((0.05, 0.0, 0.0), (0.04, 0.01, 0.01)))
    with pytest.raises(ValueError, match="tolerance"):
        TipReachTask(tolerance=0.0)
    task = TipReachTask()
    with pytest.raises(ValueError, match=r"\(x, y, z\) in m"):
        task.start(np.zeros(3), target=(0.04, 0.01))
    assert task.to_dict()["target_box"] == [[0.035, -0.02, -0.02], [0.05, 0.02, 0.02]]
    assert math.isclose(task.reward(np.zeros(3), np.array([0.001, 0, 0]), np.array([0.01, 0, 0])), 10.0)
