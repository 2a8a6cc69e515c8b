"""Which channel means a baseline scale can move (issue 11: a radial force sensor's zero; docs/calibration.md
Sec. 1, "Sensor conventions and faults nobody declared"; history Sec. 8.58).

A baseline update (the mesh or bearing stiffness and damping scales, Sec. 8.1) is not taken when it moves a
channel mean that is already more than 3 sigma off further away (``search_rounds.mean_moved_further``; a
stiffer mesh cannot explain a DTE mean that grew, the worn records). That test is only physical for means the
scales act on: the DTE's (``b + F / k``), a displacement's, an axial force's (thermal, with the axial bearing
stiffness, which the bearing set leaves alone). A **radial bearing force's mean is an equilibrium load**: each
shaft sits on two bearings, so its radial reactions are the lever-rule shares of the mesh force ``T / r_b``
and the weights whatever the stiffness and damping (``load_check.py``, Sec. 2 "Load check"). Its static
residual ``d - g m`` (``Comparison.score``) holds the sensor's gain and zero and the order gain ``g`` fitted
on the mesh carriers, which on the independent records sits at its 0.8 bound (Sec. 8.22): on the saved
benchmark reports at 1500-6000 rpm every radial mean reads 1.98-2.85 sigma off before the fit, and a zero 5 %
of the mean off one of them (-67 N on ``bearing2_fy`` of the pinion-tooth record) put it at 3.24-3.26 sigma.
The bearing update moved it further (by how much the report does not say) and was not taken, the mesh set took
the round instead, and the damaged pinion tooth was lost (history Secs. 8.53, 8.58). The radial means are
therefore left out of that test (:func:`baseline_judged_means`, applied by :func:`moved_judged_mean` where the
rule is read); they still enter the static family and every other rule as before. Where that decides (the rule
would have fired on a radial mean alone), a note names the channel: its mean is off by the sensor's zero or
gain, or by the load (Sec. 2, "Load check").
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from gear_rotor_sim.calibration.features_bearing import RADIAL_DIRECTIONS

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.residual import Score


def is_equilibrium_load(quantity: str, direction: str | None) -> bool:
    """Whether a channel's mean is a radial bearing reaction (set by equilibrium, not by a stiffness)."""
    return quantity == "bearing_force" and direction in RADIAL_DIRECTIONS


def baseline_judged_means(cal: Any) -> np.ndarray | None:
    """Boolean mask over the static features (``Score.static_r``, the channels of ``cmp.static_mask``)
    of the means a baseline scale can move: every static channel but the radial bearing forces. None
    (every mean judged) for a calibrator without a comparison or channels (the scripted rounds of the
    tests)."""
    cmp, m = getattr(cal, "cmp", None), getattr(cal, "m", None)
    if cmp is None or m is None:
        return None
    chans = m.channels
    idx = np.flatnonzero(cmp.static_mask)
    return np.array([not is_equilibrium_load(chans[k].quantity, chans[k].direction) for k in idx], dtype=bool)


def moved_judged_mean(cal: Any, before: Score, after: Score, label: str) -> float | None:
    """``search_rounds.mean_moved_further`` on the means a baseline scale can move
    (:func:`baseline_judged_means`).

    Where only a radial bearing reaction's mean (more than 3 sigma off) moved further, the update is no
    longer held back by it and ``cal.notes`` gets a line naming the channel (once per channel and set).
    """
    from gear_rotor_sim.calibration.search_rounds import mean_moved_further

    judged = baseline_judged_means(cal)
    off = mean_moved_further(before, after, judged)
    if off is not None or judged is None or mean_moved_further(before, after) is None:
        return off
    idx = np.flatnonzero(cal.cmp.static_mask)
    rb, ra = np.abs(before.static_r), np.abs(after.static_r)
    for i in np.flatnonzero(~judged & (rb > 3.0) & (ra > rb)):
        col = cal.m.channels[idx[i]].column
        head = f"{label}: not held back by {col!r}'s mean"
        if any(n.startswith(head) for n in cal.notes):
            continue
        cal.notes.append(
            f"{head}, which it moves further away ({rb[i]:.3g} -> {ra[i]:.3g} sigma): a radial bearing "
            "reaction is an equilibrium load that no stiffness or damping scale moves; that mean is off by "
            "the sensor's zero or gain, or by the load"
        )
    return None
