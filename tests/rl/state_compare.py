"""Exact comparison of training states (checkpoints, seed states) for the rl tests."""

from __future__ import annotations

import torch


def assert_state_equal(a, b, path: str = "state") -> None:
    """Assert two nested states (dicts, lists, tensors, numbers) are equal, tensors bit for bit;
    the message names the first differing key path."""
    if isinstance(a, torch.Tensor):
        assert torch.equal(a, b), path
    elif isinstance(a, dict):
        assert a.keys() == b.keys(), path
        for k in a:
            assert_state_equal(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list | tuple):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            assert_state_equal(x, y, f"{path}[{i}]")
    else:
        assert a == b, path
