"""The contract's checks on the data once read: the time axis, gaps and NaN runs (never
interpolated: an error or the longest clean segment), non-physical magnitudes, isolated
spikes, and the conversion to SI (moved from ``measurement.py`` in session 16). Session 18 added
acquisition dropouts and repeated blocks (``measurement_dropouts.py``, treated like NaN runs) and
impulsive interference within the signal's range (``measurement_impulses.py``, replaced by AR
interpolation and named in ``issues``).
"""

from __future__ import annotations

import numpy as np

from gear_rotor_sim.calibration.measurement_contract import (
    QUANTITIES,
    ROTATIONS,
    SI_UNIT,
    ChannelSpec,
    Measurement,
    OperatingPoint,
    _err,
    unit_factor,
)
from gear_rotor_sim.calibration.measurement_dropouts import dropout_problems
from gear_rotor_sim.calibration.measurement_impulses import repair_spikes
from gear_rotor_sim.calibration.measurement_sensor_checks import sensor_issues

#: Largest magnitude of a measured sample per dimension (SI), beyond any vibration sensor's range:
#: a sample beyond it is refused (a sensor glitch, a wrong unit). 1 m of DTE or displacement,
#: 1e9 N, 1e4 m/s, 1e7 m/s^2 (~1e6 g, ten times a shock accelerometer's range), 1e6 rad,
#: 1e6 rad/s, 1e9 rad/s^2.
PHYSICAL_LIMITS: dict[str, float] = {
    "length": 1.0,
    "force": 1e9,
    "velocity": 1e4,
    "acceleration": 1e7,
    "angle": 1e6,
    "angular_velocity": 1e6,
    "angular_acceleration": 1e9,
}


#: A finite sample more than this many robust scales (1.4826 x MAD) from the channel's median is
#: refused as non-physical (no sensor has a dynamic range of 10^6 over its noise-plus-signal level).
GLITCH_SCALES = 1e6


#: Isolated spikes: runs of at most SPIKE_MAX_SAMPLES samples more than SPIKE_SCALES robust scales
#: from the median, with normal samples on both sides, are replaced by linear interpolation and
#: reported in ``Measurement.issues`` (a Gaussian signal exceeds 100 scales with probability ~0; the
#: impacts of a bearing defect ring over many samples and stay far below it in the CWRU records).
SPIKE_SCALES = 100.0


SPIKE_MAX_SAMPLES = 2


def nan_runs(x: np.ndarray) -> list[tuple[int, int]]:
    """Runs of non-finite samples as ``(start, length)``."""
    bad = ~np.isfinite(x)
    if not bad.any():
        return []
    d = np.diff(np.concatenate([[0], bad.astype(np.int8), [0]]))
    starts = np.flatnonzero(d == 1)
    ends = np.flatnonzero(d == -1)
    return [(int(s), int(e - s)) for s, e in zip(starts, ends, strict=True)]


