"""Tooth wear from the DTE mean when a reference record fixes the mesh stiffness (``--baseline``).

In contact the static transmission error is ``b + F/k`` (half backlash plus the mean mesh deflection
under the static mesh force ``F = T / r_b``); flank wear of depth ``h`` adds the uniform removal and
the mean of the sliding-wear profile, ``1.40 h`` for the paper pair at 25 C (``faults.gear.ToothWear``,
docs/calibration.md Sec. 8.8). Without a reference the two parts of the mean cannot be told apart:
a mesh stiffness scale moves ``F/k`` (about 10 um for the paper pair) exactly where wear moves the
mean, and the ranking decides between them on the dynamic features. A healthy reference record of
the same machine fixes the mesh stiffness scale (``calibration/baseline.py``), hence ``F/k`` at any
speed and temperature: what the record's DTE mean holds beyond the reference-updated model is then
wear, and the mean gives its depth directly, as the mean axial bearing force gives a temperature
(the static screening of ``fit.py``).

Why the dynamic features do not set the depth there: the wear's dynamic signature (the profile's
mesh harmonics) is the part two models of the same gearbox disagree on. Measured on the independent
3000 rpm record with 20 um of wear against the held 2000 rpm reference: the order features alone
are best at 10 um for either sensor-gain choice, and the ranking fitted 9.94 um (-50 %); the DTE
mean at unit gain gives 18 um and is within 0.4 sigma of the record at 20 um.

Why unit gain for the mean: the fitted per-channel gain is the gain *at the mesh frequency* of the
sensor and the unmodelled transmission path together (``residual.fit_gains``); on that record it
sits at its bound 0.8 on the DTE and the bearing forces. The DTE at frequency zero is a difference
of two encoder angles times the base radius: no transmission path, and an angle scale error of
encoders is far below the model-form tolerance (10 % of the mean) that the static feature carries
anyway. With the bound gain applied, the mean read 30 um (+50 %) on that record.

Rule (applied only with a held reference baseline and where the healthy model's teeth stay in
contact, i.e. where ``1.40 h`` holds): the DTE mean at unit gain must stand more than 3 sigma above
the model's; the depth that matches it (two full runs: the mean is linear in ``h`` in contact) must
bring it within 3 sigma, and the full features at that depth must improve the balanced chi^2 beyond
the BIC threshold. The effect is then found before the rounds (like the screened temperature) and
the dynamic features judge the rest.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from gear_rotor_sim.faults import ToothWear

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.fit import Calibrator
    from gear_rotor_sim.calibration.residual import ModelFeatures, Score

#: the healthy model must stay in contact (contact-loss fraction of its run at most this)
MAX_CONTACT_LOSS = 0.01
#: residual of the DTE mean (sigma) beyond which the mean is read as wear, and within which the
#: fitted depth must bring it
Z_TRIGGER = 3.0


def dte_channel(names: list[str], mesh: int, n_meshes: int) -> int | None:
    """Index of the DTE channel of ``mesh`` (``dte`` on a single mesh, ``mesh<k>_dte`` otherwise)."""
    want = {f"mesh{mesh}_dte"} | ({"dte"} if mesh == 1 and n_meshes == 1 else set())
    for i, n in enumerate(names):
        if n in want:
            return i
    return None


def dte_mean_residual(cal: Calibrator, feats: ModelFeatures, c: int) -> tuple[float, float]:
    """Residual of the DTE mean at unit gain: (measured - model, its standard deviation).

    The variance is the static feature's (``Comparison.score``): the scatter of the per-revolution
    means, the static model-form tolerance on the smaller of the two means, and the fluctuation term.
    """
    cmp = cal.cmp
    m = float(feats.static[c])
    d = float(cmp.d_static[c])
    s2 = (
        float(cmp.v_static[c])
        + (cmp.s.static_tolerance * min(abs(m), abs(d))) ** 2
        + (cmp.s.tolerance * float(cmp.static_fluct[c])) ** 2
    )
    return d - m, math.sqrt(s2)


def screen_wear_on_dte_mean(cal: Calibrator, score: Score) -> tuple[ToothWear, Score, float] | None:
    """Wear depth from the DTE mean against a held reference baseline (module docstring).

    Returns (effect, its full score, standard deviation of the depth) or None; the reasons for None
    that a user needs (the mean is off but no depth fits it) go to ``cal.notes``.
    """
    if cal.fit_baseline or "static" not in score.chi2:
        return None
    cand = next((e for e in cal.candidates if isinstance(e, ToothWear)), None)
    if cand is None or not cal.base_contact_loss <= MAX_CONTACT_LOSS:
        return None
    cfg = cal.runner.cfg
    c = dte_channel(list(cal.cmp.names), cand.mesh, len(cfg.meshes))
    if c is None or not cal.cmp.static_mask[c]:
        return None
    base = cal._features(cal.base_raw)
    r0, s0 = dte_mean_residual(cal, base, c)
    if not r0 > Z_TRIGGER * s0:
        return None
    # the mean is linear in h in contact: slope from one run, then the depth, then its run
    h1 = 10e-6
    f1 = cal._features(cal._raw((cand.with_parameters(wear_depth_m=h1),)))
    slope = (float(f1.static[c]) - float(base.static[c])) / h1
    if not slope > 0:
        return None
    upper = cand.specs[0].upper
    h = float(np.clip(r0 / slope, 0.0, upper))
    eff = cand.with_parameters(wear_depth_m=h)
    feats = cal._features(cal._raw((eff,)))
    r, s = dte_mean_residual(cal, feats, c)
    if abs(r) > Z_TRIGGER * s or h >= 0.99 * upper:
        cal.notes.append(
            f"wear from the DTE mean: the mean stands {r0 / s0:.3g} sigma above the reference-updated "
            f"model, but a depth of {1e6 * h:.3g} um leaves it at {r / s:.3g} sigma: not read as wear"
        )
        return None
    sc = cal.cmp.score(feats)
    dbic = score.balanced_chi2 - sc.balanced_chi2 - math.log(score.n_total)
    if dbic <= cal.fit.bic_threshold:
        cal.notes.append(
            f"wear from the DTE mean: {1e6 * h:.3g} um matches the mean ({r0 / s0:.3g} -> {r / s:.3g} "
            f"sigma) but the full features get worse (dBIC {dbic:.3g}): not claimed"
        )
        return None
    return eff, sc, s0 / slope
