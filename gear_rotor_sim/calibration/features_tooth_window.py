"""The named tooth's part of its wheel's synchronous average, apart from the other teeth's pitch errors
(issue 11; docs/history/calibration_sessions.md Sec. 8.65).

The DTE comb (``features_dte_depth``) reads a damaged tooth's depth from the low sideband families of its
wheel's synchronous average: the pulse of extra deflection while that tooth is engaged. Every real wheel
also has manufacturing pitch errors (ISO 1328-1: a single pitch deviation of 3-12 um at quality 5-7 for the
paper's wheels). A flank ``e_i`` early or late shifts the transmission error by ``e_i`` times that pair's
share of the mesh stiffness while tooth ``i`` is engaged (Inalpolat, Handschuh & Kahraman 2015): each
tooth of the wheel puts a pulse of its own at its own angle, a *distributed* tooth signature in the same
average and the same families. Measured on the independent gearbox at 3000 rpm (``lumped_gearbox/pitch.py``,
``benchmarks/pitch_error_trace.py --ser``): with a single pitch deviation of 3 um RMS (quality 5) the
DTE's pinion average holds 0.5-3 um RMS per tooth slot on every tooth, against 3.8 um in the slot of a tooth
damaged to depth 0.4; the six families' amplitudes are 1.1-3.2 times the damaged tooth's own, and the
depth read 0.588 for 0.4.

A damaged tooth's pulse lies within a few mesh periods of its own angle; the other teeth's deviations lie
all round the wheel. So where the average holds more content away from the named tooth than near it
(:func:`outside_share` at least :data:`MIN_OUTSIDE_SHARE`, each part's noise removed), the families are read
from the average's non-carrier content within ``+- HALF_WIDTH`` mesh periods of the tooth (a flat window
with cosine tapers of ``TAPER`` mesh periods), on the record and on the model grid alike: the deviations of
the other teeth no longer count. The window's centre is where the model puts the named tooth's signature
(the energy centroid of the grid run at the largest depth minus the healthy run), so the record's angle
origin and the model's own delay both carry over.

What it assumes: the damaged tooth's pulse (the engagement, about the contact ratio in mesh periods, and the
DTE's quasi-static response) lies inside the window; content spread round the wheel is not the named
tooth's. What it cannot do: the damaged tooth's *own* pitch deviation and its neighbours' stay inside the
window and add to or subtract from the pulse (at quality 5 the pitch deviation of one tooth is of the
size of the pulse of a depth of 0.4); a wheel inspection sheet (the flanks' measured positions) would be
needed to take them out. An eccentricity or a misalignment spreads round the wheel too: with the window on,
its share of the families is left out of the tooth's reading (it is fitted as its own effect).
"""

from __future__ import annotations

import math

import numpy as np

from gear_rotor_sim.analysis.signals import resample_to_angle

#: half width of the window round the named tooth, mesh periods of its wheel (contact ratio of the paper's
#: pair about 1.6: the tooth's engagement and its neighbour's overlap)
HALF_WIDTH = 2.0
#: cosine taper on either side of the window, mesh periods
TAPER = 0.5
#: smallest share of the average's non-carrier energy (noise removed) outside the window for the window to
#: be used. A choice: a single damaged tooth leaves a few percent outside (its pulse's tail and the other
#: content of the average: 0.073 / 0.029 on the table's contact pinion / gear teeth, 0.026-0.148 on the
#: held-out contact teeth, Sec. 8.65), pitch errors of quality 5 leave 0.63 on the same pinion tooth record;
#: the rule fires where the other teeth hold more than the named one.
MIN_OUTSIDE_SHARE = 0.5


def tooth_window(spr: int, teeth: int, center_rev: float) -> np.ndarray:
    """Weights over one revolution of ``spr`` angle samples: 1 within ``HALF_WIDTH`` mesh periods of
    ``center_rev`` (revolutions), a cosine taper over ``TAPER`` mesh periods, 0 beyond."""
    ang = np.arange(spr) / spr
    slots = np.abs((ang - center_rev + 0.5) % 1.0 - 0.5) * teeth
    t = np.clip((slots - HALF_WIDTH) / TAPER, 0.0, 1.0)
    return 0.5 * (1.0 + np.cos(math.pi * t))


