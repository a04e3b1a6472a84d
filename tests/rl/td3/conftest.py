"""Shared fixtures of the TD3 tests."""

from __future__ import annotations

import pytest
from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.envs.env import MagneticCrawlerEnv
from elastica_magnetic_rl.envs.yardsticks import SteeringFieldPolicy


@pytest.fixture(scope="module")
def walked():
    """A goto robot 1.5 s into the steering law's walk toward a target abeam (training physics):
    its environment and observations along the way."""
    case = load_case("m1-4mT-goto")
    env = MagneticCrawlerEnv(case=case, physics="training", initial_field="zero", duration=30.0)
    obs, _ = env.reset(seed=3, options={"target": (0.004, 0.015)})
    law = SteeringFieldPolicy(case, markov=True)
    seen = []
    for _ in range(150):
        obs, *_ = env.step(law.act(obs))
        seen.append((obs, env.field.value.copy()))
    return env, law, seen
