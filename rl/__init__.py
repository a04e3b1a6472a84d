"""Reinforcement learning of the crawling robot: a Gymnasium environment and a PyTorch TD3 agent.

Installed as ``elastica_magnetic_rl`` (the repository's ``rl/`` folder). Importing it registers the
environment ``MagneticCrawler-v0`` with Gymnasium (the physics and torch are imported only when an
environment or agent is built)::

    import gymnasium as gym
    import elastica_magnetic_rl  # noqa: F401  (registers MagneticCrawler-v0)

    env = gym.make("MagneticCrawler-v0", pattern=1, field_limit=4e-3, physics="training")

Modules: ``env`` (environment), ``vector_env`` (N crawlers in one batched simulator, a Gymnasium
vector environment), ``td3`` (the algorithm), ``runner`` (the training loop), ``training``
(``msr train`` / ``msr refine``), ``pipeline`` (generate, ship, export), ``baselines`` (a
hand-designed rotating field to compare with), ``figures`` (figures), ``cli`` (``msr``
sub-commands).
"""

from gymnasium.envs.registration import register as _register
from gymnasium.envs.registration import registry as _registry

ENV_ID = "MagneticCrawler-v0"

if ENV_ID not in _registry:
    # The time limit is enforced (as a truncation) by the environment's own ``duration`` option.
    _register(id=ENV_ID, entry_point="elastica_magnetic_rl.env:MagneticCrawlerEnv")

__all__ = ["ENV_ID"]
