"""Mains pickup on a shaft order on more channels than hold it: the fitted effects' channel pattern decides
(issue 11; docs/calibration.md Sec. 1, "Sensor conventions and faults nobody declared"; history Sec. 8.59).

``mains_repair.py`` leaves out the order features of the channels that hold most of what the model lacks at
a mains-harmonic shaft order and diagnoses the record again. Pickup through cables can reach more channels
than those: a weaker hum on a third channel, under a fault at that order (an unbalance at the input's order
1 at 3000 rpm), is then read as part of the fault (+56 % on ``mains_50hz_split3__unbalance``, Sec. 8.54).
What separates the two is the channel pattern: a library effect reaches every channel in the proportions
and phases of the model's transfer at that order, pickup adds a free amplitude and phase on its channel.
The second diagnosis is the fit of "library effects + free pickup on the channels left out"; on a channel it
kept, content at that order that the record holds at ``MODEL_RATIO`` times the fitted model and
``MIN_RESIDUAL`` noise sigmas out (the mains check's own thresholds) is not explained by the effects'
pattern fitted on the other channels: pickup as well. Its orders at mains harmonics that stand out are
left out too (:func:`mains_orders`) and the record is diagnosed a third time (at most: the third
diagnosis is final).

On a record of one constant speed nothing else separates them (the generator's 3000 rpm records read
2999.99998 +- 5.6e-5 rpm: a 50.000 Hz line and the order drift apart by 4e-6 rad over 2 s, Sec. 8.54);
where pickup reaches every channel the effect has at that order, that order is left out everywhere and an
effect there is read from the features that stay (``issues`` says so).
"""

from __future__ import annotations

from typing import Any

from gear_rotor_sim.calibration.mains_check import MAX_HARMONIC, MIN_RESIDUAL, MODEL_RATIO


def mains_orders(
    features: list[Any], shaft: str, channels: list[str], f0: float, rate: dict[str, float], big_t: float
) -> list[tuple[str, str, int]]:
    """Every order of ``shaft`` on ``channels`` at a harmonic of ``f0`` (within ``1 / big_t``) that the
    record holds at :data:`MODEL_RATIO` times the model and :data:`MIN_RESIDUAL` sigmas out.

    Returns
    -------
    list of (str, str, int)
        ``(channel, shaft, order)``, sorted.
    """
    left = []
    for ft in features:
        if ft.family != "shaft orders" or ft.shaft != shaft or ft.channel not in channels:
            continue
        f = ft.order * rate[ft.shaft]
        h = round(f / f0)
        on_mains = 1 <= h <= MAX_HARMONIC and abs(f - h * f0) < 1.0 / big_t
        if on_mains and abs(ft.measured) >= max(MODEL_RATIO * abs(ft.model), MIN_RESIDUAL):
            left.append((ft.channel, ft.shaft, ft.order))
    return sorted(set(left))


def everywhere_orders(
    features: list[Any], shaft: str, order: int, left: list[tuple[str, str, int]]
) -> list[tuple[str, str, int]]:
    """``left`` and ``order`` of ``shaft`` on every channel that has it: pickup on more channels than
    ``mains_repair.MAX_CHANNELS`` is not separable from an effect at that order (module docstring)."""
    every = {
        (ft.channel, shaft, order)
        for ft in features
        if ft.family == "shaft orders" and ft.shaft == shaft and ft.order == order
    }
    return sorted(every | set(left))


def pattern_misfits(
    features: list[Any],
    groups: list[dict[str, Any]],
    left_out: tuple[tuple[str, str, int], ...],
    rate: dict[str, float],
    big_t: float,
) -> list[dict[str, Any]]:
    """After the diagnosis with the pickup left out: the channels it kept whose order of a group the
    fitted model does not explain (module docstring).

    Parameters
    ----------
    features : list
        Every order feature of that diagnosis as scored (``residual_trace._order_features``; the features
        left out are not among them).
    groups : list of dict
        ``mains_repair.pickup_orders``'s groups of the first diagnosis (``shaft``, ``order``, ``mains``).
    left_out : tuple of (str, str, int)
        The order features left out so far.
    rate : dict
        Each shaft's rotation frequency, Hz.
    big_t : float
        The record's length, s.

    Returns
    -------
    list of dict
        Per group with such channels: the group, ``misfit`` (``channel, measured, model`` in noise
        sigmas) and ``left_out`` (the further ``(channel, shaft, order)``).
    """
    out = []
    done = set(left_out)
    for g in groups:
        shaft, order = g["shaft"], g["order"]
        miss = [
            ft
            for ft in features
            if ft.family == "shaft orders"
            and ft.shaft == shaft
            and ft.order == order
            and (ft.channel, shaft, order) not in done
            and abs(ft.measured) >= max(MODEL_RATIO * abs(ft.model), MIN_RESIDUAL)
        ]
        if not miss:
            continue
        chans = sorted({ft.channel for ft in miss})
        more = [x for x in mains_orders(features, shaft, chans, g["mains"][0], rate, big_t) if x not in done]
        if more:
            readings = [{"channel": ft.channel, "measured": ft.measured, "model": ft.model} for ft in miss]
            out.append({**g, "misfit": readings, "left_out": more})
    return out


def describe_misfits(found: list[dict[str, Any]]) -> list[str]:
    """``issues`` entries for the further channels left out."""
    out = []
    for g in found:
        f0, h = g["mains"]
        cols = ", ".join(
            f"{x['channel']!r} (measured {x['measured']:.3g}, fitted model {x['model']:.3g} noise sigmas)"
            for x in g["misfit"]
        )
        feats = ", ".join(f"{c!r} order {k}" for c, _, k in g["left_out"])
        out.append(
            f"mains pickup on a shaft order on more channels: with the pickup left out, the fitted model "
            f"(every library effect in the proportions and phases of its transfer to each channel) still "
            f"lacks the {g['shaft']} shaft's order {g['order']} ({f0:g} Hz x{h}) on {cols}: not the "
            f"pattern of any fitted effect, pickup as well; left out of those channels' order features "
            f"({feats}) and the record diagnosed a third time"
        )
    return out
