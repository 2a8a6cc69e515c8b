"""Mains pickup ON a shaft order: the picked-up channels' order features left out, the record diagnosed
again (issue 11; docs/calibration.md Sec. 1, "Sensor conventions and faults nobody declared").

Where a mains harmonic ``h f_0`` falls on a shaft order (closer than ``1 / T``: at 3000 rpm every order of
the input shaft is a 50 Hz harmonic) frequency cannot tell the supply from the machine, and on a record of
one constant speed neither can phase (a shaft turning at 50.000 Hz keeps its order's phase to the line's).
What still tells them apart is where the line is: pickup enters through the cables of the channels wired
alike, a mechanical source at that order reaches every channel on its path in the proportions the library's
effects give. So, after the fit:

1. the mains check (``mains_check.on_order_lines``) finds the shaft order at a mains harmonic whose
   components that the fitted model lacks hold at least ``MIN_SHARE`` of the final error together, on the
   channels listed (every library effect was tried on them and none explains them);
2. the fewest channels that hold at least :data:`CONCENTRATION` of what the model lacks at that order over
   all channels (``sum (|d| - |m|)^2 / sigma^2`` where ``|d| > |m|``) are the pickup: a fault under the
   hum, e.g. an unbalance that the hum kept from being claimed, lacks its smaller share on the force
   channels, which keep their order;
3. **one or two such channels** (:data:`MAX_CHANNELS`): on those, every order of that shaft at a harmonic
   of the same ``f_0`` that the record holds at ``MODEL_RATIO`` times the model and ``MIN_RESIDUAL``
   sigma out is left out of the order features (``ResidualSettings.left_out_orders``: infinite variance),
   and the record is diagnosed again from the start (the model runs come from the cache). The other
   channels' features at that order, and every other feature of the channel, are kept: a fault at that
   order (an unbalance, an eccentricity) is then read on the channels the pickup does not reach. After
   that second diagnosis a channel it kept whose order the fitted effects' channel pattern does not
   explain is pickup as well (``mains_pattern.py``): left out, diagnosed a third time (session 21);
4. **more channels** (pickup through every cable; session 20 named it and removed nothing): per channel a
   free amplitude and phase cannot be told from an effect at that order on a record of one constant speed,
   so that order is left out on **every** channel (and the pickup channels' other mains-harmonic orders as
   in 3) and the record diagnosed again; an effect whose content is that order alone cannot be read then.

``issues`` names the channels, orders and shares and says what was left out.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from gear_rotor_sim.calibration.mains_check import on_order_lines
from gear_rotor_sim.calibration.mains_pattern import (
    describe_misfits,
    everywhere_orders,
    mains_orders,
    pattern_misfits,
)

#: pickup on at most this many channels is left out there only (the other channels over-determine an
#: effect's one amplitude and phase at that order); on more, that order is left out on every channel
MAX_CHANNELS = 2
#: ... which hold at least this share of what the model lacks at that order over all channels
CONCENTRATION = 0.9


def leave_out_features(cmp: Any) -> None:
    """Give the order features ``cmp.s.left_out_orders`` (``(channel, shaft, order)``) infinite variance
    (called by ``Comparison`` whenever it computes the measured order features)."""
    for name, shaft, order in getattr(cmp.s, "left_out_orders", ()):
        if name not in cmp.names:
            continue
        c = list(cmp.names).index(name)
        for s, sh in enumerate(cmp.shafts):
            if sh.name == shaft:
                v = cmp.v_order[c][s].copy()
                v[np.asarray(sh.orders) == order] = np.inf
                cmp.v_order[c][s] = v


def _lacking(features: list[Any], shaft: str, order: int) -> dict[str, float]:
    """Per channel, ``(|d| - |m|)^2`` in noise units at one shaft order where the record exceeds the model."""
    out: dict[str, float] = {}
    for ft in features:
        if ft.family == "shaft orders" and ft.shaft == shaft and ft.order == order and ft.model_lacks:
            out[ft.channel] = (abs(ft.measured) - abs(ft.model)) ** 2
    return out


def pickup_orders(
    trace: dict[str, Any], features: list[Any], shafts: list[tuple[str, float]], big_t: float
) -> list[dict[str, Any]]:
    """The on-order mains lines read as pickup (module docstring, steps 1-3).

    Parameters
    ----------
    trace : dict
        The final residual trace.
    features : list
        Every order feature as scored (``residual_trace._order_features``).
    shafts : list of (str, float)
        Each shaft's name and rotation frequency, Hz.
    big_t : float
        The record's length, s.

    Returns
    -------
    list of dict
        ``on_order_lines``'s group and ``pickup`` (the channels), ``concentration``, ``everywhere``
        (more than :data:`MAX_CHANNELS`: that order left out on every channel) and ``left_out``
        (``(channel, shaft, order)`` each).
    """
    rate = dict(shafts)
    out = []
    for g in on_order_lines(trace, shafts, big_t):
        lack = _lacking(features, g["shaft"], g["order"])
        total = sum(lack.values())
        if total <= 0:
            continue
        ranked = sorted(lack, key=lambda c: -lack[c])
        # the fewest channels that hold CONCENTRATION of what the model lacks there
        n = next(
            k for k in range(1, len(ranked) + 1) if sum(lack[c] for c in ranked[:k]) >= CONCENTRATION * total
        )
        chans = ranked[:n]
        held = sum(lack[c] for c in chans)
        left = mains_orders(features, g["shaft"], chans, g["mains"][0], rate, big_t)
        everywhere = n > MAX_CHANNELS
        if everywhere:  # not separable from an effect at that order: the order out on every channel
            left = everywhere_orders(features, g["shaft"], g["order"], left)
        if left:
            out.append(
                {
                    **g,
                    "pickup": chans,
                    "concentration": held / total,
                    "left_out": left,
                    "everywhere": everywhere,
                }
            )
    return out


def describe(found: list[dict[str, Any]]) -> list[str]:
    """``issues`` entries for the orders left out."""
    out = []
    for g in found:
        f0, h = g["mains"]
        feats = ", ".join(f"{c!r} order {k}" for c, _, k in g["left_out"])
        head = (
            f"mains pickup on a shaft order: the {g['shaft']} shaft's order {g['order']} "
            f"({g['frequency_hz']:.3f} Hz, the {f0:g} Hz mains frequency x{h}) unexplained by every library "
            f"effect ({100 * g['share']:.0f} % of the final error) and held by "
            f"{', '.join(repr(c) for c in g['pickup'])}"
        )
        if g.get("everywhere"):
            out.append(
                f"{head} ({100 * g['concentration']:.0f} % of what the model lacks at that order over all "
                f"channels): pickup on more than {MAX_CHANNELS} channels cannot be told from an effect at "
                "that order on a record of one constant speed (each channel's pickup is a free amplitude and "
                f"phase): that order left out on every channel ({feats}) and the record diagnosed again; an "
                "effect whose content is that order alone (an unbalance at the input's order 1) cannot be "
                "read from this record"
            )
            continue
        out.append(
            f"{head} alone ({100 * g['concentration']:.0f} % "
            "of what the model lacks at that order over all channels; a mechanical source reaches every "
            f"channel on its path): the {g['shaft']} shaft's orders at {f0:g} Hz harmonics left out of the "
            f"order features of those channels ({feats}) and the record diagnosed again; the other channels "
            "keep that order"
        )
    return out


def copy_measurement(m: Any) -> Any:
    """``m`` with its own copy of the data and the ``issues`` (the calibration changes both in place)."""
    return dataclasses.replace(m, data=np.array(m.data, copy=True), issues=list(m.issues))


def rerun_without_pickup(cal: Any, result: Any, feats: Any, score: Any) -> Any:
    """The hook at the end of ``Calibrator.run``: ``result`` itself, or the result of the same calibration
    diagnosed again with the pickup's order features left out: after the first diagnosis those of the
    channels that hold it (:func:`pickup_orders`), after the second those of the channels the fitted
    effects' pattern does not explain at that order (``mains_pattern.pattern_misfits``); the third is
    final."""
    from gear_rotor_sim.calibration.residual_trace import _order_features

    cmp = cal.cmp
    if not result.residual_trace or not cmp.shafts:
        return result
    if "order" not in cmp.families or not hasattr(cal, "_init_args"):
        return result
    shafts = [(sh.name, sh.ratio * cmp.speed_hz) for sh in cmp.shafts]
    big_t = cmp.y.shape[0] / cmp.fs
    features = _order_features(cmp, feats, score, 1.0)
    before = tuple(getattr(cal.settings, "left_out_orders", ()))
    groups = None
    if not before:
        found = pickup_orders(result.residual_trace, features, shafts, big_t)
        issues, groups = describe(found), [g for g in found if not g["everywhere"]]
    elif getattr(cal, "pickup_groups", None):
        found = pattern_misfits(features, cal.pickup_groups, before, dict(shafts), big_t)
        issues = describe_misfits(found)
    else:
        return result
    if not found:
        return result
    cal.log("; ".join(issues))
    kw = dict(cal._init_args)
    m = copy_measurement(kw.pop("measurement"))
    m.issues.extend(issues)
    left = before + tuple(x for g in found for x in g["left_out"])
    kw["settings"] = dataclasses.replace(cal.settings, left_out_orders=left)
    kw["fit_settings"] = cal.fit
    again = type(cal)(m, **kw)
    again.pickup_groups = groups  # the groups to check the pattern on after this diagnosis (None: final)
    return again.run()
