"""Round 17 of held-out tries (issue 48): options that could not act refused by name."""

from __future__ import annotations

import pytest

from elastica_magnetic.cli import main as msr


@pytest.mark.parametrize("option, value, message", [
    ("--repeats", "5", "--repeats 5: --quick measures at most 1"),
    ("--steps", "1000000000", "--steps 1000000000: --quick measures at most 200"),
])
def test_bench_quick_refuses_sizes_it_would_ignore(capsys, option, value, message):
    """Round 17 S: `msr bench --quick --repeats 5 --steps 1e9` measured once, 200 steps, without
    a word."""
    assert msr(["bench", "--quick", "--train-seeds", "0", option, value]) == 2
    assert message in capsys.readouterr().err
