"""The fluctuating load taken out of the record: its sidebands around the machine's lines removed (issue 11;
docs/calibration.md Sec. 2 "Load check", fluctuating load).

A load ``T0 [1 + a(t)]`` with ``a(t) = A sin(2 pi f* t + phi)`` modulates every line the machine makes at
the mean load: the static reactions (the line at ``f*`` itself, ``load_fluctuation.py``), the mesh harmonics
and the shaft orders, each with its own depth (the mesh harmonics' modulation is not the load's: their
dynamic part holds the static transmission error, which does not scale with the load, and the mesh
stiffness's dependence on it; on the independent 3000 rpm record the first harmonic carried 0.72 of ``A``,
the third 1.8). The sidebands ``c +- j f*`` of each line ``c`` are the whole of what the fluctuation adds to
the record as long as the response is quasi-static (``f*`` far below the first mode); the features then see
a record at the mean load.

Method (:func:`demodulate`): per channel, the carriers ``c`` are the channel mean (``c = 0``), the mesh
harmonics and their sidebands at orders 1-6 of every shaft and the shafts' orders 1-6 (below ``0.45 fs``),
of which the ``MAX_CARRIERS`` largest above ``KEEP`` of the largest are kept (a Hann-weighted projection);
the targets are ``c +- j f*`` for ``j = 1, 2`` that fall on no carrier. One Hann-weighted least-squares fit
of every kept carrier and every target (cosine and sine each) gives the targets' components, which are
subtracted; the carriers stay. Where the load is locked to an order (``f* = k f_s``), that shaft's orders
and mesh sidebands are no carriers and the targets are orders themselves (e.g. the gear's 1x and the mesh
harmonics' +-1x of the gear), and the check only fires where the DTE's modulation there is a load's
(``load_fluctuation.py``): a geometric fault at the same order would be removed with it (a limit,
docs/calibration.md Sec. 10).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

#: carriers kept per channel and their smallest amplitude relative to the channel's largest carrier
MAX_CARRIERS = 24
KEEP = 0.01
#: sidebands removed on each side of a carrier: +-j f*, j = 1..HARMONICS
HARMONICS = 2
#: shaft orders that are carriers (low orders) and mesh sidebands
ORDERS = range(1, 7)
#: projection block size (rows of the complex phasor matrix)
_BLOCK = 16


def carrier_frequencies(
    shafts_hz: Sequence[float], mesh_hz: Sequence[float], f_top: float, locked: int | None = None
) -> np.ndarray:
    """Every candidate carrier below ``f_top`` (Hz): 0, the shafts' orders 1-6, each mesh harmonic and its
    sidebands at orders 1-6 of every shaft (distinct, sorted). ``locked``: the index of the shaft the load is
    locked to, whose orders and mesh sidebands are left out (they are where the load's sidebands fall)."""
    free = [f for i, f in enumerate(shafts_hz) if i != locked]
    out = {0.0}
    for fs_ in free:
        out |= {k * fs_ for k in ORDERS}
    for fm in mesh_hz:
        h = 1
        while h * fm < f_top:
            out.add(h * fm)
            for fs_ in free:
                out |= {h * fm + s * k * fs_ for k in ORDERS for s in (-1, 1)}
            h += 1
    arr = np.array(sorted(f for f in out if 0.0 <= f < f_top))
    return arr[np.concatenate([[True], np.diff(arr) > 1e-9])]


def _project(x: np.ndarray, w: np.ndarray, t: np.ndarray, freqs: np.ndarray) -> np.ndarray:
    """Hann-weighted complex amplitudes of ``x`` at ``freqs`` (blocks of ``_BLOCK`` frequencies)."""
    out = np.empty(freqs.size, complex)
    xw = x * w
    for i in range(0, freqs.size, _BLOCK):
        f = freqs[i : i + _BLOCK]
        out[i : i + f.size] = np.exp(-2j * np.pi * np.outer(f, t)) @ xw
    return 2.0 * out / np.sum(w)


def _targets(carriers: np.ndarray, f_star: float, f_top: float) -> np.ndarray:
    tol = 1e-6 * max(1.0, f_star)
    cand = {abs(c + s * j * f_star) for c in carriers for j in range(1, HARMONICS + 1) for s in (-1, 1)}
    return np.array(
        sorted(f for f in cand if 0.0 < f < f_top and np.min(np.abs(carriers - f)) > tol),
    )


def demodulate_channel(
    x: np.ndarray, fs: float, f_star: float, candidates: np.ndarray
) -> tuple[np.ndarray, float]:
    """``x`` without the sidebands ``c +- j f*`` of its kept carriers (module docstring).

    Returns
    -------
    (numpy.ndarray, float)
        The corrected channel and the RMS of what was removed.
    """
    x = np.asarray(x, float)
    n = x.size
    t = np.arange(n) / fs
    w = np.hanning(n)
    amp = np.abs(_project(x - np.mean(x), w, t, candidates))
    amp[candidates == 0.0] = np.inf  # the mean always
    order = np.argsort(-amp)[:MAX_CARRIERS]
    finite = amp[np.isfinite(amp)]
    top = float(np.max(finite)) if finite.size else 0.0
    kept = np.sort(candidates[order[(amp[order] >= KEEP * top) | ~np.isfinite(amp[order])]])
    targets = _targets(kept, f_star, 0.45 * fs)
    if targets.size == 0:
        return x.copy(), 0.0

    def cols(freqs: np.ndarray) -> np.ndarray:
        ph = 2.0 * np.pi * np.outer(t, freqs)
        return np.hstack([np.cos(ph), np.sin(ph)])

    nz = kept[kept > 0.0]
    a = np.hstack([np.ones((n, 1)), cols(nz), cols(targets)])
    sw = np.sqrt(w)
    coef = np.linalg.lstsq(a * sw[:, None], x * sw, rcond=None)[0]
    removed = a[:, 1 + 2 * nz.size :] @ coef[1 + 2 * nz.size :]
    return x - removed, float(np.sqrt(np.mean(removed**2)))


def demodulate(
    data: np.ndarray,
    fs: float,
    f_star: float,
    shafts_hz: Sequence[float],
    mesh_hz: Sequence[float],
    locked: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Every channel of ``data`` (``(n, nc)``) without the load's sidebands at ``f_star`` (Hz); ``locked``:
    the shaft the load is locked to (:func:`carrier_frequencies`), None for a load at no order.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        The corrected data and, per channel, the RMS removed.
    """
    cands = carrier_frequencies(shafts_hz, mesh_hz, 0.45 * fs, locked)
    out = np.empty_like(np.asarray(data, float))
    rms = np.zeros(out.shape[1])
    for k in range(out.shape[1]):
        out[:, k], rms[k] = demodulate_channel(data[:, k], fs, f_star, cands)
    return out, rms


def apply_demodulation(cal: Any, found: Any, issue: str, shafts_hz: Sequence[float]) -> np.ndarray:
    """Remove the load fluctuation ``found`` (``load_fluctuation.LoadFluctuation``) from ``cal``'s record and
    set the comparison and the healthy model up again on it (as the sign fix of ``channel_conventions.py``;
    the model runs come from the runner's cache). ``issue``: the finding's ``issues`` line. Returns the
    healthy model's outputs."""
    from gear_rotor_sim.calibration.load_fluctuation import find_load_fluctuation
    from gear_rotor_sim.calibration.residual import Comparison
    from gear_rotor_sim.calibration.speed_estimate import mesh_orders_per_input

    m = cal.m
    rate = float(m.operating_point.speed_rpm) / 60.0
    mesh = [o * rate for o in mesh_orders_per_input(cal.runner.cfg)]
    data, rms = demodulate(m.data, m.sample_rate_hz, found.frequency_hz, shafts_hz, mesh, found.shaft)
    after = [
        c
        for c in find_load_fluctuation(data, m.sample_rate_hz, m.channels, shafts_hz)
        if (c.order, c.shaft) == (found.order, found.shaft)
    ]
    left = abs(after[0].amplitude) if after else float("nan")
    sd = np.std(m.data, axis=0)
    removed = ", ".join(
        f"{c.column} {r / s:.3f}" for c, r, s in zip(m.channels, rms, sd, strict=True) if s > 0
    )
    text = (
        f"{issue}; its sidebands (+-1, 2 x the modulation about the mean, the mesh harmonics and the shaft "
        f"orders) removed from every channel before the features (RMS removed / channel's: {removed}; "
        f"modulation left {100 * left:.2g} %)"
    )
    cal.log(text)
    m.data = data
    m.issues.append(text)
    cal.cmp = Comparison(m, cal.runner, cal.settings, cal._env_max)
    k = len(cal.notes)
    base_out = cal._setup()
    del cal.notes[k:]  # the setup's notes (the step count) were given by the first setup
    cal.notes.append("load_fluctuation: " + text)
    return base_out
