"""rl/td3/devices.py: whether this PyTorch can hold the networks on a device (issue 48)."""

from __future__ import annotations

import pytest
import torch
from elastica_magnetic_rl.td3.devices import device_problem


def test_cuda_on_a_cpu_build_of_pytorch_is_named(monkeypatch):
    monkeypatch.setattr(torch.version, "cuda", None)
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    assert device_problem("cuda") == "this PyTorch has no CUDA (CPU build)"
    assert device_problem("cuda:0") == "this PyTorch has no CUDA (CPU build)"
    assert device_problem("cpu") is None


def test_cuda_build_without_a_device_and_a_missing_index_are_named(monkeypatch):
    monkeypatch.setattr(torch.version, "cuda", "12.1")
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    assert device_problem("cuda").startswith("this PyTorch (CUDA 12.1) sees no CUDA device")
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    monkeypatch.setattr(torch.cuda, "device_count", lambda: 1)
    assert device_problem("cuda:0") is None
    assert device_problem("cuda:3") == "this machine has 1 CUDA device(s), numbered from 0"
    assert device_problem("tpu").startswith("not a device PyTorch knows")


def test_torch_threads_are_restored_after_the_block_even_when_it_fails():
    from elastica_magnetic_rl.td3.devices import torch_threads

    before = torch.get_num_threads()
    with pytest.raises(RuntimeError), torch_threads(before + 1):
        assert torch.get_num_threads() == before + 1
        raise RuntimeError("a failed training")
    assert torch.get_num_threads() == before
