"""Reinforcement learning of the crawling robot: a Gymnasium environment and a PyTorch TD3 agent.

Importing :mod:`elastica_magnetic_rl` registers the environment ``MagneticCrawler-v0`` with Gymnasium (the physics
and torch are imported only when an environment or agent is built)::

    import gymnasium as gym
    import elastica_magnetic_rl  # noqa: F401  (registers MagneticCrawler-v0)

    env = gym.make("MagneticCrawler-v0", pattern=1, field_limit=4e-3, physics="training")

Modules: :mod:`elastica_magnetic_rl.env` (environment), :mod:`elastica_magnetic_rl.vector_env` (N crawlers in one batched simulator,
a Gymnasium vector environment), :mod:`elastica_magnetic_rl.td3` (agent; ``train`` and ``train_vector``),
:mod:`elastica_magnetic_rl.pipeline` (train, refine, generate, ship, export), :mod:`elastica_magnetic_rl.baselines` (a hand-designed
rotating field to compare with), :mod:`elastica_magnetic_rl.figures` (figures),
:mod:`elastica_magnetic_rl.cli` (``msr`` sub-commands).
"""

from gymnasium.envs.registration import register as _register
from gymnasium.envs.registration import registry as _registry

ENV_ID = "MagneticCrawler-v0"

if ENV_ID not in _registry:
    # The time limit is enforced (as a truncation) by the environment's own ``duration`` option.
    _register(id=ENV_ID, entry_point="elastica_magnetic_rl.env:MagneticCrawlerEnv")

__all__ = ["ENV_ID"]
