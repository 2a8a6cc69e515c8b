"""Streaming anti-aliasing decimation: linear-phase Kaiser FIR, polyphase evaluation, carried history.

The filter is designed once per decimation factor ``k`` (integration rate = ``k * output_rate``):
passband edge ``0.4 * f_out``, stopband from ``0.5 * f_out`` (the output Nyquist) with at least 80 dB
attenuation (``scipy.signal.kaiserord`` / ``firwin``). Its length ``N = q k + 1`` (``q`` even) makes
the group delay ``D = (N - 1) / 2`` a multiple of ``k``, so every output sample is centred exactly on a
raw sample: output ``i`` at raw index ``p = i k`` is ``sum_m h[m] x[p + D - m]`` (zero phase; the raw
integration runs ``D`` steps ahead of the last emitted output). Only kept outputs are computed.

Evaluation (:func:`fir_decimate_polyphase`): the raw history is held in polyphase layout
``st[r, b, c] = x[b k + r, c]`` (phase ``r``, block ``b``, channel ``c``), written once when the raw
samples arrive. For a fixed tap ``m = j k + r`` the contributions to consecutive outputs are then one
contiguous run ``st[r, b0 + j : b0 + j + n_out, :]``, so the filter is a sequence of long
stride-1 multiply-adds over (output, channel), evaluated in cache-sized tiles of the output.
When ``k`` changes (speed change) the raw history is brought onto the new raw grid by cubic-spline
interpolation (see docs/solver.md).
"""

from __future__ import annotations

import collections
import threading

import numpy as np
from numba import njit
from scipy.interpolate import CubicSpline
from scipy.signal import firwin, kaiserord

STOPBAND_DB = 80.0
PASSBAND_FRACTION = 0.4  # of the output rate
STOPBAND_FRACTION = 0.5  # of the output rate (the output Nyquist)

_NO_EXTRA = np.zeros((0, 0))
#: ``StreamDecimator._xfrom`` of an extra column that does not hold one value.
_NOT_CONSTANT = np.iinfo(np.int64).max

#: Output elements (samples x channels) per tile of :func:`fir_decimate_polyphase` (16 KiB of doubles;
#: with the raw rows a tile reads it stays in the first- and second-level caches).
TILE_ELEMENTS = 2048


def _kaiser_design(k: int) -> tuple[int, float]:
    """Number of taps (``q k + 1``, ``q`` even) and Kaiser ``beta`` of :func:`design_taps` for ``k >= 2``."""
    nyq = 0.5 * k  # raw Nyquist in units of the output rate
    width = (STOPBAND_FRACTION - PASSBAND_FRACTION) / nyq
    n_min, beta = kaiserord(STOPBAND_DB + 3.0, width)
    q = 2 * int(np.ceil(n_min / (2.0 * k)))
    return q * k + 1, float(beta)


def filter_delay(k: int) -> int:
    """Group delay of :func:`design_taps` ``(k)`` in raw samples, ``(N - 1) / 2`` (0 for ``k = 1``)."""
    return 0 if k == 1 else (_kaiser_design(k)[0] - 1) // 2


def design_taps(k: int) -> np.ndarray:
    """Low-pass taps for decimation by ``k`` (normalised to the raw rate); ``[1.0]`` for ``k = 1``."""
    if k == 1:
        return np.ones(1)
    nyq = 0.5 * k  # raw Nyquist in units of the output rate
    numtaps, beta = _kaiser_design(k)
    cutoff = 0.5 * (PASSBAND_FRACTION + STOPBAND_FRACTION) / nyq
    taps = firwin(numtaps, cutoff, window=("kaiser", beta))
    return 0.5 * (taps + taps[::-1])  # exactly symmetric (linear phase)


