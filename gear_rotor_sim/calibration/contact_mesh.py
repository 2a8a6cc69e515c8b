"""The FE model's teeth separate where the record's stay in contact: the mesh stiffness set read from the DTE
mean before the search (issue 11: the baseline's plausibility; docs/calibration.md Sec. 8.3; history Sec.
8.77).

Physics. In continuous contact the DTE mean is the static deflection ``b + F / k`` (Eqs 13-18); where the
teeth separate it is set by the share of the time spent in free flight and on either flank, not by ``F / k``
(Sec. 8.3, "Channel means where the teeth separate"). So the DTE mean tells the regime: at 7538 rpm / 34 C
(blind05 of the blind set's first draw, the generator's teeth in contact) the nominal FE model's teeth
separate 29 % of the time and its DTE mean stands 14.6-15.2 sigmas off the record's on the faulty record and
its two healthy twins; with the mesh stiffness x1.6 the FE mesh mode moves from 5289 to 6204 Hz (the
generator's is at 6420 Hz), the contact loss falls to 0.14, the DTE mean matches (static family 57.6 ->
0.084 per mean on a healthy twin) and the healthy twin's error falls 4.48 -> 0.727
(``benchmarks/reference_mesh_scan.py``). Left to the rounds, the nominal rattling model was the reference of
every signature and a damaged pinion tooth 27 (depth 0.426) was read at tooth 24, depth 0.051.

Rule (:func:`contact_mesh_screen`), without a reference, before the search: where the healthy model's teeth
separate (contact loss above 1 %) and the record's DTE mean stands more than :data:`Z_TRIGGER` static sigmas
off the model's, the mesh stiffness scale is scored on full runs at :data:`GRID` (the sensor gains and
slopes refitted on each); among the scales that bring the DTE mean within 3 sigma the one of least whole
chi^2 is taken as a baseline update if it beats the BIC threshold (one parameter). The rounds then judge
every effect against that machine, and offer the mesh set again as usual. Nothing happens where the model
stays in contact (the wear and tooth records of the table: their DTE means are read by the wear rules) or
where the mean agrees.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from gear_rotor_sim.calibration.axial_zero import static_z
from gear_rotor_sim.calibration.candidates_wear_reference import dte_channel

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.fit import Calibrator
    from gear_rotor_sim.calibration.fit_types import FoundEffect
    from gear_rotor_sim.calibration.residual import Score

#: the healthy model's teeth separate: its contact-loss fraction above this
MIN_CONTACT_LOSS = 0.01
#: the record's DTE mean stands this many static sigmas off the model's
Z_TRIGGER = 5.0
#: the scale must bring the DTE mean within this many sigmas
Z_WITHIN = 3.0
#: mesh stiffness scales tried (within MeshStiffnessDamping's 0.3-2)
GRID = (0.6, 0.8, 1.25, 1.6, 2.0)


def applies(contact_loss: float, dte_z: float) -> bool:
    """Whether the screen runs: the healthy model's teeth separate and the record's DTE mean stands off."""
    return contact_loss > MIN_CONTACT_LOSS and abs(dte_z) > Z_TRIGGER


def pick_scale(trials: list[tuple[float, float, float]]) -> tuple[float, float] | None:
    """``(scale, chi2)`` of least whole chi^2 among the ``(scale, DTE mean z, chi2)`` trials whose DTE mean
    lies within :data:`Z_WITHIN` sigmas; None if none does."""
    ok = [(s, chi2) for s, z, chi2 in trials if abs(z) <= Z_WITHIN]
    return min(ok, key=lambda t: t[1]) if ok else None


def contact_mesh_screen(cal: Calibrator, score: Score) -> list[FoundEffect]:
    """The mesh set taken before the search where the model rattles and the record's DTE mean says contact
    (module docstring); ``[]`` where the rule does not apply or no scale qualifies. Joins the set to the
    calibrator's baseline."""
    from gear_rotor_sim.calibration.fit_types import FoundEffect, _logistic
    from gear_rotor_sim.faults import MeshStiffnessDamping

    if not cal.fit_baseline or "static" not in cal.cmp.families:
        return []
    c = dte_channel(list(cal.cmp.names), 1, len(cal.runner.cfg.meshes))
    if c is None or not cal.cmp.static_mask[c]:
        return []
    z0 = static_z(cal, score, c)
    if not applies(float(cal.base_contact_loss), z0):
        return []
    runs = {}
    trials, tried = [], []
    for s in GRID:
        e = MeshStiffnessDamping(stiffness_scale=s)
        feats = cal._features(cal._raw((e,)))
        cal._refit_transfer(feats)
        runs[s] = cal.cmp.score(feats)
        z = static_z(cal, runs[s], c)
        trials.append((s, z, runs[s].balanced_chi2))
        tried.append(f"x{s:g}: DTE mean {z:+.3g} sigma, contact loss {cal.runner.last_contact_loss:.3g}")
    picked = pick_scale(trials)
    best = None if picked is None else (MeshStiffnessDamping(stiffness_scale=picked[0]), runs[picked[0]])
    # the transfer slopes back on the nominal model
    cal._refit_transfer(cal._features(cal.base_raw))
    head = (
        f"contact screen: the healthy model's teeth separate {float(cal.base_contact_loss):.1%} of the "
        f"time and the record's DTE mean stands {z0:+.3g} sigma off ({'; '.join(tried)})"
    )
    if best is None:
        cal.notes.append(head + ": no mesh scale brings the mean within 3 sigma; the rounds go on nominally")
        return []
    e, sc = best
    dbic = score.balanced_chi2 - sc.balanced_chi2 - math.log(max(score.n_total, 2))
    if dbic <= cal.fit.bic_threshold:
        cal.notes.append(head + f": x{e.stiffness_scale:g} does not beat the BIC threshold ({dbic:.3g})")
        return []
    cal.notes.append(head + f": mesh x{e.stiffness_scale:g} taken as the baseline before the search")
    cal.log(head)
    cal._join_baseline(e)
    cal._refit_transfer(cal._features(cal.base_raw))
    expl = (score.balanced_chi2 - sc.balanced_chi2) / max(score.balanced_chi2 - score.n_total, 1e-12)
    return [
        FoundEffect(
            e.name,
            e.label,
            e.parameters(),
            {},
            float(_logistic(dbic / 2)),
            float(dbic),
            float(expl),
            score.error,
            sc.error,
            e,
            "baseline",
        )
    ]
