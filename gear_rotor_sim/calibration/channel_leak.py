"""Cross-talk into an axial force channel: a constant share of another force channel summed in (issue 11:
effects nobody declared; docs/calibration.md Sec. 1, "Sensor conventions and faults nobody declared";
history Sec. 8.58).

A tri-axial load cell's axes are not perfectly decoupled: its axial output holds a few percent of the radial
load (cross-axis sensitivity), and a wiring or amplifier fault mixes one channel into another the same way.
In a spur gearbox the axial bearing load is thermal and constant (Sec. 8.2), so the axial channel is where
such a leak stands out most: 5 % of ``bearing2_fy`` summed into ``bearing2_fz`` on the independent 3000 rpm
records put -67 N on its mean (``axial_zero.py`` subtracts that) and 15 N rms of dynamic force on a channel
whose own content is 0.6 N of noise; the pinion tooth then failed (error 56.3 -> 52.5, history Sec. 8.53).

What tells a leak from mechanics. A physical axial force that follows the radial ones (a misaligned gear's
axial share of the mesh force, Sec. 8.38) is the mesh force through the axial path, so its ratio to a radial
force changes with frequency (each channel has its own resonances), and it holds none of the radial
sensor's own noise. A leak is the source channel itself times a constant: the transfer ratio
``H(f) = S_ts(f) / S_ss(f)`` of target over source is the same real number at every frequency, at the mesh
harmonics and in the bands between them where the source holds only its non-synchronous content and noise.

Rule (:func:`leak_fix`). For each axial bearing-force channel (target) and each other bearing-force channel
(source): Welch cross-spectra (Hann, :data:`NPERSEG` samples, half overlap) summed over :data:`N_BANDS`
log-spaced bands from :data:`F_LOW_HZ` to 0.4 fs; per band the regression coefficient ``c_b = S_ts / S_ss``
(complex) and its variance ``(S_tt - |S_ts|^2 / S_ss) / (S_ss n_b)`` (``n_b`` the band's bins over the Hann
window's equivalent noise bandwidth of 1.5 bins, times the number of segments: the residual of a least-squares
fit over ``n_b`` independent complex samples). The leak ``c`` is the
inverse-variance mean of the real parts; it is read as one when

- it is significant, ``|c| / se >= Z_MIN``, and ``|c| <= C_MAX`` (cross-axis sensitivities are a few
  percent; more is a channel exchange, the sidecar's field);
- it is flat and real: ``chi2 / dof <= FLAT_MAX`` over the bands (real and imaginary parts against ``c``
  and 0, ``dof = 2 n_bands - 1``), and at least :data:`MIN_BANDS` bands read it at ``Z_MIN / 2``
  each on their own;
- it holds at least :data:`MIN_SHARE` of the target's fluctuating power.

Then ``c`` times the source (its mean too: the sensor's output is linear in the load) is subtracted from the
target and ``issues`` names both columns and ``c``; of several sources the most significant one is taken.
Nothing is read before :data:`MIN_SEGMENTS` Welch segments. Only the record is read (no model run).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import signal

#: Welch segment length, samples (2048 at 20 kHz: 9.8 Hz bins)
NPERSEG = 2048
#: fewest Welch segments for a reading
MIN_SEGMENTS = 8
#: equivalent noise bandwidth of the Hann window, bins: the band's independent samples are its bins over it
ENBW_BINS = 1.5
#: lower edge of the first band, Hz (above the slow wander and the sub-shaft band)
F_LOW_HZ = 20.0
#: log-spaced bands from F_LOW_HZ to 0.4 fs
N_BANDS = 8
#: the leak must stand this many standard errors out
Z_MIN = 20.0
#: the largest share read as a leak (cross-axis sensitivity)
C_MAX = 0.2
#: largest chi2 per degree of freedom of the band readings about one real constant
FLAT_MAX = 3.0
#: bands that must read the leak on their own (at Z_MIN / 2)
MIN_BANDS = 3
#: the leak must hold this share of the target's fluctuating power
MIN_SHARE = 0.5


@dataclass(frozen=True)
class LeakReading:
    """One source channel's reading on one target channel."""

    target: int
    source: int
    c: float  # the leak: target = c x source + rest
    se: float  # its standard error
    chi2_dof: float  # band readings about (c, 0) per degree of freedom
    bands_significant: int
    share: float  # of the target's fluctuating power held by c x source
    bands: tuple[tuple[float, float, complex], ...]  # (f_lo, f_hi, c_b) per band

    @property
    def z(self) -> float:
        """``|c| / se``."""
        return abs(self.c) / self.se if self.se > 0 else float("inf")

    @property
    def is_leak(self) -> bool:
        """Whether the rule reads it as a leak (module docstring)."""
        return (
            self.z >= Z_MIN
            and abs(self.c) <= C_MAX
            and self.chi2_dof <= FLAT_MAX
            and self.bands_significant >= MIN_BANDS
            and self.share >= MIN_SHARE
        )


#: ``(c, se, chi2_dof, bands_significant, share, bands)`` of :func:`leak_reading`
Reading = tuple[float, float, float, int, float, tuple]