@njit(cache=True, fastmath=True, nogil=True)
def fir_decimate_polyphase(st: np.ndarray, h: np.ndarray, b_start: int, n_out: int) -> np.ndarray:
    """Decimating FIR on a polyphase store: ``y[i, c] = sum_m h[m] x[(b_start + i) k + Q k - m, c]``.

    ``st[r, b, c] = x[b k + r, c]`` (``k = st.shape[0]``); ``h`` has ``Q k + 1`` taps. Output ``i``
    reads the raw samples ``(b_start + i) k .. (b_start + i + Q) k``, i.e. blocks
    ``b_start + i .. b_start + i + Q`` (the last one at phase 0 only), which must lie in the store.
    """
    k = st.shape[0]
    nb = st.shape[1]
    nch = st.shape[2]
    ntap = h.shape[0]
    nq = (ntap - 1) // k  # Q
    if ntap != nq * k + 1 or b_start < 0 or n_out < 0 or b_start + n_out + nq > nb:
        raise ValueError("fir_decimate_polyphase: taps must number Q k + 1 and the blocks read lie in st")
    y = np.zeros((n_out, nch))
    n = n_out * nch
    if n == 0:
        return y
    yf = y.reshape(n)
    # tap of raw x[lo + j k + r] (lo = (b_start + i) k) is h[Q k - j k - r]
    hr = np.empty(ntap)
    for m in range(ntap):
        hr[m] = h[ntap - 1 - m]
    for t0 in range(0, n, TILE_ELEMENTS):
        tn = min(TILE_ELEMENTS, n - t0)
        yt = yf[t0 : t0 + tn]
        for r in range(k):
            xr = st[r].reshape(nb * nch)[b_start * nch + t0 :]
            jmax = nq + 1 if r == 0 else nq
            j = 0
            while j + 3 < jmax:
                h0 = hr[j * k + r]
                h1 = hr[(j + 1) * k + r]
                h2 = hr[(j + 2) * k + r]
                h3 = hr[(j + 3) * k + r]
                a0 = xr[j * nch : j * nch + tn]
                a1 = xr[(j + 1) * nch : (j + 1) * nch + tn]
                a2 = xr[(j + 2) * nch : (j + 2) * nch + tn]
                a3 = xr[(j + 3) * nch : (j + 3) * nch + tn]
                for t in range(tn):
                    yt[t] += h0 * a0[t] + h1 * a1[t] + h2 * a2[t] + h3 * a3[t]
                j += 4
            while j < jmax:
                h0 = hr[j * k + r]
                a0 = xr[j * nch : j * nch + tn]
                for t in range(tn):
                    yt[t] += h0 * a0[t]
                j += 1
    return y


@njit(cache=True, nogil=True)
def _scatter(st: np.ndarray, first: int, main: np.ndarray, extra: np.ndarray) -> None:
    """Write raw rows into the polyphase store in one pass: for raw index ``b k + r = first + j``,
    ``st[r, b, :m] = main[j]`` and ``st[r, b, m + e] = extra[e, j]`` (``m = main.shape[1]``)."""
    k = st.shape[0]
    n = main.shape[0]
    m = main.shape[1]
    ne = extra.shape[0]
    b = first // k
    r = first - b * k
    for j in range(n):
        dst = st[r, b]
        src = main[j]
        for c in range(m):
            dst[c] = src[c]
        for e in range(ne):
            dst[m + e] = extra[e, j]
        r += 1
        if r == k:
            r = 0
            b += 1


@njit(cache=True, nogil=True)
def _fill(st: np.ndarray, first: int, n: int, values: np.ndarray) -> None:
    """``st[r, b, :] = values`` for the raw indices ``b k + r = first .. first + n - 1``."""
    k = st.shape[0]
    m = values.shape[0]
    b = first // k
    r = first - b * k
    for _ in range(n):
        dst = st[r, b]
        for c in range(m):
            dst[c] = values[c]
        r += 1
        if r == k:
            r = 0
            b += 1


