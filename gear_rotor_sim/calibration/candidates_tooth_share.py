"""The share of the excess residual a damaged tooth must explain without a reference, teeth in contact
(docs/history/calibration_sessions.md Sec. 8.69; the parsimony rule of ``fit.py`` step 4, Sec. 8.22 cause D).

A candidate is accepted only if it explains at least ``FitSettings.min_explained`` (0.25) of the excess
residual ``chi2 - N`` of its round, or of its own family's excess (``CandidateFit.comb_explained``).
Without a reference that excess is mostly the healthy model's own misfit (its error after the baseline
sets is 4-6 noise units on the 3000 rpm records, against 1.5-2.3 with a reference): on the held-out
x0.6 gear tooth (tooth 31, depth 0.24, 3000 rpm) the tooth's ranking candidate explained 0.164 of it
(Delta BIC 6782) and was never examined, while at its DTE-comb depth 0.264 it explains 0.220 on a full
run and halves the error (19.39 -> 4.43). So a damaged tooth is judged against
``FitSettings.min_explained_tooth`` (0.10) where the record's own baseline is fitted (no reference) and
the healthy model's teeth stay in contact; everywhere else against ``min_explained``.

Why a tooth and not every candidate: a tooth must also pass the checks of its own signature, which
every other candidate lacks: its comb gain on its own wheel's shaft, a broad sideband comb in at least
``min_comb_families`` families (``comb_families.py``), its DTE-comb depth confirmed on the whole
record (``candidates_tooth_dte.confirmed_or_fallback``) and the Delta BIC against the runner-up. On
the healthy 1500 rpm record those checks, not the share, refused tooth candidates that explained 0.94
of the excess. The margin (Sec. 8.69): the largest share of a tooth candidate with Delta BIC above
the threshold and below 0.25 on the healthy records of the table and of the held-out set without a
reference, against 0.10.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from gear_rotor_sim.calibration.candidates_tooth import ratio_depth_in_contact
from gear_rotor_sim.faults import Effect, ToothDamage

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.fit import Calibrator


def min_share(cal: Calibrator, effect: Effect) -> float:
    """The share of the excess residual ``effect`` must explain to be accepted.

    Parameters
    ----------
    cal : Calibrator
        The calibration (its ``fit`` settings, whether its baseline is fitted on the record, the
        healthy model's contact loss).
    effect : Effect
        The candidate's effect.

    Returns
    -------
    float
        ``cal.fit.min_explained_tooth`` for a damaged tooth without a reference where the teeth stay in
        contact, ``cal.fit.min_explained`` otherwise.
    """
    if isinstance(effect, ToothDamage) and cal.fit_baseline and ratio_depth_in_contact(cal):
        return float(cal.fit.min_explained_tooth)
    return float(cal.fit.min_explained)
