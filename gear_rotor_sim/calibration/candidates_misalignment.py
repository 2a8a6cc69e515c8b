"""Fitting a gear's angular misalignment (``gear_misalignment``; docs/history/calibration_sessions.md
Sec. 8.8).

The effect (:class:`gear_rotor_sim.faults.GearMisalignment`) has two parts. The axial component of
the mesh force, ``F(t) angle cos(theta + phi)`` on both wheels with ``F(t)`` the mesh force (the part
synchronous with the tilted wheel, from a first run: ``model_misalignment.py``), is at the wheel's
order 1 quasi-static (far below the axial modes) and set by the static mesh force ``T / r_b`` and the
tilt alone; at the mesh harmonics of ``F`` it adds the sidebands ``m z +- 1``. It is exactly linear in
``(angle cos phi, angle sin phi)`` (at the basis runs' tilt the mesh force does not depend on the
tilt), and its order-1 line does not depend on the uncertain mesh stiffness or damping. The
edge-loaded mesh (tangent stiffness ``1 / sqrt(rho)`` and a smaller centre approach, twice per
revolution) appears only beyond ``rho = gamma b / (2 delta0) = 1`` and depends on the
aligned approach ``delta0 = F0 / k``, i.e. on the mesh stiffness model (315 MN/m in this model's
potential-energy TVMS, 423 MN/m by ISO 6336 in the independent lumped gearbox: ``rho`` differs by a
third for the same tilt). So:

1. amplitude and phase from two basis runs far inside the full-contact range (tilt 10 urad: a
   separation of 0.1 um across a 20 mm face), weighted linear least squares (as for eccentricity),
   which the axial bearing force at the wheel's order 1 carries;
2. the candidate's features are one full simulation at that angle and phase (its mesh part
   included);
3. refinement on full simulations as for every nonlinear effect (``Calibrator._refine``).

Measured on the independent 1 mrad records (3000 rpm): step 1 gives 1.04 mrad (0.6 s record) and
0.98 mrad (2 s); a grid of full simulations over the angle instead gave 0.65 and 0.88 on the
nominal model, pulled down by the mesh part's model-form misfit.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.optimize import minimize_scalar

from gear_rotor_sim.calibration.fault_path import axial_channels, channels_chi2, channels_excess, with_path
from gear_rotor_sim.faults import Effect, GearMisalignment

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.fit import Calibrator, CandidateFit
    from gear_rotor_sim.calibration.residual import ModelFeatures

#: tilt of the linear basis runs, rad (separation 0.1 um across a 20 mm face: full contact)
LINEAR_REF_RAD = 1e-5
#: range of the tilted contact's width scale ``b_eff / b`` (:func:`fit_contact_width`): ``rho`` of the
#: edge-loaded mesh part may be off by the ratio of the two models' mesh stiffnesses (x1.34 between
#: this model's potential-energy TVMS and ISO 6336) times the lead modifications' effect
WIDTH_SCALE_RANGE = (0.5, 2.0)


def fit_gear_misalignment(cal: Calibrator, e: GearMisalignment, cur: ModelFeatures) -> CandidateFit | None:
    """Angle and phase of a misaligned wheel's tooth lines on the current model features ``cur``.

    Parameters
    ----------
    cal : Calibrator
        The calibration in progress (its signatures and scoring).
    e : GearMisalignment
        Candidate (wheel and mesh set; angle and phase fitted).
    cur : ModelFeatures
        Features of the current model (baseline-updated, accepted effects).

    Returns
    -------
    CandidateFit or None
        ``None`` when the candidate has no signature in the measured features.
    """
    # the angle and phase from the axial line below the mesh band (T / r_b and the tilt alone), not from the
    # sidebands m z +- 1, which carry the model's dynamic mesh force (Sec. 8.80)
    select = axial_low_orders(cal.cmp) if cal.fit.misalignment_axial else None
    lin = cal._fit_phase_amplitude(e, cur, ref=LINEAR_REF_RAD, select=select)
    if lin is None:
        return None
    eff = lin.effect
    if float(eff.parameters()["angle_rad"]) <= 0.0:
        return lin
    feats = cur.combo(cal._signature(eff), 1.0)
    mask = cal._path_mask(eff)
    if mask is None:
        fit = dataclasses.replace(lin, score=cal.cmp.score(feats), k=2)
        if cal.fit.misalignment_axial:
            # in contact too the axial force carries the angle: its share counts as the candidate's own
            # family's (Sec. 8.38), where the axial gain alone is significant
            fit.comb_explained = axial_share(cal, cur, feats, 2)
        return fit
    # where the teeth separate the edge-loaded mesh part reaches every lateral channel through a
    # fitted transfer factor (fault_path.py); the axial force keeps the model's quasi-static path and
    # carries the angle. Its own signature's share: the axial channels' excess it explains
    feats, _ = with_path(cal.cmp, cur, feats, mask)
    fit = dataclasses.replace(lin, score=cal.cmp.score(feats), k=2, feats=feats)
    fit.comb_explained = axial_share(cal, cur, feats, 2, significant=cal.fit.misalignment_axial)
    return fit


def axial_share(
    cal: Calibrator, cur: ModelFeatures, feats: ModelFeatures, k: int, significant: bool = True
) -> float:
    """Share of the axial bearing forces' order excess that a misalignment's features ``feats`` explain.

    Parameters
    ----------
    cal : Calibrator
        The calibration in progress (its comparison ``cal.cmp`` and settings ``cal.fit``).
    cur, feats : ModelFeatures
        The current model's features and the candidate's.
    k : int
        The candidate's parameter count (the BIC penalty ``k ln N``).
    significant : bool
        Whether the axial gain must be significant (below); False: the share alone (session 14's rule
        where the teeth separate, ``FitSettings.misalignment_axial`` off).

    Returns
    -------
    float
        ``(excess before - excess after) / excess before`` on the axial channels' orders
        (``fault_path.channels_excess``); 0 where the axial gain itself does not pass the BIC
        threshold plus ``k ln N`` (docs/history/calibration_sessions.md Sec. 8.38): a share of an excess at
        the noise level (a healthy record's axial lines) is no evidence of a tilt.
    """
    axial = axial_channels(cal.cmp.names)
    before = channels_excess(cal.cmp, cur, axial)
    if before <= 0:
        return 0.0
    gain = before - channels_excess(cal.cmp, feats, axial)
    if significant and gain <= cal.fit.bic_threshold + k * math.log(max(cal.n_total, 2)):
        return 0.0
    return gain / before


def axial_low_orders(cmp: Any) -> list[list[np.ndarray]] | None:
    """The axial bearing forces' order features below half the mesh frequency, per channel and shaft
    (``[c][s]`` boolean masks, all False on the other channels); None without an axial channel or a mesh.

    The axial force ``F(t) angle cos(theta + phi)`` puts the tilted wheel's order 1 at ``F0 angle``
    (``F0 = T / r_b``, quasi-static: far below the axial modes) and, at the mesh harmonics of ``F(t)``,
    the sidebands ``m z +- 1``, whose level is the model's *dynamic* mesh force times the angle: mesh
    stiffness, mesh mode and bearing sets move it, the angle does not. Measured on blind2_02 (gear tilted
    0.687 mrad, 2067 rpm / 34 C, no reference; the linear fit on ``bearing2_fz`` alone, gains 1): order 1
    of the gear reads 0.6768 mrad on the nominal machine, with the bearing set x0.32 and with a mesh
    x1.5 alike; the sidebands 48 and 50 (the record's 0.248 / 0.234 N against the model's 0.071 / 0.058 N
    per mrad, noise 0.012 N) read 1.06 mrad on the nominal machine and 2.70 mrad with the bearing set,
    and the fit over every feature of the candidate 0.885 mrad there (+29 %; 0.698 on the nominal
    machine)."""
    axial = axial_channels(cmp.names)
    if not axial.any() or not getattr(cmp, "mesh_hz", 0.0):
        return None
    low = [np.abs(sh.orders * sh.ratio) * cmp.speed_hz < 0.5 * cmp.mesh_hz for sh in cmp.shafts]
    none = [np.zeros(sh.orders.size, dtype=bool) for sh in cmp.shafts]
    return [low if bool(a) else none for a in axial]


def axial_chi2(cal: Calibrator, feats: ModelFeatures) -> float:
    """Objective of a misalignment's angle on full simulations: the axial bearing forces' order chi^2
    below half the mesh frequency (:func:`axial_low_orders`; every order where there is no mesh).

    The axial force ``F(t) angle cos(theta + phi)`` carries the angle model-robustly (its order-1 line
    is set by ``T / r_b`` and the tilt alone); the edge-loaded mesh part beyond ``rho = 1`` depends on
    ``F0 / k`` of the mesh stiffness model, which differs between models by a third (module
    docstring). Judged on every channel, the refinement traded the angle against that mesh part's
    misfit: 1.37 mrad for 1 on the held-out 4500 rpm / 75 C record (Sec. 8.34); judged on every order of
    the axial force, against the sidebands ``m z +- 1`` of the model's dynamic mesh force (Sec. 8.80).
    Where the teeth separate ``Calibrator._param_chi2`` already judges on these channels (the others'
    path fitted).
    """
    return channels_chi2(cal.cmp, feats, axial_channels(cal.cmp.names), select=axial_low_orders(cal.cmp))


def misalignment_path(names: Sequence[str]) -> np.ndarray:
    """Channels whose share of a misaligned wheel's response is a fitted transfer nuisance where the
    teeth separate: all but the axial bearing forces.

    The edge-loaded mesh part depends on the mesh stiffness model (above), and where the teeth
    separate on the impact dynamics too. Measured at 8000 rpm, 1 mrad, on 2 s records: the radial
    force of bearing 2 at gear order 2 is 0.578 N in the FE model and 0.009 N in the lumped gearbox
    (noise 0.028 N), the DTE at gear order 2 66 nm against 22 nm (noise 11 nm); the axial force at
    gear order 1 is 0.730 N against 0.717 N (noise 0.013 N, SNR 57). Scored at the model's transfer,
    a full run at the angle the axial force gives (1.02 mrad) was worse than the healthy model.
    """
    return ~axial_channels(names)


def fit_contact_width(cal: Calibrator, ver: CandidateFit, accepted: Sequence[Effect]) -> CandidateFit:
    """The verified misalignment ``ver`` with the width of its tilted contact fitted as a nuisance.

    In contact the angle is set by the axial bearing forces (:func:`axial_chi2`); the edge-loaded mesh
    part beyond ``rho = gamma b / (2 delta0) = 1`` depends on ``delta0 = F0 / k`` of the mesh stiffness
    model and on the face's lead modifications, which differ between models (module docstring). Its
    level is fitted with the angle and phase held: ``rho`` scaled by ``s = b_eff / b`` in
    :data:`WIDTH_SCALE_RANGE` (``GearMisalignment.face_width_m``, which enters ``rho`` only, not the
    axial force), bounded Brent on full simulations of the balanced chi^2 of every channel. Taken
    where it lowers that chi^2 by more than ``ln N`` (one parameter more); the scale is a nuisance
    reported in the notes, never a finding (docs/history/calibration_sessions.md Sec. 8.38). Measured on
    the held-out 4500 rpm / 75 C record (1 mrad, 2000 rpm reference held): error 47.9 at ``b``, 18.5 at
    ``1.75 b``, the angle 1.034 mrad in both.

    Parameters
    ----------
    cal : Calibrator
        The calibration in progress.
    ver : CandidateFit
        The misalignment after its refinement (``raw`` and ``score`` of a full simulation).
    accepted : sequence of Effect
        Effects accepted in earlier rounds (part of every run).

    Returns
    -------
    CandidateFit
        ``ver`` itself, or the same angle and phase at the fitted contact width.
    """
    e = ver.effect
    if not isinstance(e, GearMisalignment) or float(e.angle_rad) <= 0.0:
        return ver
    b0 = float(e.face_width_m)
    runs: dict[float, tuple[float, np.ndarray]] = {1.0: (ver.score.balanced_chi2, ver.raw)}

    def chi2(log_s: float) -> float:
        s = round(float(math.exp(log_s)), 4)
        if s not in runs:
            raw = cal._raw((*accepted, dataclasses.replace(e, face_width_m=s * b0)))
            runs[s] = (cal.cmp.score(cal._full_features(raw)).balanced_chi2, raw)
        return runs[s][0]

    lo, hi = (math.log(x) for x in WIDTH_SCALE_RANGE)
    minimize_scalar(chi2, bounds=(lo, hi), method="bounded", options={"xatol": 0.02, "maxiter": 10})
    s_best = min(runs, key=lambda k: runs[k][0])
    gain = ver.score.balanced_chi2 - runs[s_best][0]
    if s_best == 1.0 or gain <= math.log(max(cal.n_total, 2)):
        return ver
    raw = runs[s_best][1]
    eff = dataclasses.replace(e, face_width_m=s_best * b0)
    feats = cal._full_features(raw)
    cal.notes.append(
        f"{e.label}: tilted contact width x{s_best:.3g} of the face (nuisance: the edge-loaded mesh part's "
        f"rho scaled, the angle {e.angle_rad:.3g} rad held), chi2 {ver.score.balanced_chi2:.4g} -> "
        f"{runs[s_best][0]:.4g}"
    )
    return dataclasses.replace(ver, effect=eff, raw=raw, score=cal.cmp.score(feats), feats=feats)
