"""A channel whose gain varies slowly (a loose connector, a cable, a failing amplifier): found and
divided out (issue 11; docs/calibration.md Sec. 1, "Sensor conventions and faults nobody declared").

A sensor-side gain ``g(t) = 1 + a(t)`` multiplies EVERYTHING the channel carries alike: its mean (a
bearing force's static load), every spectral line (the mesh harmonics) and the noise. A machine effect
that modulates (a load or speed fluctuation, a rattle, a hunting-tooth pair) reaches several channels
through the structure, and modulates the lines of one channel differently (the static load not at all,
or not in proportion). So, per channel and below half the slowest shaft's rate ``f_c`` (no shaft
order's sideband falls there):

1. **carriers**: the channel's mean (its band ``(0, f_c]`` over the mean; a static quantity's: a force,
   a deflection, not a vibration acceleration's, whose mean is an offset) and each spectral line that
   stands :data:`LINE_SNR` x above the median power within ``+-5 f_c`` (a local maximum over ``+-f_c``;
   the strongest :data:`MAX_LINES`, at least ``2 f_c`` apart): its band ``+-f_c`` shifted to zero
   frequency, ``z_j(t)``, gives the relative amplitude ``r_j = |z_j| / mean |z_j| - 1`` and its
   spectrum ``A_j(f)``, ``0 < f <= f_c``. White noise of power ``P_n`` per bin around a line of power
   ``P_j`` puts ``v_j = P_n / (2 P_j)`` into each bin of ``A_j`` (in-phase half; the mean's carrier:
   ``P_n / mean^2``);
2. **the common gain**: ``A(f) = sum_j A_j / v_j / sum_j 1 / v_j`` with variance ``v = 1 / sum 1 / v_j``,
   its size ``chi2_n = sum_f |A|^2 / v / N`` (``N`` bins; noise reads about 1) and depth
   ``sqrt(2 sum_f |A|^2)`` (the rms of ``a(t)``);
3. **one gain for every carrier**: each carrier that resolves the common gain on its own (``sum_f |A|^2 /
   v_j >=`` :data:`RESOLVE_CHI2`) must read it: correlation of ``A_j`` with ``A`` at least :data:`SAME_RHO`
   times the correlation its noise allows, ``sqrt(c_j / (c_j + N))`` with ``c_j = sum_f |A|^2 / v_j``
   (``E |A_j|^2 = |A|^2 + N v_j``), and at least :data:`MIN_CARRIERS` such carriers;
4. **one channel only**: every other channel ``k`` that could see it (``sigma_beta <=``
   :data:`BETA_SIGMA_MAX`) shares less than :data:`SHARED_BETA` of it, ``beta_k = Re <A, A_k> / <A, A>``
   (``sigma_beta = sqrt(v_k / (2 sum_f |A|^2))``), and at least one such channel exists (a record of one
   channel cannot tell a sensor from the machine).

A channel that passes 2-4 with ``chi2_n >=`` :data:`CHI2N_MIN` and a depth of at least :data:`DEPTH_MIN`
is divided by ``1 + a(t)`` (``a`` the band-limited inverse transform of ``A``), and ``issues`` names it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

#: a line stands this many times above the median power of its neighbourhood
LINE_SNR = 100.0
#: the strongest lines used as carriers
MAX_LINES = 8
#: the common gain's chi2 per bin over its noise
CHI2N_MIN = 15.0
#: rms depth of the gain modulation (0.5 %)
DEPTH_MIN = 5e-3
#: a carrier resolves the common gain when it holds it at this chi2 over its own noise
RESOLVE_CHI2 = 100.0
#: ... and then reads it with at least this fraction of the correlation its noise allows
SAME_RHO = 0.7
#: carriers that must resolve and read it
MIN_CARRIERS = 2
#: another channel sharing this fraction of the modulation makes it the machine's
SHARED_BETA = 0.25
#: another channel counts as seeing the modulation when it resolves ``beta`` to this sigma
BETA_SIGMA_MAX = 0.1


@dataclass(frozen=True)
class ChannelGain:
    """The slow relative gain of one channel (module docstring, steps 1-3).

    Attributes
    ----------
    spectrum : numpy.ndarray
        ``A(f)`` on bins ``1..N`` (frequencies ``k / T``), complex; empty without a carrier.
    variance : float
        Noise variance per bin of ``A`` (``v``).
    chi2_n : float
        ``sum_f |A|^2 / v / N``.
    depth : float
        RMS of ``a(t)``.
    carriers : tuple of (str, float, float)
        ``(name, chi2 of the common gain over its noise, correlation with A)`` per carrier.
    """

    spectrum: np.ndarray
    variance: float
    chi2_n: float
    depth: float
    carriers: tuple[tuple[str, float, float], ...]

    @property
    def same_on_carriers(self) -> bool:
        """Step 3: enough carriers resolve the common gain and each reads it."""
        n = self.spectrum.size
        resolved = [(c2, rho) for _, c2, rho in self.carriers if c2 >= RESOLVE_CHI2]
        return len(resolved) >= MIN_CARRIERS and all(
            rho >= SAME_RHO * np.sqrt(c2 / (c2 + n)) for c2, rho in resolved
        )


def _carriers(x: np.ndarray, fs: float, w: int, use_mean: bool) -> list[tuple[str, np.ndarray, float]]:
    """``(name, A_j on bins 1..w, v_j)`` of the mean (if ``use_mean``) and the strongest lines (module
    docstring, step 1)."""
    n = x.size
    m = float(np.mean(x))
    spec = np.fft.fft(x - m) / n
    power = np.abs(spec[: n // 2]) ** 2
    out: list[tuple[str, np.ndarray, float]] = []
    if use_mean and m != 0.0 and 6 * w < power.size:
        out.append(("mean", spec[1 : w + 1] / m, float(np.median(power[w + 1 : 6 * w])) / m**2))
    idx = np.arange(5 * w, n // 2 - 5 * w)
    if idx.size == 0:
        return out
    win = np.lib.stride_tricks.sliding_window_view(power, 2 * w + 1)
    peak = idx[power[idx] >= win[idx - w].max(axis=1)]
    found = []
    for i in peak:
        med = float(np.median(power[i - 5 * w : i + 5 * w + 1]))
        if med > 0 and power[i] > LINE_SNR * med:
            found.append((power[i] / med, int(i), med))
    used: list[int] = []
    for _, i, med in sorted(found, reverse=True):
        if any(abs(i - u) <= 2 * w for u in used):
            continue
        used.append(i)
        base = np.zeros(n, complex)
        base[: 2 * w + 1] = spec[i - w : i + w + 1]
        amp = np.abs(np.fft.ifft(np.roll(base, -w)))
        rel = np.fft.fft(amp / amp.mean() - 1.0) / n
        out.append((f"{i * fs / n:.0f} Hz", rel[1 : w + 1], med / power[i] / 2.0))
        if len(used) >= MAX_LINES:
            break
    return out


def channel_gain(x: np.ndarray, fs: float, f_c: float, use_mean: bool = True) -> ChannelGain:
    """The slow relative gain of channel ``x`` below ``f_c`` (module docstring, steps 1-3).

    Parameters
    ----------
    x : numpy.ndarray
        The channel's samples (finite).
    fs : float
        Sample rate (Hz).
    f_c : float
        Highest modulation frequency read (Hz): half the slowest shaft's rate.
    use_mean : bool
        The channel's mean is a carrier (a static load, a mean deflection); not for a vibration
        acceleration or velocity, whose mean is an offset (``measurement_sensor_checks``).

    Returns
    -------
    ChannelGain
    """
    w = int(np.floor(f_c * x.size / fs))
    car = _carriers(np.asarray(x, float), fs, w, use_mean) if w >= 1 else []
    car = [c for c in car if c[2] > 0 and np.isfinite(c[2])]
    if not car:
        return ChannelGain(np.zeros(0, complex), float("inf"), 0.0, 0.0, ())
    inv = np.array([1.0 / v for _, _, v in car])
    a = sum(aj * iv for (_, aj, _), iv in zip(car, inv, strict=True)) / inv.sum()
    v = 1.0 / float(inv.sum())
    power = float(np.sum(np.abs(a) ** 2))
    rows = []
    for name, aj, vj in car:
        den = np.sqrt(power * float(np.sum(np.abs(aj) ** 2)))
        rho = float(np.real(np.vdot(a, aj))) / den if den > 0 else 0.0
        rows.append((name, power / vj, rho))
    return ChannelGain(a, v, power / v / w, float(np.sqrt(2.0 * power)), tuple(rows))


def shared_fraction(own: ChannelGain, other: ChannelGain) -> tuple[float, float]:
    """``(beta, sigma_beta)``: the part of ``own``'s gain that ``other`` carries (module docstring,
    step 4)."""
    power = float(np.sum(np.abs(own.spectrum) ** 2))
    if other.spectrum.size != own.spectrum.size or power <= 0:
        return 0.0, float("inf")
    beta = float(np.real(np.vdot(own.spectrum, other.spectrum))) / power
    return beta, float(np.sqrt(other.variance / (2.0 * power)))


def gain_signal(g: ChannelGain, n: int) -> np.ndarray:
    """``a(t)`` on ``n`` samples: the band-limited inverse transform of ``g.spectrum``."""
    full = np.zeros(n, complex)
    full[1 : g.spectrum.size + 1] = g.spectrum * n
    return 2.0 * np.real(np.fft.ifft(full))


@dataclass(frozen=True)
class GainModulationFix:
    """Channels divided by their slow gain and the ``issues`` entries saying so."""

    channels: tuple[int, ...]
    gains: tuple[np.ndarray, ...]
    issues: tuple[str, ...]

    def apply(self, data: np.ndarray) -> np.ndarray:
        """The corrected ``(n, nc)`` data (a new array)."""
        out = np.array(data, dtype=float, copy=True)
        for k, a in zip(self.channels, self.gains, strict=True):
            out[:, k] = out[:, k] / (1.0 + a)
        return out


def modulated_channels(gains: Sequence[ChannelGain]) -> list[tuple[int, float]]:
    """Channels whose gain passes steps 2-4 of the module docstring, with the largest share another
    channel carries."""
    out = []
    for c, g in enumerate(gains):
        if g.chi2_n < CHI2N_MIN or g.depth < DEPTH_MIN or not g.same_on_carriers:
            continue
        seen = [shared_fraction(g, h) for k, h in enumerate(gains) if k != c]
        seen = [(b, s) for b, s in seen if s <= BETA_SIGMA_MAX]
        if seen and all(b < SHARED_BETA for b, _ in seen):
            out.append((c, max(b for b, _ in seen)))
    return out


def gain_modulation_fix(
    data: np.ndarray,
    columns: Sequence[str],
    fs: float,
    f_slow: float,
    static: Sequence[bool] | None = None,
) -> GainModulationFix:
    """Find the channels of ``data`` (n, nc) that carry a slow gain of their own (module docstring).

    Parameters
    ----------
    data : numpy.ndarray
        The record (SI), one column per channel.
    columns : sequence of str
        The column names (for ``issues``).
    fs : float
        Sample rate (Hz).
    f_slow : float
        The slowest shaft's rotation rate (Hz); modulations up to half of it are read.
    static : sequence of bool, optional
        Per channel: its mean is a carrier (default: every channel); see :func:`channel_gain`.

    Returns
    -------
    GainModulationFix
        Empty (no channel) where no channel passes.
    """
    x = np.asarray(data, float)
    use = [True] * x.shape[1] if static is None else list(static)
    gains = [channel_gain(x[:, k], fs, 0.5 * f_slow, use[k]) for k in range(x.shape[1])]
    ks, arrays, issues = [], [], []
    for k, shared in modulated_channels(gains):
        g = gains[k]
        a = gain_signal(g, x.shape[0])
        f = (1 + int(np.argmax(np.abs(g.spectrum)))) * fs / x.shape[0]
        named = ", ".join(n for n, c2, _ in g.carriers if c2 >= RESOLVE_CHI2)
        ks.append(k)
        arrays.append(a)
        issues.append(
            f"column {columns[k]!r}: its gain varies by {100 * g.depth:.2g} % rms ({100 * a.min():+.2g} to "
            f"{100 * a.max():+.2g} %, strongest at {f:.3g} Hz) alike on its mean and lines ({named}), and no "
            f"other channel shares it (at most {shared:.2f} of it): a sensor or cable fault (a loose "
            "connector?), not the machine; the channel is divided by that gain"
        )
    return GainModulationFix(tuple(ks), tuple(arrays), tuple(issues))