def fir_decimate(buf: np.ndarray, h: np.ndarray, start: int, k: int, n_out: int) -> np.ndarray:
    """``y[i, c] = sum_m h[m] buf[start + i k - m, c]`` (rows outside ``buf`` count as 0).

    One-shot form of :func:`fir_decimate_polyphase` for a row-major (raw, channel) array: the rows
    used are copied once into polyphase layout. Any ``h`` (it need not be symmetric).
    """
    buf = np.asarray(buf, dtype=float)
    if buf.ndim != 2:
        raise ValueError("fir_decimate: buf must be 2-D (raw samples x channels)")
    h = np.asarray(h, dtype=float)
    k = int(k)
    n_out = int(n_out)
    nq = -(-(h.size - 1) // k)
    hp = np.zeros(nq * k + 1)
    hp[: h.size] = h  # zero taps on the oldest side: length Q k + 1
    lo = int(start) - nq * k  # raw row of the oldest sample output 0 reads
    st = np.zeros((k, n_out + nq, buf.shape[1]))
    a = max(lo, 0)
    e = min(lo + (n_out + nq) * k, buf.shape[0])
    if e > a:
        _scatter(st, a - lo, buf[a:e], _NO_EXTRA)
    return fir_decimate_polyphase(st, hp, 0, n_out)


class StreamDecimator:
    """Decimates a multichannel raw stream by ``k`` with carried filter history.

    The kept raw samples (indices ``b0 .. last_raw``, relative to the current raw segment) live in a
    growing polyphase store (``_st[r, b, c]`` = raw ``(_blk0 + b) k + r``); :meth:`push` writes new
    samples into it once and moves the kept history to the front only when the store is full.

    With ``n_main`` the columns from ``n_main`` on (the *extra* columns: the simulator's speed and
    temperature) are held in a store of their own and tracked for being constant: an output whose
    whole window (``2 delay + 1`` raw samples) holds one value in every extra column gets that value
    exactly, without filtering them (a symmetric filter of unit DC gain returns a constant to within
    round-off; docs/solver.md, "Session 10"). Where an extra column changes inside the window it is
    filtered like the others.

    Parameters
    ----------
    k : int
        Decimation factor.
    initial : ndarray
        (nch,) value of every channel at raw index 0 and (constant) before it.
    n_main : int, optional
        Number of leading (always filtered) columns; None: all of them.
    """

    def __init__(self, k: int, initial: np.ndarray, n_main: int | None = None) -> None:
        init = np.asarray(initial, float).reshape(-1)
        self.ncol = init.size
        if n_main is not None and not (isinstance(n_main, int | np.integer) and 1 <= n_main <= self.ncol):
            raise ValueError(f"n_main: {n_main!r} must be an integer in 1..{self.ncol} (the columns)")
        self.nmain = self.ncol if n_main is None else int(n_main)
        self.nx = self.ncol - self.nmain
        h = design_taps(int(k))
        delay = (h.size - 1) // 2
        self._reset(int(k), h, -delay, np.tile(init, (delay + 1, 1)), 0)

    # -------------------------------------------------------------------------------- storage
    def _reset(self, k: int, h: np.ndarray, b0: int, raw: np.ndarray, next_p: int) -> None:
        """(Re)build the store for factor ``k`` (taps ``h``) holding ``raw`` (rows = raw indices b0 ..)."""
        self.k = k
        self.h = h
        self.delay = (h.size - 1) // 2
        self.b0 = b0
        self._last = b0 + raw.shape[0] - 1
        self.next_p = next_p
        self._blk0 = b0 // k
        need = self._last // k - self._blk0 + 1
        raw = np.ascontiguousarray(raw, dtype=float)
        self._st = np.zeros((k, 2 * need + 8, self.nmain))
        self._sx = np.zeros((k, 2 * need + 8, self.nx))
        first = b0 - self._blk0 * k
        _scatter(self._st, first, np.ascontiguousarray(raw[:, : self.nmain]), _NO_EXTRA)
        # extra columns: the value each holds from raw index ``_xfrom`` on (``_NOT_CONSTANT``: none)
        self._xval = np.full(self.nx, np.nan)
        self._xfrom = np.full(self.nx, _NOT_CONSTANT, dtype=np.int64)
        if self.nx:
            xs = np.ascontiguousarray(raw[:, self.nmain :].T)
            _scatter(self._sx, first, np.zeros((raw.shape[0], 0)), xs)
            for e in range(self.nx):
                if np.all(xs[e] == xs[e, 0]):
                    self._xval[e] = xs[e, 0]
                    self._xfrom[e] = b0

    def _reserve(self, n: int) -> None:
        """Make room for raw samples up to ``last_raw + n``: compact (and grow) when needed."""
        k = self.k
        cap = self._st.shape[1]
        if (self._last + n) // k - self._blk0 < cap:
            return
        first = self.b0 // k
        s = first - self._blk0
        used = self._last // k - first + 1
        need = (self._last + n) // k - first + 1
        if need <= cap:  # move the kept history to the front
            self._st[:, :used] = self._st[:, s : s + used].copy()
            self._sx[:, :used] = self._sx[:, s : s + used].copy()
        else:  # grow to the push plus twice the history: later moves of the history stay amortised
            st = np.zeros((k, need + used + 8, self.nmain))
            st[:, :used] = self._st[:, s : s + used]
            self._st = st
            sx = np.zeros((k, need + used + 8, self.nx))
            sx[:, :used] = self._sx[:, s : s + used]
            self._sx = sx
        self._blk0 = first

    @property
    def last_raw(self) -> int:
        return self._last

    @property
    def buf(self) -> np.ndarray:
        """Copy of the kept raw samples, raw indices ``b0 .. last_raw`` (rows), channels (columns)."""
        k = self.k
        first = self.b0 // k
        nblk = self._last // k - first + 1
        s = first - self._blk0
        off = self.b0 - first * k
        parts = []
        for st in (self._st, self._sx):
            rows = st[:, s : s + nblk].transpose(1, 0, 2).reshape(nblk * k, st.shape[2])
            parts.append(rows[off : off + self._last - self.b0 + 1])
        return np.concatenate(parts, axis=1) if self.nx else parts[0].copy()

    # ------------------------------------------------------------------------------- streaming
    def push(self, *parts: np.ndarray | float) -> np.ndarray:
        """Append raw samples (raw indices last_raw+1 ...) and return the outputs now complete.

        ``parts`` are the columns side by side, ``ncol`` in all: arrays ``(n, m)`` or ``(n,)`` (the same
        ``n``) or, after the first, floats (a constant column). They are written into the store in one
        pass (the first part row-wise, the later ones as stacked columns), so the caller need not
        assemble an ``(n, ncol)`` array.
        """
        if not parts or np.ndim(parts[0]) not in (1, 2):
            raise ValueError("push: the first part must be an (n, m) or (n,) array")
        main = np.asarray(parts[0], dtype=float)
        n = main.shape[0]
        main = main.reshape(n, 1) if main.ndim == 1 else main
        cols: list[np.ndarray | float] = []  # the later parts: (m, n) row blocks or floats
        n_extra = 0
        for p in parts[1:]:
            a = np.asarray(p, dtype=float)
            if a.ndim == 0:
                cols.append(float(a))
                n_extra += 1
            elif a.ndim <= 2 and a.shape[0] == n:
                cols.append(a.reshape(1, n) if a.ndim == 1 else a.T)
                n_extra += cols[-1].shape[0]
            else:
                raise ValueError(f"push: part of shape {a.shape} does not match {n} raw samples")
        if main.shape[1] + n_extra != self.ncol:
            raise ValueError(f"push: {main.shape[1] + n_extra} columns given, {self.ncol} expected")
        if self.nx and main.shape[1] != self.nmain:
            raise ValueError(f"push: the first part has {main.shape[1]} columns, n_main = {self.nmain}")
        if n:
            self._reserve(n)
            at = self._last + 1 - self._blk0 * self.k
            if self.nx and all(isinstance(c, float) for c in cols):  # set-points held: one value each
                xv = np.array(cols)
                _scatter(self._st, at, main, _NO_EXTRA)
                _fill(self._sx, at, n, xv)
                for e in range(self.nx):
                    if xv[e] != self._xval[e] or self._xfrom[e] == _NOT_CONSTANT:
                        self._xval[e] = xv[e]
                        self._xfrom[e] = self._last + 1
            else:
                rows = [np.full((1, n), c) if isinstance(c, float) else c for c in cols]
                extra = np.concatenate(rows) if rows else _NO_EXTRA
                if self.nx:
                    _scatter(self._st, at, main, _NO_EXTRA)
                    _scatter(self._sx, at, np.empty((n, 0)), extra)
                    for e in range(self.nx):  # is each extra column still one value?
                        v = extra[e, 0]
                        if not np.all(extra[e] == v):
                            self._xval[e] = np.nan
                            self._xfrom[e] = _NOT_CONSTANT
                        elif v != self._xval[e] or self._xfrom[e] == _NOT_CONSTANT:
                            self._xval[e] = v
                            self._xfrom[e] = self._last + 1
                else:
                    _scatter(self._st, at, main, extra)
            self._last += n
        last_ok = self._last - self.delay
        if last_ok < self.next_p:
            return np.zeros((0, self.ncol))
        n_out = (last_ok - self.next_p) // self.k + 1
        p_last = self.next_p + (n_out - 1) * self.k
        # zero phase: output at raw index p uses raw p - delay .. p + delay (blocks from (p - delay) / k)
        b_start = (self.next_p - self.delay) // self.k - self._blk0
        if self.k == 1:
            y = self._st[0, b_start : b_start + n_out].copy()
        else:
            y = fir_decimate_polyphase(self._st, self.h, b_start, n_out)
        if self.nx:  # extra columns: each its value from the first output whose window holds one
            n_filt = [
                n_out
                if xf == _NOT_CONSTANT  # output i reads from raw next_p + i k - delay
                else min(n_out, max(0, -(-(int(xf) + self.delay - self.next_p) // self.k)))
                for xf in self._xfrom
            ]
            n_fir = max(n_filt)
            yx = np.empty((n_out, self.nx))
            if n_fir and self.k == 1:
                yx[:n_fir] = self._sx[0, b_start : b_start + n_fir]
            elif n_fir:
                yx[:n_fir] = fir_decimate_polyphase(self._sx, self.h, b_start, n_fir)
            for e, i0 in enumerate(n_filt):
                yx[i0:, e] = self._xval[e]
            y = np.concatenate([y, yx], axis=1)
        self.next_p = p_last + self.k
        keep_from = self.next_p - 2 * self.delay - self.k  # margin for a later regrid
        if keep_from > self.b0:
            self.b0 = keep_from
        return y

    def regrid(self, new_k: int, split_raw: int) -> None:
        """Switch to decimation ``new_k`` at raw index ``split_raw`` (a multiple of ``k``, the last raw).

        The raw history is interpolated (cubic spline) onto the new grid of step ``k / new_k`` (in
        units of the old step) ending at the split; indices restart at 0 there.
        """
        if split_raw != self.last_raw or split_raw % self.k:
            raise ValueError("regrid: the split must be the last raw sample and on the output grid")
        buf = self.buf
        old_t = (self.b0 + np.arange(buf.shape[0])) / self.k  # in output periods, relative
        new_h = design_taps(new_k)
        new_delay = (new_h.size - 1) // 2
        pending_first = (self.next_p - split_raw) / self.k  # <= 0, output periods
        n_hist = int(np.ceil(-pending_first * new_k)) + new_delay + new_k
        new_idx = np.arange(-n_hist, 1)
        new_t = split_raw / self.k + new_idx / new_k
        spline = CubicSpline(old_t, buf, axis=0)
        new_buf = spline(np.maximum(new_t, old_t[0]))
        new_buf[-1] = spline(old_t[-1])
        self._reset(int(new_k), new_h, -n_hist, new_buf, round(pending_first * new_k))

    def rebase(self, split_raw: int) -> None:
        """Restart raw indices at 0 at ``split_raw`` (a multiple of k) without changing the grid."""
        if split_raw % self.k:
            raise ValueError("rebase: the split must be on the output grid (a multiple of k)")
        self.b0 -= split_raw
        self._last -= split_raw
        self.next_p -= split_raw
        self._blk0 -= split_raw // self.k
        self._xfrom[self._xfrom != _NOT_CONSTANT] -= split_raw


class DeferredDecimator:
    """A :class:`StreamDecimator` whose filtering runs later, in the thread that takes the outputs.

    :meth:`push`, :meth:`regrid` and :meth:`rebase` only record the operation and advance the output
    count (index arithmetic identical to :class:`StreamDecimator`'s), so the producer (the
    simulator's integration) learns at once how many outputs each push completes; :meth:`take` runs
    the recorded operations in order, in the calling thread, and returns the next outputs. The
    outputs are those of a :class:`StreamDecimator` given the same operations, bit for bit. The
    simulator node takes them in its output thread, so that the FIR runs on the other core while
    the next chunk is integrated (docs/ros.md, "Timing, threads, real-time factor").

    One producer thread calls :meth:`push`, :meth:`regrid`, :meth:`rebase`; one consumer at a time
    calls :meth:`take` (serialised by a lock). The arrays given to :meth:`push` must not be changed
    until their outputs are taken.

    Parameters
    ----------
    k : int
        Decimation factor.
    initial : ndarray
        (nch,) value of every channel at raw index 0 and (constant) before it.
    n_main : int, optional
        As :class:`StreamDecimator`.
    """

    def __init__(self, k: int, initial: np.ndarray, n_main: int | None = None) -> None:
        self._dec = StreamDecimator(k, initial, n_main)
        self.ncol = self._dec.ncol
        self.k = self._dec.k
        self.delay = self._dec.delay
        self._last = self._dec.last_raw
        self._next_p = self._dec.next_p
        self._ops: collections.deque = collections.deque()
        self._lock = threading.Lock()
        self._ready: list[np.ndarray] = []  # outputs computed, not yet taken (consumer side)
        self._n_ready = 0
        self.produced = 0  # outputs completed by the recorded pushes
        self.taken = 0  # outputs returned by take

    @property
    def last_raw(self) -> int:
        return self._last

    def push(self, *parts: np.ndarray | float) -> int:
        """Record :meth:`StreamDecimator.push` of ``parts``; return the number of outputs it completes."""
        if not parts or np.ndim(parts[0]) not in (1, 2):
            raise ValueError("push: the first part must be an (n, m) or (n,) array")
        n = int(np.shape(parts[0])[0])
        self._ops.append(("push", parts))
        self._last += n
        last_ok = self._last - self.delay
        if last_ok < self._next_p:
            return 0
        n_out = (last_ok - self._next_p) // self.k + 1
        self._next_p += n_out * self.k
        self.produced += n_out
        return n_out

    def regrid(self, new_k: int, split_raw: int) -> None:
        """Record :meth:`StreamDecimator.regrid` (same arguments and checks)."""
        if split_raw != self._last or split_raw % self.k:
            raise ValueError("regrid: the split must be the last raw sample and on the output grid")
        pending_first = (self._next_p - split_raw) / self.k
        self._ops.append(("regrid", (int(new_k), int(split_raw))))
        self._next_p = round(pending_first * new_k)
        self._last = 0
        self.k = int(new_k)
        self.delay = filter_delay(self.k)

    def rebase(self, split_raw: int) -> None:
        """Record :meth:`StreamDecimator.rebase` (same argument and check)."""
        if split_raw % self.k:
            raise ValueError("rebase: the split must be on the output grid (a multiple of k)")
        self._ops.append(("rebase", (int(split_raw),)))
        self._last -= split_raw
        self._next_p -= split_raw

    def take(self, n: int, first: int | None = None) -> np.ndarray:
        """Run the recorded operations as far as needed and return the next ``n`` outputs ``(n, ncol)``.

        ``first``: the index (counted from the first output) the caller expects the outputs to start
        at; a ValueError if they do not (blocks resolved out of order).
        """
        with self._lock:
            if first is not None and first != self.taken:
                raise ValueError(f"take: outputs from {first} requested, the next one is {self.taken}")
            if n > self.produced - self.taken:
                raise ValueError(f"take: {n} outputs requested, {self.produced - self.taken} completed")
            while self._n_ready < n:
                kind, args = self._ops.popleft()
                if kind == "push":
                    y = self._dec.push(*args)
                    if y.shape[0]:
                        self._ready.append(y)
                        self._n_ready += y.shape[0]
                elif kind == "regrid":
                    self._dec.regrid(*args)
                else:
                    self._dec.rebase(*args)
            if n == 0:
                return np.zeros((0, self.ncol))
            y = self._ready[0] if len(self._ready) == 1 else np.concatenate(self._ready)
            self._ready = [y[n:]] if y.shape[0] > n else []
            self._n_ready -= n
            self.taken += n
            return y[:n]
