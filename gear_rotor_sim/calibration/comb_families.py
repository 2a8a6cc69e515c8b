"""Is an order-comb improvement broadband (a damaged tooth) or one line family (a rattle component)?

A damaged tooth changes the mesh once per revolution of its wheel for a fraction of a revolution: an
impulsive, shaft-locked event whose order spectrum is a *broad* comb, every sideband ``m z +- j``
(j = 1..6 around each mesh harmonic, and the low orders j = 1..6) raised together (McFadden 1987;
Randall 2011, Sec. 2.2). Where the teeth separate the response also holds components that are not
tied to one tooth: the rattle can lock onto a subharmonic that falls on a shaft order (measured on
the independent lumped gearbox at 8000 rpm, healthy: a 667 Hz component = 5 x the pinion rate, lines
at pinion orders 5, 29 +- 5, 58 +- 5 with SNR^2 up to 9e4, stationary over the record). It survives
the synchronous average like a shaft-locked fault, but it raises *one* family of sidebands
``m z +- j0``. A tooth candidate whose fitted comb gains on that family alone explains the rattle
component, not a tooth; and one whose gain sits in two families explains two such components (a
1x eccentricity raises the family j = 1, a locked rattle component its own). A damaged tooth is
claimed only if its comb gain is significant in at least three of the six families
(:func:`significant_families`).

Where the teeth separate the rattle can lock components onto several shaft orders at once (the
independent lumped gearbox at 8000 rpm with 20 um of tooth wear: pinion comb content in the families
2, 3, 4 and 6, none in family 1; a pinion tooth of depth 0.16 fitted it, comb gains 2.1e3-5.8e3 in
those four families and 6 in family 1). A damaged tooth is a short event once per revolution of its
wheel: its order spectrum is flat over the first few orders (``|c_j| ~ |c_1|`` for ``j << z``), so
its fundamental family ``j = 1`` (order 1 and ``m z +- 1``) gains with the others. There a tooth
candidate's gain in family :data:`FUNDAMENTAL_FAMILY` must be significant and at least
:data:`FUNDAMENTAL_SHARE` of the median gain of its other families (:func:`fundamental_present`;
``fit.py``, with the rattle rules of ``features_rattle.py``). Measured ratios (family 1 / median of
the others) on the lumped records at 8000 rpm: damaged pinion tooth 0.50, damaged gear tooth 1.09;
worn teeth 0.11 (1 s record) and 0.002 (2 s record).

The family of a shaft order ``o`` of a wheel with ``z`` teeth is ``j = min(o mod z, z - o mod z)``,
its distance to the nearest mesh harmonic (``j = o`` for the low orders); carriers (``j = 0``) are
not part of the comb.
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: the sideband family of a once-per-revolution event's fundamental (order 1 and ``m z +- 1``)
FUNDAMENTAL_FAMILY = 1
#: smallest gain of the fundamental family relative to the median gain of the other families.
#: A choice made after measuring 0.50-1.27 for damaged teeth and 0.002-0.11 for worn teeth (FE and
#: independent records, docs/history/calibration_sessions.md Sec. 8.11): a separating value, not a derived
#: one.
FUNDAMENTAL_SHARE = 0.25


def sideband_family(orders: np.ndarray, teeth: int) -> np.ndarray:
    """Distance of each order to the nearest multiple of ``teeth`` (0 for the mesh carriers)."""
    r = np.mod(orders, teeth)
    return np.minimum(r, teeth - r)


def comb_chi2_by_order(cmp: Any, feats: Any, score: Any, s: int) -> np.ndarray:
    """chi^2 per order of shaft ``s`` summed over channels (gains, transfer slopes and time shift of
    ``score``), the per-order terms of ``Comparison.comb_chi2``."""
    G = np.column_stack([score.gains, score.slopes]) if score.slopes.size else score.gains
    feats = cmp.apply_shift(feats, score.tau)
    out = np.zeros(cmp.shafts[s].orders.size)
    for c in range(cmp.nc):
        mg = cmp.order_gain(G, c, s) * feats.order[c][s]
        r = cmp.d_order[c][s] - mg
        out += 2.0 * np.abs(r) ** 2 / cmp.order_sigma2(c, s, mg)
    return out


def comb_gain_by_family(
    cmp: Any, before: tuple[Any, Any], after: tuple[Any, Any], s: int
) -> dict[int, float]:
    """chi^2 gain (before - after) on the non-carrier orders of shaft ``s``, per sideband family j.

    ``before`` and ``after`` are ``(features, score)`` pairs.
    """
    sh = cmp.shafts[s]
    if not sh.teeth:
        return {}
    gain = comb_chi2_by_order(cmp, *before, s) - comb_chi2_by_order(cmp, *after, s)
    fam = sideband_family(sh.orders, sh.teeth)
    return {int(j): float(np.sum(gain[fam == j])) for j in np.unique(fam) if j > 0}


def significant_families(families: dict[int, float], floor: float, share: float) -> list[int]:
    """Families whose gain exceeds ``floor`` (the significance threshold of one feature group) and
    ``share`` times the largest family gain, best first."""
    if not families:
        return []
    best = max(families.values())
    keep = [j for j, v in families.items() if v > floor and v >= share * best]
    return sorted(keep, key=lambda j: -families[j])


def fundamental_present(
    families: dict[int, float], significant: list[int], share: float = FUNDAMENTAL_SHARE
) -> bool:
    """Whether the fundamental family gains with the others: significant and at least ``share`` of the
    median gain of the other families (a short event's order spectrum is flat over the first orders,
    so the ratio is near 1 for a damaged tooth; ``share`` leaves a factor 4 for the path's variation
    over the families)."""
    if FUNDAMENTAL_FAMILY not in significant:
        return False
    # a family left out of the features (a locked component, features_rattle.py) gains exactly 0
    others = [v for j, v in families.items() if j != FUNDAMENTAL_FAMILY and v != 0.0]
    return not others or families[FUNDAMENTAL_FAMILY] >= share * float(np.median(others))


def narrow_comb_reason(
    families: dict[int, float], floor: float, share: float, min_families: int, fundamental: bool
) -> str:
    """Why a comb gain per family is not a damaged tooth's (empty if it is): significant in fewer than
    ``min_families`` families (:func:`significant_families` with ``floor`` and ``share``), or, with
    ``fundamental`` (where the teeth separate), without its fundamental family
    (:func:`fundamental_present`)."""
    if not families:
        return ""
    sig = significant_families(families, floor, share)
    if len(sig) < min_families:
        shown = ", ".join(
            f"m z +- {j}: {families[j]:.3g}" for j in sorted(families, key=lambda j: -families[j])
        )
        return (
            f"its comb gain is significant in {len(sig)} sideband "
            f"famil{'y' if len(sig) == 1 else 'ies'} only "
            f"({shown}): components at one or two frequencies (a rattle subharmonic, a 1x eccentricity), "
            "not the broad comb of a damaged tooth"
        )
    if fundamental and not fundamental_present(families, sig):
        return (
            f"its comb gain in the first family (order 1, m z +- 1) is "
            f"{families.get(FUNDAMENTAL_FAMILY, 0.0):.3g}, less than {FUNDAMENTAL_SHARE:g} of the median "
            "of its other families: a once-per-revolution event raises its fundamental with its harmonics"
        )
    return ""
