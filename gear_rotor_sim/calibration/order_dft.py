"""Synchronous-average order coefficients at constant speed without resampling.

Computed order tracking resamples a record uniformly in shaft angle and averages the revolutions
(McFadden 1987). With a linear interpolation onto the angle grid, every strong line at ``nu`` of the
sample rate leaves an image at ``f - fs`` of relative amplitude ``sinc^2(1 - nu)``, which the
angle grid folds back onto a shaft order. On the paper gearbox at 3000 rpm (400 samples per
pinion revolution, resampled to 512) the mesh harmonics 3-7 (pinion orders 87-203) fold onto the
pinion orders 25, 4, 33, 62 and 91, sidebands of the mesh carriers by position but images by
origin: the 4th mesh harmonic at 0.29 fs leaves 12.5 % of itself at order 4. The images are the same
for a model and a measurement only if the two agree on the harmonics above the analysed ones, which
two models of a gearbox do not (Sec. 8.18 of docs/history/calibration_sessions.md: on the independent healthy
3000 rpm record the pinion orders 4, 25, 33 of the housing-side acceleration carried 1/3 of the
order chi^2 after the reference baseline).

At a constant speed the synchronous average needs no resampling: its Fourier coefficient of order
``k`` is the integral of ``x(t) exp(-2 pi i k f t)`` over whole revolutions. Here the integral of each
revolution is taken with ``x`` linear between the samples (the trapezoidal rule, with the
revolution's fractional end points weighted by the integral of each sample's hat function), so that
the revolutions' sum is the integral over all of them: exact for the mean up to the two outer
half-samples, with no image of any line below the Nyquist frequency.
"""

from __future__ import annotations

import math
from collections import OrderedDict

import numpy as np
import scipy.sparse as sp

_CACHE: OrderedDict[tuple, object] = OrderedDict()
_CACHE_MAX = 16


def _cached(key: tuple, make: object) -> object:
    hit = _CACHE.get(key)
    if hit is not None:
        _CACHE.move_to_end(key)
        return hit
    val = make()  # type: ignore[operator]
    _CACHE[key] = val
    if len(_CACHE) > _CACHE_MAX:
        _CACHE.popitem(last=False)
    return val


def _hat_cdf(u: np.ndarray) -> np.ndarray:
    """Integral of the unit hat function (support [-1, 1]) from -inf to ``u``."""
    u = np.clip(u, -1.0, 1.0)
    return np.where(u < 0.0, 0.5 * (u + 1.0) ** 2, 1.0 - 0.5 * (1.0 - u) ** 2)


def revolution_weights(n: int, samples_per_rev: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Trapezoidal weights of the samples in each whole revolution: (rows, cols, weights, n_rev).

    The weight of sample ``m`` in revolution ``r`` is the integral of its hat function over
    ``[r N, (r + 1) N]`` (``N = samples_per_rev``): 1 inside, shared at the fractional boundaries, so
    that the weights of every sample sum to 1 over the revolutions (outer half-samples excepted).
    """
    spr = float(samples_per_rev)
    n_rev = math.floor((n - 2) / spr)
    if n_rev < 1:
        return np.zeros(0, int), np.zeros(0, int), np.zeros(0), 0
    b = np.arange(n_rev + 1) * spr  # boundaries, in samples
    fl = np.floor(b).astype(int)
    near = np.unique(np.concatenate([fl, fl + 1]))
    near = near[(near >= 0) & (near < n)]
    inner = np.ones(n, dtype=bool)
    inner[near] = False
    inner[math.floor(b[-1]) + 1 :] = False  # beyond the last whole revolution
    m_in = np.flatnonzero(inner)
    rows = [np.floor(m_in / spr).astype(int)]
    cols = [m_in]
    vals = [np.ones(m_in.size)]
    own = np.floor(near / spr).astype(int)
    for d in (-1, 0, 1):
        r = own + d
        ok = (r >= 0) & (r < n_rev)
        w = np.zeros(near.size)
        w[ok] = _hat_cdf(b[r[ok] + 1] - near[ok]) - _hat_cdf(b[r[ok]] - near[ok])
        keep = ok & (w > 0.0)
        rows.append(r[keep])
        cols.append(near[keep])
        vals.append(w[keep])
    return np.concatenate(rows), np.concatenate(cols), np.concatenate(vals), n_rev


def revolution_coefficients(
    x: np.ndarray, sample_rate_hz: float, shaft_hz: float, orders: np.ndarray
) -> np.ndarray:
    """Fourier coefficients of ``x`` at ``orders`` over each whole revolution from the first sample.

    Returns (n_rev, n_orders): ``c[r, j] = (1/N) int_{rN}^{(r+1)N} x(s) exp(-2 pi i k_j s / N) ds`` with
    ``N = fs / shaft_hz`` samples per revolution, ``s`` in samples and ``x`` linear between samples
    (:func:`revolution_weights`); ``n_rev`` the revolutions that fit (the last needs one sample more).
    """
    x = np.asarray(x, dtype=float)
    orders = np.asarray(orders)
    n = x.size
    spr = float(sample_rate_hz) / float(shaft_hz)
    rows, cols, w, n_rev = _cached(("w", n, spr), lambda: revolution_weights(n, spr))  # type: ignore[misc]
    k = orders.size
    if n_rev < 1:
        return np.zeros((0, k), dtype=complex)

    def phasors() -> np.ndarray:
        ph = 2.0 * np.pi * np.outer((np.arange(n) / spr) % 1.0, orders.astype(float))
        return np.ascontiguousarray(np.hstack([np.cos(ph), -np.sin(ph)]))

    e = _cached(("e", n, spr, orders.tobytes()), phasors)
    wx = sp.csr_matrix((w * x[cols], (rows, cols)), shape=(n_rev, n))
    out = np.asarray(wx @ e) / spr
    return out[:, :k] + 1j * out[:, k:]
