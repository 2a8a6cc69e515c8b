"""Accelerometer noise: white Gaussian noise of a given spectral density, seeded and streamable."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass
class SensorNoise:
    """Broadband sensor noise, white over ``0..fs/2``.

    The RMS at sample rate ``fs`` is ``density sqrt(fs / 2)``. The default 2e-3 (m/s^2)/sqrt(Hz)
    (about 200 ug/sqrt(Hz)) is the order of a general-purpose ICP accelerometer with its signal
    conditioning; 0.2 m/s^2 RMS at 20 kHz.

    Parameters
    ----------
    density : float
        Noise spectral density, (m/s^2)/sqrt(Hz); 0 for no noise.
    seed : int
        Seed of the generator (a stream continues the same sequence across blocks).
    """

    density: float = 2.0e-3
    seed: int = 0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.density) and self.density >= 0):
            raise ValueError(f"density: {self.density!r} must be finite and >= 0")
        self._rng = np.random.default_rng(self.seed)

    def rms(self, sample_rate_hz: float) -> float:
        """Noise RMS at ``sample_rate_hz``, m/s^2."""
        return self.density * math.sqrt(0.5 * sample_rate_hz)

    def sample(self, shape: tuple[int, ...], sample_rate_hz: float) -> np.ndarray:
        """The next ``shape`` noise samples."""
        if self.density == 0:
            return np.zeros(shape)
        return self.rms(sample_rate_hz) * self._rng.standard_normal(shape)
