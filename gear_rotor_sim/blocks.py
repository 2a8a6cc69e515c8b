"""The sample block: the unit of exchange between the simulator and everything downstream."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class SampleBlock:
    """Uniformly sampled, simultaneous samples of named channels.

    Attributes
    ----------
    t0 : float
        Time of the first sample, s (simulated time since the stream started).
    sample_rate_hz : float
        Samples per second.
    channels : tuple of str
        Channel names, e.g. ``"dte"``, ``"bearing2_fz"``, ``"node5_x"``, ``"node5_ax"``.
    units : tuple of str
        SI unit per channel (``"m"``, ``"N"``, ``"rad"``, ``"m/s^2"``, ...).
    data : numpy.ndarray
        Shape ``(n_samples, n_channels)``, float64.
    first_index : int
        Index of the first sample since the stream started (continuity across blocks).
    speed_rpm, temperature_c : numpy.ndarray
        Operating point per sample (input-shaft speed and temperature), shape ``(n_samples,)``.
    """

    t0: float
    sample_rate_hz: float
    channels: tuple[str, ...]
    units: tuple[str, ...]
    data: np.ndarray
    first_index: int = 0
    speed_rpm: np.ndarray = field(default_factory=lambda: np.zeros(0))
    temperature_c: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __post_init__(self) -> None:
        if self.data.ndim != 2 or self.data.shape[1] != len(self.channels):
            raise ValueError(f"data: shape {self.data.shape} does not match {len(self.channels)} channels")
        if len(self.units) != len(self.channels):
            raise ValueError("units: one unit per channel is required")

    @property
    def n_samples(self) -> int:
        return int(self.data.shape[0])

    @property
    def time(self) -> np.ndarray:
        """Sample times, s."""
        return self.t0 + np.arange(self.n_samples) / self.sample_rate_hz

    def channel(self, name: str) -> np.ndarray:
        """One channel's samples; KeyError naming the available channels otherwise."""
        try:
            i = self.channels.index(name)
        except ValueError:
            raise KeyError(f"channel {name!r} not in block; available: {list(self.channels)}") from None
        return self.data[:, i]

    def unit(self, name: str) -> str:
        return self.units[self.channels.index(name)]

    def select(self, names: list[str] | tuple[str, ...]) -> SampleBlock:
        idx = [self.channels.index(n) for n in names]
        return SampleBlock(
            self.t0,
            self.sample_rate_hz,
            tuple(names),
            tuple(self.units[i] for i in idx),
            self.data[:, idx],
            self.first_index,
            self.speed_rpm,
            self.temperature_c,
        )

    @staticmethod
    def concatenate(blocks: list[SampleBlock]) -> SampleBlock:
        """Join consecutive blocks of one stream; raises if they are not contiguous."""
        if not blocks:
            raise ValueError("blocks: at least one block is required")
        first = blocks[0]
        index = first.first_index
        for b in blocks:
            if b.channels != first.channels or b.sample_rate_hz != first.sample_rate_hz:
                raise ValueError("blocks: channels and sample rate must agree")
            if b.first_index != index:
                raise ValueError(f"blocks: gap or overlap at sample {index} (got {b.first_index})")
            index += b.n_samples
        return SampleBlock(
            first.t0,
            first.sample_rate_hz,
            first.channels,
            first.units,
            np.concatenate([b.data for b in blocks], axis=0),
            first.first_index,
            np.concatenate([b.speed_rpm for b in blocks]),
            np.concatenate([b.temperature_c for b in blocks]),
        )
