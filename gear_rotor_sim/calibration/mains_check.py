"""Mains interference: a line at 50 or 60 Hz or a harmonic of it that nobody declared (issue 11;
docs/calibration.md Sec. 1, "Sensor conventions and faults nobody declared").

A sensor or cable picks up the supply's field: a line at exactly the mains frequency ``f_0`` (50 or 60 Hz)
and at its harmonics ``h f_0`` (the odd ones strongest), on the channels wired alike, whatever the machine's
speed. The machine's own lines are its shafts' orders ``k f_s`` at the speed the record gives (Sec. 2,
"Speed check"), so the speed decides what a line at ``h f_0`` can be:

1. **Not an order** (``|h f_0 - k f_s| >= 1 / T`` for every shaft, ``T`` the record's own length: resolved
   from every order): since session 20 such lines are removed before the fit (``line_removal.py``, which
   names them). What this module still names after the fit (:func:`off_order_lines`): a line that stands
   :data:`LINE_SNR` above the channel's local spectrum, whose peak lies within :data:`EXACT_HZ` of
   ``h f_0`` and that the final model does not hold (:data:`MODEL_RATIO`; the model's spectrum on its own
   window): ``issues`` names the column, the frequency and the nearest order.
2. **On an order** (closer than ``1 / T``: at 3000 rpm every order of a shaft turning at 50 Hz is a 50 Hz
   harmonic): frequency cannot tell mains from the machine. Interference is then content that no physical
   effect of the fitted model explains: in the final residual trace (``residual_trace.py``) the shaft-order
   components whose largest feature is that order, where the record holds :data:`MODEL_RATIO` times the
   model's amplitude and stands :data:`MIN_RESIDUAL` sigma out, summed over the channels (a hum split over
   several channels is read together), holding at least :data:`MIN_SHARE` of the final error. ``issues``
   then names the channels: mains pickup or a machine effect outside the library, which a record at
   another speed tells apart. ``mains_repair.py`` then leaves out the orders of the channels that hold it
   (of every channel where more than two do) and diagnoses the record again (``mains_pattern.py``: once
   more where a kept channel's order is not in the pattern of the fitted effects).

The check reads the calibration's final state and changes nothing in it (effects, errors, verdicts);
its cost is one windowed DFT per channel and mains harmonic. Measured in
docs/history/calibration_sessions.md Secs. 8.51, 8.54.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

#: mains frequencies, Hz
MAINS_HZ = (50.0, 60.0)
#: harmonics of the mains frequency examined (1 .. MAX_HARMONIC)
MAX_HARMONIC = 10
#: a line: its windowed periodogram at least this many times the median of its neighbourhood (20 dB)
LINE_SNR = 100.0
#: the neighbourhood of a line for its noise level, Hz (the main lobe, +-2 / T, left out)
NEIGHBOURHOOD_HZ = 10.0
#: the peak of a mains line lies within this of ``h f_0`` (a grid holds its frequency to +-0.2 Hz, a 2 s
#: record resolves a strong line's peak to a few mHz), Hz
EXACT_HZ = 0.05
#: the record holds at least this many times the model's amplitude at the line
MODEL_RATIO = 3.0
#: on an order: the component's largest feature at least this many noise sigmas out ...
MIN_RESIDUAL = 10.0
#: ... and the component at least this share of the final E^2 (the 3000 rpm benchmark records' largest
#: such component, the generator's input-shaft order 4 on node5_ay that the FE model lacks: 0.14)
MIN_SHARE = 0.5


#: zero padding of the periodogram (grid ``1 / (PAD T)``: 0.03 Hz on a 2 s record)
PAD = 16


class Spectrum:
    """Hann-windowed amplitude spectrum of one channel (mean removed) on a zero-padded grid.

    Parameters
    ----------
    x : numpy.ndarray
        Samples.
    fs : float
        Sample rate, Hz.
    """

    def __init__(self, x: np.ndarray, fs: float) -> None:
        n = x.size
        w = np.hanning(n)
        self.fs, self.duration = fs, n / fs
        nfft = 1 << math.ceil(math.log2(PAD * n))
        self.df = fs / nfft
        self.amp = 2.0 * np.abs(np.fft.rfft((x - float(np.mean(x))) * w, nfft)) / float(np.sum(w))

    def at(self, f_hz: float) -> float:
        """Amplitude at the grid point nearest ``f_hz``."""
        return float(self.amp[min(self.amp.size - 1, round(f_hz / self.df))])

    def line(self, f_hz: float) -> tuple[float, float, float] | None:
        """A line at ``f_hz``: ``(amplitude, peak frequency, power over the local median)``.

        The peak is the largest grid point within +-0.5 / T, refined by a parabola through
        the log amplitudes; the local median is that of the power within :data:`NEIGHBOURHOOD_HZ`, the
        main lobe left out. None when the neighbourhood does not fit in the spectrum.
        """
        lobe = 2.0 / self.duration
        lo, hi = round((f_hz - NEIGHBOURHOOD_HZ) / self.df), round((f_hz + NEIGHBOURHOOD_HZ) / self.df)
        if lo < 1 or hi >= self.amp.size - 1:
            return None
        i0, i1 = round((f_hz - lobe) / self.df), round((f_hz + lobe) / self.df)
        half = round(0.5 / (self.duration * self.df))
        c0 = round(f_hz / self.df) - half
        i = c0 + int(np.argmax(self.amp[c0 : c0 + 2 * half + 1]))
        a, b, c = np.log(np.maximum(self.amp[i - 1 : i + 2], 1e-300))
        den = a - 2.0 * b + c
        peak = (i + (0.5 * (a - c) / den if den < 0 else 0.0)) * self.df
        ring = np.r_[self.amp[lo:i0], self.amp[i1 + 1 : hi + 1]] ** 2
        local = float(np.median(ring))
        at = self.at(f_hz)
        return at, float(peak), (at**2 / local if local > 0 else math.inf)


def nearest_order(f_hz: float, shafts: Sequence[tuple[str, float]]) -> tuple[str, int, float]:
    """The shaft order nearest ``f_hz``: ``(shaft name, order, distance Hz)``."""
    best = ("", 0, math.inf)
    for name, fs_hz in shafts:
        k = max(1, round(f_hz / fs_hz))
        d = abs(f_hz - k * fs_hz)
        if d < best[2]:
            best = (name, k, d)
    return best


def off_order_lines(
    y: np.ndarray, model: np.ndarray, fs: float, names: Sequence[str], shafts: Sequence[tuple[str, float]]
) -> list[dict[str, Any]]:
    """Case 1 of the module docstring: lines at a mains harmonic that are no shaft's order.

    Parameters
    ----------
    y, model : numpy.ndarray
        Measured and final model signals ``(n, channels)``: each spectrum on its own length (the model window
        may be shorter; the line is resolved on the record's).
    fs : float
        Sample rate, Hz.
    names : sequence of str
        Channel names (the measured columns).
    shafts : sequence of (str, float)
        Every shaft's name and rotation frequency, Hz.

    Returns
    -------
    list of dict
        ``channel, mains_hz, harmonic, frequency_hz, amplitude, over_local, over_model, nearest`` per line.
    """
    big_t = y.shape[0] / fs  # the record's own resolution (the model window may be shorter)
    spectra = [Spectrum(y[:, c], fs) for c in range(len(names))]
    model_spectra = [Spectrum(model[:, c], fs) for c in range(len(names))] if model.size else []
    out = []
    for f0 in MAINS_HZ:
        for h in range(1, MAX_HARMONIC + 1):
            f = h * f0
            shaft, k, d = nearest_order(f, shafts) if shafts else ("", 0, math.inf)
            if d < 1.0 / big_t:
                continue  # on an order: case 2
            for c, name in enumerate(names):
                line = spectra[c].line(f)
                if line is None or line[2] < LINE_SNR or abs(line[1] - f) > EXACT_HZ:
                    continue
                mod = model_spectra[c].at(f) if model_spectra else 0.0
                if line[0] < MODEL_RATIO * mod:
                    continue
                out.append(
                    {
                        "channel": name,
                        "mains_hz": f0,
                        "harmonic": h,
                        "frequency_hz": line[1],
                        "amplitude": line[0],
                        "over_local": line[2],
                        "over_model": line[0] / mod if mod > 0 else math.inf,
                        "nearest": (shaft, k, d),
                    }
                )
    return out


def on_order_lines(trace: dict[str, Any], shafts: Sequence[tuple[str, float]], big_t: float) -> list[dict]:
    """Case 2 of the module docstring: shaft-order components of the final residual trace at a mains
    harmonic that the model lacks (``trace`` as ``residual_trace.trace_residual`` returns it), summed over
    the channels: a hum split over several channels (each below :data:`MIN_SHARE`) is read together.

    Returns
    -------
    list of dict
        Per shaft order at a mains harmonic whose channels hold at least :data:`MIN_SHARE` of the final error
        together: ``shaft, order, frequency_hz, mains, share`` and ``channels`` (``channel, measured, model,
        share`` each), largest share first.
    """
    rate = dict(shafts)
    groups: dict[tuple[str, int], dict[str, Any]] = {}
    for comp in trace.get("components", []):
        fam = str(comp.get("family", ""))
        if not fam.startswith("shaft orders ("):
            continue
        shaft = fam[len("shaft orders (") : -1]
        top = comp.get("largest", {})
        at = str(top.get("at", ""))
        if shaft not in rate or not at.startswith("order "):
            continue
        k = int(at.split()[1])
        f = k * rate[shaft]
        mains = [
            (f0, round(f / f0))
            for f0 in MAINS_HZ
            if round(f / f0) >= 1 and abs(f - round(f / f0) * f0) < 1.0 / big_t
        ]
        measured, model = float(top.get("measured_over_noise", 0.0)), float(top.get("model_over_noise", 0.0))
        if not mains or top.get("normalised_residual", 0.0) < MIN_RESIDUAL or measured < MODEL_RATIO * model:
            continue
        g = groups.setdefault(
            (shaft, k), {"shaft": shaft, "order": k, "frequency_hz": f, "mains": mains[0], "channels": []}
        )
        share = float(comp.get("model_lacks_share", 0.0))
        g["channels"].append(
            {"channel": comp["channel"], "measured": measured, "model": model, "share": share}
        )
    out = []
    for g in groups.values():
        g["channels"].sort(key=lambda c: -c["share"])
        g["share"] = sum(c["share"] for c in g["channels"])
        if g["share"] >= MIN_SHARE:
            out.append(g)
    return sorted(out, key=lambda g: -g["share"])


def mains_issues(cal: Any, trace: dict[str, Any], model: np.ndarray) -> list[str]:
    """``issues`` entries for mains lines (module docstring), from the calibrator's final state.

    Parameters
    ----------
    cal : Calibrator
        After its search: its comparison (``cmp``: measured signals, channels, shafts, speed) is read. A
        record without the order family (no mesh, CWRU: the speed is nominal, the orders not known to
        the line's resolution) is not examined.
    trace : dict
        The final residual trace (``residual_trace.trace_residual``).
    model : numpy.ndarray
        The final model's signals ``(n, channels)``.

    Returns
    -------
    list of str
        One entry per mains frequency and case, naming the columns.
    """
    cmp = cal.cmp
    if "order" not in cmp.families or not cmp.shafts:
        return []
    shafts = [(sh.name, sh.ratio * cmp.speed_hz) for sh in cmp.shafts]
    out: list[str] = []
    off = off_order_lines(cmp.y, model, cmp.fs, cmp.names, shafts)
    for f0 in MAINS_HZ:
        lines = [_off_text(x) for x in off if x["mains_hz"] == f0]
        if lines:
            out.append(
                f"line(s) at the {f0:g} Hz mains frequency or its harmonics that are no shaft's order at the "
                f"measured speed and not in the model: {'; '.join(lines)}: electrical interference from the "
                "supply (or a motor's electromagnetic vibration at a mains harmonic), not a fault of the "
                "gearbox; the synchronous features average it out"
            )
    out += [_on_text(x) for x in on_order_lines(trace, shafts, cmp.y.shape[0] / cmp.fs)]
    return out


def _off_text(x: dict[str, Any]) -> str:
    shaft, k, d = x["nearest"]
    return (
        f"{x['channel']!r} {x['frequency_hz']:.3f} Hz (x{x['harmonic']}, {_db(x['over_local'])} dB above its "
        f"neighbourhood; nearest order: {shaft} shaft x{k}, {d:.2f} Hz away)"
    )


def _on_text(x: dict[str, Any]) -> str:
    f0, h = x["mains"]
    where = f"the {x['shaft']} shaft's order {x['order']} ({x['frequency_hz']:.3f} Hz)"
    cols = ", ".join(
        f"{c['channel']!r} (measured {c['measured']:.3g}, model {c['model']:.3g} noise sigmas, "
        f"{100 * c['share']:.0f} %)"
        for c in x["channels"]
    )
    one = len(x["channels"]) == 1
    return (
        f"column{'' if one else 's'} {cols}: {where} falls on the {f0:g} Hz mains frequency (x{h}) and the "
        f"fitted model does not explain it ({100 * x['share']:.0f} % of the final error): mains pickup on "
        f"{'this channel' if one else 'these channels'} or a machine effect outside the library; on a shaft "
        "order frequency cannot tell them apart (a record at another speed can)"
    )


def _db(ratio: float) -> str:
    return f"{10.0 * math.log10(ratio):.0f}" if ratio > 0 and math.isfinite(ratio) else "inf"
