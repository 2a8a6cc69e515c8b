"""Order-domain features that survive model-form error (issue 11, ``docs/calibration.md`` Sec. 8.2).

* :func:`remove_synchronous`: the non-synchronous part of a signal, i.e. the signal minus the
  time-synchronous average (TSA) of every shaft, evaluated back on the time samples
  ("discrete/random separation" by synchronous averaging; Braun 1975; Randall & Antoni 2011,
  Sec. 3.3). Gear-mesh content of any amplitude (the part of the signal a model gets most wrong) is
  periodic with one of the shafts and is removed; impacts of a rolling-bearing defect are not
  (their rate is no integer multiple of a shaft rate and it jitters by the rolling elements' slip),
  so the envelope of the remainder shows the bearing whatever the error of the mesh model.
* :func:`sideband_ratios`: sideband-to-carrier ratios ``c_{mz+k} / c_{mz}`` of a shaft's
  synchronous average at the mesh harmonics; the gain and a smooth transfer path cancel.
* :func:`leading_transient_s`: length of a start-up transient at the head of a record.

FM4 / NA4 of the residual signal are computed by :mod:`gear_rotor_sim.fault_indicators` (the
monitor's indicators); they are not features of the fit.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence

import numpy as np
from scipy import signal as _sig
from scipy.ndimage import median_filter

from gear_rotor_sim.analysis.signals import resample_to_angle

#: highest frequency of a synchronous part as a fraction of the sample rate: above it the 4x upsampling
#: filter's transition band (``_upsampling_taps``) bends the orders, so content there (a mesh harmonic
#: between 0.45 fs and the Nyquist frequency too) stays in the non-synchronous part
SYNCHRONOUS_TOP_FRACTION = 0.45


def _linear_interp_response(freq_ratio: np.ndarray) -> np.ndarray:
    """Mean amplitude response of linear interpolation at uniformly spread fractional positions:
    ``sinc^2(f / fs)`` (the triangular kernel's transform)."""
    return np.sinc(freq_ratio) ** 2


@functools.lru_cache(maxsize=4)
def _upsampling_taps(up: int) -> np.ndarray:
    """The low-pass FIR ``scipy.signal.resample_poly(x, up, 1)`` designs on every call (``firwin`` of
    ``20 up + 1`` taps, cut-off ``1 / up`` of Nyquist, Kaiser window beta 5, its default), designed once;
    passed as its ``window`` it gives the same samples to the bit (resample_poly copies and scales it)."""
    taps = _sig.firwin(2 * 10 * up + 1, 1.0 / up, window=("kaiser", 5.0))
    taps.flags.writeable = False
    return taps


def synchronous_part(
    x: np.ndarray,
    fs: float,
    shaft_hz: float,
    f_max_hz: float | None = None,
    significance: float = 3.0,
    floor_bins: int = 0,
) -> np.ndarray:
    """The part of ``x`` periodic with a shaft turning at ``shaft_hz`` (its TSA on the time samples).

    The signal is upsampled 4 times (polyphase FIR), resampled uniformly in shaft angle
    (``2^p >= 4 fs / shaft_hz`` points per revolution, linear interpolation), averaged over the
    whole revolutions, orders within ``significance`` standard errors of zero (between-revolution
    scatter / number of revolutions) are dropped, the others are corrected for the mean response
    of the linear interpolation (``sinc^2``), and the average is evaluated at the angle of every time sample
    (Fourier synthesis on a grid twice finer, then linear interpolation). The angle origin is
    the first sample: the result does not depend on an absolute shaft-angle reference.

    Parameters
    ----------
    x : numpy.ndarray
        Signal (n,), constant speed.
    fs : float
        Sample rate, Hz.
    shaft_hz : float
        Shaft rotation frequency, Hz.
    f_max_hz : float, optional
        Highest frequency kept in the synchronous part (default and at most
        ``SYNCHRONOUS_TOP_FRACTION fs``, 0.45 fs).
    significance : float
        Orders whose averaged amplitude is below this many standard errors are not synchronous
        content (0 keeps every order: the plain synchronous average).
    floor_bins : int
        Floor each order's between-revolution variance by its running median over ``+- floor_bins``
        orders (0: not floored). Over few revolutions (two hunting periods: ``envelope_hunting.py``) the
        variance of one order has too few degrees of freedom to judge it alone.

    Returns
    -------
    numpy.ndarray
        The synchronous part (n,), zero mean. Zeros if the record holds fewer than 2 revolutions.
    """
    x = np.asarray(x, dtype=float)
    if shaft_hz <= 0 or not np.isfinite(shaft_hz):
        raise ValueError(f"shaft_hz: must be positive and finite, got {shaft_hz!r}")
    up = 4  # band-limited 4x upsampling first: the linear interpolation to the angle grid then errs
    fs_up = up * fs  # by less than 1 % up to 0.25 fs
    spr = int(2 ** math.ceil(math.log2(max(fs_up / shaft_hz, 8.0))))
    xu = _sig.resample_poly(x - np.mean(x), up, 1, window=_upsampling_taps(up))
    _, xa = resample_to_angle(xu, fs_up, shaft_hz * 60.0, spr)
    n_rev = (xa.size - 1) // spr
    if n_rev < 2:
        return np.zeros_like(x)
    per = np.fft.rfft(xa[: n_rev * spr].reshape(n_rev, spr), axis=1)
    coef = per.mean(axis=0)
    # only orders that stand out of their own between-revolution scatter (3 standard errors): the
    # average of content that is not periodic with the shaft (noise, slipping bearing impacts) is
    # itself random, and subtracting it would add 1/n_rev of that content back as periodic
    # pseudo-lines at the shaft's harmonics
    var = np.sum(np.abs(per - coef) ** 2, axis=0) / max(n_rev - 1, 1) / n_rev
    if floor_bins > 0:
        var = np.maximum(var, median_filter(var, size=2 * floor_bins + 1, mode="nearest"))
    k = np.arange(coef.size)
    f_k = k * shaft_hz
    top = SYNCHRONOUS_TOP_FRACTION * fs
    f_top = top if f_max_hz is None else min(f_max_hz, top)
    coef[np.abs(coef) ** 2 <= significance**2 * var] = 0.0
    coef[0] = 0.0
    coef[f_k > f_top] = 0.0
    coef /= np.maximum(_linear_interp_response(f_k / fs_up), 0.5)
    fine = 2 * spr
    pattern = np.fft.irfft(coef * (fine / spr), fine)
    angle = (np.arange(x.size) * shaft_hz / fs) % 1.0
    grid = np.arange(fine + 1) / fine
    return np.interp(angle, grid, np.concatenate([pattern, pattern[:1]]))


def remove_synchronous(
    x: np.ndarray, fs: float, shafts_hz: Sequence[float], f_max_hz: float | None = None
) -> np.ndarray:
    """``x`` without the synchronous parts of the given shafts (in the order given).

    The first shaft's TSA removes its orders and every mesh harmonic (a multiple of both shafts'
    rates); the next shaft's TSA is taken of the remainder. What is left: noise and content that is
    not periodic with any shaft (bearing-defect impacts with their slip, resonances they excite).
    """
    out = np.asarray(x, dtype=float) - np.mean(x)
    for f in shafts_hz:
        out = out - synchronous_part(out, fs, f, f_max_hz)
    return out


def leading_transient_s(
    x: np.ndarray,
    fs: float,
    shafts_hz: Sequence[float],
    window_s: float = 0.05,
    ratio: float = 3.0,
    max_fraction: float = 0.25,
) -> float:
    """Length of a start-up transient at the head of a record, s (0 if none).

    A record that starts from rest or from static equilibrium (``gear-rotor-sim record``, a machine
    just switched on) holds free vibration that decays: content that is periodic with no shaft. The
    non-synchronous part (:func:`remove_synchronous`) of each channel is cut into windows of
    ``window_s``; the transient is the leading run of windows in which any channel's RMS exceeds
    ``ratio`` times that channel's median window RMS, at most ``max_fraction`` of the record. A
    steady record (noise, gear content, slipping bearing impacts are all stationary) gives 0.

    Parameters
    ----------
    x : numpy.ndarray
        Record (n, c), constant speed.
    fs : float
        Sample rate, Hz.
    shafts_hz : sequence of float
        Rotation frequency of every shaft, Hz.
    """
    x = np.asarray(x, dtype=float).reshape(x.shape[0], -1)
    w = max(round(window_s * fs), 1)
    n_win = x.shape[0] // w
    if n_win < 4 or not shafts_hz:
        return 0.0
    hot = np.zeros(n_win, dtype=bool)
    for c in range(x.shape[1]):
        if not np.std(x[:, c]) > 0:
            continue
        r = remove_synchronous(x[:, c], fs, shafts_hz)
        rms = np.sqrt(np.mean(r[: n_win * w].reshape(n_win, w) ** 2, axis=1))
        med = float(np.median(rms))
        if med > 0:
            hot |= rms > ratio * med
    n_lead = int(np.argmin(hot)) if not hot.all() else n_win
    return min(n_lead, int(max_fraction * n_win)) * w / fs


def sideband_ratios(
    coef: np.ndarray, orders: np.ndarray, teeth: int, harmonics: int, sidebands: int
) -> tuple[np.ndarray, np.ndarray]:
    """Complex sideband-to-carrier ratios ``c_{m z + k} / c_{m z}`` of one shaft's synchronous average.

    Parameters
    ----------
    coef : numpy.ndarray
        Complex order coefficients of the shaft (at ``orders``).
    orders : numpy.ndarray
        Integer orders of ``coef``.
    teeth : int
        Teeth of the shaft's gear (carriers at ``m * teeth``).
    harmonics, sidebands : int
        Mesh harmonics ``m = 1..harmonics`` and sidebands ``k = +-1..+-sidebands``.

    Returns
    -------
    ratios : numpy.ndarray
        Complex ratios, one per (m, k) present in ``orders`` (carrier present too).
    index : numpy.ndarray
        ``(m, k)`` rows of the ratios.
    """
    pos = {int(o): i for i, o in enumerate(orders)}
    out, idx = [], []
    for m in range(1, harmonics + 1):
        c = pos.get(m * teeth)
        if c is None or coef[c] == 0:
            continue
        for k in (*range(-sidebands, 0), *range(1, sidebands + 1)):
            j = pos.get(m * teeth + k)
            if j is not None:
                out.append(coef[j] / coef[c])
                idx.append((m, k))
    return np.asarray(out, dtype=complex), np.asarray(idx, dtype=int).reshape(-1, 2)
