"""A damaged tooth's signature in the transmission error, below the mesh carriers' dynamics (issue 11;
docs/history/calibration_sessions.md Sec. 8.25).

A tooth whose stiffness drops by a fraction ``d`` raises the elastic mesh deflection while it is
engaged: once per revolution of its wheel the dynamic transmission error (DTE) carries a short pulse
of extra deflection, which in that wheel's synchronous average is a broad comb at the shaft orders
``k`` and the sidebands ``z +- k`` of the first mesh carrier. This module reads the depth from that
comb **at the DTE only** and **in the lowest band only** (per sideband family ``k = 1..6``, the
energy of the orders ``k``, ``z - k`` and ``z + k``):

* the DTE measures the mesh itself: no shaft, bearing or housing transfer lies between the tooth and
  the sensor (``fault_path.mesh_channels``), and a DTE from two shaft encoders has no sensor gain. The
  bearing forces and housing accelerations see the same pulse through the shaft-bearing transfer,
  whose model form (lateral modes near the mesh harmonics) moves their sidebands by factors of 2-4
  between two models of one gearbox (docs/history/calibration_sessions.md Sec. 8.25);
* at and below the first mesh carrier the DTE follows the quasi-static deflection ``F / k(t)``: the
  pulse's low orders are its area, the compliance-time the damaged tooth adds in one revolution,
  which depends on the stiffness-time the tooth loses (the same in any model that reduces that
  tooth's stiffness by ``d`` over its engagement) and not on how a pair enters and leaves contact
  (tip relief, contact ratio): those shape the higher mesh harmonics, where the sideband-to-carrier
  ratios of :mod:`.features_sidebands` disagree between two models by +-50 %;
* one depth per family and their median: an effect at one or two orders that the model does not hold
  yet (an eccentricity at order 1 and its sidebands ``z +- 1``, a misalignment at order 2) moves one
  or two families, not the median.

What it assumes: continuous contact (a linear, quasi-static response of the DTE below the first
mesh-coupled resonance; not used where the teeth separate), a known speed, and the model's static
mesh compliance ``F / k``: the pulse is ``F / k`` times a function of ``d``, so a mesh stiffer by a
factor ``s`` than the model reads a depth lower by roughly ``1 - 1 / s`` at small depth (Sec. 8.25:
x1.342 moves the read by +18 % at depth 0.33). The reading takes the model's mesh scale as it is (or
the one the sideband-ratio step fits, ``candidates_tooth_dte.py``). At 4500 rpm, where the first
carrier's sidebands lie nearer the mesh-coupled modes, it read +42 % on one record (Sec. 8.25).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from gear_rotor_sim.calibration.features_tooth_window import (
    angle_revolutions,
    residual_revolutions,
    tooth_window,
)

#: sideband families ``k = 1..FAMILIES``: orders ``k``, ``z - k``, ``z + k`` of the damaged wheel
FAMILIES = 6


def dte_tooth_signature(
    x: np.ndarray,
    fs: float,
    shaft_hz: float,
    teeth: int,
    families: int = FAMILIES,
    debias: bool = True,
    center_rev: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Amplitude of each sideband family of the DTE's synchronous average of one shaft.

    Parameters
    ----------
    x : numpy.ndarray
        The DTE, (n,), constant speed, m.
    fs : float
        Sample rate, Hz.
    shaft_hz : float
        Rotation frequency of the damaged wheel's shaft, Hz.
    teeth : int
        Teeth of the damaged wheel (first mesh carrier at order ``teeth``).
    families : int
        Families ``k = 1..families``; must be below ``teeth / 2`` (the families stay apart).
    debias : bool
        Subtract each coefficient's noise variance (between-revolution scatter / revolutions) from its
        squared magnitude (measured records; a model run over whole hunting periods has no noise).
    center_rev : float, optional
        Read the families from the average's non-carrier content within the window round the named tooth
        centred there (revolutions from the first sample; ``features_tooth_window``, Sec. 8.65: the other
        teeth's pitch errors left out); None: the whole revolution.

    Returns
    -------
    amp : numpy.ndarray
        (families,) ``sqrt(|c_k|^2 + |c_{z-k}|^2 + |c_{z+k}|^2)``, m (NaN where the debiased energy is
        not positive).
    se : numpy.ndarray
        Their standard errors (jackknife over revolutions).
    """
    if not 1 <= families < teeth / 2:
        top = math.ceil(teeth / 2) - 1
        raise ValueError(f"families: must be in 1..{top} for {teeth} teeth, got {families}")
    if not (shaft_hz > 0 and math.isfinite(shaft_hz)):
        raise ValueError(f"shaft_hz: must be positive and finite, got {shaft_hz!r}")
    xs = np.asarray(x, dtype=float).ravel()
    o_max = teeth + families
    if o_max * shaft_hz > 0.42 * fs:
        lim = 0.42 * fs
        raise ValueError(f"order {o_max} of a {shaft_hz:.3g} Hz shaft lies above 0.42 fs ({lim:.4g} Hz)")
    spr = int(2 ** math.ceil(math.log2(max(fs / shaft_hz, 2 * (o_max + 2)))))
    revs = angle_revolutions(xs, fs, shaft_hz, spr)
    n_rev = revs.shape[0]
    if n_rev < 4:
        raise ValueError(f"record shorter than 4 revolutions of a {shaft_hz:.3g} Hz shaft")
    if center_rev is not None:
        revs = residual_revolutions(revs, teeth) * tooth_window(spr, teeth, center_rev)
    per = np.fft.rfft(revs, axis=1)[:, : o_max + 1] / spr
    mean = per.mean(axis=0)
    var = np.sum(np.abs(per - mean) ** 2, axis=0) / max(n_rev - 1, 1) / n_rev
    bias = var if debias else np.zeros_like(var)
    loo = (n_rev * mean - per) / (n_rev - 1)  # leave-one-revolution-out means
    amp = np.full(families, np.nan)
    se = np.full(families, np.nan)
    for k in range(1, families + 1):
        idx = np.array([k, teeth - k, teeth + k])
        e = float(np.sum(np.abs(mean[idx]) ** 2 - bias[idx]))
        if e > 0:
            amp[k - 1] = math.sqrt(e)
        reps = np.sqrt(np.maximum(np.sum(np.abs(loo[:, idx]) ** 2 - bias[idx], axis=1), 0.0))
        se[k - 1] = float(np.sqrt((n_rev - 1) / n_rev * np.sum((reps - reps.mean()) ** 2)))
    return amp, se


