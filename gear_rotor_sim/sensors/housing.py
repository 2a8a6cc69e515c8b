"""Accelerometers on the bearing housings: the transfer path from the bearing force.

Each housing direction is a single-DOF mode (mass ``m``, natural frequency ``f_n``, damping ratio
``zeta``) driven by the bearing force ``F`` that the shaft transmits (the ``bearing<k>_f<d>``
channels of the simulator, Eq 37)::

    m x'' + 2 zeta omega_n m x' + omega_n^2 m x = F,   a_h = x''

so ``H(s) = a_h / F = s^2 / (m (s^2 + 2 zeta omega_n s + omega_n^2))``: the mass line ``1/m`` above the
resonance, ``s^2 / k`` below it, and the housing resonance where bearing impacts ring in the kHz
band seen in real recordings (McFadden & Smith 1984). Discretisation: the bilinear (Tustin)
transform with the frequency pre-warped at ``f_n``, so the digital resonance is exactly at ``f_n``
(``omega_a = 2 fs tan(omega_n / (2 fs))`` is used in the analogue prototype); ``f_n`` is limited to
0.45 fs. Away from ``f_n`` Tustin's frequency map ``Omega = 2 fs tan(pi f / fs)`` applies: well below
the resonance the gain ``~ (f / f_n)^2 / m`` is low by the factor ``(f_n / (f_a))^2`` with
``f_a = omega_a / 2 pi``: 15 % at 3 kHz and 20 kHz sampling, 2.6 % at 48 kHz. The static (mean)
force does not reach the accelerometer (``H(0) = 0``); a stream starts from the steady state of
its first force sample, so there is no start-up transient.

Defaults: 5 kg, 3 kHz, zeta 0.05 (a cast housing of a small gearbox; its first local mode is
typically 2-5 kHz). Channels: ``bearing<k>_housing_ax`` / ``_ay`` in m/s^2, one SDOF per
direction, no coupling between directions or bearings.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import signal

from gear_rotor_sim.sensors.noise import SensorNoise


@dataclass(frozen=True)
class HousingSensor:
    """Single-DOF housing mode seen by an accelerometer (module docstring).

    Attributes
    ----------
    frequency_hz : float
        Housing natural frequency f_n.
    damping_ratio : float
        zeta.
    mass_kg : float
        Effective housing mass m.
    prewarp : bool
        Pre-warp the bilinear transform at ``f_n`` (the digital resonance lands exactly on ``f_n``).
        Without it the resonance lands slightly below ``f_n``; the calibration's housing mode
        (``calibration.model_runner.HousingSensor``) is read that way, its frequency being a fitted
        nuisance (the CWRU reports were fitted with it).
    """

    frequency_hz: float = 3000.0
    damping_ratio: float = 0.05
    mass_kg: float = 5.0
    prewarp: bool = True

    def coefficients(self, sample_rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
        """Digital filter ``(b, a)`` from force (N) to acceleration (m/s^2), bilinear transform."""
        fn = min(self.frequency_hz, 0.45 * sample_rate_hz)
        wd = 2.0 * math.pi * fn
        wa = 2.0 * sample_rate_hz * math.tan(wd / (2.0 * sample_rate_hz)) if self.prewarp else wd
        m = self.mass_kg
        return signal.bilinear(
            [1.0, 0.0, 0.0], [m, 2.0 * self.damping_ratio * wa * m, wa * wa * m], fs=sample_rate_hz
        )

    def apply(self, force: np.ndarray, sample_rate_hz: float) -> np.ndarray:
        """Housing acceleration (m/s^2) for a whole bearing-force history (N)."""
        b, a = self.coefficients(sample_rate_hz)
        return signal.lfilter(b, a, force - np.mean(force))


def housing_channels(bearings: Sequence[int], directions: str = "xy") -> tuple[str, ...]:
    """``bearing<k>_housing_a<d>`` names for 1-based bearings."""
    return tuple(f"bearing{k}_housing_a{d}" for k in bearings for d in directions)


def force_channel(housing_channel: str) -> str:
    """``bearing<k>_housing_a<d>`` -> ``bearing<k>_f<d>``."""
    b, d = housing_channel.split("_housing_a")
    return f"{b}_f{d}"


class HousingAccelerometers:
    """Streaming housing accelerometers: bearing-force blocks in, housing accelerations out.

    Parameters
    ----------
    channels : sequence of str
        ``bearing<k>_housing_a<d>`` channels.
    sample_rate_hz : float
    sensor : HousingSensor
        The same housing model for every channel.
    noise : SensorNoise or None
        Added to every channel (None: noiseless).
    """

    def __init__(
        self,
        channels: Sequence[str],
        sample_rate_hz: float,
        sensor: HousingSensor | None = None,
        noise: SensorNoise | None = None,
    ) -> None:
        self.channels = tuple(channels)
        self.sources = tuple(force_channel(c) for c in self.channels)
        self.sample_rate_hz = float(sample_rate_hz)
        self.sensor = sensor or HousingSensor()
        self.noise = noise
        self.b, self.a = self.coefficients = self.sensor.coefficients(self.sample_rate_hz)
        self._zi: np.ndarray | None = None

    def process(self, forces: np.ndarray) -> np.ndarray:
        """Accelerations (n, n_channels) for the next forces (n, n_channels) in ``sources`` order."""
        forces = np.asarray(forces, float)
        if self._zi is None:
            zi0 = signal.lfilter_zi(self.b, self.a)
            self._zi = zi0[:, None] * (forces[0] if forces.shape[0] else np.zeros(forces.shape[1]))[None, :]
        out, self._zi = signal.lfilter(self.b, self.a, forces, axis=0, zi=self._zi)
        if self.noise is not None:
            out = out + self.noise.sample(out.shape, self.sample_rate_hz)
        return out


def append_housing(block: Any, housing: HousingAccelerometers) -> Any:
    """``block`` (a SampleBlock holding ``housing.sources``) with the housing channels appended."""
    from gear_rotor_sim.blocks import SampleBlock

    acc = housing.process(block.select(housing.sources).data)
    return SampleBlock(
        block.t0,
        block.sample_rate_hz,
        block.channels + housing.channels,
        block.units + ("m/s^2",) * len(housing.channels),
        np.hstack([block.data, acc]),
        block.first_index,
        block.speed_rpm,
        block.temperature_c,
    )
