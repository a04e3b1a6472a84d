"""Domain randomization in the vector environment: each episode of each crawler runs on a robot
drawn from the case's variations (reproducibly, from the sub-environment's generator), built like
any spec in the run's physics; states save and restore each robot's draw; evaluations (an
environment without ``randomize``) keep the nominal robot."""

from __future__ import annotations

import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.cases.variations import default_variations, parse_variation
from elastica_magnetic_rl.envs.randomization import RobotRandomizer
from elastica_magnetic_rl.envs.vector_env import MagneticCrawlerVectorEnv

CASE = "m1-4mT"
DURATION = 0.03  # s: 3 steps per episode, so a few steps cross autoresets (new draws)


def _variations():
    return default_variations(load_case(CASE).robot.tables)


def _env(n=3, randomize=True):
    return MagneticCrawlerVectorEnv(n, case=CASE, duration=DURATION,
                                    randomize=_variations() if randomize else None)


def test_each_crawler_gets_its_own_robot_drawn_in_the_ranges():
    env = _env(3)
    env.reset(seed=5)
    nominal = load_case(CASE).robot_spec("training")
    settings = env.robot_settings
    assert len({tuple(s.values()) for s in settings}) == 3  # three different robots
    for i, s in enumerate(settings):
        for v in _variations():
            assert v.low <= s[v.name] <= v.high
        spec = env.robots.specs[i]
        assert spec.youngs_modulus == pytest.approx(nominal.youngs_modulus * s["modulus"], rel=1e-12)
        assert spec.ground.kinetic_mu == pytest.approx(nominal.ground.kinetic_mu * s["friction"])
        rod = env.robots.rod(i)  # the block holds the drawn robot's masses
        assert rod.mass.sum() == pytest.approx(env.robots.rods[i].volume.sum()
                                               * nominal.effective_density * s["density"], rel=1e-9)
    # an environment without randomize stays nominal (what evaluations use)
    plain = _env(3, randomize=False)
    plain.reset(seed=5)
    assert all(s is None for s in plain.robot_settings)
    assert all(spec == nominal for spec in plain.robots.specs)


def test_draws_are_reproducible_and_renewed_at_each_episode():
    a, b = _env(2), _env(2)
    a.reset(seed=11)
    b.reset(seed=11)
    assert a.robot_settings == b.robot_settings
    first = [dict(s) for s in a.robot_settings]
    actions = np.zeros((2, 2), dtype=np.float32)
    for _ in range(3):  # the episodes end: autoreset draws new robots
        obs_a = a.step(actions)[0]
        obs_b = b.step(actions)[0]
        assert np.array_equal(obs_a, obs_b)
    assert a.robot_settings == b.robot_settings
    assert all(new != old for new, old in zip(a.robot_settings, first, strict=True))


def test_state_roundtrip_restores_each_robot_and_continues_bit_for_bit():
    env = _env(2)
    env.reset(seed=3)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, size=(6, 2, 2)).astype(np.float32)
    for k in range(2):
        env.step(actions[k])
    state = env.get_state()
    assert state["robot_settings"].shape == (2, len(_variations()))
    expected = [env.step(actions[k]) for k in range(2, 6)]  # crosses autoresets
    other = _env(2)
    other.reset(seed=99)  # other robots
    other.set_state(state)
    for k, exp in zip(range(2, 6), expected, strict=True):
        got = other.step(actions[k])
        for x, y in zip(got[:4], exp[:4], strict=True):
            assert np.array_equal(x, y)
    with pytest.raises(ValueError, match="randomized"):
        plain = _env(2, randomize=False)
        plain.reset(seed=0)
        plain.set_state(state)


def test_a_randomized_robot_moves_as_its_own_nominal_environment():
    """Robot 0 of a randomized env follows the same trajectory as an unrandomized env whose case
    IS that robot: the draw changes the robot, nothing else."""
    env = _env(1)
    env.reset(seed=2, options={"initial_field": "zero"})
    settings = env.robot_settings[0]
    case = load_case(CASE)
    from elastica_magnetic_rl.cases.case import case_from_dict
    from elastica_magnetic_rl.cases.variations import Variant, apply_variant

    varied = apply_variant(case.to_dict(), _variations(), Variant("x", "sample", settings))
    twin = MagneticCrawlerVectorEnv(1, case=case_from_dict(varied, "varied"), duration=1.0)
    twin.reset(seed=2, options={"initial_field": "zero"})
    env_long = MagneticCrawlerVectorEnv(1, case=CASE, duration=1.0, randomize=_variations())
    env_long.reset(seed=2, options={"initial_field": "zero"})
    assert env_long.robot_settings[0] == settings
    action = np.array([[1.0, 0.5]], dtype=np.float32)
    for _ in range(5):
        o1 = env_long.step(action)[0]
        o2 = twin.step(action)[0]
    assert np.array_equal(o1, o2)


def test_randomizer_refuses_what_it_cannot_do():
    with pytest.raises(ValueError, match="needs a case"):
        MagneticCrawlerVectorEnv(1, duration=DURATION, randomize=_variations())
    tables = load_case(CASE).robot.tables
    randomizer = RobotRandomizer(tables, [parse_variation("robot.density=0.5:0.6")], "training")
    with pytest.raises(ValueError, match="expected 1 settings"):
        randomizer.from_array([1.0, 2.0])


def test_a_spec_accepting_a_key_of_another_table_randomizes_its_robot():
    """A crawl whose ``[checks] accept`` names a key outside the robot (``yardstick.period``: msr loop
    accepts a sweep's period faster than the rate limit turns) with ``[training] randomize``: the
    ranges' ends and every drawn robot were read again with the robot's tables alone, where that
    key names nothing, and the training failed ("'yardstick.period' names no key of this spec")."""
    from elastica_magnetic_rl.cases.case import case_from_dict

    data = load_case("m1-4mT").to_dict()
    data["yardstick"].update(period=0.05, clockwise=True)
    data["checks"] = {"accept": ["yardstick.period"]}
    data["training"]["randomize"] = "default"
    case = case_from_dict(case_from_dict(data, "fast-turn.toml").to_dict(), "copy.toml")  # ranges written out
    randomizer = RobotRandomizer(case.robot.tables, case.training.randomize, "training")
    robot = randomizer.robot(randomizer.draw(np.random.default_rng(0)))
    assert robot.n_elements == case.robot_spec("training").n_elements
