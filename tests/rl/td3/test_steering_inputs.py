"""The steering actor of a goto case (rl/td3/steering_inputs.py, ``actor_input = "steering"``): what it
reads is the field and the target seen from the robot, what it answers is turned into the lab's
frame by the observed heading, the same in acting, the stacked updates and a reloaded actor."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.envs.crawler_observation import observation_layout
from elastica_magnetic_rl.td3.algorithm import TD3
from elastica_magnetic_rl.td3.config import TD3Config
from elastica_magnetic_rl.td3.networks import Actor, actor_from_state, networks_from_state
from elastica_magnetic_rl.td3.replay_buffer import Batch
from elastica_magnetic_rl.td3.steering_inputs import (
    STEERING_FEATURES,
    steering_features,
    steering_start,
    steering_to_lab,
)

torch.set_num_threads(1)


def _frame(obs, layout):
    c, s = (float(v) for v in obs[layout["heading"]])
    return np.array([c, 0.0, -s]), np.array([-s, 0.0, -c])


def test_the_features_are_the_field_and_the_target_seen_from_the_robot(walked):
    env, _, seen = walked
    start = steering_start(env.layout)
    for obs, field in seen[::30]:
        forward, left = _frame(obs, env.layout)
        features = steering_features(torch.as_tensor(obs, dtype=torch.float64), start).numpy()
        assert features.shape == (STEERING_FEATURES,)
        # the field along the robot's forward, up, left, 200 per T (float32 observation: 1e-6 of 0.8)
        np.testing.assert_allclose(features[:3], 200.0 * np.array([field @ forward, field[1], field @ left]),
                                   atol=2e-6)
        offset = obs[env.layout["target_offset"]]
        np.testing.assert_allclose(features[3:5], offset, rtol=1e-12)
        assert features[5] == pytest.approx(math.hypot(*offset), rel=1e-6)
        np.testing.assert_array_equal(features[6:], obs[env.layout["clock"]])
    assert abs(seen[-1][1][1]) > 1e-3 or abs(seen[-2][1][1]) > 1e-3  # the field is on: a real test


def test_a_lab_action_turned_into_the_robot_frame_comes_back_whole(walked):
    """The law's lab increments, seen along forward, up, left (each over sqrt 2 in the floor
    plane), are turned back to the same lab increments by the observed heading."""
    env, law, seen = walked
    start = steering_start(env.layout)
    for obs, _ in seen[::15]:
        lab = law.act(obs).astype(np.float64)
        forward, left = _frame(obs, env.layout)
        command = np.array([lab @ forward / math.sqrt(2.0), lab[1], lab @ left / math.sqrt(2.0)])
        assert np.all(np.abs(command) <= 1.0)
        back = steering_to_lab(torch.as_tensor(obs, dtype=torch.float64), torch.as_tensor(command), start)
        np.testing.assert_allclose(back.numpy(), lab, atol=1e-6)  # float32 heading


def test_turning_the_whole_scene_about_the_vertical_turns_the_steering_actor_s_answer(walked):
    """Equivariance, what the steering actor is for: the same robot-frame situation at another
    heading (the field turned with the robot) gets the same answer, turned with it."""
    env, _, seen = walked
    layout, (obs, field) = env.layout, seen[-1]
    start = steering_start(layout)
    torch.manual_seed(0)
    actor = Actor(len(obs), 3, (32, 32), start)

    def turned(angle: float) -> np.ndarray:
        out = np.array(obs, dtype=np.float64)
        c, s = out[layout["heading"]]
        heading = math.atan2(s, c) + angle
        out[layout["heading"]] = math.cos(heading), math.sin(heading)
        # a turn by +angle about +y (counter-clockwise seen from above): x, z -> rotated
        rot = np.array([[math.cos(angle), 0.0, math.sin(angle)], [0.0, 1.0, 0.0],
                        [-math.sin(angle), 0.0, math.cos(angle)]])
        b = rot @ field
        out[layout["field_amplitude"]] = 200.0 * math.hypot(b[0], b[1])
        out[layout["field_angle"]] = math.atan2(b[1], b[0])
        out[layout["field_z"]] = 200.0 * b[2]
        return out, rot

    base, _ = turned(0.0)
    compared = 0
    with torch.no_grad():
        answer = actor(torch.as_tensor(base[None], dtype=torch.float32)).double().numpy()[0]
        for angle in (0.3, 1.7, -2.5):
            other, rot = turned(angle)
            got = actor(torch.as_tensor(other[None], dtype=torch.float32)).double().numpy()[0]
            if np.all(np.abs(rot @ answer) < 0.999):  # no clipping in the lab's frame
                np.testing.assert_allclose(got, rot @ answer, atol=2e-5)
                compared += 1
    assert compared == 3 and np.any(np.abs(answer) > 1e-3)


def test_a_steering_actor_is_rebuilt_from_its_state(walked):
    env, _, seen = walked
    obs = torch.as_tensor(np.stack([o for o, _ in seen[::10]]))
    torch.manual_seed(1)
    actor = Actor(obs.shape[1], 3, (16, 16), steering_start(env.layout))
    state = actor.state_dict()
    assert int(state["steering_start"]) == steering_start(env.layout)
    again = actor_from_state(obs.shape[1], 3, (16, 16), state)
    again.load_state_dict(state)
    loaded, _ = networks_from_state(obs.shape[1], 3, (16, 16), state, None)
    with torch.no_grad():
        torch.testing.assert_close(again(obs), actor(obs), rtol=0, atol=0)
        torch.testing.assert_close(loaded(obs), actor(obs), rtol=0, atol=0)
    plain = Actor(obs.shape[1], 3, (16, 16)).state_dict()  # an observation actor stays one
    assert not actor_from_state(obs.shape[1], 3, (16, 16), plain).steering


def test_the_stacked_learner_acts_and_clones_as_its_saved_actors(walked):
    env, law, seen = walked
    obs = np.stack([o for o, _ in seen]).astype(np.float32)
    labels = np.stack([law.label(o) for o in obs]).astype(np.float32)
    configs = [TD3Config(seed=s, hidden_sizes=(32, 32), batch_size=64, actor_input="steering")
               for s in (0, 1)]
    learner = TD3(obs.shape[1], 3, -np.ones(3), np.ones(3), configs)
    assert learner.actor_net.sizes[0] == STEERING_FEATURES
    acted = learner.select_actions(np.stack([obs[:20], obs[20:40]]), explore=False)
    for k in (0, 1):
        with torch.no_grad():
            alone = learner.actor_module(k)(torch.as_tensor(obs[20 * k: 20 * k + 20])).numpy()
        np.testing.assert_allclose(acted[k], alone, atol=1e-6)
    batch = Batch(obs, labels, np.zeros((len(obs), 1), np.float32), obs, np.zeros((len(obs), 1), np.float32))
    first = learner.clone_step([batch, batch]).numpy()
    for _ in range(300):
        last = learner.clone_step([batch, batch]).numpy()
    assert np.all(last < 0.3 * first), (first, last)


def test_layouts_without_the_steering_blocks_are_refused_by_name():
    planar = observation_layout(64, ())  # the paper's crawl: no heading, no target, no field_z
    with pytest.raises(ValueError, match="heading"):
        steering_start(planar)
    case = load_case("m1-4mT-goto")
    blocks = (*case.actuation.observation_blocks, *case.task.extra_observation)
    assert steering_start(observation_layout(64, blocks)) == 4 * 64 + 4 - 2
    with pytest.raises(ValueError, match="actor_input"):
        TD3Config(actor_input="robot")
    assert TD3Config.parse_setting("actor_input", "steering") == "steering"
    with pytest.raises(ValueError, match="observation or steering"):
        TD3Config.parse_setting("actor_input", "robot-frame")


def test_training_a_case_that_cannot_steer_with_a_steering_actor_is_refused_before_any_work(tmp_path):
    from elastica_magnetic_rl.sweep.training import train_cases

    out = tmp_path / "runs"
    with pytest.raises(ValueError, match="case m1-4mT has the crawl task"):
        train_cases(["m1-4mT"], seeds=1, steps=50, out=out, progress=False,
                    config_overrides={"actor_input": "steering", "learning_starts": 10})
    assert not out.exists() or not any(out.rglob("checkpoint.pt"))
