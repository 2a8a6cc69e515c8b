"""Gear and bearing fault indicators of one window of housing accelerations (pure NumPy/SciPy, no ROS).

Per channel (``x`` the window minus its mean, ``f_m`` the mesh frequency, ``f_p``/``f_g`` the pinion
and gear shaft frequencies; lines are read from the Hann-windowed amplitude spectrum of
:func:`gear_rotor_sim.indicators.amplitude_spectrum`, removed in the FFT by zeroing the bins within
``+-0.4`` shaft orders):

* ``rms``, ``kurtosis``, ``crest_factor``: :func:`gear_rotor_sim.indicators.statistics`.
* ``fm0 = (max x - min x) / sum_h A(h f_m)``: peak-to-peak over the mesh harmonics
  (Stewart 1977; Samuel & Pines 2005, Eq 4).
* ``fm4``: kurtosis of the *difference signal* ``d`` = ``x`` without the mesh harmonics, their first
  sidebands (+-1 order of either shaft) and shaft orders 1-3 (Stewart 1977; Samuel & Pines Eq 6).
* ``na4``: kurtosis of the *residual signal* ``r`` = ``x`` without the mesh harmonics and shaft orders 1-3,
  normalised by the residual's own variance in the window (Zakrajsek et al. 1993 with one record,
  ``M = 1``; the trended form divides by the mean variance of past records).
* ``ser``: sideband energy ratio, the sum of the amplitudes of the sidebands ``f_m +- k f_s``
  (k = 1..3, both shafts) over the amplitude of the mesh line ``A(f_m)`` (Hanson et al. 2007).
* ``order1``, ``order2``: amplitudes of the lines at orders 1 and 2 of the shaft in the bearing
  (unbalance, eccentricity: 1x; misalignment: 2x), m/s^2.
* ``env_bpfo``, ``env_bpfi``, ``env_bsf``: envelope analysis (band 1.5-6 kHz around the housing
  resonance, Hilbert envelope, Hann spectrum): the envelope line at the bearing's BPFO, BPFI and
  2 BSF (its shaft's rate, the 6206 geometry of the library), divided by the median envelope
  spectrum level up to 1 kHz: how many times the line stands out of the envelope floor
  (Randall & Antoni 2011).

The monitor's computation (``benchmarks/detection.py``) is :func:`window_features` over the housing
channels of each window.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy import signal

from gear_rotor_sim.faults.bearing import BEARING_6205, BEARING_6206, BearingGeometry
from gear_rotor_sim.indicators import amplitude_spectrum, statistics

FEATURES = (
    "rms",
    "kurtosis",
    "crest_factor",
    "fm0",
    "fm4",
    "na4",
    "ser",
    "order1",
    "order2",
    "env_bpfo",
    "env_bpfi",
    "env_bsf",
)
HALFWIDTH_ORDERS = 0.4
ENVELOPE_BAND_HZ = (1500.0, 6000.0)
ENVELOPE_FLOOR_HZ = 1000.0


def _kurtosis(x: np.ndarray) -> float:
    d = x - x.mean()
    m2 = float(np.mean(d * d))
    return float(np.mean(d**4) / (m2 * m2)) if m2 > 0 else 0.0


def _remove_lines(x: np.ndarray, fs: float, lines: Sequence[float], halfwidth_hz: float) -> np.ndarray:
    spec = np.fft.rfft(x - x.mean())
    f = np.fft.rfftfreq(x.size, 1.0 / fs)
    mask = np.zeros(f.size, dtype=bool)
    for fl in lines:
        if 0 < fl < fs / 2:
            mask |= np.abs(f - fl) <= halfwidth_hz
    spec[mask] = 0.0
    return np.fft.irfft(spec, x.size)


def _line(freqs: np.ndarray, amp: np.ndarray, f: float, halfwidth_hz: float) -> float:
    if not 0 < f < freqs[-1]:
        return 0.0
    band = np.abs(freqs - f) <= max(halfwidth_hz, freqs[1] - freqs[0])
    return float(amp[band].max()) if band.any() else 0.0


@functools.lru_cache(maxsize=8)
def _band_sos(fs: float) -> np.ndarray:
    lo, hi = ENVELOPE_BAND_HZ
    hi = min(hi, 0.45 * fs)
    return signal.butter(4, [lo, hi], btype="bandpass", fs=fs, output="sos")


def channel_features(
    x: np.ndarray,
    fs: float,
    mesh_hz: float | None,
    shaft_hz: Sequence[float],
    bearing_shaft_hz: float,
    geometry: BearingGeometry = BEARING_6206,
) -> dict[str, float]:
    """All :data:`FEATURES` of one channel (module docstring).

    Parameters
    ----------
    x : ndarray
        One window of a housing acceleration, m/s^2.
    fs : float
        Sample rate, Hz.
    mesh_hz : float or None
        Mesh frequency, Hz. ``None``: a machine without a gear mesh (the CWRU rig): ``fm0``,
        ``fm4`` and ``ser`` are not returned, ``na4`` is the kurtosis of ``x`` without shaft orders 1-3.
    shaft_hz : sequence of float
        Rotation frequencies of the shafts carrying the mesh (pinion, gear), Hz; without a mesh, the
        shaft's.
    bearing_shaft_hz : float
        Rotation frequency of the shaft in the bearing under this accelerometer, Hz.
    """
    x = np.asarray(x, float)
    rms, _, crest, kurt = (float(v[0]) for v in statistics(x))
    freqs, amp = amplitude_spectrum(x, fs)
    amp = amp[:, 0]
    fmin = min(shaft_hz)
    hw = HALFWIDTH_ORDERS * fmin
    harmonics = [h * mesh_hz for h in range(1, int(0.5 * fs / mesh_hz) + 1)] if mesh_hz else []
    shaft_lines = [k * s for s in shaft_hz for k in (1, 2, 3)]
    residual = _remove_lines(x, fs, harmonics + shaft_lines, hw)
    env = np.abs(signal.hilbert(signal.sosfiltfilt(_band_sos(fs), x - x.mean())))
    ef, ea = amplitude_spectrum(env, fs)
    ea = ea[:, 0]
    floor = float(np.median(ea[(ef > 0) & (ef <= ENVELOPE_FLOOR_HZ)])) or 1e-300
    mult = geometry.multiples()
    env_hw = max(0.01 * bearing_shaft_hz * mult["bpfo"], 2.0 * (ef[1] - ef[0]))
    out = {
        "rms": rms,
        "kurtosis": kurt,
        "crest_factor": crest,
        "na4": _kurtosis(residual),
        "order1": _line(freqs, amp, bearing_shaft_hz, HALFWIDTH_ORDERS * bearing_shaft_hz),
        "order2": _line(freqs, amp, 2.0 * bearing_shaft_hz, HALFWIDTH_ORDERS * bearing_shaft_hz),
        "env_bpfo": _line(ef, ea, mult["bpfo"] * bearing_shaft_hz, env_hw) / floor,
        "env_bpfi": _line(ef, ea, mult["bpfi"] * bearing_shaft_hz, env_hw) / floor,
        "env_bsf": _line(ef, ea, 2.0 * mult["bsf"] * bearing_shaft_hz, env_hw) / floor,
    }
    if mesh_hz:
        sidebands = [f + sgn * s for f in harmonics for s in shaft_hz for sgn in (-1, 1)]
        difference = _remove_lines(residual, fs, sidebands, hw)
        a_mesh = _line(freqs, amp, mesh_hz, hw)
        ser_lines = [mesh_hz + sgn * k * s for s in shaft_hz for k in (1, 2, 3) for sgn in (-1, 1)]
        ser_sum = sum(_line(freqs, amp, f, hw) for f in ser_lines)
        mesh_sum = sum(_line(freqs, amp, f, hw) for f in harmonics)
        out["fm0"] = float(np.ptp(x) / mesh_sum) if mesh_sum > 0 else 0.0
        out["fm4"] = _kurtosis(difference)
        out["ser"] = ser_sum / a_mesh if a_mesh > 0 else 0.0
    return out


#: rolling-bearing geometry by a config's bearing type name (other names: the paper gearbox's 6206)
GEOMETRY_BY_TYPE: dict[str, BearingGeometry] = {"6205": BEARING_6205, "6206": BEARING_6206}


@functools.lru_cache(maxsize=8)
def _rig(config: str) -> tuple[int, tuple[float, ...], tuple[float, ...], tuple[BearingGeometry, ...]]:
    """Pinion teeth (0: no gear mesh), |speed ratios| of the meshing shafts, |speed ratio| of each
    bearing's shaft, each bearing's geometry (:data:`GEOMETRY_BY_TYPE`)."""
    from gear_rotor_sim.config import load_config
    from gear_rotor_sim.system import shaft_speed_ratios

    cfg = load_config(config)
    ratios = np.abs(shaft_speed_ratios(cfg))
    bearing = tuple(float(ratios[cfg.shaft_of_node(b.node0)]) for b in cfg.bearings)
    geometry = tuple(GEOMETRY_BY_TYPE.get(b.type_name, BEARING_6206) for b in cfg.bearings)
    if not cfg.meshes:
        return 0, (), bearing, geometry
    m = cfg.meshes[0]
    sp = cfg.shaft_of_node(cfg.gear(m.pinion).node0)
    sg = cfg.shaft_of_node(cfg.gear(m.gear).node0)
    return int(m.pinion_teeth), (float(ratios[sp]), float(ratios[sg])), bearing, geometry


def has_gear_mesh(config: str) -> bool:
    """Whether the rig of ``config`` has a gear mesh (the mesh features and gear fault groups apply)."""
    return _rig(config)[0] > 0


def window_features(window: Any, config: str = "paper_sun2021") -> dict[str, float]:
    """Features of the housing channels of a :class:`gear_rotor_sim.datasets.Window`:
    ``{"<channel>.<feature>": value}``. On a rig without a gear mesh (``config/cwru_rig.yaml``) the
    mesh features are left out and the shaft orders are those of the bearing's shaft."""
    teeth, mesh_ratios, bearing_ratios, geometry = _rig(config)
    f_in = window.speed_rpm / 60.0
    shafts = [r * f_in for r in mesh_ratios]
    mesh_hz = teeth * shafts[0] if teeth else None
    out: dict[str, float] = {}
    for j, name in enumerate(window.channels):
        if "_housing_a" not in name:
            continue
        k = int(name[len("bearing") : name.index("_")])
        f_b = bearing_ratios[k - 1] * f_in
        feats = channel_features(
            window.data[:, j], window.sample_rate_hz, mesh_hz, shafts or [f_b], f_b, geometry[k - 1]
        )
        out.update({f"{name}.{key}": v for key, v in feats.items()})
    return out
