"""Tooth wear judged on the channel means where an off mean holds the baseline sets back (issue 11;
docs/history/calibration_sessions.md Sec. 8.78).

Wear removes flank material, and in contact the DTE mean grows by the removal (``1.40 h`` in the FE
model; ``candidates_wear.wear_static_inconsistency``): the channel means are wear's model-robust
evidence. A baseline stiffness or damping scale must not move a channel mean that is significantly off
further away (``search_rounds.mean_moved_further``, issue 11 item 3), so while the DTE mean is off by
the wear, no baseline set is taken. At an operating point where the nominal model's order features
misfit the record (2000-2500 rpm: the healthy twins' order family reads 35-41 before their bearing
baseline update and 1.5-1.8 after), that misfit is most of the record's excess, and the share rule
(``FitSettings.min_explained``: a quarter of the excess) weighs the wear against content that the
blocked baseline set would take once the mean is explained. Measured on the blind record of tooth
wear 23.3 um at 2467 rpm / 81 C (blind set 1, ``blind11``) before this rule: the bearing set
(Delta BIC 3.0e5) and the mesh set (1.2e5) refused for moving the DTE mean (10.1 sigma off) further,
the wear (24.7 um from the basis runs, Delta BIC 8.0e4) skipped at 0.243 of the excess (< 0.25),
nothing claimed, the error 13.8 -> 13.8 against the healthy twins' 1.5 after their baseline update.

Rule (:func:`static_share`, :func:`judged_on_means`): in a round where a baseline set was refused
for moving an off channel mean further, a tooth-wear candidate is judged on the family that holds the
evidence the set waits for, where that deadlock holds: its share of the whole record's excess below
``min_explained`` and its basis runs removing at least ``min_explained`` of the static family's excess
(the channel means' chi^2 above their count). Then that share counts as its share, and the refused set
is no rival for it (it does not explain the means, it moves them further); after its full simulation
the verified share of the means is what counts. A wear that passes on the whole record's share is
judged as before (measured: the table's contact wear at 3000 rpm, whose mesh set is held back by the
DTE mean and whose wear explains 48 % of the excess, took the wear one round earlier with the mesh set
no rival, then a bearing stiffness x1.31 for x0.464 and an error after of 4.31 for 3.68). The wear's
other rules stay: its verification from the DTE mean (``candidates_wear_contact``), the Delta BIC on
the whole record, the static consistency, the runner-up among the other candidates. Assumes the off
mean is the one the wear moves (the DTE's, in contact); a wear that does not remove a quarter of the
means' excess gains nothing from the rule.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from gear_rotor_sim.faults import ToothWear

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.residual import Score


def static_share(before: Score, after: Score) -> float:
    """Share of the static family's excess chi^2 (above one per mean) that ``after`` removes.

    0 where either score has no static family or ``before``'s means are within their noise.
    """
    if "static" not in before.chi2 or "static" not in after.chi2:
        return 0.0
    excess = float(before.chi2["static"]) - max(int(before.n.get("static", 0)), 0)
    if not excess > 0:
        return 0.0
    return (float(before.chi2["static"]) - float(after.chi2["static"])) / excess


def judged_on_means(
    effect: Any, blocked: bool, share_whole: float, share_of_means: float, min_share: float
) -> bool:
    """Whether ``effect`` is judged on the channel means: a tooth wear whose share of the whole record's
    excess (``share_whole``) is below ``min_share`` while it removes at least ``min_share`` of the static
    family's excess (``share_of_means``, :func:`static_share`), in a round where a baseline set was refused
    for moving an off channel mean further (``blocked``). A wear that passes on the whole record's share
    is judged as before, against every rival."""
    return bool(blocked) and isinstance(effect, ToothWear) and share_whole < min_share <= share_of_means
