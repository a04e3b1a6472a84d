"""What produced a run's or a policy's files: the library versions recorded in ``run.json``
(:func:`versions`) and the machine fingerprint recorded with a shipped policy's waveform
(:func:`machine_fingerprint`). One home for both records."""

from __future__ import annotations

import platform

import numpy as np

__all__ = ["machine_fingerprint", "versions"]


def versions() -> dict[str, str]:
    """The versions of Python, torch, Gymnasium, PyElastica and numpy (``run.json``'s ``versions``)."""
    import importlib.metadata

    import gymnasium
    import torch

    try:  # PyElastica 1.0 has no ``elastica.__version__``; its distribution metadata has it
        pyelastica = importlib.metadata.version("pyelastica")
    except importlib.metadata.PackageNotFoundError:
        pyelastica = "unknown"
    return {"python": platform.python_version(), "torch": torch.__version__,
            "gymnasium": gymnasium.__version__, "pyelastica": pyelastica,
            "numpy": np.__version__}


def machine_fingerprint() -> dict[str, str]:
    """What decides the round-off of a rollout: the CPU model and the numerical libraries. Two
    rollouts of one policy are bit-identical when these agree; on another CPU the closed loop
    amplifies round-off through contact switches (the waveforms part after a few rows while the
    distance agrees to ~1e-4)."""
    import llvmlite
    import numba
    import torch

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as handle:
            cpu = next((line.split(":", 1)[1].strip() for line in handle
                        if line.startswith("model name")), cpu)
    except OSError:
        pass
    return {"cpu": cpu, "machine": platform.machine(), "numpy": np.__version__,
            "numba": numba.__version__, "llvmlite": llvmlite.__version__, "torch": torch.__version__}
