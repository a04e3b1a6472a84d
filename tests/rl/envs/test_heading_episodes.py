"""Heading episodes in a goto training (issue 51): ``[task] heading_share`` makes that share of the
drawn episodes a heading to crawl along (the target kept ``distance`` ahead on the line from the
start), so one policy learns to stop at a point and to keep going along a line. The draws of a
case without it are unchanged; the single and the vector environment agree and resume alike."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import case_from_dict, load_case
from elastica_magnetic_rl.cases.tasks import GotoTask
from elastica_magnetic_rl.envs.env import MagneticCrawlerEnv
from elastica_magnetic_rl.envs.vector_env import MagneticCrawlerVectorEnv

from elastica_magnetic.specfile import SpecError


def _directions(states):
    return np.asarray(states)[:, 4:6]


def test_a_share_of_the_drawn_episodes_follows_a_heading_given_targets_never():
    task = GotoTask(heading_share=0.3)
    rng = np.random.default_rng(4)
    pose = np.array([0.02, -0.01, 0.6])
    states = np.array([task.start(pose, rng) for _ in range(2000)])
    assert states.shape == (2000, 6) and task.state_shape == (6,)
    moving = np.any(_directions(states) != 0.0, axis=1)
    assert abs(moving.mean() - 0.3) < 0.04  # 2000 draws: 3 standard deviations are 0.031
    # a heading episode's line starts at the middle and points at its first target, 15 mm away
    d = _directions(states[moving])
    assert np.hypot(d[:, 0], d[:, 1]) == pytest.approx(1.0)
    assert states[moving, :2] == pytest.approx(pose[:2] + 0.015 * d)
    assert np.all(states[:, 2:4] == pose[:2])
    given = task.start(pose, target=(0.0, 0.015))
    assert np.all(given[4:] == 0.0) and task.error(pose, given) == pytest.approx(0.015)


def test_without_a_heading_share_the_draws_and_the_state_are_as_before():
    """The bearing is drawn first: a case with heading episodes draws the same targets, and one
    without them draws nothing more (its runs and saved states are unchanged)."""
    pose = np.array([0.0, 0.0, -1.2])
    plain, rng_plain = GotoTask(), np.random.default_rng(9)
    shared, rng_shared = GotoTask(heading_share=1.0), np.random.default_rng(9)
    for _ in range(5):
        a, b = plain.start(pose, rng_plain), shared.start(pose, rng_shared)
        assert a.shape == (2,) and b[:2] == pytest.approx(a, abs=0.0)
        rng_plain.uniform()  # in place of the share's draw: then both generators are in step again
    assert rng_plain.uniform() == rng_shared.uniform()
    assert "heading_share" not in plain.to_dict() and shared.to_dict()["heading_share"] == 1.0


@pytest.mark.parametrize("heading", [0.0, 2.4, -1.0])
def test_follow_keeps_the_target_distance_ahead_of_the_middle_on_the_line(heading):
    task = GotoTask(heading_share=1.0, distance=0.01)
    start = np.array([0.1, 0.2, heading])
    state = task.start(start, np.random.default_rng(1))
    direction = state[4:6]
    for pose in ([0.1, 0.2, 0.0], [0.13, 0.18, 1.0], [0.05, 0.3, -2.0]):
        moved = task.follow(state, np.array(pose))
        offset = moved[:2] - start[:2]
        cross = offset[0] * direction[1] - offset[1] * direction[0]
        along_target = offset @ direction
        along_middle = (np.array(pose[:2]) - start[:2]) @ direction
        assert cross == pytest.approx(0.0, abs=1e-15)
        assert along_target == pytest.approx(along_middle + 0.01, abs=1e-15)
        assert np.array_equal(moved[2:], state[2:])
    fixed = task.start(start, target=(0.01, 0.0))
    assert np.array_equal(task.follow(fixed, np.array([0.5, 0.5, 0.0])), fixed)


def _heading_case(share: float = 1.0):
    case = load_case("m1-4mT-goto")
    return dataclasses.replace(case, task=dataclasses.replace(case.task, heading_share=share))


def test_the_environments_serve_heading_episodes_alike_and_the_target_moves():
    case = _heading_case()
    single = MagneticCrawlerEnv(case=case, physics="training", duration=0.3)
    vector = MagneticCrawlerVectorEnv(2, case=case, physics="training", duration=0.3)
    one, _ = single.reset(seed=21)
    obs, _ = vector.reset(seed=21)
    first = single.task_state.copy()
    assert np.array_equal(obs[0], one) and np.array_equal(vector._task_state[0], first)
    rng = np.random.default_rng(2)
    for _ in range(25):
        actions = rng.uniform(-1, 1, size=(2, 3)).astype(np.float32)
        obs, rewards, *_ = vector.step(actions)
        one, reward, *_ = single.step(actions[0])
        assert np.array_equal(obs[0], one) and rewards[0] == reward
        assert np.array_equal(vector._task_state[0], single.task_state)
    assert not np.array_equal(single.task_state[:2], first[:2])  # the carrot moved with the robot
    pose = single.task.position(single.simulation.rod, single.middle_node)
    (ux, uz), (dx, dz) = single.task_state[4:6], pose[:2] - first[2:4]
    assert single.task.error(pose, single.task_state) == pytest.approx(math.hypot(0.015, ux * dz - uz * dx),
                                                                       rel=1e-12)


def test_a_saved_vector_state_resumes_heading_episodes_bit_for_bit():
    case = _heading_case(0.5)
    env = MagneticCrawlerVectorEnv(3, case=case, physics="training", duration=0.2)
    env.reset(seed=5)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, size=(40, 3, 3)).astype(np.float32)
    for a in actions[:12]:
        env.step(a)
    state = env.get_state()
    assert state["task_state"].shape == (3, 6)
    ahead = [env.step(a) for a in actions[12:]]  # crosses episode ends (0.2 s = 20 steps)
    other = MagneticCrawlerVectorEnv(3, case=case, physics="training", duration=0.2)
    other.set_state(state)
    for a, (obs, rewards, *_rest) in zip(actions[12:], ahead, strict=True):
        again, again_rewards, *_ = other.step(a)
        assert np.array_equal(again, obs) and np.array_equal(again_rewards, rewards)
    assert np.array_equal(other._task_state, env._task_state)


def _spec(**task):
    data = load_case("m1-4mT-goto").to_dict()
    data["task"].update(task)
    return data


def test_the_spec_key_is_read_and_a_share_outside_0_1_refused_by_name():
    case = case_from_dict(_spec(heading_share=0.25), "my.toml", "my")
    assert case.task.heading_share == 0.25
    assert "heading_share = 0.25  # of the drawn training episodes" in case.toml()
    with pytest.raises(SpecError, match=r"my.toml: \[task\] heading_share: must be <= 1"):
        case_from_dict(_spec(heading_share=25), "my.toml", "my")
