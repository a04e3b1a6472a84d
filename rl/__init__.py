"""Reinforcement learning of the crawling robot: a Gymnasium environment and a PyTorch TD3 agent.

Installed as ``elastica_magnetic_rl`` (the repository's ``rl/`` folder). Importing it registers the
environment ``MagneticCrawler-v0`` with Gymnasium (the physics and torch are imported only when an
environment or agent is built)::

    import gymnasium as gym
    import elastica_magnetic_rl  # noqa: F401  (registers MagneticCrawler-v0)

    env = gym.make("MagneticCrawler-v0", pattern=1, field_limit=4e-3, physics="training")

Subpackages, from the bottom layer up (each imports only the ones listed before it; the map is
docs/architecture.md):

- ``runfiles``: the files of a training run (the run folder's names, the checkpoint format);
- ``td3``: the algorithm (hyperparameters, networks, the update, replay buffer, exploration);
- ``cases``: what to learn (case spec files, tasks, training recipes);
- ``envs``: the crawler as a Gymnasium environment, single and vector, and recorded rollouts;
- ``runner``: the training loop of K seeds, each seed's bookkeeping, evaluation;
- ``sweep``: ``msr train`` / ``msr refine``: seeds and cases over worker processes or Ray;
- ``reports``: figures, the networks' health (``msr policy diagnose``), benchmarks (``msr bench``);
- ``shipping``: policy files, generate, ship, export, every seed's report, shipped-policy checks;
- ``cli``: the ``msr`` sub-commands (thin wrappers).

Data: ``specs/`` (the cases' spec files) and ``policies/`` (the shipped policies).
"""

from gymnasium.envs.registration import register as _register
from gymnasium.envs.registration import registry as _registry

ENV_ID = "MagneticCrawler-v0"

if ENV_ID not in _registry:
    # The time limit is enforced (as a truncation) by the environment's own ``duration`` option.
    _register(id=ENV_ID, entry_point="elastica_magnetic_rl.envs.env:MagneticCrawlerEnv")

__all__ = ["ENV_ID"]
