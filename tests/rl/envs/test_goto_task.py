"""The goto task (issue 51, first piece): a target on the floor drawn per episode on a ring (or
given in the start frame), the reward for closing the distance, the heading and the target in the
robot's own frame as observation; the single and the vector environment agree."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from elastica_magnetic_rl.cases.tasks import GotoTask, floor_pose
from elastica_magnetic_rl.envs.env import MagneticCrawlerEnv
from elastica_magnetic_rl.envs.vector_env import MagneticCrawlerVectorEnv
from gymnasium.utils.env_checker import check_env

from elastica_magnetic import yao2023_robot


def _rod_along(heading: float, n_nodes: int = 9, length: float = 0.02, start=(0.0, 0.0)):
    """A straight rod's node positions pointing along ``heading`` (rad, counter-clockwise seen
    from above) from ``start`` (x, z)."""
    s = np.linspace(0.0, length, n_nodes)
    x = start[0] + s * math.cos(heading)
    z = start[1] - s * math.sin(heading)
    return SimpleNamespace(position_collection=np.stack([x, np.zeros_like(s), z]))


@pytest.mark.parametrize("heading", [0.0, math.pi / 2, -2.0, 3.0])
def test_the_floor_pose_reads_the_heading(heading):
    pose = floor_pose(_rod_along(heading, start=(0.1, -0.2)), 4)
    assert pose[2] == pytest.approx(heading)
    assert pose[0] == pytest.approx(0.1 + 0.01 * math.cos(heading))
    assert pose[1] == pytest.approx(-0.2 - 0.01 * math.sin(heading))


@pytest.mark.parametrize("heading", [0.0, math.pi / 2, -2.0])
def test_a_given_target_is_in_the_start_frame_and_observed_there(heading):
    task = GotoTask()
    pose = np.array([0.1, -0.2, heading])
    target = task.start(pose, target=(0.012, 0.005))  # 12 mm ahead, 5 mm to the left
    ahead = np.array([math.cos(heading), -math.sin(heading)])
    left = np.array([-math.sin(heading), -math.cos(heading)])
    assert target == pytest.approx(pose[:2] + 0.012 * ahead + 0.005 * left)
    obs = task.observe(pose, target)
    assert obs == pytest.approx([math.cos(heading), math.sin(heading), 1.2, 0.5, 1.0, 0.0])  # clock at 0 s
    assert task.error(pose, target) == pytest.approx(math.hypot(0.012, 0.005))


def test_drawn_targets_lie_on_the_ring_within_the_bearings():
    task = GotoTask(distance=0.015, angle_low=-0.5, angle_high=1.0)
    rng = np.random.default_rng(3)
    pose = np.array([0.0, 0.0, 0.7])
    for _ in range(50):
        target = task.start(pose, rng)
        assert task.error(pose, target) == pytest.approx(0.015)
        offset = task.observe(pose, target)[2:] / 100.0
        assert -0.5 - 1e-12 <= math.atan2(offset[1], offset[0]) <= 1.0 + 1e-12


def test_the_reward_pays_for_closing_the_distance_and_charges_moving_at_the_target():
    task = GotoTask(distance=0.015, slow_zone=0.004, speed_penalty=0.5)
    target = np.array([0.01, 0.0])
    toward = task.reward(np.array([0.0, 0.0, 0.0]), np.array([0.001, 0.0, 0.0]), target)
    away = task.reward(np.array([0.0, 0.0, 0.0]), np.array([-0.001, 0.0, 0.0]), target)
    assert toward == pytest.approx(1e4 * 0.001) and away == pytest.approx(-1e4 * 0.001)
    # sideways past the target (distance unchanged): the speed penalty near it
    at = task.reward(np.array([0.01, 0.001, 0.0]), np.array([0.01, -0.001, 0.0]), target)
    assert at == pytest.approx(-1e4 * 0.5 * 0.002)
    with pytest.raises(ValueError, match="distance must be a positive finite number"):
        GotoTask(distance=0.0)


def test_the_environments_serve_the_goto_task_alike():
    kwargs = dict(spec=yao2023_robot(1, "training"), task=GotoTask(), initial_field="random", duration=0.2)
    single = MagneticCrawlerEnv(**kwargs)
    assert single.observation_space.shape == (4 * 64 + 4 + 6,)
    check_env(MagneticCrawlerEnv(**{**kwargs, "duration": 0.05}), skip_render_check=True)
    vector = MagneticCrawlerVectorEnv(2, **kwargs)
    obs, _ = vector.reset(seed=11)
    one, _ = single.reset(seed=11)
    assert np.array_equal(obs[0], one) and np.array_equal(vector._task_state[0], single.task_state)
    rng = np.random.default_rng(0)
    for _ in range(6):
        actions = rng.uniform(-1, 1, size=(2, 2)).astype(np.float32)
        obs, rewards, *_ = vector.step(actions)
        one, reward, *_ = single.step(actions[0])
        assert np.array_equal(obs[0], one) and rewards[0] == reward
    obs, _ = vector.reset(options={"target": (0.0, 0.015)})  # 15 mm to the left of each
    assert obs[:, single.layout["target_offset"]] == pytest.approx(np.array([[0.0, 1.5]] * 2), abs=1e-5)


def test_the_paper_tasks_take_no_target_option():
    env = MagneticCrawlerEnv(spec=yao2023_robot(1, "training"), duration=0.05)
    with pytest.raises(ValueError, match="the crawl task has no target"):
        env.reset(options={"target": (0.01, 0.0)})


def test_retarget_moves_the_target_in_the_start_frame_mid_episode():
    """A path's next waypoint: ``retarget`` takes (forward, left) in the episode's start frame, not
    the robot's present one, and the observation it returns shows the new target."""
    env = MagneticCrawlerEnv(case="m1-4mT-goto", physics="training", initial_field="zero", duration=1.0)
    obs, _ = env.reset(seed=0, options={"target": (0.015, 0.0)})
    for _ in range(20):
        obs, *_ = env.step(np.array([1.0, 1.0, 1.0], dtype=np.float32))
    start = env.start_pose
    moved = env.retarget((0.0, 0.004))
    assert env.task_state == pytest.approx(env.task.start(start, target=(0.0, 0.004)))
    offset = moved[env.layout["target_offset"]]
    pose = floor_pose(env.simulation.rod, env.middle_node)
    assert offset == pytest.approx(env.task.observe(pose, env.task_state, env.time)[2:4], abs=1e-6)
    assert not np.allclose(offset, obs[env.layout["target_offset"]])
    crawl = MagneticCrawlerEnv(case="m1-4mT", physics="training")
    crawl.reset(seed=0)
    with pytest.raises(ValueError, match="retarget\\(\\) moves a goto task's target; this environment's task "
                                         "is crawl"):
        crawl.retarget((0.0, 0.004))


