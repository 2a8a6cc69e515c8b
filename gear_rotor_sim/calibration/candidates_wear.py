"""Mesh-periodic candidates (tooth wear, gear misalignment): what must carry their evidence
(docs/history/calibration_sessions.md Sec. 8.8).

**Periodic effects need periodic evidence.** Wear and misalignment act on every mesh cycle or shaft
revolution alike: their response is synchronous with the shafts and appears in the order features
and the channel means. Where the envelope family is taken of the whole signal (a healthy model that
is not periodic at the operating point), its lines around the mesh harmonics are the mesh modulation
that a model gets most wrong; a candidate whose improvement sits there while its orders get worse
explains model-form content, not itself (the healthy 3000 rpm / 225 C record: wear 2.2 um claimed,
envelope chi^2 1.46e6 -> 1.08e6, order chi^2 1.113e5 -> 1.124e5). Such a candidate must gain on the
synchronous families (order, static) beyond the BIC penalty and by at least ``min_explained`` of its
whole gain.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from gear_rotor_sim.faults import GearMisalignment, ToothWear

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.fit import Calibrator, CandidateFit
    from gear_rotor_sim.calibration.residual import Score

#: the families whose features are synchronous with the shafts
SYNCHRONOUS_FAMILIES = ("order", "static")


def synchronous_gain(before: Score, after: Score) -> tuple[float, float]:
    """Gain of the balanced chi^2 on the synchronous families, and the whole gain.

    The weights are those of :attr:`Score.balanced_chi2` (spectral families balanced to equal counts,
    the static family one per mean).
    """
    fams = [f for f in before.chi2 if before.n[f] > 0 and f != "static"]
    ntot = sum(before.n[f] for f in fams)
    w = {f: ntot / (len(fams) * before.n[f]) for f in fams}
    w["static"] = 1.0
    sync = sum(w[f] * (before.chi2[f] - after.chi2.get(f, 0.0)) for f in SYNCHRONOUS_FAMILIES if f in w)
    return float(sync), float(before.balanced_chi2 - after.balanced_chi2)


def periodic_signature_present(cal: Calibrator, fit: CandidateFit, cur: Score) -> bool:
    """Whether a wear or misalignment candidate's gain is carried by the synchronous features.

    Notes the refusal in ``cal.notes``. Other candidates pass.
    """
    if not isinstance(fit.effect, ToothWear | GearMisalignment):
        return True
    sync, whole = synchronous_gain(cur, fit.score)
    thr = cal.fit.bic_threshold + fit.k * math.log(cur.n_total)
    if sync > thr and sync >= cal.fit.min_explained * whole:
        return True
    cal.notes.append(
        f"{fit.effect.label}: not claimed, its gain on the synchronous features (orders, channel means) "
        f"is {sync:.3g} of {whole:.3g}: a mesh-periodic effect must explain periodic content, not the "
        "envelope of a non-periodic response"
    )
    return False


def wear_static_inconsistency(fit: CandidateFit, cur: Score) -> str:
    """Why a tooth-wear fit contradicts the channel means ('' if it does not).

    Wear removes flank material: in contact the DTE mean grows by the uniform removal plus the mean
    of the sliding-wear profile (faults.gear.mesh_wear_profile). That static offset is wear's
    model-robust signature; a wear depth whose channel means fit worse than the unworn model's
    explains dynamic model-form content, not wear (issue 11 item 3).
    """
    if not isinstance(fit.effect, ToothWear) or "static" not in cur.chi2 or "static" not in fit.score.chi2:
        return ""
    before, after = cur.chi2["static"], fit.score.chi2["static"]
    n_s = max(cur.n["static"], 1)
    if before <= 9.0 * n_s + 25.0:
        return (
            f"the channel means agree with the unworn model (static chi2 {before:.3g} for {n_s} means): "
            "no static offset for wear to explain"
        )
    if after <= before:
        return ""
    return (
        f"its channel means fit worse than without it (static chi2 {before:.3g} -> {after:.3g}): wear "
        "must move the DTE mean toward the measured one"
    )
