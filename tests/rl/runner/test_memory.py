"""The memory probes (rl/runner/memory.py): this process's peak, a process tree's current memory."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from elastica_magnetic_rl.runner.memory import peak_rss_bytes, process_tree_rss


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="getrusage and /proc as on Linux")
def test_peak_memory_grows_with_an_allocation_touched():
    before = peak_rss_bytes()
    block = np.ones(64 * 1024 * 1024 // 8)  # 64 MiB, every page touched
    after = peak_rss_bytes()
    assert block.sum() > 0
    assert after >= before and after >= 64 * 1024 * 1024


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc")
def test_process_tree_memory_counts_a_child():
    alone = process_tree_rss(os.getpid())
    assert alone > 0
    child = subprocess.Popen([sys.executable, "-c", "import sys, numpy as np; a = np.ones(2**24);"
                              " print(a.sum(), flush=True); sys.stdin.read()"],
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        child.stdout.readline()  # its 128 MiB array is touched
        with_child = process_tree_rss(os.getpid())
        assert with_child - alone > 100 * 1024 * 1024
    finally:
        child.stdin.close()
        child.wait(timeout=30)
