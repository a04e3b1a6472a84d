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


def _held_by_a_shipped_policy(folder):
    """A shipped policy holds its folder whole even where its record does not say so (the path
    rule's recognizer; the policy's format is read where it lives, when a folder is judged)."""
    from .shipping.policy_files import shipped_policy_holding

    return shipped_policy_holding(folder)


def _a_seed_export(folder):
    """A seed campaign written before markers is a result of ``msr policy export-seeds`` (the path
    rule's recognizer: nothing goes inside it)."""
    if not (folder / "seeds.json").is_file():  # most folders: judged without loading the policy code
        return None
    from .shipping.seed_export import recognized_seed_export

    return recognized_seed_export(folder)


def _register_recognizers() -> None:
    from elastica_magnetic.result_markers import register_held_recognizer, register_result_recognizer

    register_held_recognizer(_held_by_a_shipped_policy)
    register_result_recognizer(_a_seed_export)


_register_recognizers()

#: What a script needs, importable from the top (``from elastica_magnetic_rl import train_cases``),
#: by concept; each is loaded from its module when first used, so that importing the package stays
#: light (no torch, no physics).
_EXPORTS: dict[str, str] = {
    # environments
    "MagneticCrawlerEnv": "envs.env", "make_env": "envs.env",
    "MagneticCrawlerVectorEnv": "envs.vector_env", "make_vector_env": "envs.vector_env",
    # cases and recipes
    "Case": "cases.case", "load_case": "cases.case",
    "Recipe": "cases.recipes", "RECIPE_LIST": "cases.recipes", "crawler_config": "cases.recipes",
    # the algorithm
    "TD3": "td3.algorithm", "TD3Config": "td3.algorithm",
    # training and refining
    "SweepSettings": "sweep.sweep_settings", "train_case": "sweep.training",
    "train_cases": "sweep.training", "refine": "sweep.refine",
    # policies
    "generate": "shipping.generate", "resolve_policy": "shipping.policy_files",
    "ship": "shipping.ship",
}

__all__ = ["ENV_ID", *_EXPORTS]


def __getattr__(name: str):
    """The names of :data:`_EXPORTS`, imported from their modules on first use (PEP 562)."""
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_EXPORTS})
