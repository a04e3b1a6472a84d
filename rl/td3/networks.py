"""One seed's networks as plain PyTorch modules: the actor ``mu(s) = tanh(MLP(s))``, the twin critic,
the actor scaled onto the environment's action box, and their loading from saved weights with a clear
error. :class:`~elastica_magnetic_rl.td3.algorithm.TD3` trains them stacked
(:class:`~elastica_magnetic_rl.td3.stacked.StackedMLP`); these are what acting, evaluation, diagnosis and
export use.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch
import torch.nn as nn

from .steering_inputs import (
    STEERING_BLOCK,
    STEERING_FEATURES,
    mirror_symmetric,
    steering_features,
    steering_to_lab,
)

__all__ = ["Actor", "ScaledPolicy", "TwinCritic", "actor_from_state", "mlp", "networks_from_state"]


def mlp(in_dim: int, out_dim: int, hidden_sizes: tuple[int, ...],
        layer_norm: bool = False) -> nn.Sequential:
    """Linear-ReLU-...-Linear (Linear-LayerNorm-ReLU-... with ``layer_norm``) with PyTorch's
    default initialisation (Kaiming-uniform linear layers, unit gain and zero bias of the norms)."""
    layers: list[nn.Module] = []
    d = in_dim
    for h in hidden_sizes:
        layers += [nn.Linear(d, h), nn.LayerNorm(h), nn.ReLU()] if layer_norm else \
            [nn.Linear(d, h), nn.ReLU()]
        d = h
    layers.append(nn.Linear(d, out_dim))
    return nn.Sequential(*layers)


class Actor(nn.Module):
    """Deterministic policy ``mu(s) = tanh(MLP(s))`` in normalised action units [-1, 1] (one
    seed's actor as a plain module: for acting, evaluation and export).

    With ``steering_start`` (a goto case's steering actor, ``actor_input = "steering"``): ``mu(s) =
    lab(s, tanh(MLP(features(s))))``, the features and the turn into the lab's frame of
    :mod:`~elastica_magnetic_rl.td3.steering_inputs`; the index is kept in the state dict
    (``steering_start``), so that :func:`actor_from_state` rebuilds the same actor. With ``mirror``
    as well (``actor_mirror``): the MLP's mirror-symmetric part
    (:func:`~elastica_magnetic_rl.td3.steering_inputs.mirror_symmetric`), kept in the state dict as
    ``steering_mirror``."""

    def __init__(self, obs_dim: int, act_dim: int, hidden_sizes: tuple[int, ...],
                 steering_start: int | None = None, mirror: bool = False) -> None:
        super().__init__()
        self.steering = steering_start is not None
        if mirror and not self.steering:
            raise ValueError("a mirror-symmetric actor is a steering actor: give its steering_start")
        self.mirror = bool(mirror)
        if self.mirror:
            self.register_buffer("steering_mirror", torch.tensor(1))
        if self.steering:
            if act_dim != 3 or not 0 <= int(steering_start) <= obs_dim - STEERING_BLOCK:
                raise ValueError(f"a steering actor answers 3 field increments and reads the last "
                                 f"{STEERING_BLOCK} of the observation's entries: got {act_dim} actions, "
                                 f"start {steering_start} of {obs_dim}")
            self.register_buffer("steering_start", torch.tensor(int(steering_start)))
            self.start = int(steering_start)  # a plain int: traced and exported as the constant it is
        self.net = mlp(STEERING_FEATURES if self.steering else obs_dim, act_dim, hidden_sizes)

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        if not self.steering:
            return torch.tanh(self.net(obs))
        features = steering_features(obs, self.start)
        pre = mirror_symmetric(self.net, features) if self.mirror else self.net(features)
        return steering_to_lab(obs, torch.tanh(pre), self.start)


def actor_from_state(obs_dim: int, act_dim: int, hidden_sizes: tuple[int, ...], state: dict) -> Actor:
    """An :class:`Actor` of the kind ``state`` (its state dict) was saved from, not yet loaded: a
    steering actor where it holds ``steering_start``, mirror-symmetric where ``steering_mirror``."""
    start = state.get("steering_start") if isinstance(state, dict) else None
    mirror = isinstance(state, dict) and "steering_mirror" in state
    return Actor(obs_dim, act_dim, hidden_sizes, None if start is None else int(start), mirror)


class TwinCritic(nn.Module):
    """Two independent Q networks ``Q_i(s, a) = MLP_i([s, a])`` (one seed's, as plain modules;
    ``layer_norm``: :attr:`~elastica_magnetic_rl.td3.config.TD3Config.critic_layer_norm`)."""

    def __init__(self, obs_dim: int, act_dim: int, hidden_sizes: tuple[int, ...],
                 layer_norm: bool = False) -> None:
        super().__init__()
        self.q1_net = mlp(obs_dim + act_dim, 1, hidden_sizes, layer_norm)
        self.q2_net = mlp(obs_dim + act_dim, 1, hidden_sizes, layer_norm)

    def forward(self, obs: torch.Tensor, act: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        x = torch.cat([obs, act], dim=-1)
        return self.q1_net(x), self.q2_net(x)

    def q1(self, obs: torch.Tensor, act: torch.Tensor) -> torch.Tensor:
        return self.q1_net(torch.cat([obs, act], dim=-1))


def networks_from_state(obs_dim: int, act_dim: int, hidden: tuple[int, ...], actor_state: dict,
                        critic_state: dict | None, source: Any = None,
                        critic_layer_norm: bool = False,
                        critic_hidden: tuple[int, ...] | None = None) -> tuple[Actor, TwinCritic | None]:
    """The actor (hidden widths ``hidden``) and the twin critic when ``critic_state`` is given
    (``critic_hidden``, default ``hidden``) loaded with ``actor_state``/``critic_state``, in eval
    mode and without gradients. Weights that do not fit
    the architecture (``obs_dim``, ``act_dim``, ``hidden``) raise a ``ValueError`` naming
    ``source`` (the file they came from)."""

    def load(network: nn.Module, state: dict, what: str) -> nn.Module:
        try:
            network.load_state_dict(state)
        except (RuntimeError, KeyError, TypeError, AttributeError) as exc:
            first = str(exc).strip().splitlines()
            raise ValueError(
                f"{source}: the {what} weights do not fit the architecture it declares "
                f"(observations {obs_dim}, actions {act_dim}, hidden sizes {list(hidden)}): "
                f"{' '.join(first[1:3] or first)[:300]}"
            ) from None
        return network.eval().requires_grad_(False)

    actor = load(actor_from_state(obs_dim, act_dim, hidden, actor_state), actor_state, "actor")
    critic = None
    if critic_state is not None:
        critic = load(TwinCritic(obs_dim, act_dim, critic_hidden or hidden, critic_layer_norm),
                      critic_state, "critic")
    return actor, critic


class ScaledPolicy(nn.Module):
    """Actor followed by the affine map onto the environment's action box (for export)."""

    def __init__(self, actor: Actor, low: np.ndarray, high: np.ndarray) -> None:
        super().__init__()
        self.actor = actor
        self.register_buffer("scale", torch.as_tensor((high - low) / 2.0, dtype=torch.float32))
        self.register_buffer("center", torch.as_tensor((high + low) / 2.0, dtype=torch.float32))

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return self.center + self.scale * self.actor(obs)
