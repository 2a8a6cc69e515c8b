"""Impulsive interference in a record: short spikes an acquisition chain adds and nobody declares (issue 11;
docs/calibration.md Sec. 1, "Sensor conventions and faults nobody declared").

An electrical event (a relay, a motor drive switching, a static discharge) puts a spike of a few samples
into one channel or, common-mode, into every channel at the same sample. Its height is often within the
vibration's own range (10-50 x the noise is 0.2-2.5 x the RMS of a channel with 2-5 % noise), so a
threshold on the signal (:func:`measurement_checks._replace_spikes`, 100 robust scales) does not see it,
while its broadband energy raises an envelope spectrum, the classic false bearing alarm.

Detection (autoregressive click detection: Vaseghi & Rayner 1990; Godsill & Rayner 1998, Ch. 5):

1. a linear predictor of order :data:`AR_ORDER` fitted by least squares to the channel (median removed),
   refitted once without the samples near the first pass's outliers; the prediction error ``e = A x``
   is nearly white where the record is the machine's vibration plus noise (the gear mesh lines are
   predictable);
2. the interpolation error of each sample from both sides, ``d = A^T e / sum(a_k^2)``, the matched filter of
   a single-sample impulse: a spike of height ``h`` at sample ``n`` gives ``d[n] = h``; its scale is robust
   (1.4826 x MAD);
3. a spike is a run of at most :data:`MAX_WIDTH` samples with ``|d|`` beyond :data:`Z_SPIKE` robust
   scales, isolated: no other sample within :data:`GUARD` samples beyond :data:`Z_QUIET` scales once every
   other such run is interpolated too (a mechanical impact rings through the structure's modes and its
   prediction error does not stop after three samples; two spikes within the predictor's reach of each
   other must not hide each other: the runs are judged together, session 19, Sec. 8.51);
4. events at the same sample on at least two channels (and on at least half of them) are reported as
   common-mode.

A machine's impacts that its structure does not ring long (or that the predictor explains as single
innovations) can pass these tests too; but they recur at the defect's rate, while interference comes at
random times: events whose phases cohere at some rate (:func:`regular_rate`, a Rayleigh test) are left
alone. A channel with at least :data:`MIN_EVENTS` spikes at random times has them replaced by the
least-squares AR interpolation from their neighbours (Janssen, Veldhuis & Vries 1986: the values that
minimise the prediction-error energy around them) and is named in ``issues`` with the count and the
first times. Fewer events are left as they are: whether they come at a regular rate cannot be told, and
a few outliers move no averaged feature much. The
thresholds were checked on the 71 benchmark records and the CWRU files, on none of which the check fires
(docs/history/calibration_sessions.md Sec. 8.47).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gear_rotor_sim.calibration.measurement_contract import ChannelSpec

#: order of the linear predictor (samples)
AR_ORDER = 24
#: a spike's interpolation error beyond this many robust scales ...
Z_SPIKE = 9.0
#: ... in a run of at most this many samples ...
MAX_WIDTH = 3
#: ... with no other sample within GUARD samples beyond Z_QUIET scales
GUARD = 12
Z_QUIET = 4.5
#: more runs than this within GUARD samples of each other are one ringing event, not spikes
MAX_CLUSTER = 2
#: sweeps that interpolate each spike again with the others' interpolation in place (two spikes within the
#: predictor's reach of each other: the first was interpolated with the second still there)
REFINE_SWEEPS = 2
#: shortest channel analysed (samples)
MIN_SAMPLES = 50 * AR_ORDER
#: events at a regular rate: ``K R^2`` beyond this at some rate (R the events' phase coherence) ...
REGULAR_KR2 = 15.0
#: fewest spikes at random times on a channel for it to be repaired and reported: ``K R^2 <= K``, so only
#: more than REGULAR_KR2 events can show whether they come at a regular rate (a machine's) or not
MIN_EVENTS = int(REGULAR_KR2) + 1
#: ... searched from two cycles per record up to this rate, Hz
REGULAR_MAX_HZ = 2000.0
#: an event belongs to a train when another event is this close (in periods) to 1 .. TRAIN_MULTIPLES periods
#: away (an inner race's impacts are seen where the load zone passes: some once per shaft turn, 5-6 periods)
TRAIN_TOLERANCE = 0.08
TRAIN_MULTIPLES = 8


@dataclass(frozen=True)
class Spikes:
    """The spikes found on one channel: start samples, widths, and the largest ``|d|`` in robust scales."""

    starts: np.ndarray
    widths: np.ndarray
    peak_z: np.ndarray


def _design(x: np.ndarray, p: int) -> tuple[np.ndarray, np.ndarray]:
    """Rows ``[x[n-1], ..., x[n-p]]`` and targets ``x[n]`` for ``n = p .. N-1``."""
    cols = np.lib.stride_tricks.sliding_window_view(x, p + 1)[:, ::-1]
    return cols[:, 1:], cols[:, 0]


def fit_predictor(x: np.ndarray, p: int = AR_ORDER, exclude: np.ndarray | None = None) -> np.ndarray:
    """Prediction-error filter ``[1, -c_1, ..., -c_p]`` of ``x`` by least squares.

    Parameters
    ----------
    x : numpy.ndarray
        Finite samples (mean or median removed).
    p : int
        Order of the predictor.
    exclude : numpy.ndarray of bool, optional
        Samples not to use: every equation that holds one of them is dropped.

    Returns
    -------
    numpy.ndarray
        The ``p + 1`` filter coefficients ``a`` (``e = a * x``, convolution).
    """
    rows, target = _design(x, p)
    if exclude is not None:
        touched = np.lib.stride_tricks.sliding_window_view(exclude, p + 1).any(axis=1)
        rows, target = rows[~touched], target[~touched]
    c, *_ = np.linalg.lstsq(rows, target, rcond=None)
    return np.concatenate([[1.0], -c])


def interpolation_error(x: np.ndarray, a: np.ndarray) -> np.ndarray:
    """``d = A^T A x / sum(a^2)``: each sample minus its AR interpolation from both sides (to first order)."""
    e = np.convolve(x, a, mode="full")[: x.size]  # e[n] = sum_k a_k x[n-k]
    e[: a.size - 1] = 0.0
    back = np.convolve(e[::-1], a, mode="full")[: x.size][::-1]  # sum_k a_k e[n+k]
    return back / float(np.dot(a, a))


def _robust(d: np.ndarray) -> float:
    return 1.4826 * float(np.median(np.abs(d - np.median(d))))


def _zscores(y: np.ndarray, a: np.ndarray, scale: float | None = None) -> tuple[np.ndarray, float]:
    """``d / scale`` with ``d`` the interpolation error (zero where the filter does not reach)."""
    d = interpolation_error(y, a)
    p = a.size - 1
    d[:p] = 0.0
    d[-p:] = 0.0
    if scale is None:
        scale = _robust(d[p:-p])
    return (d / scale if scale > 0 else np.zeros_like(d)), scale


def channel_zscores(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, float] | None:
    """The channel less its median, its prediction-error filter (refitted once without the first pass's
    outliers), the z-scores of its interpolation error and their robust scale; None for a short,
    non-finite or constant channel."""
    if x.size < MIN_SAMPLES or not np.all(np.isfinite(x)):
        return None
    y = x - float(np.median(x))
    if _robust(y) <= 0.0:
        return None
    a = fit_predictor(y)
    z, _ = _zscores(y, a)
    far = np.abs(z) > Z_QUIET
    if far.any():  # refit without the outliers' neighbourhoods
        near = np.convolve(far, np.ones(2 * AR_ORDER + 1), mode="same") > 0
        if near.mean() < 0.5:
            a = fit_predictor(y, exclude=near)
    z, scale = _zscores(y, a)
    return (y, a, z, scale) if scale > 0 else None


def find_spikes(x: np.ndarray) -> tuple[Spikes, np.ndarray]:
    """Short spikes of one channel and the channel with them interpolated (module docstring).

    Seeds (``|z| > Z_SPIKE``) are taken in decreasing ``|z|``; for each that is still beyond
    :data:`Z_SPIKE` on the record as cleaned so far (an echo of a removed spike is not), the run of 1 to
    :data:`MAX_WIDTH` samples around it whose AR interpolation removes most of the prediction-error
    energy is interpolated. Then the runs are judged together (:func:`_isolated`): a run is a spike when,
    with every other run interpolated too, no sample within :data:`GUARD` samples of it is beyond
    :data:`Z_QUIET` (a spike's echoes through the predictor vanish with it, an impact's ring-down does
    not), and it is not one of more than :data:`MAX_CLUSTER` runs within :data:`GUARD` samples of each other
    (a ringing impact cut into short runs). Runs that fail are restored and the rest judged again until
    none fails. Judging the runs together keeps two spikes a few samples apart, or a spike next to a short
    impact, from hiding each other (session 19, docs/history/calibration_sessions.md Sec. 8.51).

    Parameters
    ----------
    x : numpy.ndarray
        One channel's samples (finite).

    Returns
    -------
    (Spikes, numpy.ndarray)
        The spikes, and ``x`` with them replaced by AR interpolation (``x`` itself without spikes).
    """
    empty = Spikes(np.zeros(0, int), np.zeros(0, int), np.zeros(0))
    fitted = channel_zscores(x)
    if fitted is None:
        return empty, x
    y, a, z, scale = fitted
    med = float(np.median(x))
    seeds = np.flatnonzero(np.abs(z) > Z_SPIKE)
    seeds = seeds[np.argsort(-np.abs(z[seeds]))]
    p = a.size - 1
    var_e = scale**2 * float(np.dot(a, a))  # var(d) = var(e) / sum(a^2)
    penalty = float(np.log(y.size))
    work = y.copy()
    runs: list[tuple[int, int, float]] = []
    reach = MAX_WIDTH + GUARD + 3 * p  # samples around a seed that its trials can touch
    for n in seeds:
        lo, hi = n - reach, n + reach + 1
        if lo < 0 or hi > y.size:
            continue
        loc = work[lo:hi]  # a view: an accepted interpolation is written into work
        c = n - lo
        zn = _zscores(loc, a, scale)[0][c]
        if abs(zn) <= Z_SPIKE:
            continue  # an echo of a run already interpolated
        best = (-np.inf, c, 1, loc)
        for w in range(1, MAX_WIDTH + 1):
            for s0 in range(c - w + 1, c + 1):
                trial = ar_interpolate(loc, a, s0, w)
                # energy removed in units of the prediction-error variance, less a BIC penalty per sample
                score = (_energy(loc, a, s0, w) - _energy(trial, a, s0, w)) / var_e - w * penalty
                if score > best[0]:
                    best = (score, s0, w, trial)
        _, s0, w, trial = best
        loc[:] = trial
        runs.append((lo + s0, w, abs(float(zn))))
    runs = _isolated(y, work, a, scale, runs)
    if not runs:
        return empty, x
    runs.sort()
    for _ in range(REFINE_SWEEPS):  # each run again with its neighbours' interpolation in place
        for s0, w, _ in runs:
            lo, hi = max(0, s0 - 2 * p), min(work.size, s0 + w + 2 * p)
            work[lo:hi] = ar_interpolate(work[lo:hi], a, s0 - lo, w)
    spikes = Spikes(
        np.array([r[0] for r in runs]), np.array([r[1] for r in runs]), np.array([r[2] for r in runs])
    )
    return spikes, work + med


def _isolated(
    y: np.ndarray, work: np.ndarray, a: np.ndarray, scale: float, runs: list[tuple[int, int, float]]
) -> list[tuple[int, int, float]]:
    """The runs that are isolated short spikes, judged together (:func:`find_spikes`); ``work`` (``y`` with
    every run interpolated) has the others restored from ``y``."""
    while runs:
        zc = np.abs(_zscores(work, a, scale)[0])
        own = np.zeros(work.size, dtype=bool)  # every run and the sample on each side of it
        for s0, w, _ in runs:
            own[max(0, s0 - 1) : s0 + w + 1] = True
        loud = (zc > Z_QUIET) & ~own
        starts = np.array([r[0] for r in runs])
        order = np.argsort(starts)
        # clusters: runs whose starts are within GUARD of the previous one's
        label = np.cumsum(np.r_[True, np.diff(starts[order]) > GUARD])
        sizes = np.bincount(label)
        bad = set()
        for rank, i in enumerate(order):
            s0, w, _ = runs[i]
            if sizes[label[rank]] > MAX_CLUSTER or loud[max(0, s0 - GUARD) : s0 + w + GUARD].any():
                bad.add(i)
        if not bad:
            break
        for i in bad:
            s0, w, _ = runs[i]
            work[s0 : s0 + w] = y[s0 : s0 + w]
        runs = [r for i, r in enumerate(runs) if i not in bad]
    return runs


def _energy(y: np.ndarray, a: np.ndarray, s0: int, w: int) -> float:
    """Prediction-error energy of the equations that hold samples ``s0 .. s0 + w - 1``."""
    p = a.size - 1
    seg = y[s0 - p : s0 + w + p]
    e = np.convolve(seg, a, mode="valid")
    return float(np.dot(e, e))


def ar_interpolate(x: np.ndarray, a: np.ndarray, start: int, width: int) -> np.ndarray:
    """Least-squares AR interpolation of ``x[start : start + width]`` (Janssen et al. 1986).

    The unknown samples minimise the prediction-error energy ``sum e^2`` of the equations that hold them;
    returns a copy of ``x`` with them replaced.
    """
    p = a.size - 1
    lo, hi = max(0, start - p), min(x.size, start + width + p)
    seg = x[lo:hi].astype(float)
    m = seg.size
    rows = m - p
    if rows < 1:
        return x.copy()
    # prediction-error matrix: E[i] = sum_k a_k seg[i + p - k]
    A = np.zeros((rows, m))
    for k in range(p + 1):
        A[np.arange(rows), np.arange(rows) + p - k] = a[k]
    unknown = np.arange(start - lo, start - lo + width)
    known = np.setdiff1d(np.arange(m), unknown)
    sol, *_ = np.linalg.lstsq(A[:, unknown], -A[:, known] @ seg[known], rcond=None)
    out = x.copy()
    out[start : start + width] = sol
    return out


def regular_rate(times_s: np.ndarray, duration_s: float) -> tuple[float, float] | None:
    """The rate at which events recur, if they are regular (a machine's impacts), else None.

    The phase coherence ``R(f) = |mean exp(2 pi i f t_k)|`` of ``K`` events at random times gives
    ``K R^2`` of about 1 at every rate (exponentially distributed); a train of impacts at a rate ``f``
    with a slip of a few percent keeps ``R(f)`` near 1 (Rayleigh test). Rates from ``2 / duration`` to
    :data:`REGULAR_MAX_HZ` on a grid of a quarter of the resolution ``1 / duration``.

    Returns
    -------
    (float, float) or None
        ``(rate_hz, K R^2)`` when ``K R^2 > REGULAR_KR2``.
    """
    k = times_s.size
    if k < 2 or duration_s <= 0:
        return None
    f = np.arange(2.0 / duration_s, REGULAR_MAX_HZ, 0.25 / duration_s)
    best_kr2, best_f = 0.0, 0.0
    for lo in range(0, f.size, 2048):
        fb = f[lo : lo + 2048]
        r = np.abs(np.exp(2j * np.pi * np.outer(fb, times_s)).mean(axis=1))
        i = int(np.argmax(r))
        if k * r[i] ** 2 > best_kr2:
            best_kr2, best_f = float(k * r[i] ** 2), float(fb[i])
    return (best_f, best_kr2) if best_kr2 > REGULAR_KR2 else None


def train_members(times_s: np.ndarray, rate_hz: float) -> np.ndarray:
    """Which events belong to a train at ``rate_hz``: those with another event 1 to :data:`TRAIN_MULTIPLES`
    periods away, within :data:`TRAIN_TOLERANCE` of a period (a slip of a few percent and missed impacts
    allowed).

    A spike at a random time between the impacts of a train is that close to a multiple of the period
    from an impact with a probability of about ``2 x TRAIN_TOLERANCE``."""
    if times_s.size < 2:
        return np.zeros(times_s.size, dtype=bool)
    gaps = np.abs(times_s[:, None] - times_s[None, :]) * rate_hz
    near = np.zeros_like(gaps, dtype=bool)
    for m in range(1, TRAIN_MULTIPLES + 1):
        near |= np.abs(gaps - m) < TRAIN_TOLERANCE
    return near.any(axis=1)


def _interference(spikes: Spikes, fs: float, duration_s: float) -> np.ndarray:
    """Indices of the events of a channel that are interference: all of them when they come at random
    times; when they recur at a regular rate (a machine's impacts), those outside that train, provided
    these are themselves at random times."""
    t = spikes.starts / fs
    regular = regular_rate(t, duration_s)
    if regular is None:
        return np.arange(t.size)
    loose = np.flatnonzero(~train_members(t, regular[0]))
    if loose.size < MIN_EVENTS or regular_rate(t[loose], duration_s) is not None:
        return np.zeros(0, dtype=int)
    return loose


def repair_spikes(
    data: np.ndarray, channels: Sequence[ChannelSpec], t0: float, fs: float, issues: list[str]
) -> np.ndarray:
    """Find and replace impulsive spikes on every channel of SI ``data`` (n, nc); ``issues`` entries name
    each repaired column, the count, the first times, and the events common to several channels.

    Parameters
    ----------
    data : numpy.ndarray
        ``(n_samples, n_channels)`` finite samples.
    channels : sequence of ChannelSpec
        One per column (their ``column`` names the channel in ``issues``).
    t0, fs : float
        Time of the first sample (s) and sample rate (Hz), for the times in ``issues``.
    issues : list of str
        Appended to.

    Returns
    -------
    numpy.ndarray
        ``data`` itself when no channel has :data:`MIN_EVENTS` spikes, else a repaired copy.
    """
    found = [find_spikes(data[:, k]) for k in range(data.shape[1])]
    duration = data.shape[0] / fs
    chosen = {
        k: _interference(s, fs, duration) for k, (s, _) in enumerate(found) if s.starts.size >= MIN_EVENTS
    }
    repaired = [k for k, idx in chosen.items() if idx.size >= MIN_EVENTS]
    if not repaired:
        return data
    out = data.copy()
    counts: dict[int, int] = {}
    for k in repaired:
        spikes, cleaned = found[k]
        x = data[:, k].copy()
        idx = chosen[k]
        if idx.size == spikes.starts.size:
            x = cleaned
        else:  # only the events outside the machine's impact train
            for i in idx:
                s0, w = int(spikes.starts[i]), int(spikes.widths[i])
                x[s0 : s0 + w] = cleaned[s0 : s0 + w]
        out[:, k] = x
        for i in idx:
            counts[int(spikes.starts[i])] = counts.get(int(spikes.starts[i]), 0) + 1
    common = sorted(s for s, c in counts.items() if c >= 2 and c >= 0.5 * len(repaired))
    for k in repaired:
        spikes, _ = found[k]
        idx = chosen[k]
        times = ", ".join(f"{t0 + spikes.starts[i] / fs:.6g}" for i in idx[:3])
        kept = spikes.starts.size - idx.size
        issues.append(
            f"column {channels[k].column!r}: {idx.size} impulsive spike(s) of 1-{MAX_WIDTH} samples at "
            f"random times (up to {float(np.max(spikes.peak_z[idx])):.3g} robust scales of the AR "
            f"interpolation error, isolated), first at t = {times} s: interference, not vibration; "
            "replaced by AR interpolation"
            + (f" ({kept} impulses at a regular rate kept: the machine's)" if kept else "")
        )
    if common:
        names = ", ".join(repr(channels[k].column) for k in repaired)
        issues.append(
            f"{len(common)} of these spikes sit at the same sample on several of the columns {names} "
            "(common-mode: an electrical event in the acquisition, not the machine)"
        )
    return out
