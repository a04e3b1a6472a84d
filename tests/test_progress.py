"""Progress reporting: a tqdm bar on a terminal, sparse plain lines when the output is a file."""

from __future__ import annotations

import io

import pytest

from elastica_magnetic.progress import PlainProgress, progress_bar


class FakeClock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


class TTY(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_plain_lines_every_ten_percent_not_every_update():
    out, clock = io.StringIO(), FakeClock()
    bar = PlainProgress(1000, "simulate", "x10ms", stream=out, every_percent=10, every_s=1e9,
                        clock=clock)
    for _ in range(1000):
        clock.t += 0.01
        bar.update(1)
    bar.close()
    lines = out.getvalue().splitlines()
    assert len(lines) == 10  # 10 %, 20 %, ..., 100 % (closing repeats no line)
    assert lines[0] == "simulate: 10% (100/1000 x10ms), 1 s elapsed, ~9 s left"
    assert lines[-1] == "simulate: 100% (1000/1000 x10ms), 10 s elapsed"


def test_plain_lines_at_least_every_every_s_and_postfix():
    out, clock = io.StringIO(), FakeClock()
    with PlainProgress(10_000, "train", "step", stream=out, every_percent=50, every_s=60,
                       clock=clock, initial=2000) as bar:
        bar.set_postfix(ep=3, ret="1.5", refresh=False)
        for _ in range(10):  # 10 updates of one step, 30 s apart: a line each 60 s
            clock.t += 30.0
            bar.update(1)
    lines = out.getvalue().splitlines()
    assert len(lines) == 5  # one per 60 s (the last is the closing state)
    assert lines[0] == "train: 20% (2002/10000 step), 1 min 00 s elapsed, ~66 h 39 min left, ep=3, ret=1.5"


def test_progress_bar_chooses_by_terminal_and_disable():
    from tqdm import tqdm

    tty = TTY()
    bar = progress_bar(10, "x", stream=tty, leave=False)
    assert isinstance(bar, tqdm)
    bar.close()
    plain = progress_bar(10, "x", stream=io.StringIO(), leave=False)
    assert isinstance(plain, PlainProgress)
    silent = io.StringIO()
    off = progress_bar(10, "x", stream=silent, disable=True)
    off.update(10)
    off.close()
    assert silent.getvalue() == ""
    with pytest.raises(ValueError, match="every_percent"):
        PlainProgress(10, every_percent=0)


def test_setting_n_and_refreshing_often_still_gives_sparse_lines():
    """msr field replay/simulate set ``n`` and refresh every 20 steps, as for a tqdm bar."""
    out, clock = io.StringIO(), FakeClock()
    bar = PlainProgress(1000, "replay", "x10ms", stream=out, clock=clock)
    for done in range(1, 1001):
        clock.t += 0.01
        bar.n = done
        if done % 20 == 0:
            bar.refresh()
    bar.close()
    assert len(out.getvalue().splitlines()) == 10
    bar.refresh(force=True)
    assert len(out.getvalue().splitlines()) == 11
