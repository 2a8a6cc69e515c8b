"""Lines locked to no shaft, removed before the fit: mains off or near a shaft order, and the tones of a
neighbouring machine (issue 11; docs/calibration.md Sec. 1, "Sensor conventions and faults nobody declared").

The machine's own lines are its shafts' orders ``k f_s`` at the speed the record gives (Sec. 2, "Speed
check"). A line that the record resolves from every order (at least ``1 / T`` away, ``T`` the record's
own length: 0.5 Hz on a 2 s record) is no part of the machine's rotation:

1. **Mains** (``mains_check.py``): a line at ``h f_0`` (``f_0`` = 50 or 60 Hz, ``h`` = 1-10) standing
   :data:`~gear_rotor_sim.calibration.mains_check.LINE_SNR` above its neighbourhood with its frequency within
   :data:`~gear_rotor_sim.calibration.mains_check.EXACT_HZ` of ``h f_0`` (:func:`line_at`).
2. **A neighbouring machine** (a motor or a pump on the same foundation): a comb of lines at ``f_n`` and
   at least one of its harmonics ``2 f_n .. HARMONICS f_n``, each standing ``LINE_SNR`` out and resolved
   from every order (the fundamental by ``2 / T``, outside an order's Hann lobe), ``f_n`` between
   :data:`F_MIN` and :data:`F_MAX`, no mains harmonic and none of the
   machine's own non-synchronous lines: a bearing's defect frequencies (FTF, BSF, 2 BSF, BPFO, BPFI of the
   library's geometry at every shaft's rate), their harmonics 1-4 and their cage sidebands (+-1, 2 FTF),
   within :data:`BEARING_TOL` (a defect's slip, another geometry) or ``1 / T`` (on the benchmark's ball
   record the cage at 19.8 Hz, 2 BSF at 231.3 Hz and 2 BSF - FTF stand 21-31 dB out; the outer race's
   178.5 Hz and its harmonics 20-29 dB).

Each such line is removed from the channels it stands out on: a Hann-weighted least-squares sinusoid at
the line's frequency (refined within :data:`REFINE_HZ` to the least residual) fitted over the whole record
together with the shaft orders within :data:`NEIGHBOURS` ``/ T`` of it (so that an order 0.82 Hz away is not
taken with it) and subtracted; the orders stay. As the load demodulation does for the load's
sidebands (``load_demodulation.py``), the record is then compared and set up again, and ``issues`` names
each column, frequency and the nearest order. A record whose speed was tracked (resampled to the shaft
angle, ``order_tracking.py``) is left alone: its mains lines are no longer lines.

A line ON an order (closer than ``1 / T``) is not removed here: frequency cannot tell it from the machine
(``mains_check.on_order_lines`` after the fit).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import ndimage, optimize

from gear_rotor_sim.calibration.mains_check import (
    EXACT_HZ,
    LINE_SNR,
    MAINS_HZ,
    MAX_HARMONIC,
    NEIGHBOURHOOD_HZ,
    Spectrum,
    nearest_order,
)
from gear_rotor_sim.faults.bearing import BEARING_6206

#: a neighbouring machine's fundamental: lowest and highest frequency searched, Hz
F_MIN, F_MAX = 5.0, 250.0
#: harmonics of a neighbouring machine's fundamental examined (2 .. HARMONICS)
HARMONICS = 4
#: the line's frequency is refined within +- this of its peak (least Hann-weighted residual), Hz
REFINE_HZ = 0.05
#: shaft orders within NEIGHBOURS / T of a removed line are fitted with it (and kept)
NEIGHBOURS = 3.0
#: relative distance within which a line is read as a bearing's defect frequency (slip 1-2 %, geometry)
BEARING_TOL = 0.05
#: harmonics and cage sidebands of a bearing's defect frequencies that are the machine's own lines
BEARING_HARMONICS, CAGE_SIDEBANDS = 4, 2
#: a comb's line within SIDELOBE_BINS / T of an order must stand SIDELOBE_MARGIN above that order's sidelobe
SIDELOBE_BINS, SIDELOBE_MARGIN = 12.0, 3.0


@dataclass(frozen=True)
class Line:
    """A line to remove from one channel.

    Attributes
    ----------
    channel : int
    frequency_hz : float
        Its frequency, Hz (:func:`line_at`).
    over_local : float
        Its power over the median of its neighbourhood.
    source : str
        ``"mains 50 Hz x3"`` or ``"a neighbouring machine's 24.7 Hz x2"``.
    nearest : tuple of (str, int, float)
        The nearest shaft order: shaft, order, distance Hz.
    """

    channel: int
    frequency_hz: float
    over_local: float
    source: str
    nearest: tuple[str, int, float]


def _resolved(f_hz: float, shafts: Sequence[tuple[str, float]], big_t: float) -> tuple[bool, tuple]:
    near = nearest_order(f_hz, shafts)
    return near[2] >= 1.0 / big_t, near


def line_at(
    x: np.ndarray, sp: Spectrum, f_hz: float, tol_hz: float, shafts: Sequence[tuple[str, float]]
) -> tuple[float, float] | None:
    """A line within ``tol_hz`` of ``f_hz`` (0: at ``f_hz``, its spectral peak within ``0.5 / T``) on one
    channel (``x``, its spectrum ``sp``) standing ``LINE_SNR`` out: ``(frequency, power over the local
    median)``, or None. The spectral peak where no order lies within
    ``NEIGHBOURS / T``; else (an order beside it pulls the peak away: a Hann lobe is ``2 / T`` wide) the
    frequency and amplitude of the least-squares fit with those orders (:func:`fit_line`). Not a sidelobe of
    a farther order (:func:`sidelobe`)."""
    line = sp.line(f_hz)
    if line is None or not line[0] > 0 or not math.isfinite(line[2]) or line[2] < LINE_SNR:
        return None  # (a channel without content there, e.g. an exactly zero axial force, has no local level)
    orders = orders_near(f_hz, shafts, sp.duration)
    if not orders:
        f_fit, amp, snr = line[1], line[0], line[2]
        inside = abs(f_fit - f_hz) <= (tol_hz or 0.5 / sp.duration)
    else:
        f_fit, amp, _ = fit_line(x, sp.fs, f_hz, orders, tol_hz)
        snr = amp**2 * line[2] / line[0] ** 2  # over the same local median
        inside = tol_hz <= 0 or abs(f_fit - f_hz) < 0.95 * tol_hz
    if not inside or snr < LINE_SNR or sidelobe(sp, f_fit, amp, shafts):
        return None
    return f_fit, snr


def mains_lines(
    data: np.ndarray, spectra: Sequence[Spectrum], shafts: Sequence[tuple[str, float]]
) -> list[Line]:
    """Case 1 of the module docstring on every channel of ``data`` (``spectra``: one per channel)."""
    big_t = spectra[0].duration if spectra else 1.0
    out = []
    for f0 in MAINS_HZ:
        for h in range(1, MAX_HARMONIC + 1):
            ok, near = _resolved(h * f0, shafts, big_t)
            if not ok:
                continue
            for c, sp in enumerate(spectra):
                found = line_at(data[:, c], sp, h * f0, EXACT_HZ, shafts)
                if found is not None:
                    out.append(Line(c, found[0], found[1], f"mains {f0:g} Hz x{h}", near))
    return out


def orders_near(f_hz: float, shafts: Sequence[tuple[str, float]], big_t: float) -> list[float]:
    """Every shaft order within ``NEIGHBOURS / T`` of ``f_hz``, Hz."""
    w = NEIGHBOURS / big_t
    return [
        k * f
        for _, f in shafts
        for k in range(max(1, math.floor((f_hz - w) / f)), 1 + math.ceil((f_hz + w) / f))
        if abs(k * f - f_hz) < w
    ]


def _is_mains(f_hz: float, big_t: float) -> bool:
    return any(abs(f_hz - round(f_hz / f0) * f0) < 1.0 / big_t for f0 in MAINS_HZ if round(f_hz / f0) >= 1)


def peaks(sp: Spectrum, snr: float = LINE_SNR) -> np.ndarray:
    """Frequencies of the local maxima in ``[F_MIN, F_MAX]`` whose power stands ``snr`` above the running
    median of its neighbourhood (candidates; :meth:`Spectrum.line` then judges each)."""
    lo, hi = round((F_MIN - NEIGHBOURHOOD_HZ) / sp.df), round((F_MAX + NEIGHBOURHOOD_HZ) / sp.df)
    lo, hi = max(lo, 1), min(hi, sp.amp.size - 1)
    p = sp.amp[lo:hi] ** 2
    med = ndimage.median_filter(p, size=2 * round(NEIGHBOURHOOD_HZ / sp.df) + 1, mode="nearest")
    peak = (p[1:-1] >= p[:-2]) & (p[1:-1] >= p[2:]) & (p[1:-1] >= snr * med[1:-1])
    f = (np.flatnonzero(peak) + 1 + lo) * sp.df
    return f[(f >= F_MIN) & (f <= F_MAX)]


def bearing_lines_hz(shaft_hz: Sequence[float], multiples: dict[str, float]) -> np.ndarray:
    """A bearing's own non-synchronous lines at every shaft rate ``shaft_hz``: ``h X + b FTF`` for ``X`` in
    FTF, BSF, 2 BSF, BPFO, BPFI (``multiples``: ``BearingGeometry.multiples``), ``h`` = 1..BEARING_HARMONICS,
    ``b`` = -CAGE_SIDEBANDS..CAGE_SIDEBANDS (Hz, positive)."""
    out = []
    for f in shaft_hz:
        ftf = multiples["ftf"] * f
        for x in (
            ftf,
            multiples["bsf"] * f,
            2.0 * multiples["bsf"] * f,
            multiples["bpfo"] * f,
            multiples["bpfi"] * f,
        ):
            for h in range(1, BEARING_HARMONICS + 1):
                out += [h * x + b * ftf for b in range(-CAGE_SIDEBANDS, CAGE_SIDEBANDS + 1)]
    arr = np.array(out)
    return arr[arr > 0]


def _a_bearings(f_hz: float, bearing_hz: np.ndarray, big_t: float) -> bool:
    return bool(bearing_hz.size) and bool(
        np.any(np.abs(bearing_hz - f_hz) <= max(BEARING_TOL * f_hz, 1.0 / big_t))
    )


def is_unlocked(
    f_hz: float, shafts: Sequence[tuple[str, float]], big_t: float, bearing_hz: np.ndarray
) -> bool:
    """Whether a neighbouring machine's fundamental can lie at ``f_hz``: outside the Hann main lobe of every
    shaft order (``2 / T``: a strong order's lobe holds local maxima, 0.84 Hz from the eccentric pinion's 1x
    on the benchmark's record, 33 dB out), no mains harmonic and no bearing line (``bearing_hz``)."""
    return (
        nearest_order(f_hz, shafts)[2] >= 2.0 / big_t
        and not _is_mains(f_hz, big_t)
        and not _a_bearings(f_hz, bearing_hz, big_t)
    )


def sidelobe(sp: Spectrum, f_hz: float, amp: float, shafts: Sequence[tuple[str, float]]) -> bool:
    """Whether a line of amplitude ``amp`` at ``f_hz`` can be a Hann sidelobe of a shaft order between
    ``NEIGHBOURS / T`` (nearer orders are fitted with the line) and ``SIDELOBE_BINS / T`` away: its amplitude
    below ``SIDELOBE_MARGIN`` times the order's times the Hann window's sidelobe envelope
    ``1 / (pi x (x^2 - 1))`` at ``x = |f - f_order| T`` bins (-31 dB at 2.5 bins, -49 dB at 6.5; the
    benchmark's eccentric gear's DTE 1x, 3e6 x its noise, puts sidelobes 2563 x the local median 1.18 Hz
    away)."""
    for _, fs_hz in shafts:
        k0 = max(1, math.floor((f_hz - SIDELOBE_BINS / sp.duration) / fs_hz))
        for k in range(k0, 1 + math.ceil((f_hz + SIDELOBE_BINS / sp.duration) / fs_hz)):
            x = abs(f_hz - k * fs_hz) * sp.duration
            if NEIGHBOURS <= x <= SIDELOBE_BINS and amp < SIDELOBE_MARGIN * sp.at(k * fs_hz) / (
                math.pi * x * (x * x - 1.0)
            ):
                return True
    return False


def neighbour_lines(
    data: np.ndarray,
    spectra: Sequence[Spectrum],
    shafts: Sequence[tuple[str, float]],
    bearing_hz: np.ndarray | None = None,
) -> list[Line]:
    """Case 2 of the module docstring: the combs of lines locked to no shaft, on every channel
    (``bearing_hz``: :func:`bearing_lines_hz`, none if not given)."""
    bearing_hz = np.zeros(0) if bearing_hz is None else np.asarray(bearing_hz, float)
    big_t = spectra[0].duration if spectra else 1.0
    out: list[Line] = []
    found: list[float] = []
    for sp in spectra:
        for f in peaks(sp):
            line = sp.line(float(f))
            if line is None or not math.isfinite(line[2]) or line[2] < LINE_SNR:
                continue
            fn = line[1]
            if not is_unlocked(fn, shafts, big_t, bearing_hz) or any(
                round(fn / g) >= 1 and abs(fn - round(fn / g) * g) < 1.0 / big_t for g in found
            ):
                continue
            comb = _comb(data, spectra, fn, shafts)
            harmonics = {h for _, h, _, _ in comb}
            if 1 not in harmonics or len(harmonics) < 2:
                continue
            found.append(fn)
            out += [
                Line(
                    k, fk, snr, f"a neighbouring machine's {fn:.2f} Hz x{h}", _resolved(fk, shafts, big_t)[1]
                )
                for k, h, fk, snr in comb
            ]
    return out


def _comb(
    data: np.ndarray, spectra: Sequence[Spectrum], fn: float, shafts: Sequence[tuple[str, float]]
) -> list[tuple[int, int, float, float]]:
    """``(channel, harmonic, Hz, power over local)`` of the lines at ``h fn`` (h = 1..HARMONICS) that stand
    out and are resolved from every order and from the mains harmonics: the fundamental refined within
    ``0.5 / T``, its harmonics at exactly ``h`` times it (a free frequency beside an order finds the largest
    of the noise and the order's leakage)."""
    comb = []
    big_t = spectra[0].duration
    for k, sp in enumerate(spectra):
        first = line_at(data[:, k], sp, fn, 0.5 / big_t, shafts)
        f1 = fn if first is None else first[0]
        if first is not None:
            comb.append((k, 1, *first))
        for h in range(2, HARMONICS + 1):
            if not _resolved(h * f1, shafts, big_t)[0] or _is_mains(h * f1, big_t):
                continue
            found = line_at(data[:, k], sp, h * f1, 0.0, shafts)
            if found is not None:
                comb.append((k, h, *found))
    return sorted(comb, key=lambda x: (x[1], x[0]))


def _design(t: np.ndarray, freqs: Sequence[float]) -> np.ndarray:
    return np.column_stack([g(2.0 * math.pi * f * t) for f in freqs for g in (np.cos, np.sin)])


def fit_line(
    x: np.ndarray, fs: float, f_hz: float, orders_hz: Sequence[float], refine_hz: float = REFINE_HZ
) -> tuple[float, float, np.ndarray]:
    """Hann-weighted least-squares sinusoid at ``f_hz`` (refined within ``refine_hz`` to the least residual,
    0: at ``f_hz``), fitted with the orders ``orders_hz`` over the whole record (mean removed).

    Returns
    -------
    (float, float, numpy.ndarray)
        The refined frequency, the line's amplitude and the fitted line alone (``x``'s shape; the orders
        are not in it).
    """
    t = np.arange(x.size) / fs
    y = x - float(np.mean(x))
    sw = np.sqrt(np.hanning(x.size))  # Hann-weighted: the far lines' leakage as in the spectrum (-31 dB)

    def fit(f: float) -> tuple[float, float, np.ndarray]:
        a = _design(t, [f, *orders_hz])
        coef, res, *_ = np.linalg.lstsq(a * sw[:, None], y * sw, rcond=None)
        left = float(res[0]) if res.size else float(np.sum((y * sw - (a * sw[:, None]) @ coef) ** 2))
        return left, float(np.hypot(coef[0], coef[1])), a[:, :2] @ coef[:2]

    f = f_hz
    if refine_hz > 0:
        res = optimize.minimize_scalar(
            lambda f: fit(f)[0],
            bounds=(f_hz - refine_hz, f_hz + refine_hz),
            method="bounded",
            options={"xatol": 1e-5},
        )
        f = float(res.x)
    _, a, fitted = fit(f)
    return f, a, fitted


def find_lines(
    data: np.ndarray, fs: float, shafts: Sequence[tuple[str, float]], bearing_multiples: dict[str, float]
) -> list[Line]:
    """Every line of the module docstring on the record ``data`` ``(n, channels)``; ``shafts``: each shaft's
    name and rotation frequency (Hz) at the record's speed; ``bearing_multiples``: the bearings' defect
    frequencies over the shaft rate (``BearingGeometry.multiples``)."""
    spectra = [Spectrum(data[:, c], fs) for c in range(data.shape[1])]
    bearing_hz = bearing_lines_hz([f for _, f in shafts], bearing_multiples)
    return mains_lines(data, spectra, shafts) + neighbour_lines(data, spectra, shafts, bearing_hz)


def remove_lines(
    data: np.ndarray, fs: float, lines: Sequence[Line], shafts: Sequence[tuple[str, float]]
) -> tuple[np.ndarray, list[float]]:
    """``data`` with each line subtracted from its channel (module docstring); the RMS removed per line."""
    out = np.array(data, dtype=float, copy=True)
    big_t = data.shape[0] / fs
    rms = []
    for ln in lines:
        orders = orders_near(ln.frequency_hz, shafts, big_t)
        _, _, fitted = fit_line(out[:, ln.channel], fs, ln.frequency_hz, orders)
        out[:, ln.channel] -= fitted
        rms.append(float(np.std(fitted)))
    return out, rms


def describe(lines: Sequence[Line], rms: Sequence[float], names: Sequence[str]) -> list[str]:
    """``issues`` entries: one for the mains lines, one per neighbouring machine."""
    groups: dict[str, list[str]] = {}
    for ln, r in zip(lines, rms, strict=True):
        key = (
            ln.source.split(" x")[0] if ln.source.startswith("a neighbouring") else ln.source.split(" Hz")[0]
        )
        shaft, k, d = ln.nearest
        groups.setdefault(key, []).append(
            f"{names[ln.channel]!r} {ln.frequency_hz:.3f} Hz ({ln.source.rsplit(' ', 1)[-1]}, "
            f"{10.0 * math.log10(ln.over_local):.0f} dB above its neighbourhood, RMS {r:.3g}; nearest order: "
            f"{shaft} shaft x{k}, {d:.2f} Hz away)"
        )
    out = []
    for key, items in groups.items():
        if key.startswith("mains"):
            what = (
                f"line(s) at the {key[6:]} Hz mains frequency or its harmonics that are no shaft's order at "
                "the measured speed (resolved on the record's length)"
            )
            cause = (
                "electrical interference from the supply (or a motor's electromagnetic vibration at a mains "
                "harmonic)"
            )
        else:
            what = f"a line not locked to any shaft and its harmonics ({key[2:]})"
            cause = "a neighbouring machine's vibration (a motor or a pump on the same foundation)"
        out.append(
            f"{what}: {'; '.join(items)}: {cause}, not a fault of the gearbox; removed from the record "
            "before the fit (a sinusoid at its frequency fitted with the nearby orders and subtracted)"
        )
    return out


def remove_unlocked_lines(cal: Any) -> None:
    """The hook in ``Calibrator.run`` (before the setup): find and remove the lines of the module docstring
    from ``cal``'s record; a record without one, without the order family (no mesh: CWRU) or resampled to
    the shaft angle is left untouched."""
    from gear_rotor_sim.calibration.residual import Comparison

    cmp = cal.cmp
    var = getattr(cal.speed, "variation", None) if cal.speed is not None else None
    if "order" not in cmp.families or not cmp.shafts or (var is not None and var.varies):
        return
    shafts = [(sh.name, abs(sh.ratio) * cmp.speed_hz) for sh in cmp.shafts]
    m = cal.m
    geometry = cal._init_args.get("bearing_geometry", BEARING_6206)
    lines = find_lines(m.data, m.sample_rate_hz, shafts, geometry.multiples())
    if not lines:
        return
    m.data, rms = remove_lines(m.data, m.sample_rate_hz, lines, shafts)
    issues = describe(lines, rms, [c.column for c in m.channels])
    cal.log("; ".join(issues))
    m.issues.extend(issues)
    cal._issues_at_init = [*cal._issues_at_init, *issues]
    cal.cmp = Comparison(m, cal.runner, cal.settings, cal._env_max)
