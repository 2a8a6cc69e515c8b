"""The share of the excess residual a candidate must explain: a damaged tooth's own threshold
(docs/history/calibration_sessions.md Sec. 8.69; the parsimony rule of ``fit.py`` step 4, Sec. 8.22 cause D).

A candidate is accepted only if it explains at least ``FitSettings.min_explained`` of the excess residual
``chi2 - N`` of its round (or of its own family's excess, ``CandidateFit.comb_explained``). The excess holds
the model-form residual of the healthy model, which at 3000 rpm is mostly the mesh harmonics and their
sidebands of the accelerations and bearing forces; a shallow tooth's signature is small against it. A
damaged tooth is judged against ``FitSettings.min_explained_tooth``, every other candidate against
``min_explained``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from gear_rotor_sim.faults import Effect, ToothDamage

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.fit import Calibrator


def min_share(cal: Calibrator, effect: Effect) -> float:
    """The share of the excess residual ``effect`` must explain to be accepted.

    Parameters
    ----------
    cal : Calibrator
        The calibration (its ``fit`` settings).
    effect : Effect
        The candidate's effect.

    Returns
    -------
    float
        ``cal.fit.min_explained_tooth`` for a damaged tooth, ``cal.fit.min_explained`` otherwise.
    """
    if isinstance(effect, ToothDamage):
        return float(cal.fit.min_explained_tooth)
    return float(cal.fit.min_explained)
