"""The data-acquisition chain: integrate at a converged step, low-pass, then sample (issue 11).

A real measurement chain low-passes a signal before sampling it (a DAQ's anti-aliasing filter;
sigma-delta converters decimate through a linear-phase FIR), so a record holds no content folded
from above half its sample rate. The chain here does the same with the lumped model:

1. the model is integrated with classical RK4 at ``substeps`` steps per output sample
   (:data:`DAQ_SUBSTEPS` = 32, 1.5625 us at 20 kHz: the step at which the rattle record's comb
   families and channel RMS change by less than 1 % when the step is halved, docs/independent_data.md,
   "Session 13, the data-acquisition chain"), and *every* step is kept;
2. the whole output path runs at that fine rate: DTE, bearing forces with the bearing-defect pulses
   (averaged over each fine step), the accelerations and, with ``housing``, the housing path;
3. each channel goes through one linear-phase FIR low-pass (:func:`anti_alias_fir`: Kaiser window,
   passband 0 - 0.4 fs flat within 1e-3 relative, stopband from 0.5 fs attenuated by >= 80 dB, unit
   gain at 0 Hz so the static content is kept exactly), applied centred (zero phase: the record's
   sample ``i`` is at time ``i / fs`` exactly), and only the kept samples are computed (polyphase
   ``scipy.signal.upfirdn``).

The mechanics (mesh law, faults, bearings, housing mode) are those of :func:`simulate.run`; only the
step and the sampling differ. ``make_record(..., sampling="point")`` keeps the earlier chain (RK4 at 8
substeps, every 8th state stored, no low-pass) so that the tables of sessions 1-12 stay reproducible.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
from scipy import signal

from lumped_gearbox.housing import housing_acceleration
from lumped_gearbox.sensors import SensorFilter, apply_chain
from lumped_gearbox.simulate import CHANNELS, Setup, channels, integrate_from_rest

#: RK4 steps per output sample of the data-acquisition chain (chosen by convergence, module docstring)
DAQ_SUBSTEPS = 32
#: filter specification, as fractions of the output sample rate, and the stopband attenuation (dB)
PASSBAND_FRACTION = 0.4
STOPBAND_FRACTION = 0.5
STOPBAND_DB = 80.0
#: attenuation the Kaiser window is designed for (a margin over STOPBAND_DB for the window's ripple)
_DESIGN_DB = 85.0
HOUSING_CHANNELS = ("bearing2_housing_ax", "bearing2_housing_ay")


def anti_alias_fir(substeps: int) -> np.ndarray:
    """Taps of the anti-aliasing low-pass at ``substeps`` times the output rate.

    Kaiser-window design (``scipy.signal.kaiserord`` / ``firwin``) for :data:`_DESIGN_DB` with the
    transition band 0.4 - 0.5 fs, cut-off 0.45 fs; odd length ``2 M substeps + 1`` so that the
    group delay is ``M`` whole output samples; taps normalised to unit DC gain.
    """
    if substeps < 1:
        raise ValueError(f"substeps: {substeps!r} must be >= 1")
    width = 2.0 * (STOPBAND_FRACTION - PASSBAND_FRACTION) / substeps  # relative to the fine Nyquist
    numtaps, beta = signal.kaiserord(_DESIGN_DB, width)
    m = math.ceil((numtaps - 1) / (2 * substeps))
    cutoff = 0.5 * (PASSBAND_FRACTION + STOPBAND_FRACTION) / substeps  # of the fine rate
    h = signal.firwin(2 * m * substeps + 1, cutoff, window=("kaiser", beta), fs=1.0)
    return h / np.sum(h)


def low_pass_sample(x: np.ndarray, substeps: int, n_out: int, taps: np.ndarray | None = None) -> np.ndarray:
    """Low-pass ``x`` (sampled at ``substeps`` times the output rate) and keep every ``substeps``-th.

    ``x[j]`` is at fine time ``j - M substeps`` (``M`` the filter's group delay in output samples), so
    ``x`` holds ``(n_out - 1 + 2 M) substeps + 1`` values; output ``i`` is the centred (zero-phase)
    filter output at fine index ``M substeps + i substeps``, i.e. at the output instant ``i``.
    """
    h = anti_alias_fir(substeps) if taps is None else taps
    half = (h.size - 1) // 2
    m = half // substeps
    need = (n_out - 1) * substeps + 2 * half + 1
    if x.size < need:
        raise ValueError(f"x: {x.size} samples, {need} needed for {n_out} outputs at {substeps} substeps")
    return signal.upfirdn(h, x[:need], 1, substeps)[2 * m : 2 * m + n_out]


def acquire(
    setup: Setup,
    duration_s: float,
    sample_rate_hz: float = 20000.0,
    substeps: int = DAQ_SUBSTEPS,
    preroll_s: float = 0.3,
    housing: bool = False,
    sensors: Mapping[str, Sequence[SensorFilter]] | None = None,
) -> dict[str, np.ndarray]:
    """Integrate at ``substeps`` per sample, low-pass every channel, sample at ``sample_rate_hz``.

    Returns the same keys as :func:`simulate.run` (plus the housing channels with ``housing``): the
    six channels low-passed and sampled; ``mesh_force``, ``mesh_stiffness``, ``q``, ``v``, ``a`` are
    the model's state at the sample instants (diagnostics, not measured channels). ``sensors``: column ->
    a sensor's own filters (``sensors.py``), applied to that column's fine signal before the low-pass
    (the housing path is driven by the true force).
    """
    if not (math.isfinite(duration_s) and duration_s > 0):
        raise ValueError(f"duration_s: {duration_s!r} must be positive")
    if not (math.isfinite(sample_rate_hz) and sample_rate_hz > 0):
        raise ValueError(f"sample_rate_hz: {sample_rate_hz!r} must be positive")
    if not (isinstance(substeps, int) and substeps >= 1):
        raise ValueError(f"substeps: {substeps!r} must be an integer >= 1")
    h = anti_alias_fir(substeps)
    half = (h.size - 1) // 2  # fine steps either side of a sample: M * substeps
    fs_fine = sample_rate_hz * substeps
    dt = 1.0 / fs_fine
    n_out = round(duration_s * sample_rate_hz)
    n_fine = (n_out - 1) * substeps + 2 * half + 1  # from -M/fs to (n_out - 1 + M)/fs
    n_pre = round(preroll_s * fs_fine)  # steps from static equilibrium to t = 0, as in run()
    if n_pre < half:
        raise ValueError(f"preroll_s: {preroll_s!r} shorter than the filter's half length {half * dt:.3g} s")
    out = integrate_from_rest(setup, -n_pre * dt, dt, 1, n_fine, n_pre - half)
    fine = channels(setup, out, (np.arange(n_fine) - half) * dt)
    names = list(CHANNELS)
    if housing:
        for c in HOUSING_CHANNELS:
            # the fine force is already 32x oversampled: the housing is stepped on it directly
            fine[c] = housing_acceleration(fine[f"bearing2_f{c[-1]}"], fs_fine, oversample=1)
        names += list(HOUSING_CHANNELS)
    for c, chain in (sensors or {}).items():
        fine[c] = apply_chain(fine[c], fs_fine, chain)
    keep = half + substeps * np.arange(n_out)  # fine index of each sample instant
    res: dict[str, np.ndarray] = {"time_s": np.arange(n_out) / sample_rate_hz}
    for c in names:
        res[c] = low_pass_sample(fine[c], substeps, n_out, h)
    for c in ("mesh_force", "mesh_stiffness", "q", "v", "a"):
        res[c] = fine[c][keep]
    return res
