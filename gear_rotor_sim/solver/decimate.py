"""Streaming anti-aliasing decimation: linear-phase Kaiser FIR, polyphase evaluation, carried history.

The filter is designed once per decimation factor ``k`` (integration rate = ``k * output_rate``):
passband edge ``0.4 * f_out``, stopband from ``0.5 * f_out`` (the output Nyquist) with at least 80 dB
attenuation (``scipy.signal.kaiserord`` / ``firwin``). Its length ``N = q k + 1`` (``q`` even) makes
the group delay ``D = (N - 1) / 2`` a multiple of ``k``, so every output sample is centred exactly on a
raw sample: output ``i`` at raw index ``p = i k`` is ``sum_m h[m] x[p + D - m]`` (zero phase; the raw
integration runs ``D`` steps ahead of the last emitted output). Only kept outputs are computed
(a compiled polyphase loop, :func:`fir_decimate`). When ``k`` changes (speed change) the raw
history is brought onto the new raw grid by cubic-spline interpolation (see docs/solver.md).
"""

from __future__ import annotations

import numpy as np
from numba import njit
from scipy.interpolate import CubicSpline
from scipy.signal import firwin, kaiserord

STOPBAND_DB = 80.0
PASSBAND_FRACTION = 0.4  # of the output rate
STOPBAND_FRACTION = 0.5  # of the output rate (the output Nyquist)


def design_taps(k: int) -> np.ndarray:
    """Low-pass taps for decimation by ``k`` (normalised to the raw rate); ``[1.0]`` for ``k = 1``."""
    if k == 1:
        return np.ones(1)
    nyq = 0.5 * k  # raw Nyquist in units of the output rate
    width = (STOPBAND_FRACTION - PASSBAND_FRACTION) / nyq
    n_min, beta = kaiserord(STOPBAND_DB + 3.0, width)
    q = 2 * int(np.ceil(n_min / (2.0 * k)))
    numtaps = q * k + 1
    cutoff = 0.5 * (PASSBAND_FRACTION + STOPBAND_FRACTION) / nyq
    taps = firwin(numtaps, cutoff, window=("kaiser", beta))
    return 0.5 * (taps + taps[::-1])  # exactly symmetric (fir_decimate relies on it)


@njit(cache=True, fastmath=True, nogil=True)
def fir_decimate(buf: np.ndarray, h: np.ndarray, start: int, k: int, n_out: int) -> np.ndarray:
    """``y[i, c] = sum_m h[m] buf[start + i k - m, c]``: only the kept outputs are computed.

    ``h`` must be symmetric (linear phase, as :func:`design_taps` gives), so the sum is evaluated as a
    forward dot product over a contiguous window of one channel, which vectorises.
    """
    nch = buf.shape[1]
    ntap = h.shape[0]
    xt = np.ascontiguousarray(buf.T)
    y = np.zeros((n_out, nch))
    for c in range(nch):
        x = xt[c]
        for i in range(n_out):
            lo = start + i * k - (ntap - 1)
            seg = x[lo : lo + ntap]
            acc = 0.0
            for m in range(ntap):
                acc += h[m] * seg[m]
            y[i, c] = acc
    return y


class StreamDecimator:
    """Decimates a multichannel raw stream by ``k`` with carried filter history.

    Parameters
    ----------
    k : int
        Decimation factor.
    initial : ndarray
        (nch,) value of every channel at raw index 0 and (constant) before it.
    """

    def __init__(self, k: int, initial: np.ndarray) -> None:
        self.k = int(k)
        self.h = design_taps(self.k)
        self.delay = (self.h.size - 1) // 2
        nch = initial.size
        # buffer of raw samples; buf[0] has raw index b0 (relative to the current raw segment)
        self.buf = np.tile(np.asarray(initial, float), (self.delay + 1, 1)).reshape(self.delay + 1, nch)
        self.b0 = -self.delay
        self.next_p = 0  # raw index of the next output centre

    @property
    def last_raw(self) -> int:
        return self.b0 + self.buf.shape[0] - 1

    def push(self, raw: np.ndarray) -> np.ndarray:
        """Append raw samples (raw indices last_raw+1 ...) and return the outputs now complete."""
        self.buf = np.ascontiguousarray(np.concatenate([self.buf, raw], axis=0))
        last_ok = self.last_raw - self.delay
        if last_ok < self.next_p:
            return np.zeros((0, self.buf.shape[1]))
        n_out = (last_ok - self.next_p) // self.k + 1
        p_last = self.next_p + (n_out - 1) * self.k
        if self.k == 1:
            s0 = self.next_p - self.b0
            y = self.buf[s0 : s0 + n_out].copy()
        else:
            # zero phase: output at raw index p uses raw p - delay .. p + delay (h is symmetric)
            y = fir_decimate(self.buf, self.h, self.next_p + self.delay - self.b0, self.k, n_out)
        self.next_p = p_last + self.k
        keep_from = self.next_p - 2 * self.delay - self.k - self.b0  # margin for a later regrid
        if keep_from > 0:
            self.buf = self.buf[keep_from:]
            self.b0 += keep_from
        return y

    def regrid(self, new_k: int, split_raw: int) -> None:
        """Switch to decimation ``new_k`` at raw index ``split_raw`` (a multiple of ``k``, the last raw).

        The raw history is interpolated (cubic spline) onto the new grid of step ``k / new_k`` (in
        units of the old step) ending at the split; indices restart at 0 there.
        """
        if split_raw != self.last_raw or split_raw % self.k:
            raise ValueError("regrid: the split must be the last raw sample and on the output grid")
        old_t = (self.b0 + np.arange(self.buf.shape[0])) / self.k  # in output periods, relative
        new_h = design_taps(new_k)
        new_delay = (new_h.size - 1) // 2
        pending_first = (self.next_p - split_raw) / self.k  # <= 0, output periods
        n_hist = int(np.ceil(-pending_first * new_k)) + new_delay + new_k
        new_idx = np.arange(-n_hist, 1)
        new_t = split_raw / self.k + new_idx / new_k
        spline = CubicSpline(old_t, self.buf, axis=0)
        self.buf = spline(np.maximum(new_t, old_t[0]))
        self.buf[-1] = spline(old_t[-1])
        self.b0 = -n_hist
        self.next_p = round(pending_first * new_k)
        self.k = int(new_k)
        self.h = new_h
        self.delay = new_delay

    def rebase(self, split_raw: int) -> None:
        """Restart raw indices at 0 at ``split_raw`` (a multiple of k) without changing the grid."""
        self.b0 -= split_raw
        self.next_p -= split_raw