def test_a_time_penalty_charges_each_step_that_ends_away_from_the_target():
    plain = GotoTask(distance=0.015, tolerance=0.002)
    timed = GotoTask(distance=0.015, tolerance=0.002, time_penalty=0.003)  # m/s
    target = np.array([0.01, 0.0])
    poses = np.array([[0.0, 0.0, 0.0], [0.0005, 0.0, 0.0], [0.007, 0.0, 0.0], [0.0095, 0.0, 0.0]])
    before, after = poses[:-1], poses[1:]  # two steps ending beyond the tolerance, one within it
    cost = 1e4 * 0.003 * 0.01  # reward_scale x time_penalty x the 0.01 s step
    assert timed.reward(before, after, target) == pytest.approx(plain.reward(before, after, target)
                                                                - np.array([cost, cost, 0.0]))
    assert np.array_equal(GotoTask(time_penalty=0.0).reward(before, after, target),
                          GotoTask().reward(before, after, target))
    with pytest.raises(ValueError, match=r"time_penalty must be a finite speed >= 0 \(m/s\)"):
        GotoTask(time_penalty=-0.001)


def test_the_environments_charge_the_time_penalty_alike():
    robot = yao2023_robot(1, "training")
    rewards = {}
    for penalty in (0.0, 0.004):
        task = GotoTask(time_penalty=penalty)
        single = MagneticCrawlerEnv(spec=robot, task=task, initial_field="zero", duration=0.1)
        vector = MagneticCrawlerVectorEnv(1, spec=robot, task=task, initial_field="zero", duration=0.1)
        single.reset(seed=3, options={"target": (0.0, 0.015)})
        vector.reset(seed=3, options={"target": (0.0, 0.015)})
        actions = np.random.default_rng(1).uniform(-1, 1, size=(5, 2)).astype(np.float32)
        one = [single.step(a)[1] for a in actions]
        many = [float(vector.step(a[None])[1][0]) for a in actions]
        assert one == many
        rewards[penalty] = np.array(one)
    # 15 mm away all along: every step costs 1e4 x 0.004 m/s x 0.01 s
    assert rewards[0.004] == pytest.approx(rewards[0.0] - 0.4)
