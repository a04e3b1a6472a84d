"""The steering actor's view of a goto case: what it reads of the observation, in the robot's own
frame, and how its command is turned back into the lab's field increments (torch, any leading
shape, so that acting, the stacked updates and the exported policy compute the same numbers).

Why: a goto policy's job is the same whatever way the robot faces (bring the target abeam, turn
the field in a plane toward it). The observation and the action are in the lab's frame, so an
actor that reads them must learn the same manoeuvre once per heading, a product of the heading
with the field that a small network fits badly: clones of the steering law in the lab's frame
reached 0-1 of 12 ring targets, in the robot's frame 3 of 12, and reading only the steering
state below 5 of 12 before DAgger (the package's benchmark log, 2026-12-05/06). So the steering
actor

- reads :data:`STEERING_FEATURES` values: the field in the robot's frame (forward, up, left;
  200 per T, as the observation's amplitude), the target's offset (forward, left; 100 per m, as
  the observation) and its distance, and the observation's clock (cos, sin); the body's
  angular velocities, orientations, heights and contacts are left to the critics, which read the
  whole observation;
- answers field increments along forward, up and left, which are turned into the lab's x, y, z by
  the observed heading: ``a_x = sqrt(2) (f cos h - l sin h)``, ``a_y = u``,
  ``a_z = -sqrt(2) (f sin h + l cos h)``, each clipped to [-1, 1] (the ``sqrt(2)`` lets a command
  along a diagonal of the robot reach the lab's full increment on both axes).

It needs the goto task's observation with three axes: its last :data:`STEERING_BLOCK` entries are
``field_amplitude``, ``field_angle``, ``field_z``, ``heading`` (2), ``target_offset`` (2) and
``clock`` (2) (:func:`steering_start` checks a layout).

A steering actor may be made **mirror-symmetric** (``actor_mirror``, :func:`mirror_symmetric`): a
robot whose magnetization has no z component is its own mirror image through its vertical plane
(z -> -z: the heading's sine, the field's left component and the target's left offset change sign,
the rest not), so the best command for a state's mirror image is the mirror image (the left
component negated) of the best command for the state. The symmetric actor answers
``(g(x) + M g(M x)) / 2`` before its ``tanh``, ``M`` the mirror of the features or of the command:
it learns a manoeuvre once for both sides, and for a state that is its own mirror image (a straight
robot, no left field, the target straight ahead or behind) its left command is exactly 0, so that
it cannot tip a tumble that the symmetric field keeps straight.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import torch

__all__ = ["MIRROR_COMMAND", "MIRROR_FEATURES", "STEERING_BLOCK", "STEERING_FEATURES", "mirror_symmetric",
           "steering_features", "steering_start", "steering_to_lab"]

#: The observation's entries the steering actor reads: its last ones, from ``field_amplitude``.
STEERING_BLOCK = 9
#: The steering actor's inputs: field forward, up, left; target forward, left, distance; clock cos, sin.
STEERING_FEATURES = 8
#: The blocks the steering actor reads, in the observation's order (name, size).
STEERING_BLOCKS = (("field_amplitude", 1), ("field_angle", 1), ("field_z", 1), ("heading", 2),
                   ("target_offset", 2), ("clock", 2))

#: The mirror image z -> -z of the steering features (field forward, up, left; target forward,
#: left, distance; clock cos, sin): the left components change sign.
MIRROR_FEATURES = (1.0, 1.0, -1.0, 1.0, -1.0, 1.0, 1.0, 1.0)
#: The mirror image of a steering command (forward, up, left).
MIRROR_COMMAND = (1.0, 1.0, -1.0)

_SQRT2 = math.sqrt(2.0)


def steering_start(layout: dict[str, slice]) -> int:
    """The index of ``field_amplitude`` in an observation ``layout`` whose last blocks are
    :data:`STEERING_BLOCKS` (a goto case with three axes); a ``ValueError`` naming what is missing
    otherwise."""
    names = list(layout)
    tail = [(name, layout[name].stop - layout[name].start) for name in names[-len(STEERING_BLOCKS):]]
    if tail != list(STEERING_BLOCKS):
        missing = [name for name, _ in STEERING_BLOCKS if name not in layout]
        why = (f"it has no {', '.join(missing)}" if missing else
               f"its last blocks are {', '.join(n for n, _ in tail)}")
        raise ValueError("actor_input = 'steering' reads the field in three axes, the robot's heading, "
                         f"its target and the clock of a goto case with [actuation] axes = \"xyz\": {why}")
    return layout["field_amplitude"].start


def steering_features(obs: torch.Tensor, start: int) -> torch.Tensor:
    """The steering actor's inputs ``(..., STEERING_FEATURES)`` from observations ``(..., obs_dim)``
    whose steering blocks begin at ``start`` (see the module docstring)."""
    amplitude, angle, field_z = obs[..., start], obs[..., start + 1], obs[..., start + 2]
    cos_h, sin_h = obs[..., start + 3], obs[..., start + 4]
    forward, left = obs[..., start + 5], obs[..., start + 6]
    field_x, field_y = amplitude * torch.cos(angle), amplitude * torch.sin(angle)
    return torch.stack([field_x * cos_h - field_z * sin_h, field_y, -field_x * sin_h - field_z * cos_h,
                        forward, left, torch.sqrt(forward * forward + left * left),
                        obs[..., start + 7], obs[..., start + 8]], dim=-1)


def steering_to_lab(obs: torch.Tensor, command: torch.Tensor, start: int) -> torch.Tensor:
    """Field increments along the lab's x, y, z ``(..., 3)`` in [-1, 1] from the steering actor's
    ``command`` ``(..., 3)`` (forward, up, left, in [-1, 1]) and the heading the observations
    ``(..., obs_dim)`` show."""
    cos_h, sin_h = obs[..., start + 3], obs[..., start + 4]
    forward, up, left = command[..., 0], command[..., 1], command[..., 2]
    lab = torch.stack([_SQRT2 * (forward * cos_h - left * sin_h), up,
                       -_SQRT2 * (forward * sin_h + left * cos_h)], dim=-1)
    return lab.clamp(-1.0, 1.0)


def mirror_symmetric(net: Callable[[torch.Tensor], torch.Tensor], features: torch.Tensor) -> torch.Tensor:
    """The mirror-symmetric part ``(g(x) + M g(M x)) / 2`` of a steering network ``g`` (pre-``tanh``
    commands ``(..., 3)`` from features ``(..., STEERING_FEATURES)``) at ``features`` ``x``, ``M``
    :data:`MIRROR_FEATURES` on the features and :data:`MIRROR_COMMAND` on the commands (see the
    module docstring). The two images go through ``net`` in two calls of one shape, so that where
    ``M x == x`` they come out bit for bit alike and the left command is exactly 0."""
    flip_in = torch.tensor(MIRROR_FEATURES, dtype=features.dtype, device=features.device)
    direct, mirrored = net(features), net(features * flip_in)
    flip_out = torch.tensor(MIRROR_COMMAND, dtype=mirrored.dtype, device=mirrored.device)
    return 0.5 * (direct + mirrored * flip_out)