@dataclass
class DteDepthFit:
    """Depth read from the DTE's sideband families."""

    depth: float  # median of the families' depths
    sigma: float  # statistical: the families' scatter (1.4826 MAD / sqrt(n)) and the noise, in quadrature
    per_family: np.ndarray = field(default_factory=lambda: np.zeros(0))  # NaN where not read
    n_families: int = 0


def read_rising(y: float, depths: np.ndarray, values: np.ndarray) -> float:
    """Depth at which ``values`` (a family's amplitude over the grid ``depths``, from 0) reaches ``y``,
    on the rising branch from the first grid depth (log-linear interpolation); NaN beyond that branch.

    The quasi-static pulse grows with the depth, but the model's response to a very deep tooth need not
    (Sec. 8.25: the pinion's order-1 DTE falls from depth 0.7 on); only the branch that starts at the
    healthy model is a reading."""
    ly = math.log(y)
    lv = np.log(np.maximum(np.asarray(values, dtype=float), 1e-300))
    if ly <= lv[0]:
        return float(depths[0])
    for i in range(len(depths) - 1):
        a, b = lv[i], lv[i + 1]
        if b <= a:
            return float("nan")
        if ly <= b:
            return float(depths[i] + (ly - a) / (b - a) * (depths[i + 1] - depths[i]))
    return float("nan")


def depth_from_dte(
    measured: np.ndarray,
    measured_se: np.ndarray,
    model: Mapping[float, np.ndarray],
    significance: float = 3.0,
    min_families: int = 3,
) -> DteDepthFit | None:
    """Depth of each sideband family against the model grid and their median.

    Parameters
    ----------
    measured, measured_se : numpy.ndarray
        (families,) the record's family amplitudes and standard errors (:func:`dte_tooth_signature`).
    model : mapping
        Depth -> the model's family amplitudes at that depth (full runs), at least two depths.
    significance : float
        A family is read only if it stands this many standard errors above zero.
    min_families : int
        Fewest families read for a depth (None below).

    Returns
    -------
    DteDepthFit or None
    """
    depths = np.array(sorted(model), dtype=float)
    if depths.size < 2:
        raise ValueError("model: family amplitudes at two depths at least are needed")
    grid = np.array([model[d] for d in depths])
    y = np.asarray(measured, dtype=float)
    s = np.asarray(measured_se, dtype=float)
    per = np.full(y.shape, np.nan)
    stat = np.full(y.shape, np.nan)
    for j in range(y.size):
        if not (np.isfinite(y[j]) and np.isfinite(s[j]) and y[j] > significance * s[j]):
            continue
        if not np.all(np.isfinite(grid[:, j])):
            continue
        d = read_rising(y[j], depths, grid[:, j])
        if not math.isfinite(d):
            continue
        per[j] = d
        # the noise's part: the depth at y + se
        d_hi = read_rising(y[j] + s[j], depths, grid[:, j])
        stat[j] = abs(d_hi - d) if math.isfinite(d_hi) else float("nan")
    ok = np.isfinite(per)
    n = int(ok.sum())
    if n < min_families:
        return None
    med = float(np.median(per[ok]))
    mad = 1.4826 * float(np.median(np.abs(per[ok] - med)))
    st = stat[ok & np.isfinite(stat)]
    noise = float(np.sqrt(np.mean(st**2)) / math.sqrt(st.size)) if st.size else 0.0
    return DteDepthFit(med, math.hypot(mad / math.sqrt(n), noise), per, n)
