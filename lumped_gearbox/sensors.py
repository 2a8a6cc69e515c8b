"""A sensor's own frequency response in front of the acquisition: AC coupling and band limits (issue 11).

Every transducer has a band, and a sidecar rarely states it:

- a **piezoelectric force sensor** with its charge amplifier is AC-coupled: the charge leaks through the
  amplifier's feedback resistor, a first-order high-pass ``H(s) = s tau / (1 + s tau)`` with
  ``f_c = 1 / (2 pi tau)`` of 0.1-1 Hz (Kistler, PCB: "quasi-static" long time constants are 1-100 s).
  Under a load held since long before the record its output holds **no mean**: the bearing reactions'
  static parts (the radial loads, the thermal axial load of calibration.md Sec. 8.2) are gone;
- an **accelerometer** on a magnet or an adhesive pad, or behind an IEPE conditioner with a low-pass, is
  band-limited below the converter's band: a second-order low-pass (Butterworth, ``Q = 1/sqrt(2)``) at
  2-5 kHz; IEPE conditioners also high-pass (first order, a few Hz to 10 Hz).

Each filter is a Butterworth design of the given order, discretised by the bilinear transform with the
cut-off pre-warped (``scipy.signal.butter(..., fs=fs)``), so the response is -3 dB at ``cutoff_hz``
exactly. It is applied where the analog sensor sits: in the data-acquisition chain (``daq.acquire``) on
the 32x oversampled signal before the anti-aliasing low-pass (at 640 kHz the bilinear map's warping is
below 0.1 % up to 10 kHz), with ``sampling="point"`` on the sampled signal. A high-pass acts on the
signal about its mean from a zero state (the sensor settled under the static load before the record: a
constant input gives zero output); a low-pass starts in its steady state for the first sample.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import signal

from lumped_gearbox.faults import check_range

KINDS = ("highpass", "lowpass")
#: allowed cut-off range, Hz
CUTOFF_HZ_RANGE = (0.01, 20000.0)


@dataclass(frozen=True)
class SensorFilter:
    """One Butterworth section of a sensor's response (module docstring).

    Attributes
    ----------
    kind : {"highpass", "lowpass"}
    cutoff_hz : float
        The -3 dB frequency, Hz.
    order : int
        1 (an RC high-pass: a charge amplifier, IEPE coupling) or 2 (a mounted accelerometer's low-pass).
    """

    kind: str
    cutoff_hz: float
    order: int = 1

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"sensor.kind: {self.kind!r} not one of {', '.join(KINDS)}")
        check_range("sensor.cutoff_hz", self.cutoff_hz, *CUTOFF_HZ_RANGE)
        if self.order not in (1, 2, 3, 4):
            raise ValueError(f"sensor.order: {self.order!r} not one of 1, 2, 3, 4")

    def apply(self, x: np.ndarray, fs: float) -> np.ndarray:
        """``x`` sampled at ``fs`` through the filter (module docstring for the initial state)."""
        if not self.cutoff_hz < 0.5 * fs:
            raise ValueError(f"sensor.cutoff_hz: {self.cutoff_hz!r} not below half the rate {fs:g} Hz")
        sos = signal.butter(self.order, self.cutoff_hz, btype=self.kind, fs=fs, output="sos")
        if self.kind == "highpass":
            return signal.sosfilt(sos, x - np.mean(x))
        return signal.sosfilt(sos, x, zi=signal.sosfilt_zi(sos) * x[0])[0]

    def truth(self) -> dict[str, Any]:
        return {"kind": self.kind, "cutoff_hz": self.cutoff_hz, "order": self.order}


def parse_sensor(text: str) -> tuple[str, SensorFilter]:
    """``"COLUMN:KIND:HZ[:ORDER]"`` (the command line's ``--sensor``) as (column, filter)."""
    parts = text.split(":")
    if len(parts) not in (3, 4):
        raise ValueError(f"sensor: {text!r} is not COLUMN:KIND:HZ[:ORDER]")
    order = int(parts[3]) if len(parts) == 4 else (2 if parts[1] == "lowpass" else 1)
    return parts[0], SensorFilter(parts[1], float(parts[2]), order)


def sensor_chains(
    spec: Mapping[str, SensorFilter | Sequence[SensorFilter]] | None, columns: Sequence[str]
) -> dict[str, tuple[SensorFilter, ...]]:
    """``spec`` as column -> filters, every column one of ``columns`` (else a ValueError naming it)."""
    out: dict[str, tuple[SensorFilter, ...]] = {}
    for col, f in (spec or {}).items():
        if col not in columns:
            raise ValueError(f"sensors: column {col!r} not one of {', '.join(columns)}")
        out[col] = (f,) if isinstance(f, SensorFilter) else tuple(f)
    return out


def apply_chain(x: np.ndarray, fs: float, filters: Sequence[SensorFilter]) -> np.ndarray:
    """``x`` through each filter of ``filters`` in turn."""
    for f in filters:
        x = f.apply(x, fs)
    return x
