"""Streaming decimation (gear_rotor_sim.solver.decimate) against independent computations.

Truths used: ``scipy.signal.lfilter`` / ``np.convolve`` followed by slicing (the decimating FIR),
``scipy.signal.freqz`` (the filter specification), analytic sinusoids (delay, zero phase, a change of
the decimation factor) and plain concatenation of the pushed samples (the kept history).
"""

from __future__ import annotations

import numpy as np
import pytest
from roundoff import roundoff
from scipy.signal import freqz, lfilter

from gear_rotor_sim.solver.decimate import (
    DeferredDecimator,
    StreamDecimator,
    design_taps,
    filter_delay,
    fir_decimate,
    fir_decimate_polyphase,
)


def _zero_phase_reference(
    x: np.ndarray, initial: np.ndarray, h: np.ndarray, k: int, n_out: int
) -> np.ndarray:
    """Outputs ``y[i] = sum_m h[m] x[i k + D - m]`` with ``x[j] = initial`` for ``j <= 0`` and
    ``x[j] = pushed[j - 1]`` after, by full convolution (np.convolve) and slicing."""
    d = (h.size - 1) // 2
    ext = np.vstack([np.tile(initial, (d + 1, 1)), x])  # ext[j + d] = x[j]
    y = np.empty((n_out, x.shape[1]))
    for c in range(x.shape[1]):
        full = np.convolve(ext[:, c], h)  # full[n] = sum_m h[m] ext[n - m]
        y[:, c] = full[d + np.arange(n_out) * k + d]  # n = (i k + d) + d in ext indices
    return y


def _push_all(dec: StreamDecimator, x: np.ndarray, sizes: list[int]) -> np.ndarray:
    out, i = [], 0
    for n in sizes:
        out.append(dec.push(x[i : i + n]))
        i += n
    return np.concatenate(out)


@pytest.mark.parametrize("k", [2, 3, 5, 16])
def test_design_meets_spec_and_whole_sample_delay(k: int) -> None:
    h = design_taps(k)
    w, r = freqz(h, worN=1 << 16, fs=float(k))  # frequency in units of the output rate
    db = 20 * np.log10(np.abs(r) + 1e-300)
    assert np.max(db[w >= 0.5]) < -80.0
    assert np.max(np.abs(db[w <= 0.4])) < 0.01
    q, rem = divmod(h.size - 1, k)
    assert rem == 0 and q % 2 == 0  # group delay (N - 1) / 2 = (q / 2) k: whole output periods
    np.testing.assert_array_equal(h, h[::-1])


@pytest.mark.parametrize(
    ("k", "ntap", "start"), [(3, 163, 170), (4, 30, 5), (16, 865, 900), (1, 1, 0), (5, 7, 2)]
)
def test_fir_decimate_matches_lfilter(k: int, ntap: int, start: int) -> None:
    rng = np.random.default_rng(k * 1000 + ntap)
    h = rng.standard_normal(ntap)  # not symmetric: the orientation of the sum matters
    buf = rng.standard_normal((start + 60 * k + 3, 4)) + np.array([0.0, 100.0, -3.0, 1e-6])
    n_out = (buf.shape[0] - 1 - start) // k + 1
    y = fir_decimate(buf, h, start, k, n_out)
    ref = lfilter(h, [1.0], buf, axis=0)[start + np.arange(n_out) * k]  # zero history before row 0
    assert y.shape == ref.shape
    np.testing.assert_allclose(y, ref, rtol=1e-12, atol=1e-12 * np.max(np.abs(ref)))


def test_fir_decimate_polyphase_refuses_reads_outside_the_store() -> None:
    st = np.zeros((3, 10, 2))
    h = np.ones(7)  # Q = 2
    assert fir_decimate_polyphase(st, h, 0, 8).shape == (8, 2)
    with pytest.raises(ValueError):
        fir_decimate_polyphase(st, h, 1, 8)
    with pytest.raises(ValueError):
        fir_decimate_polyphase(st, np.ones(6), 0, 4)


@pytest.mark.parametrize("k", [1, 3, 16])
def test_stream_matches_offline_zero_phase_filter_for_any_chunking(k: int) -> None:
    rng = np.random.default_rng(k)
    nch = 5
    initial = rng.standard_normal(nch) + 10.0
    x = rng.standard_normal((40 * k + 2000, nch)) + initial
    h = design_taps(k)
    d = (h.size - 1) // 2
    n_out = (x.shape[0] - d) // k + 1  # outputs i with i k + d <= last raw index
    ref = _zero_phase_reference(x, initial, h, k, n_out)
    scale = np.max(np.abs(ref), axis=0)
    for sizes in ([x.shape[0]], [1, 2, 3, 5, 7, 11] * 200, list(rng.integers(0, 3 * k + d, 500))):
        sizes = [int(s) for s in sizes]
        total = sum(sizes)
        if total < x.shape[0]:
            sizes.append(x.shape[0] - total)
        else:  # trim the last sizes to the data
            acc, cut = 0, []
            for s in sizes:
                cut.append(min(s, x.shape[0] - acc))
                acc += cut[-1]
            sizes = cut
        dec = StreamDecimator(k, initial)
        assert dec.delay == d
        y = _push_all(dec, x, sizes)
        assert y.shape == ref.shape
        assert np.max(np.abs(y - ref) / scale) < 1e-12
        if k == 1:
            np.testing.assert_array_equal(y, ref)
        # the kept history is the tail of what was pushed (plus the initial value before it)
        hist = dec.buf
        assert dec.last_raw == x.shape[0]
        np.testing.assert_array_equal(hist, np.vstack([np.tile(initial, (d + 1, 1)), x])[-hist.shape[0] :])