def angle_revolutions(x: np.ndarray, fs: float, shaft_hz: float, spr: int) -> np.ndarray:
    """The whole revolutions of ``x`` (constant speed) resampled uniformly in the shaft's angle,
    ``(n_rev, spr)``, the first sample's angle as origin."""
    xs = np.asarray(x, dtype=float).ravel()
    _, xa = resample_to_angle(xs - np.mean(xs), fs, shaft_hz * 60.0, spr)
    n_rev = (xa.size - 1) // spr
    return xa[: n_rev * spr].reshape(n_rev, spr)


def residual_revolutions(revs: np.ndarray, teeth: int) -> np.ndarray:
    """Each revolution (``(n_rev, spr)``) without the average's mesh carriers (orders that are multiples of
    ``teeth``: the mesh-periodic part common to every tooth); their scatter between revolutions (noise)
    stays, for the debiasing."""
    per = np.fft.rfft(revs, axis=1)
    carriers = np.arange(per.shape[1]) % teeth == 0
    per[:, carriers] -= per[:, carriers].mean(axis=0)
    return np.fft.irfft(per, revs.shape[1], axis=1)


def signature_center(tooth_revs: np.ndarray, healthy_revs: np.ndarray, teeth: int) -> float:
    """Angle (revolutions) of the energy centroid of the named tooth's signature in the model's average:
    the non-carrier average of the run with the tooth minus that of the healthy run."""
    r = residual_revolutions(tooth_revs, teeth).mean(axis=0) - residual_revolutions(healthy_revs, teeth).mean(
        axis=0
    )
    phase = np.exp(2j * math.pi * np.arange(r.size) / r.size)
    return float((np.angle(np.sum(r**2 * phase)) / (2.0 * math.pi)) % 1.0)


def outside_share(revs: np.ndarray, teeth: int, window: np.ndarray) -> float:
    """Share of the average's non-carrier energy outside ``window`` (weights ``1 - window``), each part's
    noise (between-revolution scatter over the number of revolutions) removed; 0 if none is left."""
    per = residual_revolutions(revs, teeth)
    n_rev = per.shape[0]
    parts = []
    for w in (window, 1.0 - window):
        y = per * w
        noise = float(np.sum(y.var(axis=0, ddof=1))) / n_rev
        parts.append(max(float(np.sum(y.mean(axis=0) ** 2)) - noise, 0.0))
    total = parts[0] + parts[1]
    return parts[1] / total if total > 0 else 0.0


def named_tooth_window(
    measured: np.ndarray,
    model_tooth: np.ndarray,
    model_healthy: np.ndarray,
    fs: float,
    shaft_hz: float,
    teeth: int,
    model_lead_rev: float = 0.0,
) -> tuple[float | None, float]:
    """Centre (revolutions, in the record's angle) of the window round the named tooth, or None where the
    rule does not fire, and the record's :func:`outside_share` there.

    Parameters
    ----------
    measured : numpy.ndarray
        The record's channel (the DTE), (n,).
    model_tooth, model_healthy : numpy.ndarray
        The model's same channel with the named tooth (the grid's deepest run) and without it.
    fs, shaft_hz : float
        Sample rate and the wheel's shaft rate, Hz.
    teeth : int
        The wheel's teeth.
    model_lead_rev : float
        The shaft angle of the model's first sample minus the record's (revolutions).
    """
    spr = int(2 ** math.ceil(math.log2(max(fs / shaft_hz, 8.0 * teeth))))
    center_model = signature_center(
        angle_revolutions(model_tooth, fs, shaft_hz, spr),
        angle_revolutions(model_healthy, fs, shaft_hz, spr),
        teeth,
    )
    center = (center_model + model_lead_rev) % 1.0
    share = outside_share(
        angle_revolutions(measured, fs, shaft_hz, spr), teeth, tooth_window(spr, teeth, center)
    )
    return (center if share >= MIN_OUTSIDE_SHARE else None), share
