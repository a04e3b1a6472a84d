"""The torch threads a training worker takes by default: the cores shared among the workers, no
more than the user's ``OMP_NUM_THREADS``."""

import os

import pytest
from elastica_magnetic_rl.sweep.sweep_plan import _groups_and_workers

LAYOUT = {"workers": 1, "seeds_per_simulator": 2}


def _threads(threads=None, address=None) -> int:
    return _groups_and_workers([0, 1], LAYOUT, 1, threads, address)[2]


@pytest.mark.skipif(len(os.sched_getaffinity(0)) < 2, reason="needs two cores")
def test_one_worker_takes_every_core_unless_omp_num_threads_says_fewer(monkeypatch):
    cores = len(os.sched_getaffinity(0))
    monkeypatch.delenv("OMP_NUM_THREADS", raising=False)
    assert _threads() == cores
    monkeypatch.setenv("OMP_NUM_THREADS", "1")
    assert _threads() == 1
    monkeypatch.setenv("OMP_NUM_THREADS", str(cores + 4))  # more than the cores: the cores
    assert _threads() == cores
    monkeypatch.setenv("OMP_NUM_THREADS", "auto")  # not a count: the cores
    assert _threads() == cores


def test_given_threads_and_a_cluster_are_not_changed_by_omp_num_threads(monkeypatch):
    monkeypatch.setenv("OMP_NUM_THREADS", "1")
    assert _threads(threads=3) == 3
    assert _threads(address="ray://head:10001") == 1