def test_push_parts_side_by_side_equal_one_array() -> None:
    rng = np.random.default_rng(7)
    k, n = 4, 3000
    a = rng.standard_normal((n, 3))
    b = rng.standard_normal(n)
    c = 2.5
    init = np.array([0.1, 0.2, 0.3, 0.4, 2.5])
    one = StreamDecimator(k, init)
    parts = StreamDecimator(k, init)
    full = np.column_stack([a, b, np.full(n, c)])
    y1 = _push_all(one, full, [700, 1300, 1000])
    y2 = np.concatenate([parts.push(a[s:e], b[s:e], c) for s, e in ((0, 700), (700, 2000), (2000, 3000))])
    np.testing.assert_array_equal(y1, y2)
    with pytest.raises(ValueError):
        parts.push(a[:10], b[:10])  # 4 columns, 5 expected
    with pytest.raises(ValueError):
        parts.push(a[:10], b[:9], c)
    with pytest.raises(ValueError):
        parts.push(1.0, a[:10], b[:10])


@pytest.mark.parametrize("k", [3, 16])
def test_streamed_impulse_response_is_the_designed_filter(k: int) -> None:
    """Impulses at k successive raw indices (one per channel) recover every tap through the stream."""
    h = design_taps(k)
    d = (h.size - 1) // 2
    j0 = d + 5 * k + 1  # every tap m = i k + d - j (i >= 0) is reached
    x = np.zeros((j0 + h.size + 4 * k, k))
    for c in range(k):
        x[j0 + c - 1, c] = 1.0  # raw index j0 + c (push row j is raw index j + 1)
    dec = StreamDecimator(k, np.zeros(k))
    y = _push_all(dec, x, [37, 5, x.shape[0] - 60, 18])
    rec = np.full(h.size, np.nan)
    for c in range(k):
        for i in range(y.shape[0]):
            m = i * k + d - (j0 + c)  # output i = sum_m h[m] x[i k + d - m]
            if 0 <= m < h.size:
                rec[m] = y[i, c]
    assert not np.any(np.isnan(rec))
    np.testing.assert_allclose(rec, h, rtol=0, atol=roundoff(np.abs(h).max(), h.size))
    w, r = freqz(rec, worN=1 << 15, fs=float(k))
    assert np.max(20 * np.log10(np.abs(r[w >= 0.5]) + 1e-300)) < -80.0


