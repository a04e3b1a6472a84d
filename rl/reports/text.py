"""How reports write numbers in words: one spelling of a distance for every command's text."""

from __future__ import annotations

__all__ = ["millimetres"]


def millimetres(value: float | None) -> str:
    """A distance (m) as reports say it: to 0.1 mm, or to two significant digits below that (a
    smoke run's micrometres are not shown as +0.0 mm); ``None`` is a diverged run."""
    if value is None:
        return "diverged"
    mm = 1e3 * value
    return f"{mm:+.1f} mm" if mm == 0.0 or abs(mm) >= 0.1 else f"{mm:+.2g} mm"