def leak_reading(target: np.ndarray, source: np.ndarray, fs: float) -> Reading:
    """The band readings of ``target = c source + rest`` (module docstring).

    Parameters
    ----------
    target, source : numpy.ndarray
        Two channels' samples (SI), same length.
    fs : float
        Sample rate, Hz.

    Returns
    -------
    tuple
        ``(c, se, chi2_dof, bands_significant, share, bands)`` as :class:`LeakReading`; ``c`` NaN where the
        record is too short or no band carries the source.
    """
    nan = (float("nan"), float("inf"), float("inf"), 0, 0.0, ())
    n_seg = (target.size - NPERSEG // 2) // (NPERSEG // 2)
    if n_seg < MIN_SEGMENTS:
        return nan
    kw = {"fs": fs, "nperseg": NPERSEG, "noverlap": NPERSEG // 2, "window": "hann", "detrend": "constant"}
    f, s_ts = signal.csd(target, source, **kw)  # conj(target) x source: take the conjugate below
    _, s_ss = signal.welch(source, **kw)
    _, s_tt = signal.welch(target, **kw)
    s_ts = np.conj(s_ts)  # S_ts = E[t conj(s)]: the regression of t on s is S_ts / S_ss
    edges = np.geomspace(F_LOW_HZ, 0.4 * fs, N_BANDS + 1)
    cs, vs, bands = [], [], []
    for lo, hi in itertools.pairwise(edges):
        sel = (f >= lo) & (f < hi)
        nb = int(np.count_nonzero(sel)) * n_seg / ENBW_BINS
        sss, stt, sts = float(np.sum(s_ss[sel])), float(np.sum(s_tt[sel])), complex(np.sum(s_ts[sel]))
        if nb < 2 or not sss > 0:
            continue
        cb = sts / sss
        var = max(stt - abs(sts) ** 2 / sss, 1e-30 * stt) / (sss * nb)
        cs.append(cb)
        vs.append(var)
        bands.append((float(lo), float(hi), cb))
    if len(cs) < 2:
        return nan
    cb_arr, v_arr = np.array(cs), np.array(vs)
    w = 1.0 / v_arr
    c = float(np.sum(w * cb_arr.real) / np.sum(w))
    se = float(np.sqrt(1.0 / np.sum(w)))
    # real and imaginary parts each of variance var / 2 (a complex regression)
    chi2 = float(np.sum(((cb_arr.real - c) ** 2 + cb_arr.imag**2) / (0.5 * v_arr)))
    dof = 2 * len(cs) - 1
    sig = int(np.count_nonzero(np.abs(cb_arr.real) / np.sqrt(v_arr) >= 0.5 * Z_MIN))
    t0, s0 = target - np.mean(target), source - np.mean(source)
    pt = float(np.sum(t0**2))
    share = float(1.0 - np.sum((t0 - c * s0) ** 2) / pt) if pt > 0 else 0.0
    return c, se, chi2 / dof, sig, share, tuple(bands)


@dataclass(frozen=True)
class LeakFix:
    """Targets whose leak is subtracted, their readings and the ``issues`` entries."""

    channels: tuple[int, ...]
    readings: tuple[LeakReading, ...]
    issues: tuple[str, ...]

    def apply(self, data: np.ndarray) -> np.ndarray:
        """The ``(n, nc)`` data with ``c`` x the source subtracted from each target (a new array)."""
        out = np.array(data, dtype=float, copy=True)
        for r in self.readings:
            out[:, r.target] -= r.c * np.asarray(data[:, r.source], float)
        return out


def leak_readings(
    data: np.ndarray,
    quantities: Sequence[str],
    directions: Sequence[str | None],
    fs: float,
) -> list[LeakReading]:
    """Every (axial target, bearing-force source) reading of ``data`` (n, nc; SI)."""
    forces = [k for k, q in enumerate(quantities) if q == "bearing_force"]
    out = []
    for t in forces:
        if directions[t] != "z":
            continue
        x = np.asarray(data[:, t], float)
        if not np.std(x) > 0:
            continue
        for s in forces:
            if s == t:
                continue
            c, se, chi, sig, share, bands = leak_reading(x, np.asarray(data[:, s], float), fs)
            if np.isfinite(c):
                out.append(LeakReading(t, s, c, se, chi, sig, share, bands))
    return out


def leak_fix(
    data: np.ndarray,
    columns: Sequence[str],
    quantities: Sequence[str],
    directions: Sequence[str | None],
    fs: float,
) -> LeakFix:
    """The axial channels of ``data`` that hold a constant share of another force channel (module
    docstring), the most significant source per target, with their ``issues``."""
    best: dict[int, LeakReading] = {}
    for r in leak_readings(data, quantities, directions, fs):
        if r.is_leak and (r.target not in best or r.z > best[r.target].z):
            best[r.target] = r
    readings = tuple(best[t] for t in sorted(best))
    issues = tuple(
        f"column {columns[r.target]!r}: holds {r.c:+.4g} x {columns[r.source]!r} (the same real ratio at "
        f"every frequency band, chi2/dof {r.chi2_dof:.2g}, {r.z:.3g} standard errors; "
        f"{100 * r.share:.0f} % of its fluctuating power), where no mechanical path is flat in frequency: "
        "cross-talk (a load cell's "
        f"cross-axis sensitivity or the wiring); that share of {columns[r.source]!r}, its mean included, is "
        "subtracted"
        for r in readings
    )
    return LeakFix(tuple(r.target for r in readings), readings, issues)
