"""Residual learning's environments and controller (rl/envs/residual.py): a zero correction plays the
case's yardstick bit for bit (goto, crawl and catheter cases, with autoresets, partial resets and a
saved state), a correction moves the command by its weight and is clipped, the single environment,
the vector one and the controller play the same actions, and a case without a yardstick is refused
by name."""

from __future__ import annotations

import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.envs.env import make_env
from elastica_magnetic_rl.envs.residual import (
    ResidualController,
    ResidualEnv,
    ResidualVectorEnv,
    residual_action,
    residual_base,
    residual_vector_env,
)
from elastica_magnetic_rl.envs.vector_env import make_vector_env


def test_the_played_action_is_the_command_plus_the_weighted_correction_clipped():
    command = np.array([0.2, -0.9, 1.0])
    correction = np.array([0.5, -1.0, 0.4])
    np.testing.assert_allclose(residual_action(command, correction, 0.5), [0.45, -1.0, 1.0], atol=1e-7)
    np.testing.assert_array_equal(residual_action(command, np.zeros(3), 2.0), command)


def _yardstick_returns(case, seeds, steps, duration):
    """The case's yardstick alone on a plain vector environment: returns per sub-environment and the
    observations of the last step."""
    env = make_vector_env(case, len(seeds), physics="training", initial_field="zero", duration=duration)
    bases = [residual_base(case)() for _ in seeds]
    obs, _ = env.reset(seed=list(seeds))
    total = np.zeros(len(seeds))
    for _ in range(steps):
        actions = np.stack([b.act(o) for b, o in zip(bases, obs, strict=True)])
        obs, rewards, terminated, truncated, _ = env.step(actions)
        total += rewards
        for i in np.flatnonzero(terminated | truncated):
            bases[i].reset()
    env.close()
    return total, obs


@pytest.mark.parametrize("name", ["m1-4mT-goto", "m1-4mT-designed", "catheter-magnet-reach"])
def test_a_zero_correction_plays_the_yardstick_through_an_autoreset(name):
    case = load_case(name)
    steps, duration = 30, 0.2  # the episodes end at step 20 and start again
    expected, last = _yardstick_returns(case, (3, 4), steps, duration)
    env = residual_vector_env(make_vector_env, case, 0.7, case, 2, physics="training", initial_field="zero",
                              duration=duration)
    env.reset(seed=[3, 4])
    total = np.zeros(2)
    for _ in range(steps):
        obs, rewards, _, _, infos = env.step(np.zeros((2, env.single_action_space.shape[0]), np.float32))
        total += rewards
    np.testing.assert_array_equal(total, expected)
    np.testing.assert_array_equal(obs, last)
    assert infos["played_action"].shape == (2, env.single_action_space.shape[0])


def test_a_saved_state_continues_the_yardstick_s_manoeuvre_exactly():
    """The goto yardstick remembers its manoeuvre: a state saved inside an episode and restored in a
    new environment goes on exactly as the environment it came from."""
    case = load_case("m1-4mT-goto")
    rng = np.random.default_rng(5)
    corrections = rng.uniform(-1, 1, (60, 2, 3)).astype(np.float32)

    def fresh():
        plain = make_vector_env(case, 2, physics="training", initial_field="zero", duration=1.0)
        return ResidualVectorEnv(plain, residual_base(case), 0.3)

    first = fresh()
    first.reset(seed=[1, 2])
    for a in corrections[:30]:
        first.step(a)
    state = first.get_state()
    assert any(s["walking"] is not None for s in state["yardsticks"])  # a manoeuvre under way
    second = fresh()
    second.reset(seed=[0, 0])
    second.set_state(state)
    for a in corrections[30:]:
        one, two = first.step(a), second.step(a)
        np.testing.assert_array_equal(one[0], two[0])
        np.testing.assert_array_equal(one[1], two[1])


def test_a_partial_reset_restarts_only_the_masked_yardsticks():
    case = load_case("m1-4mT-goto")
    env = ResidualVectorEnv(make_vector_env(case, 2, physics="training", initial_field="zero", duration=1.0),
                            residual_base(case), 0.5)
    env.reset(seed=[1, 2])
    for _ in range(10):
        env.step(np.zeros((2, 3), np.float32))
    steps = [b.state()["step"] for b in env.bases]
    env.reset(seed=[7, None], options={"reset_mask": np.array([True, False])})
    assert [b.state()["step"] for b in env.bases] == [0, steps[1]]


def test_the_single_environment_the_vector_one_and_the_controller_play_the_same_actions():
    case = load_case("m1-4mT-goto")

    def correction(obs):  # any function of the observation
        rows = np.atleast_2d(obs)
        return np.tanh(rows[:, -3:] * 3.0).astype(np.float32)

    single = ResidualEnv(make_env(case, "training", "zero", 0.3), residual_base(case), 0.4)
    vector = ResidualVectorEnv(make_vector_env(case, 1, physics="training", initial_field="zero",
                                               duration=0.3), residual_base(case), 0.4)
    plain = make_env(case, "training", "zero", 0.3)
    controller = ResidualController(correction, residual_base(case), 0.4)
    obs_s, _ = single.reset(seed=9)
    obs_v, _ = vector.reset(seed=[9])
    obs_p, _ = plain.reset(seed=9)
    controller.reset()
    for _ in range(25):
        played = controller.act(obs_p)
        obs_p, reward_p, *_ = plain.step(played)
        obs_s, reward_s, _, _, info_s = single.step(correction(obs_s)[0])
        obs_v, reward_v, _, _, info_v = vector.step(correction(obs_v))
        np.testing.assert_array_equal(info_s["played_action"], played)
        np.testing.assert_array_equal(info_v["played_action"][0], played)
        np.testing.assert_array_equal(obs_s, obs_p)
        np.testing.assert_array_equal(obs_v[0], obs_p)
        assert reward_s == reward_p == reward_v[0]
    assert np.abs(played - ResidualController(lambda o: np.zeros((len(o), 3)), residual_base(case), 0.4)
                  .act(obs_p)).max() > 0.0  # the correction did change the command


def test_a_case_without_a_yardstick_is_refused_by_name():
    with pytest.raises(ValueError, match="corrects the case's yardstick.*'hu2018-crawl' has none"):
        residual_base(load_case("hu2018-crawl"))  # its [yardstick] records no rotating field's period
