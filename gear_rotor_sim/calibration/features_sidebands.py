"""Scale-free signature of a damaged tooth: sideband-to-carrier energy ratios (issue 11, Sec. 8.10).

A tooth whose stiffness drops by a fraction ``d`` modulates the mesh stiffness once per revolution of
its wheel: in that wheel's synchronous average it puts sidebands at ``m z +- k`` around every mesh
carrier ``m z``. The absolute sideband amplitude is ``delta0 d`` times the transfer of the machine
(``delta0 = F / k`` the elastic mesh deflection), so read against a model whose mesh stiffness is a
third off it gives a depth a third off (``docs/history/calibration_sessions.md`` Sec. 8.7). The carrier of
the same record and channel comes from the regular stiffness variation of the same mesh, through the same
sensor and (within ``+- k`` shaft orders) nearly the same transfer path, so the ratio

``SER_m = sqrt(sum_{k = 1..K} |c_{m z - k}|^2 + |c_{m z + k}|^2) / |c_{m z}|``

(sideband energy ratio of mesh harmonic ``m``; the sideband-to-carrier ratios of
:func:`~gear_rotor_sim.calibration.features_orders.sideband_ratios` summed in energy over the
``2 K`` sidebands) cancels the sensor gain, ``F / k`` and most of the transfer path. What it keeps:
the depth (``SER`` grows like ``d / (1 - d)``: the damaged pair's compliance), and the shape of the
regular stiffness variation (its ``m``-th harmonic relative to the mean stiffness, a geometric
property of the tooth pair: contact ratio, single- and double-contact stiffness).

* :func:`sideband_energy_ratios`: ``SER_m`` per channel of one shaft's synchronous average, noise
  bias removed, with the standard error from a jackknife over revolutions.
* :func:`ensemble_log_spread`: model-form uncertainty of each ``log SER_m`` from the spread of the
  model over a plausible ensemble of the uncertain baseline (:data:`CONTACT_ENSEMBLE`).
* :func:`fit_depth_from_ratios`: depth from ``log SER`` against the model's ``log SER`` at a grid of
  depths (piecewise-linear interpolation), with the noise and model-form variances.
* :func:`ensemble_depth_spread`: the depth's own model-form uncertainty: the depth each ensemble
  member's ratios read against the nominal grid (the members move every ratio together, so the
  per-feature variances alone, treated as independent, would understate it).

Assumes a known speed (order tracking), and that the model reproduces how the sidebands grow with
the depth: in continuous contact a linear response to the stiffness modulation; where the teeth
separate the sidebands are impact products, and the model's ratios come from full simulations of the
rattling model (``candidates_tooth.py``; docs/history/calibration_sessions.md Sec. 8.14).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from gear_rotor_sim.analysis.signals import resample_to_angle
from gear_rotor_sim.faults import BearingStiffnessDamping, Effect, MeshStiffnessDamping

#: Plausible spread of the uncertain baseline where the teeth stay in contact, one run each, each
#: changed alone around the current (baseline-updated) machine: the stiffness scales by x0.8 / x1.25
#: (the rattle ensemble's bearing spread, ``features_rattle.ENSEMBLE``; here for the mesh too, whose
#: scale the record's own dynamics do not identify, Sec. 8.7) and the mesh damping by x0.7 / x1.4.
CONTACT_ENSEMBLE: tuple[Effect, ...] = (
    MeshStiffnessDamping(stiffness_scale=0.8),
    MeshStiffnessDamping(stiffness_scale=1.25),
    MeshStiffnessDamping(damping_scale=0.7),
    MeshStiffnessDamping(damping_scale=1.4),
    BearingStiffnessDamping(stiffness_scale=0.8),
    BearingStiffnessDamping(stiffness_scale=1.25),
)

#: Depths of the full-simulation grid the ratios are read against (the library's bound is 0.9).
DEPTH_GRID: tuple[float, ...] = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9)


def sideband_energy_ratios(
    x: np.ndarray,
    fs: float,
    shaft_hz: float,
    teeth: int,
    harmonics: int = 3,
    sidebands: int = 6,
    debias: bool = True,
    skip: Sequence[int] = (),
) -> tuple[np.ndarray, np.ndarray]:
    """Sideband energy ratios ``SER_m`` (``m = 1..harmonics``) of one shaft's synchronous average.

    Parameters
    ----------
    x : numpy.ndarray
        Signals (n,) or (n, c), constant speed.
    fs : float
        Sample rate, Hz.
    shaft_hz : float
        Rotation frequency of the shaft, Hz.
    teeth : int
        Teeth of the shaft's gear (carriers at orders ``m * teeth``).
    harmonics, sidebands : int
        Mesh harmonics ``m`` and sidebands ``k = 1..sidebands`` on each side.
    debias : bool
        Subtract the noise variance from each squared coefficient (measured records). A model run
        over whole hunting periods has no noise: its between-revolution scatter is the other
        shaft's content, which cancels exactly in its average, so it is not subtracted there.
    skip : sequence of int
        Sideband families ``k`` left out of the sums (``m z +- k``): where the teeth separate, a
        family holding a locked rattle component that the model does not predict
        (``features_rattle.locked_families``; the pinion's family 5 of the independent gearbox at
        8000 rpm).

    Returns
    -------
    ser : numpy.ndarray
        (c, harmonics) ratios; NaN where the carrier is not significant (below 3 standard errors) or
        the order lies above ``0.42 fs``.
    se : numpy.ndarray
        Their standard errors (jackknife over revolutions: noise and any non-synchronous content).

    Notes
    -----
    The synchronous average is the mean of the revolutions resampled uniformly in angle (computed
    order tracking, McFadden 1987). Each squared coefficient is debiased by its noise variance
    (between-revolution scatter / revolutions), so noise does not read as sidebands.
    """
    if teeth < 1 or harmonics < 1 or sidebands < 1:
        raise ValueError(f"teeth, harmonics, sidebands: must be >= 1, got {teeth}, {harmonics}, {sidebands}")
    if not (shaft_hz > 0 and math.isfinite(shaft_hz)):
        raise ValueError(f"shaft_hz: must be positive and finite, got {shaft_hz!r}")
    xs = np.asarray(x, dtype=float)
    xs = xs.reshape(xs.shape[0], -1)
    o_max = harmonics * teeth + sidebands
    spr = int(2 ** math.ceil(math.log2(max(fs / shaft_hz, 2 * (o_max + 2)))))
    ser = np.full((xs.shape[1], harmonics), np.nan)
    se = np.full((xs.shape[1], harmonics), np.nan)
    for c in range(xs.shape[1]):
        _, xa = resample_to_angle(xs[:, c] - np.mean(xs[:, c]), fs, shaft_hz * 60.0, spr)
        n_rev = (xa.size - 1) // spr
        if n_rev < 4:
            raise ValueError(f"record shorter than 4 revolutions of a {shaft_hz:.3g} Hz shaft")
        per = np.fft.rfft(xa[: n_rev * spr].reshape(n_rev, spr), axis=1)[:, : o_max + 1] / spr
        mean = per.mean(axis=0)
        var = np.sum(np.abs(per - mean) ** 2, axis=0) / max(n_rev - 1, 1) / n_rev
        bias = var if debias else np.zeros_like(var)
        # leave-one-revolution-out means (jackknife replicates)
        loo = (n_rev * mean - per) / (n_rev - 1)
        for m in range(1, harmonics + 1):
            o = m * teeth
            if (o + sidebands) * shaft_hz > 0.42 * fs:
                continue
            if debias and abs(mean[o]) ** 2 <= 9.0 * var[o]:
                continue
            ks = np.array([k for k in range(1, sidebands + 1) if k not in skip], dtype=int)
            side = np.r_[o - ks, o + ks]
            ser[c, m - 1] = float(_energy_ratio(mean, side, o, bias))
            reps = _energy_ratio(loo, side, o, bias)
            se[c, m - 1] = float(np.sqrt((n_rev - 1) / n_rev * np.sum((reps - reps.mean()) ** 2)))
    return ser, se


def _energy_ratio(cs: np.ndarray, side: np.ndarray, o: int, bias: np.ndarray) -> np.ndarray:
    """``sqrt(sum |c_side|^2 / |c_o|^2)`` with each squared magnitude debiased by ``bias`` (NaN where
    the debiased carrier power is not positive)."""
    num = np.sum(np.abs(cs[..., side]) ** 2 - bias[side], axis=-1)
    den = np.abs(cs[..., o]) ** 2 - bias[o]
    ok = den > 0
    return np.where(ok, np.sqrt(np.maximum(num, 0.0) / np.where(ok, den, 1.0)), np.nan)


def ensemble_log_spread(nominal: np.ndarray, members: Sequence[np.ndarray]) -> np.ndarray:
    """RMS over the ensemble members of ``log(SER_member / SER_nominal)`` per feature (NaN where a
    member or the nominal model has no ratio)."""
    if not members:
        return np.zeros_like(nominal)
    logs = np.array([np.log(m / nominal) for m in members])
    return np.sqrt(np.mean(logs**2, axis=0))


@dataclass
class RatioDepthFit:
    """Depth read from the sideband energy ratios."""

    depth: float
    sigma: float  # standard deviation (chi^2 + 1 interval, scaled by the reduced chi^2 when > 1)
    n_features: int
    chi2: float
    at_edge: bool  # minimum at the first or last grid depth
    used: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))  # feature mask


def fit_depth_from_ratios(
    measured: np.ndarray,
    measured_se: np.ndarray,
    model: dict[float, np.ndarray],
    model_form: np.ndarray | None = None,
    tolerance: float = 0.05,
    significance: float = 3.0,
) -> RatioDepthFit | None:
    """Depth minimising ``sum ((log SER_meas - log SER_model(d)) / sigma)^2``.

    Parameters
    ----------
    measured, measured_se : numpy.ndarray
        Measured ratios and standard errors (any shape, same as each model array).
    model : dict
        Depth -> the model's ratios at that depth (full simulations), at least two depths.
    model_form : numpy.ndarray, optional
        Model-form standard deviation of each ``log SER`` (:func:`ensemble_log_spread`).
    tolerance : float
        Floor of the model-form standard deviation of ``log SER`` (a few percent).
    significance : float
        A measured ratio is used only if it stands this many standard errors above zero.

    Returns
    -------
    RatioDepthFit or None
        None when fewer than two features are usable (no significant sidebands).
    """
    depths = np.array(sorted(model), dtype=float)
    if depths.size < 2:
        raise ValueError("model: ratios at two depths at least are needed")
    grid = np.array([model[d] for d in depths])  # (n_d, ...)
    y = np.asarray(measured, dtype=float)
    s = np.asarray(measured_se, dtype=float)
    mf = np.zeros_like(y) if model_form is None else np.asarray(model_form, dtype=float)
    used = (
        np.isfinite(y)
        & np.isfinite(s)
        & (y > significance * s)
        & np.all(np.isfinite(grid) & (grid > 0), axis=0)
        & np.isfinite(mf)
    )
    if int(used.sum()) < 2:
        return None
    ly = np.log(y[used])
    lg = np.log(grid[:, used])
    var = (s[used] / y[used]) ** 2 + np.maximum(mf[used], tolerance) ** 2

    fine = np.linspace(depths[0], depths[-1], 721)
    # piecewise-linear interpolation of log SER between the grid depths
    lm = np.stack([np.interp(fine, depths, lg[:, j]) for j in range(lg.shape[1])], axis=1)
    chi = np.sum((ly - lm) ** 2 / var, axis=1)
    i = int(np.argmin(chi))
    c_min = float(chi[i])
    n = int(used.sum())
    scale = max(c_min / max(n - 1, 1), 1.0)
    inside = fine[chi <= c_min + scale]
    sigma = 0.5 * float(inside.max() - inside.min()) if inside.size > 1 else float(fine[1] - fine[0])
    return RatioDepthFit(float(fine[i]), sigma, n, c_min, bool(i == 0 or i == fine.size - 1), used.copy())


def ensemble_depth_spread(
    members: Sequence[np.ndarray],
    depth: float,
    model: dict[float, np.ndarray],
    model_form: np.ndarray | None = None,
    tolerance: float = 0.05,
) -> float:
    """Relative RMS deviation of the depth read from each ensemble member's ratios (computed at
    ``depth``) against the nominal ``model`` grid: the model-form part of the depth's uncertainty.

    Returns NaN when no member gives a fit.
    """
    rel = []
    for m in members:
        r = fit_depth_from_ratios(m, np.zeros_like(m), model, model_form, tolerance, significance=0.0)
        if r is not None and depth > 0:
            rel.append((r.depth - depth) / depth)
    return float(np.sqrt(np.mean(np.square(rel)))) if rel else float("nan")
