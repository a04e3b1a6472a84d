"""What a model card says of a residual policy (the case's yardstick corrected by the actor,
:attr:`~elastica_magnetic_rl.td3.config.TD3Config.residual`): how its action is made and how to play
it, the same on every kind of card."""

from __future__ import annotations

from typing import Any

__all__ = ["residual_use_lines"]


def residual_use_lines(info: dict[str, Any]) -> list[str]:
    """The card's "Use" lines of a residual policy described by ``info`` (its ``policy.json``);
    none for a policy whose actor is the whole policy."""
    residual = float(info["architecture"].get("residual", 0.0))
    if not residual:
        return []
    return [f"- A residual policy: the action played is the case's yardstick's command plus {residual:g} x "
            "the actor's output, clipped to [-1, 1] (`architecture.residual`; docs/training.md, \"Correcting "
            "the yardstick\"). The yardstick is a controller with a memory, not a network, so `msr policy "
            f"export` refuses it: play it with `msr policy generate` or `resolve_policy(\"{info['name']}\")"
            ".act(obs)` in Python (`reset()` at each episode), which compose the two."]