def _finish(
    src: str,
    time: np.ndarray | None,
    t0: float,
    fs: float,
    data: np.ndarray,
    channels: tuple[ChannelSpec, ...],
    op: OperatingPoint,
    gearbox: str,
    nan_policy: str,
    issues: list[str],
    breaks: list[int] | None = None,
) -> Measurement:
    """Convert, check the time axis, report gaps/NaN runs, apply the NaN policy."""
    if nan_policy not in ("error", "longest_segment"):
        raise ValueError(f"nan_policy: {nan_policy!r} is not one of ['error', 'longest_segment']")
    n = data.shape[0]
    if n < 2:
        raise _err(src, f"only {n} sample(s); at least 2 are required")
    cut = np.zeros(n + 1, dtype=bool)  # cut[i]: a segment boundary before sample i
    problems: list[str] = []
    if time is not None:
        if not np.all(np.isfinite(time)):
            i = int(np.flatnonzero(~np.isfinite(time))[0])
            raise _err(src, f"time_s: non-finite value at row {i + 2}")
        dt = np.diff(time)
        if np.any(dt <= 0):
            i = int(np.flatnonzero(dt <= 0)[0])
            raise _err(
                src,
                f"time_s: not strictly increasing at row {i + 3} "
                f"({float(time[i])!r} -> {float(time[i + 1])!r})",
            )
        nominal = 1.0 / fs
        med = float(np.median(dt))
        if abs(med - nominal) > 1e-3 * nominal:
            raise _err(
                src, f"time_s: median step {med:.6g} s disagrees with sample_rate_hz {fs} ({nominal:.6g} s)"
            )
        jumps = np.flatnonzero(dt > 1.5 * nominal)
        for j in jumps:
            problems.append(f"gap in time_s of {dt[j]:.6g} s after t = {time[j]:.6g} s")
            cut[j + 1] = True
        irregular = np.flatnonzero((dt < 0.5 * nominal) | ((dt > 1.01 * nominal) & (dt <= 1.5 * nominal)))
        if irregular.size:
            raise _err(
                src, f"time_s: {irregular.size} irregular step(s), first after t = {time[irregular[0]]:.6g} s"
            )
        t0 = float(time[0])
    for b in breaks or []:
        problems.append(f"discontinuity (lost chunk) before sample {b}")
        cut[b] = True
    _check_magnitudes(src, data, channels, time if time is not None else t0 + np.arange(n) / fs)
    bad = np.zeros(n, dtype=bool)
    for k, c in enumerate(channels):
        runs = nan_runs(data[:, k])
        if runs:
            longest = max(r[1] for r in runs)
            first = runs[0][0]
            kind = "NaN/inf" if np.isinf(data[:, k]).any() else "NaN"
            problems.append(
                f"column {c.column!r}: {len(runs)} {kind} run(s), {sum(r[1] for r in runs)} samples, "
                f"longest {longest}, first at t = {t0 + first / fs:.6g} s"
            )
            bad |= ~np.isfinite(data[:, k])
    t_all = time if time is not None else t0 + np.arange(n) / fs
    held, held_problems = dropout_problems(
        data, [c.column for c in channels], [SI_UNIT[_dimension(c)] for c in channels], t_all
    )
    bad |= held
    problems.extend(held_problems)
    if problems and nan_policy == "error":
        raise _err(
            src,
            "; ".join(problems) + " (gaps and NaNs are not interpolated; use nan_policy="
            "'longest_segment' / --allow-gaps to analyse the longest clean segment)",
        )
    if problems:
        # longest run of good samples that crosses no cut
        good = ~bad
        best = (0, 0)
        start = None
        for i in range(n + 1):
            end_here = i == n or not good[i] or (cut[i] and i > 0)
            if start is not None and end_here:
                if i - start > best[1] - best[0]:
                    best = (start, i)
                start = None
            if i < n and good[i] and start is None:
                start = i
        if best[1] - best[0] < 2:
            raise _err(src, "no clean segment of at least 2 samples: " + "; ".join(problems))
        issues.extend(problems)
        issues.append(
            f"kept the longest clean segment: samples {best[0]}..{best[1] - 1} "
            f"({(best[1] - best[0]) / fs:.4g} s of {n / fs:.4g} s)"
        )
        data = data[best[0] : best[1]]
        t0 = float(time[best[0]]) if time is not None else t0 + best[0] / fs
    data = _replace_spikes(data, channels, t0, fs, issues)
    data = repair_spikes(data, channels, t0, fs, issues)
    issues.extend(sensor_issues(data, channels, [SI_UNIT[_dimension(c)] for c in channels]))
    return Measurement(src, fs, float(t0), np.ascontiguousarray(data, float), channels, op, gearbox, issues)


def _dimension(c: ChannelSpec) -> str:
    _, trans, rot = QUANTITIES[c.quantity]
    return rot if c.direction in ROTATIONS and rot else trans


