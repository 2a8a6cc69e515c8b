"""Fitting a gear's angular misalignment (``gear_misalignment``; docs/calibration.md Sec. 8.7).

The effect (:class:`gear_rotor_sim.faults.GearMisalignment`) has two parts of different
linearity. The axial component of the mesh force, ``F0 angle cos(theta + phi)`` on both wheels, is
exactly linear in ``(angle cos phi, angle sin phi)``: for a tilt whose separation across the face
stays within the mesh deflection (``rho <= 1``) it is the whole signature. The edge-loaded mesh
(tangent stiffness ``1/sqrt(rho)`` and a smaller centre approach, twice per revolution) appears only
beyond, and grows nonlinearly with the angle. So:

1. amplitude and phase from two basis runs far inside the linear range (tilt 10 urad: a separation
   of 0.1 um across a 20 mm face), weighted linear least squares (as for eccentricity); the axial
   bearing force at the wheel's order 1 and its sidebands carry it;
2. at that phase, the angle on a geometric grid of full simulations (0.25-5 mrad), the features
   interpolated between them, so that the edge-loaded part beyond ``rho = 1`` is in the fit;
3. refinement on full simulations as for every nonlinear effect (``Calibrator._refine``).

Before (a 4-point phase grid, one basis run at 0.5 mrad scaled linearly) the fit rested on a
signature whose mesh part was ten times the independent record's (docs/calibration.md Sec. 8.7).
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

from gear_rotor_sim.faults import GearMisalignment

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.fit import Calibrator, CandidateFit
    from gear_rotor_sim.calibration.residual import ModelFeatures

#: tilt of the linear basis runs, rad (separation 0.1 um across a 20 mm face: full contact)
LINEAR_REF_RAD = 1e-5
#: angles of the full-simulation grid, rad (geometric, x2 to the 5 mrad bound)
ANGLE_GRID_RAD = (0.25e-3, 0.5e-3, 1e-3, 2e-3, 5e-3)


def fit_gear_misalignment(cal: Calibrator, e: GearMisalignment, cur: ModelFeatures) -> CandidateFit | None:
    """Angle and phase of a misaligned wheel's tooth lines on the current model features ``cur``.

    Parameters
    ----------
    cal : Calibrator
        The calibration in progress (its signatures, scoring and grid fits).
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
    phase = float(lin.effect.parameters()["phase_rad"])
    up = e.specs[0].upper
    grid = [g for g in ANGLE_GRID_RAD if g <= up]
    fit = cal._fit_grid_scalar(e.with_parameters(phase_rad=phase), "angle_rad", grid, 0.0, cur, (0.0, up))
    if fit is None:
        return None
    unc = {**fit.uncertainty, "phase_rad": lin.uncertainty.get("phase_rad", float("nan"))}
    return dataclasses.replace(fit, k=2, uncertainty=unc)
