"""Tooth wear from the DTE mean when a reference record fixes the mesh stiffness (``--baseline``).

In contact the static transmission error is ``b + F/k`` (half backlash plus the mean mesh deflection
under the static mesh force ``F = T / r_b``); flank wear of depth ``h`` adds the uniform removal and
the mean of the sliding-wear profile, ``1.40 h`` for the paper pair at 25 C (``faults.gear.ToothWear``,
docs/history/calibration_sessions.md Sec. 8.8). Without a reference the two parts of the mean cannot be told
apart: a mesh stiffness scale moves ``F/k`` (about 10 um for the paper pair) exactly where wear moves the
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

The profile's variation is a nuisance (``ToothWear.profile_scale`` in [0, 1], steps of 0.1; the mean
removal ``1.40 h`` does not depend on it, so the depth is still the mean's): how the removal varies
along the path of contact is Archard's linear sliding law here and the lumped model's own profile
there, and the two disagree on the mesh harmonics (Sec. 8.12). With the step-grid lines gone from the
model runs (docs/history/calibration_sessions.md Sec. 8.18) those harmonics decided the confirmation: on the
independent 3000 rpm record (20 um) against the 2000 rpm reference the DTE mean gave 17.7 um and
brought the static chi^2 from 102 to 6, but the full Archard profile raised the order chi^2 from
7 948 to 8 788 (the DTE and ``node5_ay`` carriers: the FE profile cancels much of the second and third
mesh harmonics, the record's do not move): balanced chi^2 8 148 against 7 754 without wear, so the
mean's reading was refused. In contact the response is linear in the transmission error, so the
features at scale ``a`` are ``f0 + a (f1 - f0)`` from the runs at 0 and 1; the best scale on the
balanced chi^2 is taken (one more full run) and the BIC counts it as a second parameter.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np

from gear_rotor_sim.calibration.dte_zero import wear_reading
from gear_rotor_sim.faults import ToothWear

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.fit import Calibrator
    from gear_rotor_sim.calibration.residual import ModelFeatures, Score

#: the healthy model must stay in contact (contact-loss fraction of its run at most this)
MAX_CONTACT_LOSS = 0.01
#: residual of the DTE mean (sigma) beyond which the mean is read as wear, and within which the
#: fitted depth must bring it
Z_TRIGGER = 3.0
#: grid step of the sliding-wear profile's scale (a nuisance in [0, 1], fitted on the full features)
PROFILE_STEP = 0.1


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
    if cal.fit_baseline:
        return None
    return dte_mean_wear(cal, score)


def dte_mean_wear(cal: Calibrator, score: Score) -> tuple[ToothWear, Score, float] | None:
    """The DTE-mean reading of the module docstring on the current baseline-updated model (held from a
    reference, or fitted on the record itself: ``candidates_wear_contact.py``): the trigger, the depth
    from the mean, the profile scale and the BIC confirmation. Same returns as
    :func:`screen_wear_on_dte_mean`."""
    if "static" not in score.chi2:
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
            f"wear from the DTE mean: the mean stands {r0 / s0:.3g} sigma above the baseline-updated "
            f"model, but a depth of {1e6 * h:.3g} um leaves it at {r / s:.3g} sigma: not read as wear"
        )
        return None
    # the profile's amplitude is a nuisance in [0, 1] (module docstring): in contact the response is
    # linear in the transmission error, so the features at scale a are f0 + a (f1 - f0), exactly
    eff, sc = _fit_profile_scale(cal, eff, feats)
    dbic = score.balanced_chi2 - sc.balanced_chi2 - 2.0 * math.log(score.n_total)
    if dbic <= cal.fit.bic_threshold:
        cal.notes.append(
            f"wear from the DTE mean: {1e6 * h:.3g} um matches the mean ({r0 / s0:.3g} -> {r / s:.3g} "
            f"sigma) but the full features get worse (dBIC {dbic:.3g} with the profile scale "
            f"{eff.profile_scale:.2g}): not claimed"
        )
        return None
    # what the depth rests on, for the report (dte_zero.py: a DTE zero offset reads the same)
    cal.wear_mean_reading = wear_reading(eff, score, sc, r0, s0, cal.m.channels[c].column)
    return eff, sc, s0 / slope


def _fit_profile_scale(cal: Calibrator, eff: ToothWear, full: ModelFeatures) -> tuple[ToothWear, Score]:
    """The wear with the profile scale (0..1, steps of ``PROFILE_STEP``) that scores best, and its
    score on a full run. ``full``: features of ``eff`` with the whole Archard profile (scale 1)."""
    uniform = cal._features(cal._raw((dataclasses.replace(eff, profile_scale=0.0),)))
    diff = full.combo(uniform, -1.0)
    grid = np.linspace(0.0, 1.0, round(1.0 / PROFILE_STEP) + 1)
    chi2 = [cal.cmp.score(uniform.combo(diff, float(a))).balanced_chi2 for a in grid]
    a = float(grid[int(np.argmin(chi2))])
    best = dataclasses.replace(eff, profile_scale=a)
    if a == 1.0:
        return best, cal.cmp.score(full)
    feats = uniform if a == 0.0 else cal._features(cal._raw((best,)))
    return best, cal.cmp.score(feats)
