"""Progress reporting that suits where the output goes.

On a terminal, :func:`progress_bar` gives a ``tqdm`` bar. When the output is not a terminal (a log
file, a pipe, a batch job), a bar that redraws itself many times a second floods the file, so it
gives a :class:`PlainProgress` instead: one plain line each time another ``every_percent`` of the
work is done or ``every_s`` seconds have passed, whichever comes first, and a last line when it
closes. Both take the same calls (``update``, ``n``, ``refresh``, ``set_postfix``, ``close``,
``with``), so a caller does not need to know which one it got.
"""

from __future__ import annotations

import sys
import time
from typing import Any, TextIO

__all__ = ["PlainProgress", "progress_bar"]


class PlainProgress:
    """A progress reporter that writes sparse plain lines (see the module docstring).

    Parameters
    ----------
    total : int or None
        Units of work in all (``None``: unknown; lines then come every ``every_s`` seconds only).
    desc : str
        What is progressing, at the start of each line.
    unit : str
        Name of one unit of work.
    stream : text stream
        Where the lines go (default: ``sys.stderr``, as tqdm).
    every_percent : float
        A line each time this much more of ``total`` is done, percent in ``(0, 100]``.
    every_s : float
        A line at least this often, s (> 0), whatever the progress.
    initial : int
        Units already done when it starts (a resumed run).
    disable : bool
        Write nothing (the calls still count).
    clock : callable
        Monotonic seconds (for tests).
    """

    def __init__(self, total: int | None, desc: str = "", unit: str = "it", *,
                 stream: TextIO | None = None, every_percent: float = 10.0, every_s: float = 60.0,
                 initial: int = 0, disable: bool = False, clock: Any = time.monotonic) -> None:
        if not 0.0 < every_percent <= 100.0:
            raise ValueError(f"every_percent must be in (0, 100], got {every_percent}")
        if not every_s > 0.0:
            raise ValueError(f"every_s must be > 0 s, got {every_s}")
        self.total, self.desc, self.unit = total, desc, unit
        self.stream = stream
        self.every_percent, self.every_s = float(every_percent), float(every_s)
        self.disable = disable
        self.n = int(initial)
        self.postfix = ""
        self._clock = clock
        self._start = self._last_time = clock()
        self._start_n = self.n
        self._last_step = self._step(self.n)
        self._written_n: int | None = None
        self.closed = False

    def _step(self, n: int) -> int:
        """The ``every_percent`` slice that ``n`` units have reached."""
        if not self.total:
            return 0
        return int(100.0 * n / self.total / self.every_percent + 1e-9)

    def update(self, n: int = 1) -> None:
        """Count ``n`` more units done; write a line if one is due."""
        self.n += int(n)
        self.refresh()

    def refresh(self, force: bool = False) -> None:
        """Write a line if one is due (the next ``every_percent`` slice reached, or ``every_s``
        passed since the last line), or now with ``force``. Callers that set :attr:`n` directly
        and refresh often (as for a tqdm bar) still get sparse lines."""
        now = self._clock()
        step = self._step(self.n)
        if not force and step <= self._last_step and now - self._last_time < self.every_s:
            return
        self._last_step, self._last_time = max(step, self._last_step), now
        self._written_n = self.n
        self._write(self.line(now))

    def set_postfix(self, ordered_dict: dict[str, Any] | None = None, refresh: bool = True,
                    **kwargs: Any) -> None:
        """``key=value`` pairs shown at the end of the following lines (as tqdm's)."""
        items = {**(ordered_dict or {}), **kwargs}
        self.postfix = ", ".join(f"{k}={v}" for k, v in items.items())
        if refresh:
            self.refresh()

    def set_postfix_str(self, s: str = "", refresh: bool = True) -> None:
        self.postfix = s
        if refresh:
            self.refresh()

    def set_description_str(self, desc: str | None = None, refresh: bool = True) -> None:
        """The text at the start of the following lines (as tqdm's)."""
        self.desc = desc or ""
        if refresh:
            self.refresh()

    def set_description(self, desc: str | None = None, refresh: bool = True) -> None:
        self.set_description_str(desc, refresh)

    def line(self, now: float | None = None) -> str:
        """The current progress as one line (no newline)."""
        now = self._clock() if now is None else now
        elapsed = now - self._start
        head = f"{self.desc}: " if self.desc else ""
        if self.total:
            text = f"{head}{100.0 * self.n / self.total:.0f}% ({self.n}/{self.total} {self.unit})"
            done = self.n - self._start_n
            if 0 < done and self.n < self.total:
                left = elapsed / done * (self.total - self.n)
                text += f", {_duration(elapsed)} elapsed, ~{_duration(left)} left"
            else:
                text += f", {_duration(elapsed)} elapsed"
        else:
            text = f"{head}{self.n} {self.unit}, {_duration(elapsed)} elapsed"
        return f"{text}, {self.postfix}" if self.postfix else text

    def _write(self, text: str) -> None:
        if self.disable:
            return
        stream = self.stream if self.stream is not None else sys.stderr
        stream.write(text + "\n")
        stream.flush()

    def write(self, text: str) -> None:
        """Write a message line (as ``tqdm.write``)."""
        self._write(text)

    def close(self) -> None:
        """Write the last line (once; not if the last line written already says the same)."""
        if self.closed:
            return
        self.closed = True
        if self._written_n != self.n and (self.n != self._start_n or self.total == 0):
            self._write(self.line())

    def __enter__(self) -> PlainProgress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _duration(seconds: float) -> str:
    seconds = max(0.0, seconds)
    if seconds < 60.0:
        return f"{seconds:.0f} s"
    if seconds < 3600.0:
        return f"{seconds // 60:.0f} min {seconds % 60:02.0f} s"
    return f"{seconds // 3600:.0f} h {seconds % 3600 // 60:02.0f} min"


def progress_bar(total: int | None, desc: str = "", unit: str = "it", *, disable: bool = False,
                 stream: TextIO | None = None, every_percent: float = 10.0, every_s: float = 60.0,
                 initial: int = 0, **tqdm_kwargs: Any) -> Any:
    """A progress reporter for ``total`` units of work: a ``tqdm`` bar when ``stream`` (default
    ``sys.stderr``) is a terminal, else a :class:`PlainProgress` writing a line every
    ``every_percent`` percent or ``every_s`` seconds. ``disable``: report nothing (a disabled
    :class:`PlainProgress`). ``tqdm_kwargs`` (``leave``, ``position``, ``dynamic_ncols``...) go to
    tqdm and are ignored for plain lines."""
    target = stream if stream is not None else sys.stderr
    if disable:
        return PlainProgress(total, desc, unit, stream=target, initial=initial, disable=True)
    isatty = getattr(target, "isatty", None)
    if isatty is not None and isatty():
        from tqdm import tqdm

        return tqdm(total=total, desc=desc, unit=unit, file=target, initial=initial, **tqdm_kwargs)
    return PlainProgress(total, desc, unit, stream=target, every_percent=every_percent,
                         every_s=every_s, initial=initial)
