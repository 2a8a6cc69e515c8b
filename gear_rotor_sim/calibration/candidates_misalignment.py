"""Fitting a gear's angular misalignment (``gear_misalignment``; docs/calibration.md Sec. 8.8).

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
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from gear_rotor_sim.calibration.fault_path import axial_channels, channels_excess, with_path
from gear_rotor_sim.faults import GearMisalignment

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.fit import Calibrator, CandidateFit
    from gear_rotor_sim.calibration.residual import ModelFeatures

#: tilt of the linear basis runs, rad (separation 0.1 um across a 20 mm face: full contact)
LINEAR_REF_RAD = 1e-5


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
    lin = cal._fit_phase_amplitude(e, cur, ref=LINEAR_REF_RAD)
    if lin is None:
        return None
    eff = lin.effect
    if float(eff.parameters()["angle_rad"]) <= 0.0:
        return lin
    feats = cur.combo(cal._signature(eff), 1.0)
    mask = cal._path_mask(eff)
    if mask is None:
        return dataclasses.replace(lin, score=cal.cmp.score(feats), k=2)
    # where the teeth separate the edge-loaded mesh part reaches every lateral channel through a
    # fitted transfer factor (fault_path.py); the axial force keeps the model's quasi-static path and
    # carries the angle. Its own signature's share: the axial channels' excess it explains
    feats, _ = with_path(cal.cmp, cur, feats, mask)
    fit = dataclasses.replace(lin, score=cal.cmp.score(feats), k=2, feats=feats)
    axial = axial_channels(cal.cmp.names)
    before = channels_excess(cal.cmp, cur, axial)
    if before > 0:
        fit.comb_explained = (before - channels_excess(cal.cmp, feats, axial)) / before
    return fit


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