def robust_scale(x: np.ndarray) -> tuple[float, float]:
    """Median and robust standard deviation (1.4826 x median absolute deviation) of the finite samples."""
    f = x[np.isfinite(x)]
    if f.size == 0:
        return 0.0, 0.0
    med = float(np.median(f))
    return med, 1.4826 * float(np.median(np.abs(f - med)))


def _check_magnitudes(src: str, data: np.ndarray, channels: tuple[ChannelSpec, ...], t: np.ndarray) -> None:
    """Refuse samples beyond :data:`PHYSICAL_LIMITS` or :data:`GLITCH_SCALES` robust scales (SI data)."""
    for k, c in enumerate(channels):
        x = data[:, k]
        finite = np.isfinite(x)
        dim = _dimension(c)
        limit = PHYSICAL_LIMITS[dim]
        over = np.flatnonzero(finite & (np.abs(x) > limit))
        what = f"beyond the physical limit {limit:g} {SI_UNIT[dim]} of a {dim} channel"
        if over.size == 0:
            med, scale = robust_scale(x)
            if scale > 0:
                over = np.flatnonzero(finite & (np.abs(x - med) > GLITCH_SCALES * scale))
                what = (
                    f"more than {GLITCH_SCALES:g} robust scales ({scale:.3g} {SI_UNIT[dim]}, "
                    f"1.4826 x MAD) from the median {med:.3g} {SI_UNIT[dim]}"
                )
        if over.size:
            i = int(over[0])
            raise _err(
                src,
                f"column {c.column!r}: {over.size} non-physical sample(s), first {x[i]:.6g} {SI_UNIT[dim]} "
                f"at t = {t[i]:.6g} s (sample {i}), {what}; a sensor glitch? remove or repair those samples",
            )


def _replace_spikes(
    data: np.ndarray, channels: tuple[ChannelSpec, ...], t0: float, fs: float, issues: list[str]
) -> np.ndarray:
    """Isolated spikes (runs of at most :data:`SPIKE_MAX_SAMPLES` samples more than
    :data:`SPIKE_SCALES` robust scales from the median) replaced by linear interpolation between
    their neighbours and reported in ``issues``; longer excursions are kept and reported."""
    out = data
    for k, c in enumerate(channels):
        x = data[:, k]
        med, scale = robust_scale(x)
        if scale <= 0:
            continue
        far = np.abs(x - med) > SPIKE_SCALES * scale
        if not far.any():
            continue
        d = np.diff(np.concatenate([[0], far.astype(np.int8), [0]]))
        starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
        spikes = [
            (s, e)
            for s, e in zip(starts, ends, strict=True)
            if e - s <= SPIKE_MAX_SAMPLES and s > 0 and e < x.size
        ]
        kept = len(starts) - len(spikes)
        if spikes:
            if out is data:
                out = data.copy()
            for s, e in spikes:
                out[s:e, k] = np.interp(np.arange(s, e), [s - 1, e], [x[s - 1], x[e]])
            times = ", ".join(f"{t0 + s / fs:.6g}" for s, _ in spikes[:5])
            times += ", ..." if len(spikes) > 5 else ""
            issues.append(
                f"column {c.column!r}: {len(spikes)} isolated spike(s) (<= {SPIKE_MAX_SAMPLES} samples, "
                f"> {SPIKE_SCALES:g} robust scales from the median) replaced by linear interpolation "
                f"at t = {times} s"
            )
        if kept:
            issues.append(
                f"column {c.column!r}: {kept} excursion(s) beyond {SPIKE_SCALES:g} robust scales kept "
                f"(longer than {SPIKE_MAX_SAMPLES} samples or at an end of the record)"
            )
    return out


def _si(data: np.ndarray, channels: tuple[ChannelSpec, ...]) -> np.ndarray:
    out = np.array(data, dtype=float, copy=True)
    for k, c in enumerate(channels):
        _, trans, rot = QUANTITIES[c.quantity]
        dim = rot if c.direction in ROTATIONS and rot else trans
        out[:, k] *= unit_factor(c.unit, dim)
    return out
