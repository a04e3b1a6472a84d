"""Temporally correlated exploration noise: Gaussian noise with a power-law spectrum.

White noise (``beta = 0``: independent at every step, the paper's) explores a 0.01 s control step
by step; to roll, the crawler needs ~25 consecutive field increments in the same sense, which
independent noise almost never produces. Noise whose power falls as ``1 / f^beta`` keeps its
sign for longer: pink (``beta = 1``: Eberhard et al., "Pink Noise Is All You Need: Colored Noise
Exploration in Deep Reinforcement Learning", ICLR 2023) sits between white and red/Brownian
(``beta = 2``).

:func:`colored_noise` draws whole sequences (one per episode and action dimension) with the
method of Timmer & Koenig (1995): Gaussian Fourier amplitudes scaled by ``f^(-beta/2)``, an inverse FFT,
normalised to unit variance. The exploration of :class:`elastica_magnetic_rl.td3.config.TD3Config` with
``noise_color = beta > 0`` adds ``sigma x`` such a sequence, step by step.
"""

from __future__ import annotations

import numpy as np


def colored_noise(beta: float, steps: int, dims: int, rng: np.random.Generator) -> np.ndarray:
    """``(steps, dims)`` float64: ``dims`` independent Gaussian sequences of ``steps`` samples with
    power spectrum ``~ 1 / f^beta`` (frequencies in cycles per step, the lowest ``1 / steps``),
    zero mean and unit variance in expectation over draws, from ``rng``.

    ``beta = 0`` gives white noise, ``1`` pink, ``2`` red. Raises ``ValueError`` for
    ``steps < 2``, ``dims < 1`` or a ``beta`` that is negative or not finite.
    """
    if steps < 2 or dims < 1:
        raise ValueError(f"colored noise needs steps >= 2 and dims >= 1, got {steps}, {dims}")
    if not (np.isfinite(beta) and beta >= 0):
        raise ValueError(f"the noise exponent beta must be finite and >= 0, got {beta}")
    freqs = np.fft.rfftfreq(steps)  # 0, 1/steps, ..., 1/2
    freqs[0] = 1.0 / steps  # (the mean's bin; zeroed below)
    scale = freqs ** (-beta / 2.0)
    # standard deviation of the resulting sequence, to normalise it to unit variance
    weights = scale[1:].copy()
    weights[-1] *= (1 + steps % 2) / 2.0  # the Nyquist bin counts once for even lengths
    sigma = 2.0 * np.sqrt(np.sum(weights**2)) / steps
    real = rng.normal(size=(dims, freqs.size)) * scale
    imag = rng.normal(size=(dims, freqs.size)) * scale
    if steps % 2 == 0:  # the Nyquist component of a real signal is real
        imag[:, -1] = 0.0
        real[:, -1] *= np.sqrt(2.0)
    # zero mean: the reference method also draws a random mean per sequence, which would add to
    # the variance (by ~40 % at beta = 2); the lowest frequency, one cycle per sequence, remains
    real[:, 0] = 0.0
    imag[:, 0] = 0.0
    series = np.fft.irfft(real + 1j * imag, n=steps, axis=1) / sigma
    return np.ascontiguousarray(series.T)
