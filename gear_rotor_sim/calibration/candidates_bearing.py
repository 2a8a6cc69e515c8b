"""A bearing defect's amplitude with the shaft's share of its impact path as a fitted nuisance
(issue 11; docs/calibration.md Sec. 8.30).

A defect's impact is an internal force pair of the bearing (``BearingDefect.impact_force``): the race's
share goes through the outer ring straight into the housing and a force sensor under it (the direct
path, ``residual.add_direct_bearing_forces``); the shaft receives the opposite force and answers
through the shaft-bearing dynamics, which reach the same sensor through the bearing's stiffness and
damping (the shaft path). In the envelope band (one octave between about 1 and 9 kHz) the shaft path
is of the direct path's size (band RMS 0.3-1.3 times it on the paper gearbox's bearing 2) and adds to
it with a phase set by the shaft's kHz modes, so the envelope lines per newton change with the band
by a factor 0.5-2 in line power (docs/calibration.md Sec. 8.30). Those modes are what a model knows
least: the bearing stiffness scale that a record fits from its low-frequency content (0.3-0.5 on the
independent records) says nothing about the kHz response of the ball-inner ring contact that carries
the reaction to the shaft. The direct path needs only the defect's force and the sensor.

Rule (:func:`fit_shaft_path_share`, in the verification of an accepted bearing defect): the defect's
response is split into the direct path and the shaft path (``BearingDefect.shaft_path_share`` 0 and
1, one extra simulation), and the force is fitted to the envelope family (where a defect's impacts
act) for each share ``beta`` in ``SHARE_GRID`` of the modelled shaft path, superposed (the response
is linear in the impact force). The share enters only if it improves the envelope chi^2 by more than
``ln N`` over the full shaft path (Schwarz's penalty for one parameter), and the defect at the fitted
force and share is then verified on a full simulation (the whole record's balanced chi^2, again by
``ln N``). It is not fitted where the shaft path cancels
the direct path in an envelope band (the whole response below ``QUASI_STATIC_LIMIT`` of the direct
one: the quasi-static regime, where the cancellation is momentum balance). The share is a transfer
nuisance, reported in the notes, never a finding.

Assumes: the direct path is the model's (a force pulse of the race's defect on the outer ring into the
housing); the shaft path's shape is the model's and only its strength is uncertain, within [0, 1]
(none of it to all of it). A machine whose shaft answers as the model does fits ``beta = 1`` and the
rule changes nothing.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar

from gear_rotor_sim.faults.base import Effect
from gear_rotor_sim.faults.bearing import BearingDefect

#: Shares of the modelled shaft path tried (0: the direct path alone, 1: the model's internal pair).
SHARE_GRID: tuple[float, ...] = tuple(float(x) for x in np.linspace(0.0, 1.0, 11))
#: Below this ratio of the whole response to the direct path (band RMS, :func:`path_ratio`) the shaft
#: path cancels the direct path: the band lies below the shaft-bearing resonance, where an internal
#: force pair exerts no net force (for one mode ``|whole / direct| = w^2 / |w_n^2 - w^2|``, 0.5 at
#: ``w = 0.58 w_n``). That cancellation is momentum balance, not an uncertain path, and a share would
#: be ill-conditioned there (the force ``~ 1 / (1 - share)``): the share is not fitted.
QUASI_STATIC_LIMIT = 0.5
#: Range of the force over the candidate's fitted force in the fit at each share.
FORCE_RANGE: tuple[float, float] = (0.1, 5.0)


def path_ratio(cmp: Any, d_direct: Any, d_shaft: Any) -> float:
    """Smallest band-RMS ratio of the defect's whole response (direct + shaft path) to its direct path,
    over the envelope channels whose direct path is not zero (``inf`` where none is)."""
    out = math.inf
    for c, (a, b) in enumerate(zip(d_direct.analytic, d_shaft.analytic, strict=True)):
        if not cmp.env_use[c]:
            continue
        rd = float(np.sqrt(np.mean(np.abs(a) ** 2)))
        if rd > 0:
            out = min(out, float(np.sqrt(np.mean(np.abs(a + b) ** 2))) / rd)
    return out


@dataclasses.dataclass
class SharedPathFit:
    """Result of :func:`fit_shaft_path_share`."""

    effect: BearingDefect
    share: float
    chi2_full_path: float  # envelope chi^2 at the best force with the full shaft path (superposed)
    chi2: float  # envelope chi^2 at the fitted force and share (superposed)
    taken: bool  # the share beat the full path by more than ln N
    force_full_path: float = math.nan  # the best force with the full shaft path (the estimate before)


def fit_force_and_share(
    chi2: Any, force0: float, shares: Sequence[float] = SHARE_GRID
) -> tuple[float, float, float, float, float]:
    """Force and shaft-path share minimising ``chi2(force, share)``: bounded Brent in the force (within
    ``FORCE_RANGE`` times ``force0``) at each share of the grid.

    Returns ``(force, share, chi2_min, force_at_share_1, chi2_at_share_1)`` (share 1 is always tried).
    """
    lo, hi = FORCE_RANGE[0] * force0, FORCE_RANGE[1] * force0
    best = (force0, 1.0, math.inf)
    at_one = (force0, math.inf)
    for b in sorted({*(float(x) for x in shares), 1.0}):
        res = minimize_scalar(
            lambda x, b=b: chi2(x, b), bounds=(lo, hi), method="bounded", options={"xatol": 1e-3 * force0}
        )
        v = float(res.fun)
        if b == 1.0:
            at_one = (float(res.x), v)
        if v < best[2]:
            best = (float(res.x), b, v)
    return best[0], best[1], best[2], at_one[0], at_one[1]


def fit_shaft_path_share(cal: Any, e: BearingDefect, accepted: Sequence[Effect]) -> SharedPathFit:
    """Fit the force of the bearing defect ``e`` with the share of its modelled shaft path as a nuisance
    (module docstring), on the machine with the accepted effects ``accepted``.

    Parameters
    ----------
    cal : Calibrator
        The calibration (its model runner, features and comparison).
    e : BearingDefect
        The candidate at its fitted force (full shaft path).
    accepted : sequence of Effect
        Effects already in the model.

    Returns
    -------
    SharedPathFit
        The defect at the fitted force and share (``share = 1`` and the force refitted where the share
        does not beat the full path by ``ln N``).
    """
    force0 = float(e.force_n)
    if not force0 > 0 or "envelope" not in cal.cmp.families:
        return SharedPathFit(e, 1.0, math.nan, math.nan, False)
    full = dataclasses.replace(e, shaft_path_share=1.0)
    f_prev = cal._full_features(cal._raw(tuple(accepted)))
    f_full = cal._full_features(cal._raw((*accepted, full)))
    f_direct = cal._full_features(cal._raw((*accepted, dataclasses.replace(e, shaft_path_share=0.0))))
    d_direct = f_direct.combo(f_prev, -1.0).scaled(1.0 / force0)
    d_shaft = f_full.combo(f_direct, -1.0).scaled(1.0 / force0)
    if path_ratio(cal.cmp, d_direct, d_shaft) < QUASI_STATIC_LIMIT:
        return SharedPathFit(e, 1.0, math.nan, math.nan, False)

    def chi2(force: float, share: float) -> float:
        # the envelope family: a defect's impacts act there; its path's small synchronous leakage must
        # not fit the order family's model-form misfit (on the nominal model of the 3000 rpm outer race
        # x0.6 record the balanced chi^2 preferred a share of 0.5 by 300 of 5.7e5 through the orders,
        # the envelope alone 0-0.25: Sec. 8.30)
        feats = f_prev.combo(d_direct, force).combo(d_shaft, force * share)
        return float(cal.cmp.score(feats).chi2["envelope"])

    force, share, val, force1, at_one = fit_force_and_share(chi2, force0)
    taken = share < 1.0 and at_one - val > math.log(max(cal.n_total, 2))
    if not taken:
        force, share, val = force1, 1.0, at_one
    eff = dataclasses.replace(e.with_parameters(force_n=force), shaft_path_share=float(share))
    return SharedPathFit(eff, float(share), float(at_one), float(val), bool(taken), float(force1))


def share_note(fit: SharedPathFit) -> str:
    """The notes' line on a fitted shaft-path share."""
    e = fit.effect
    if not fit.taken:
        return (
            f"{e.label}: shaft path of the impact as modelled (share 1; a smaller share did not improve "
            f"the record by more than ln N)"
        )
    return (
        f"{e.label}: share of the modelled shaft path of the impact {fit.share:.2g} (fitted transfer "
        f"nuisance, not a finding; envelope chi^2 {fit.chi2_full_path:.6g} -> {fit.chi2:.6g} against the "
        f"full path at its best force {fit.force_full_path:.4g} N): the force {e.force_n:.4g} N is read "
        "mainly from the direct path race -> housing (candidates_bearing.py)"
    )