def test_regrid_and_rebase_keep_time_and_phase() -> None:
    """A sinusoid well inside the passband, sampled on the raw grid of the current k, comes out at the
    output times i / f_out (zero phase, whole-sample delay) across a change of k and a rebase."""
    f = 0.031  # cycles per output period
    k = 3
    dec = StreamDecimator(k, np.array([0.0, 1.0]))  # sin(0) = 0, cos(0) = 1

    def raw(t0: float, kk: int, n: int) -> np.ndarray:  # raw samples after t0 (output periods)
        t = t0 + np.arange(1, n + 1) / kk
        return np.column_stack([np.sin(2 * np.pi * f * t), np.cos(2 * np.pi * f * t)])

    # the initial constant (0, 1) before t = 0 is not a sinusoid: judge outputs from 60 periods on
    seg_t0, last, out = 0, 0, []
    for n in (700, 1100, 901):  # last one not on the output grid
        out.append(dec.push(raw(seg_t0 + last / k, k, n)))
        last += n
    top = -(-last // k) * k  # bring the last raw index onto the output grid, then switch 3 -> 16
    out.append(dec.push(raw(seg_t0 + last / k, k, top - last)))
    seg_t0 += top // k
    dec.regrid(16, top)
    k, last = 16, 0
    assert dec.delay == (design_taps(16).size - 1) // 2
    for n in (5000, 7001, 3999):
        out.append(dec.push(raw(seg_t0 + last / k, k, n)))
        last += n
    dec.rebase(last)  # a multiple of 16: raw indices restart at 0 there
    seg_t0 += last // k
    with pytest.raises(ValueError):
        dec.rebase(5)
    out.append(dec.push(raw(seg_t0, k, 4000)))
    y = np.concatenate(out)
    t = np.arange(y.shape[0])  # output i is at t = i output periods
    ref = np.column_stack([np.sin(2 * np.pi * f * t), np.cos(2 * np.pi * f * t)])
    # passband ripple < 0.01 dB (1.2e-3) bounds the error; the spline regrid adds less than that here
    assert np.max(np.abs(y[60:] - ref[60:])) < 2e-3
    # every output whose window is complete was emitted: the last one is ``delay`` raw samples back
    assert y.shape[0] - 1 == seg_t0 + (4000 - dec.delay) // 16


def test_deferred_decimator_counts_at_once_and_takes_the_stream_outputs_later() -> None:
    """DeferredDecimator: each push returns at once the number of outputs whose window it completes
    (the StreamDecimator's output count for the same push, and ``filter_delay`` its group delay), and
    outputs taken later, in arbitrary portions interleaved with further pushes, across a change of
    the decimation factor and a rebase, are the StreamDecimator's, bit for bit."""
    rng = np.random.default_rng(7)
    init = rng.standard_normal(3)
    ref = StreamDecimator(3, init)
    dd = DeferredDecimator(3, init)
    expected: list[np.ndarray] = []
    got: list[np.ndarray] = []

    def push(n: int) -> None:
        x = rng.standard_normal((n, 3))
        y = ref.push(x)
        assert dd.push(x) == y.shape[0]
        expected.append(y)

    def take_some() -> None:
        n = int(rng.integers(0, dd.produced - dd.taken + 1))
        got.append(dd.take(n, first=dd.taken))

    for n in (700, 1, 0, 1100, 901):
        push(n)
        take_some()
    top = -(-ref.last_raw // 3) * 3
    push(top - ref.last_raw)  # onto the output grid, then 3 -> 16
    ref.regrid(16, top)
    dd.regrid(16, top)
    assert dd.delay == ref.delay == filter_delay(16) == (design_taps(16).size - 1) // 2
    for n in (5000, 7001, 3999):
        push(n)
        take_some()
    with pytest.raises(ValueError):
        dd.rebase(5)
    ref.rebase(ref.last_raw)
    dd.rebase(dd.last_raw)
    push(4000)
    with pytest.raises(ValueError):  # blocks resolved out of order
        dd.take(1, first=dd.taken + 1)
    with pytest.raises(ValueError):  # more than completed
        dd.take(dd.produced - dd.taken + 1)
    got.append(dd.take(dd.produced - dd.taken))
    assert np.array_equal(np.concatenate(got), np.concatenate(expected))
    assert dd.take(0).shape == (0, 3)


def test_extra_columns_held_constant_come_out_exactly() -> None:
    """With ``n_main`` the extra columns (the simulator's speed and temperature) held at one value over
    an output's whole window give that value exactly; where one changes inside the window they are
    filtered as any column (against the full-convolution reference); the main columns are unchanged.
    Scalars and constant arrays are the same thing."""
    rng = np.random.default_rng(11)
    k, n = 16, 9000
    h = design_taps(k)
    d = (h.size - 1) // 2
    main = rng.standard_normal((n, 2))
    speed = np.full(n, 3000.0)
    speed[4000:5000] = 3000.0 + 0.37 * np.arange(1000)  # a ramp, then held at its end value
    speed[5000:] = speed[4999]
    temp = np.full(n, 25.0)
    init = np.array([0.0, 0.0, 3000.0, 25.0])
    x = np.column_stack([main, speed, temp])
    sizes = [1000, 3000, 500, 700, 800, 3000]
    split = StreamDecimator(k, init, n_main=2)
    out, i = [], 0
    for s in sizes:  # held parts as floats, the ramp's chunk as arrays
        sp = speed[i : i + s] if np.any(speed[i : i + s] != speed[i]) else float(speed[i])
        out.append(split.push(main[i : i + s], sp, np.full(s, 25.0) if s == 700 else 25.0))
        i += s
    y = np.concatenate(out)
    n_out = y.shape[0]
    ref = _zero_phase_reference(x, init, h, k, n_out)
    scale = np.max(np.abs(x), axis=0)
    assert np.all(np.abs(y - ref) <= roundoff(1.0, h.size) * scale)
    # outputs whose window (raw p - d .. p + d; raw index j is row j - 1) lies in a stretch pushed as
    # one value (before the ramp's chunk, or from the first chunk after the one where it ends): exact
    p = np.arange(n_out) * k
    held = (p + d <= 4000) | (p - d > 5200)
    assert np.count_nonzero(held) > n_out // 2
    assert np.array_equal(y[held, 2], np.concatenate([[3000.0], speed])[p[held]])
    assert np.all(y[:, 3] == 25.0)
    assert not np.all(y[~held, 2] == np.round(y[~held, 2]))  # the ramp's windows were filtered
    with pytest.raises(ValueError, match="n_main"):
        StreamDecimator(k, init, n_main=5)
    with pytest.raises(ValueError, match="first part"):
        split.push(main[:10, :1], 1.0, 2.0, 3.0)
