"""Tooth wear from the DTE mean without a reference record, on the record's own baseline-updated model
(docs/history/calibration_sessions.md Sec. 8.32).

With a reference (``--baseline``) the DTE-mean reading of ``candidates_wear_reference.py`` runs on the
held baseline before any effect is sought. Without one the baseline sets (bearing and mesh stiffness and
damping) are fitted on the record in the rounds, in competition with the effects, and the wear was left
to the ranking, which judges it on every feature at once. Where the teeth stay in contact that fails in
two ways, both traced on the independent simulator's worn records at 3000 rpm (Sec. 8.32):

- the ranking's wear carries the library's Archard profile at full scale, whose mesh harmonics are the
  part two models of the same gearbox disagree on (the FE profile's second mesh harmonic is 0.122 h,
  the lumped gearbox's 0.069 h): on the 32 um record the basis run at 37.5 um explains 21 % of the
  excess after the bearing update, below the 25 % share, and nothing is claimed;
- the channel means enter its score through the sensor gain fitted at the mesh frequency (at its bound
  0.8 on the DTE there: the carriers' model-form misfit), so the static family reads the DTE mean 25 %
  low in the model and prefers a deeper wear (the 12 um record: verified at 20.7 um, +72 %).

The reading from the mean does neither: it compares the DTE mean at unit gain (no transmission path at
frequency zero, ``candidates_wear_reference.py``), takes the depth from it and the profile's amplitude
as a nuisance, and confirms it on the full features. Without a reference it runs where the baseline
sets are in force, i.e. right after each baseline update of the rounds while no effect has been
accepted (an effect accepted first has taken the round's evidence; its own signature may move the
mean). Nothing else changes: the trigger (the unit-gain DTE mean more than 3 standard deviations of the
static feature above the model), the depth, the BIC threshold and the consistency rules are the
reference's.

Why the mean is readable without a reference record. In contact the DTE mean is ``b + F/k + 1.40 h``;
the static feature's model-form tolerance (10 % of the mean, 4.5 um for the paper pair) already covers a
mesh stiffness 50 % off (``F/k`` = 9.2 um); the stiffness is also fitted by the mesh set on the dynamic
features before the screen, and a baseline scale may not move a mean that is off further away (Sec.
8.8). Measured at the nominal FE model on the 27 table and 41 held-out independent records: every
record without wear has its DTE mean between 2.1 sigma below and 0.1 sigma below the model's (the FE
model's softer mesh puts its mean 1.5-3 um above the lumped gearbox's at 25 C), the worn ones +2.7
(12 um), +5.1 and +5.3 (20 um), +9.4 (32 um). What it assumes: a DC-coupled DTE (two encoders), and
that wear is the only library effect that moves the DTE mean in contact beyond the tolerance apart from
the temperature, which the static screening fits first from the axial bearing force.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import TYPE_CHECKING

from gear_rotor_sim.calibration.candidates_wear_reference import dte_mean_wear
from gear_rotor_sim.faults import ToothWear

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.fit import Calibrator, CandidateFit
    from gear_rotor_sim.calibration.residual import Score
    from gear_rotor_sim.faults import Effect


def screen_wear_after_baseline_update(cal: Calibrator, score: Score) -> tuple[ToothWear, Score, float] | None:
    """Wear from the DTE mean on the model whose baseline was just updated on this record.

    Only without a held reference (with one the reading ran before the rounds). Returns (effect, its
    full score, standard deviation of the depth) or None, as
    :func:`~gear_rotor_sim.calibration.candidates_wear_reference.screen_wear_on_dte_mean`.
    """
    if not cal.fit_baseline:
        return None
    return dte_mean_wear(cal, score)


def wear_depth_from_mean_in_round(
    cal: Calibrator, fit: CandidateFit, accepted: Sequence[Effect]
) -> CandidateFit | None:
    """The ranked wear candidate ``fit`` at the DTE mean's depth, where the mean reads one.

    Without a held reference the reading above runs after a baseline update; a worn record whose wear
    leads a round before any baseline set is taken (round 0) was left to the ranking's depth, which the
    dynamic features set. Where the worn machine's teeth separate and the healthy model's do not, those
    features are the separation response, whose onset the model's own mesh stiffness and damping set:
    on the independent 6000 rpm record with 20 um of wear (the lumped teeth separating 40 % of the time)
    the nominal FE model separates only from about 22 um and the ranking verified 27.6 um (+38 %), while
    the DTE mean at unit gain stands 5.06 sd above the model and reads 15.7 um
    (docs/history/calibration_sessions.md Sec. 8.34). So the reading runs wherever a wear candidate is
    verified while no effect has been accepted (``accepted`` empty; the screened temperature is part of
    the model) and the healthy model stays in contact: the same trigger, depth, profile-scale nuisance and BIC
    confirmation as after a baseline update. Returns the verified fit (a full run at that depth; two
    parameters: depth and profile scale) or None (no reading: the ranking's refinement goes on).
    """
    if not cal.fit_baseline or accepted or not isinstance(fit.effect, ToothWear):
        return None
    ranked = float(fit.effect.wear_depth_m)
    hit = dte_mean_wear(cal, cal.cmp.score(cal._cur_feat))
    if hit is None:
        return None
    eff, _, sd = hit
    raw = cal._raw((eff,))
    feats = cal._full_features(raw, eff)
    cal.notes.append(
        f"tooth_wear: depth {1e6 * eff.wear_depth_m:.3g} um from the DTE mean (profile scale "
        f"{eff.profile_scale:.2g}; the ranking's basis runs gave {1e6 * ranked:.3g} um), verified in its "
        "round (candidates_wear_contact.py)"
    )
    unc = {"wear_depth_m": sd}
    return dataclasses.replace(
        fit, effect=eff, raw=raw, score=cal.cmp.score(feats), k=2, uncertainty=unc, feats=feats
    )
