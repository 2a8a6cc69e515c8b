"""A load torque that fluctuates within the record, read from the radial bearing-force "means" (issue 11:
effects nobody declared; docs/calibration.md Sec. 2 "Load check", fluctuating load).

Physics. Below the drivetrain's torsional modes the gear's angular acceleration is negligible, so the mesh
force follows the output torque, ``W(t) = T(t) / r_b2``, and every shaft's radial bearing reactions follow
``W`` by the lever rule (``load_check.py``: no other radial static load in the model). A load that
fluctuates, ``T(t) = T0 [1 + a(t)]``, therefore modulates every radial bearing-force channel by the SAME
relative amount ``x_k(t) ~ m_k [1 + a(t)]`` (``m_k`` its mean; the sensor gain cancels in ``x_k / m_k``),
and the DTE's elastic part ``W / k`` by ``a(t)`` too (the DTE's mean also holds the backlash offset, so its
relative modulation is at most ``a``). No library fault does that:

- at a frequency that is no order of any shaft (a slow load change: a pump, a conveyor, a few Hz), no library
  effect puts a line into the bearing forces at all below the slowest shaft's rate;
- locked to a shaft order (a reciprocating driven machine: 1x / 2x of the output shaft), an eccentric wheel
  or a damaged tooth also modulates the mesh, but through its geometry: the DTE moves by the centre offset
  or the tooth's deflection (micrometres) while the force hardly moves (the torque holds it), so the DTE's
  relative modulation exceeds the force's many times (``rho >> 1`` below); a rotating force (unbalance, an
  eccentric mass) turns the bearing-force vector, so its x and y channels are not modulated alike.

Statistic (:func:`find_load_fluctuation`):

1. non-order: each radial channel's relative signal ``x_k / m_k - 1``, Hann-windowed and zero-padded 8x, its
   periodogram over ``[2 / T, 0.8 f_slow]`` (``f_slow`` the slowest shaft's rate) divided by its median there;
   the peak of their sum; at it each channel's complex relative amplitude ``a_k`` and its power over the
   band's median (the line's SNR);
2. order-locked: for every shaft and orders 1-4, ``a_k`` from the synchronous coefficients of whole
   revolutions (``order_dft.revolution_coefficients``), the SNR from their between-revolution scatter;
3. a candidate reads as a load fluctuation (:attr:`LoadFluctuation.fires`) when at least ``MIN_CHANNELS``
   radial channels carry it with SNR above ``MIN_SNR`` (power, 20 dB; for the orders: ``|mean|`` over its
   standard error squared), their ``a_k`` agree (``max |a_k - a| <= AGREE |a|``, ``a`` their mean) and
   ``|a| >= MIN_RELATIVE``; order-locked also needs a DTE channel whose relative modulation at that order,
   ``rho = (D / d) / a`` (``D`` its coefficient, ``d`` its mean), is a load's: ``|rho| <= RHO_MAX`` and
   ``Re rho > 0`` (the elastic deflection grows with the force). Without a DTE an order-locked candidate is
   not read (a geometric fault cannot be told from it).

What the calibration does with it (:func:`check_load_fluctuation`, called by ``load_check.check_load``):
the load's sidebands are removed from every channel (``load_demodulation.py``), the record is diagnosed at
the mean torque, and an ``issues`` entry names ``operating_point.output_torque_nm``, the modulation found
(frequency or shaft order, relative amplitude per channel, the DTE's ratio) and what was removed; a note
repeats it. A record on which no candidate fires is passed on as loaded (the same report).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from gear_rotor_sim.calibration.order_dft import revolution_coefficients
from gear_rotor_sim.system import shaft_rates_hz

#: line power over the band's median (non-order) or |mean|^2 over its variance (order-locked): 20 dB
MIN_SNR = 100.0
#: the radial channels' relative modulations agree within this fraction of their mean (complex)
AGREE = 0.25
#: smallest relative modulation of the static load that is read (1 % of the mean torque)
MIN_RELATIVE = 0.01
#: order-locked: the DTE's relative modulation at most this many times the force's, in phase
RHO_MAX = 1.5
#: radial channels needed: the modulation must be common to them
MIN_CHANNELS = 2
#: orders of each shaft tested for an order-locked load
ORDERS = (1, 2, 3, 4)
#: non-order band: from BAND_LO_PERIODS / T to BAND_HI x the slowest shaft's rate
BAND_LO_PERIODS = 2.0
BAND_HI = 0.8
#: zero padding of the non-order periodogram
PAD = 8


@dataclass(frozen=True)
class LoadFluctuation:
    """A modulation common to the radial bearing forces (module docstring).

    Attributes
    ----------
    frequency_hz : float
        Its frequency.
    shaft, order : int or None
        0-based shaft index and order where it is locked to a shaft; None for a non-order line.
    columns : tuple of str
        The radial bearing-force channels.
    relative : tuple of complex
        ``a_k`` of each (relative to the channel's mean).
    snr : tuple of float
        Each line's SNR (power ratio).
    dte_ratio : complex or None
        ``rho``: the DTE's relative modulation over the force's (None without a DTE).
    """

    frequency_hz: float
    shaft: int | None
    order: int | None
    columns: tuple[str, ...]
    relative: tuple[complex, ...]
    snr: tuple[float, ...]
    dte_ratio: complex | None = None

    @property
    def amplitude(self) -> complex:
        """``a``: the channels' mean relative modulation (complex)."""
        return complex(np.mean(np.asarray(self.relative, dtype=complex)))

    @property
    def spread(self) -> float:
        """``max |a_k - a| / |a|``."""
        a = self.amplitude
        if abs(a) == 0.0:
            return math.inf
        return float(max(abs(r - a) for r in self.relative) / abs(a))

    @property
    def fires(self) -> bool:
        """Whether the record's load fluctuates (the module docstring's rule)."""
        if len(self.columns) < MIN_CHANNELS or min(self.snr) < MIN_SNR:
            return False
        if self.spread > AGREE or abs(self.amplitude) < MIN_RELATIVE:
            return False
        if self.order is None:
            return True
        rho = self.dte_ratio
        return rho is not None and abs(rho) <= RHO_MAX and rho.real > 0.0

    def where(self) -> str:
        if self.order is None:
            return f"{self.frequency_hz:.3g} Hz (no order of any shaft)"
        return f"{self.order}x of shaft {self.shaft + 1} ({self.frequency_hz:.4g} Hz)"

    def describe(self, declared_nm: float | None = None) -> str:
        """The ``issues`` line."""
        a = abs(self.amplitude)
        tq = (
            "" if declared_nm is None else f" (about +-{a * declared_nm:.3g} N m about {declared_nm:.4g} N m)"
        )
        dte = (
            ""
            if self.dte_ratio is None
            else f"; the DTE's relative modulation {abs(self.dte_ratio):.2f} of it"
        )
        chans = ", ".join(f"{c} {abs(r):.3f}" for c, r in zip(self.columns, self.relative, strict=True))
        return (
            f"operating_point.output_torque_nm: the load fluctuates: the radial bearing-force means are "
            f"modulated by {100 * a:.3g} %{tq} at {self.where()}, alike on every radial channel ({chans} of "
            f"their means){dte}: a fluctuating torque of the driven machine, not a library fault; the model "
            "runs at the mean torque"
        )


def _relative(x: np.ndarray) -> tuple[np.ndarray, float]:
    m = float(np.mean(x))
    return x / m - 1.0, m


def _nonorder(rel: np.ndarray, fs: float, f_slow: float) -> tuple[float, np.ndarray, np.ndarray] | None:
    """Peak of the summed median-normalised periodograms of the columns of ``rel`` within the non-order
    band: (frequency, complex relative amplitudes, SNRs); None where the band holds under 8 bins."""
    n = rel.shape[0]
    t_len = n / fs
    lo, hi = BAND_LO_PERIODS / t_len, BAND_HI * f_slow
    if hi - lo < 8.0 / t_len:
        return None
    w = np.hanning(n)
    nfft = PAD * n
    spec = np.fft.rfft(rel * w[:, None], nfft, axis=0)
    f = np.fft.rfftfreq(nfft, 1.0 / fs)
    band = (f >= lo) & (f <= hi)
    p = np.abs(spec[band]) ** 2
    med = np.median(p, axis=0)
    j = int(np.argmax(np.sum(p / med, axis=1)))
    # the line's main lobe left out of the noise level (Hann: +-2 bins of the unpadded grid)
    fb = f[band]
    off = np.abs(fb - fb[j]) > 3.0 / t_len
    noise = np.median(p[off], axis=0)
    amp = 2.0 * spec[band][j] / np.sum(w)
    return float(fb[j]), amp, p[j] / noise


def _ordered(rel: np.ndarray, fs: float, shaft_hz: float, order: int) -> tuple[np.ndarray, np.ndarray]:
    """Complex relative amplitudes and SNRs of the columns of ``rel`` at ``order`` of a shaft."""
    amps, snrs = [], []
    for c in range(rel.shape[1]):
        cr = revolution_coefficients(rel[:, c], fs, shaft_hz, np.array([order]))[:, 0]
        if cr.size < 4:
            return np.zeros(0, complex), np.zeros(0)
        mean = cr.mean()
        var = np.sum(np.abs(cr - mean) ** 2) / (cr.size - 1) / cr.size
        amps.append(2.0 * mean)
        snrs.append(abs(mean) ** 2 / var if var > 0 else math.inf)
    return np.asarray(amps), np.asarray(snrs)


def find_load_fluctuation(
    data: np.ndarray, fs: float, channels: Sequence[Any], shafts_hz: Sequence[float]
) -> list[LoadFluctuation]:
    """Every candidate modulation common to the radial bearing forces (module docstring), strongest first.

    Parameters
    ----------
    data : numpy.ndarray
        ``(n, nc)`` measured channels in SI.
    fs : float
        Sample rate, Hz.
    channels : sequence of ChannelSpec
        ``quantity``, ``direction``, ``column`` of each.
    shafts_hz : sequence of float
        Every shaft's rotation rate, Hz.

    Returns
    -------
    list of LoadFluctuation
        The non-order peak and each shaft order's reading, by decreasing ``|a|``; empty without two
        radial bearing-force channels with a non-zero mean.
    """
    data = np.asarray(data, float)
    radial = [
        k
        for k, c in enumerate(channels)
        if c.quantity == "bearing_force" and c.direction in ("x", "y") and np.mean(data[:, k]) != 0.0
    ]
    if len(radial) < MIN_CHANNELS or not shafts_hz:
        return []
    dte = next((k for k, c in enumerate(channels) if c.quantity == "dynamic_transmission_error"), None)
    cols = radial + ([dte] if dte is not None else [])
    rel = np.column_stack([_relative(data[:, k])[0] for k in cols])
    names = tuple(str(channels[k].column) for k in radial)
    nr = len(radial)
    out: list[LoadFluctuation] = []

    def ratio(amps: np.ndarray) -> complex | None:
        if dte is None:
            return None
        a = complex(np.mean(amps[:nr]))
        return complex(amps[nr] / a) if a != 0 else None

    peak = _nonorder(rel, fs, min(shafts_hz))
    if peak is not None:
        f0, amps, snr = peak
        out.append(
            LoadFluctuation(
                f0,
                None,
                None,
                names,
                tuple(map(complex, amps[:nr])),
                tuple(map(float, snr[:nr])),
                ratio(amps),
            )
        )
    for s, fsh in enumerate(shafts_hz):
        for k in ORDERS:
            if k * fsh >= 0.45 * fs:
                continue
            amps, snr = _ordered(rel, fs, fsh, k)
            if amps.size == 0:
                continue
            out.append(
                LoadFluctuation(
                    k * fsh,
                    s,
                    k,
                    names,
                    tuple(map(complex, amps[:nr])),
                    tuple(map(float, snr[:nr])),
                    ratio(amps),
                )
            )
    return sorted(out, key=lambda c: -abs(c.amplitude))


def first_firing(cands: Sequence[LoadFluctuation]) -> LoadFluctuation | None:
    """The strongest candidate that reads as a load fluctuation, else None."""
    return next((c for c in cands if c.fires), None)


def check_load_fluctuation(cal: Any, base_out: np.ndarray) -> np.ndarray:
    """The check on a set-up calibrator (``load_check.check_load``). Where the load fluctuates its sidebands
    are removed from the record (``load_demodulation.py``), the comparison and the healthy setup are redone
    on the corrected record, and an ``issues`` entry and a note say what was found and removed
    (module docstring); ``cal.load_fluctuation`` is the finding or None.

    Returns
    -------
    numpy.ndarray
        The healthy model's outputs (of the new setup where the record was corrected, else ``base_out``).
    """
    from gear_rotor_sim.calibration.load_demodulation import apply_demodulation

    cal.load_fluctuation = None
    m = cal.m
    if getattr(cal.runner.cfg, "load", None) is None or not m.operating_point.speed_rpm:
        return base_out
    shafts = shaft_rates_hz(cal.runner.cfg, float(m.operating_point.speed_rpm))
    found = first_firing(find_load_fluctuation(m.data, m.sample_rate_hz, m.channels, shafts))
    if found is None:
        return base_out
    torque = m.operating_point.output_torque_nm
    if torque is None:
        torque = float(cal.runner.cfg.load.torque_nm)
    cal.load_fluctuation = found
    return apply_demodulation(cal, found, found.describe(float(torque)), shafts)


def statistic_table_head() -> str:
    """Head of the benchmark's statistic table (:func:`statistic_row`)."""
    return (
        "| record | non-order: f (Hz), a, spread, SNR min | strongest order: where, a, spread, SNR min, "
        "rho | fires |\n|---|---|---|---|"
    )


def statistic_row(m: Any) -> str:
    """One row of the statistic table for a loaded measurement ``m`` (its gearbox config's shafts)."""
    from gear_rotor_sim.config import load_config

    cfg = load_config(m.gearbox)
    cands = find_load_fluctuation(
        m.data, m.sample_rate_hz, m.channels, shaft_rates_hz(cfg, float(m.operating_point.speed_rpm))
    )
    non = next((c for c in cands if c.order is None), None)
    ords = [c for c in cands if c.order is not None]
    # the largest significant order line (every channel's SNR >= MIN_SNR), else the largest
    best = next((c for c in ords if min(c.snr) >= MIN_SNR), ords[0] if ords else None)

    def cell(c: LoadFluctuation | None) -> str:
        if c is None:
            return "-"
        rho = (
            "-"
            if c.dte_ratio is None
            else f"{abs(c.dte_ratio):.3g} ({math.degrees(np.angle(c.dte_ratio)):+.0f} deg)"
        )
        head = f"{c.frequency_hz:.3g}" if c.order is None else f"{c.order}x shaft {c.shaft + 1}"
        return f"{head}, {abs(c.amplitude):.2e}, {c.spread:.2f}, {min(c.snr):.3g}, {rho}"

    fired = first_firing(cands)
    return f"{cell(non)} | {cell(best)} | {'-' if fired is None else fired.where()} |"
