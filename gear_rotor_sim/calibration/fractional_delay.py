"""A record delayed or advanced by a fraction of a sample: band-limited interpolation (issue 11).

Two uses in the calibration: a channel the acquisition delayed by a few samples against the others is
read back at its own instants (``channel_skew.py``), and a model window moved on by whole hunting periods
that are not a whole number of samples is read at the instants of the window it stands for
(``model_settle.py``).

:func:`delay_samples` evaluates ``y[i] = x(i - d)`` by a Kaiser-windowed sinc of
:data:`~gear_rotor_sim.calibration.order_tracking.SINC_HALF_WIDTH` samples each side (the same kernel as
the order tracking's resampling, 80 dB): for a constant delay the weights are the same at every sample,
so the delay is one short correlation. Lines up to about 0.45 of the sample rate keep their amplitude
within 3e-4 and take the phase ``-2 pi f d / fs`` (``test/test_calibration_clock_skew.py``). Beyond its
first and last sample the record is held at that sample (as an acquisition that delays a channel fills its
first samples): mirrored ends put a kink into the last samples of a channel read earlier, and on the 3-sample
skew of ``bearing2_fx`` the envelope family read it as a line 470 times its noise (the healthy model's error
21 -> 114 for an exact 3-sample advance; held: 21.0, the undisturbed record's 20.9; Sec. 8.57).
"""

from __future__ import annotations

import math

import numpy as np

from gear_rotor_sim.calibration.order_tracking import SINC_HALF_WIDTH, sinc_weights


def delay_weights(d: float) -> tuple[int, np.ndarray]:
    """Offset and weights of ``x(i - d)``: ``sum_j w[j] x[i + k0 + j]`` over ``j = 0 .. 2 L - 1``.

    Parameters
    ----------
    d : float
        Delay, samples (negative: an advance).

    Returns
    -------
    (int, numpy.ndarray)
        ``k0`` (the first neighbour's offset from ``i``) and the ``2 L`` weights.
    """
    pos = -float(d)  # the instant i - d, relative to i
    base = math.floor(pos)
    frac = pos - base
    L = SINC_HALF_WIDTH
    j = np.arange(-L + 1, L + 1)
    u = frac - j  # distance from the instant to each neighbour base + j
    return base - L + 1, sinc_weights(u)


def delay_samples(x: np.ndarray, d: float) -> np.ndarray:
    """``x`` (samples along axis 0) delayed by ``d`` samples: ``y[i] = x(i - d)``.

    A whole-number ``d`` moves the samples exactly (the ends hold the first or last sample); a fractional
    one interpolates (module docstring). Returns a new array of the same shape.
    """
    a = np.asarray(x, dtype=float)
    one = a.ndim == 1
    a2 = a[:, None] if one else a
    n = a2.shape[0]
    k0, w = delay_weights(d)
    if abs(d - round(d)) < 1e-12:
        k0, w = -round(d), np.ones(1)
    pad_lo = max(0, -k0)
    pad_hi = max(0, k0 + w.size - 1)
    p = np.pad(a2, ((pad_lo, pad_hi), (0, 0)), mode="edge")
    out = np.zeros_like(a2)
    for jj, wj in enumerate(w):
        s = pad_lo + k0 + jj
        out += wj * p[s : s + n]
    return out[:, 0] if one else out
