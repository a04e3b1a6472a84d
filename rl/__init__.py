"""Reinforcement learning of the crawling robot: a Gymnasium environment and a PyTorch TD3 agent.

Importing :mod:`rl` registers the environment ``MagneticCrawler-v0`` with Gymnasium (the physics
and torch are imported only when an environment or agent is built)::

    import gymnasium as gym
    import rl  # noqa: F401  (registers MagneticCrawler-v0)

    env = gym.make("MagneticCrawler-v0", pattern=1, field_limit=4e-3, physics="training")

Modules: :mod:`rl.env` (environment), :mod:`rl.vector_env` (N crawlers in one batched simulator,
a Gymnasium vector environment), :mod:`rl.td3` (agent; ``train`` and ``train_vector``),
:mod:`rl.pipeline` (train, refine, generate, ship, export), :mod:`rl.baselines` (a hand-designed
rotating field to compare with), :mod:`rl.figures` (figures),
:mod:`rl.cli` (``msr`` sub-commands).
"""

from gymnasium.envs.registration import register as _register
from gymnasium.envs.registration import registry as _registry

ENV_ID = "MagneticCrawler-v0"

if ENV_ID not in _registry:
    # The time limit is enforced (as a truncation) by the environment's own ``duration`` option.
    _register(id=ENV_ID, entry_point="rl.env:MagneticCrawlerEnv")

__all__ = ["ENV_ID"]
