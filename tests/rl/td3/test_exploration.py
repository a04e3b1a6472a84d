"""Coloured exploration noise (rl/td3/exploration.py): its spectrum and variance."""

from __future__ import annotations

import numpy as np
import pytest
import torch

torch.set_num_threads(1)


# ----------------------------------------------------------------------------------------------
# colored exploration noise
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("beta", [0.0, 1.0, 2.0])
def test_colored_noise_has_the_power_law_spectrum_and_unit_variance(beta):
    from elastica_magnetic_rl.td3.exploration import colored_noise

    rng = np.random.default_rng(0)
    # (draws, steps, dims); red noise needs many draws: its variance sits in a few low frequencies
    x = np.stack([colored_noise(beta, 1000, 2, rng) for _ in range(2000)])
    assert x.shape == (2000, 1000, 2)
    assert np.abs(x.mean(axis=1)).max() < 1e-12  # every sequence has zero mean
    assert abs(np.mean(x**2) - 1.0) < 0.05
    power = (np.abs(np.fft.rfft(x, axis=1)) ** 2).mean(axis=(0, 2))
    freqs = np.fft.rfftfreq(1000)
    band = (freqs > 0.005) & (freqs < 0.4)
    slope = np.polyfit(np.log(freqs[band]), np.log(power[band]), 1)[0]
    assert slope == pytest.approx(-beta, abs=0.05)
    again = colored_noise(beta, 1000, 2, np.random.default_rng(0))
    np.testing.assert_array_equal(again, x[0])  # a function of the generator only
    with pytest.raises(ValueError, match="beta"):
        colored_noise(-1.0, 10, 1, rng)
