"""Model runs whose analysed window holds no switch of the simulator's step rule.

The simulator's default dt rule (``docs/solver.md``, "Default dt rule") raises the integration rate
and locates the mesh events for a rule window (0.1 s) after any step in which the teeth separate,
and returns to the contact setting after a window in continuous contact. A calibration run starts
from static equilibrium; the start-up transient of a strong once-per-revolution excitation can
separate the teeth for a few steps although the steady response stays in contact (measured: the
FE paper gearbox at 3000 rpm with a 15 um pinion eccentricity, 2 steps of free flight in the first
0.1 s, none afterwards; 10 um: none; since docs/history/calibration_sessions.md Sec. 8.33 at phase -2 rad,
none at 0.5). The rule then runs in its contact-loss setting until about 0.2 s, i.e. into the analysed
window that starts after the 0.15 s warm-up, and the response there differs from the steady one:
the non-synchronous part of ``bearing2_fy`` holds 19 N RMS in 0.10-0.20 s against the steady 0.5 N
(the same run with the rule off: 0.5-0.7 N throughout).
That content does not scale with the effect's amplitude (the same at 15 and 70 um), so a signature
scaled as if linear carries it multiplied, and the envelope of the non-synchronous part reads it
as a large misfit (pinion eccentricity on an independent record: fitted 71 um, chi^2 worse by a
factor 3.6, not claimed).

:func:`run_settled` advances the simulator in short pieces and reads the rule's setting after each
(``Simulator.last_chunk_stats``). If the setting changed after ``settle_s`` before the window's
start, the window is moved on by whole hunting periods of the mesh, past the last change plus
``settle_s``: every library effect's response is periodic in the hunting period (``model_window.py``),
so the features of the moved window equal those of a settled run at the original times (order
phases included). Where the period is not a whole number of samples (any speed whose hunting period
is not a multiple of the sample interval: 4500 rpm at 20 kHz, a corrected speed, a record whose clock is
not the declared one), the window is moved by the nearest whole number of samples and read at the
original instants by band-limited interpolation (``fractional_delay.py``; before session 21 such a window
was not moved at all, and a start-up separation stayed in it: the gear eccentricity of a record at 2991
rpm read +76 %, docs/history/calibration_sessions.md Sec. 8.57). A run whose rule keeps switching
(teeth separating in some windows only) is returned as it is after ``max_shifts`` moves.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from gear_rotor_sim.calibration.fractional_delay import delay_samples
from gear_rotor_sim.calibration.order_tracking import SINC_HALF_WIDTH

#: ``Simulator.last_chunk_stats`` entries that describe the step rule's setting
RULE_STATS = ("decimation", "contact_loss_rule", "exact_modal_map", "located")
#: pieces in which the window is advanced (shorter than the rule window, 0.1 s, so that a setting
#: held for one rule window is always seen)
PIECE_S = 0.05
#: shortest run without a grown effect before it is switched on (``ModelRunner.grown_effects``): the
#: FE paper gearbox at 8000 rpm reaches its rattle branch from the static equilibrium within 0.2 s
GROWN_START_S = 0.2
#: the setting must be unchanged from this long before the window's start
SETTLE_S = 0.05


@dataclass
class SettledRun:
    """Result of :func:`run_settled`."""

    data: np.ndarray  # (n, channels)
    first_index: int  # output index of data[0]
    shifts: int  # hunting periods the window was moved on
    settled: bool  # no change of the rule's setting from SETTLE_S before the window on


def whole_period_samples(period_s: float | None, sample_rate_hz: float, tol: float = 0.01) -> int | None:
    """The hunting period in output samples if it is a whole number of them (within ``tol``), else
    None (a window moved by it would shift the order phases)."""
    if period_s is None or not period_s > 0:
        return None
    p = period_s * sample_rate_hz
    n = round(p)
    return int(n) if n >= 1 and abs(p - n) <= tol else None


def window_period_samples(period_s: float | None, sample_rate_hz: float, tol: float = 0.01) -> float | None:
    """The hunting period in output samples for moving a window (:func:`run_settled`): the whole number
    where it is one within ``tol`` (:func:`whole_period_samples`), else the exact fractional count; None
    without a period."""
    whole = whole_period_samples(period_s, sample_rate_hz, tol)
    if whole is not None:
        return whole
    if period_s is None or not period_s * sample_rate_hz >= 1.0:
        return None
    return float(period_s * sample_rate_hz)


def grown_start_samples(
    period_samples: int | None, sample_rate_hz: float, min_s: float = GROWN_START_S
) -> int:
    """Length of the run before a grown effect is switched on: the fewest whole hunting periods that
    last at least ``min_s`` (the healthy response is then on its branch), or 0 when the period is not
    a whole number of samples (the effect is then present from the start).

    Every library effect's response is periodic in the hunting period (``model_window.py``), so a
    window taken after such a start has the order phases of a run started at time 0.
    """
    if period_samples is None or period_samples < 1:
        return 0
    return int(period_samples * max(1, math.ceil(min_s * sample_rate_hz / period_samples)))


def _rule(sim: Any) -> tuple[float, ...]:
    stats = getattr(sim, "last_chunk_stats", None) or {}
    return tuple(float(stats.get(k, -1.0)) for k in RULE_STATS)


def run_settled(
    sim: Any,
    first_index: int,
    n: int,
    sample_rate_hz: float,
    period_samples: float | None,
    settle_s: float = SETTLE_S,
    piece_s: float = PIECE_S,
    max_shifts: int = 2,
) -> SettledRun:
    """Output samples ``first_index .. first_index + n`` of ``sim`` (a fresh Simulator at time 0), or
    of the same window moved on by whole hunting periods if the step rule's setting changed in or
    shortly before it.

    Parameters
    ----------
    sim : Simulator
        Fresh simulator (time 0); advanced in place.
    first_index : int
        Output index of the window's first sample (the warm-up before it is discarded).
    n : int
        Window length, samples.
    sample_rate_hz : float
        Output rate.
    period_samples : float or None
        Hunting period in samples (:func:`window_period_samples`: a whole number, or a fractional one,
        whose moved window is read at the original instants by interpolation); None: never moved.
    settle_s, piece_s : float
        Settling margin before the window and length of the pieces, s.
    max_shifts : int
        Largest number of moves.

    Returns
    -------
    SettledRun
    """
    fs = float(sample_rate_hz)
    margin = min(max(round(settle_s * fs), 0), first_index)
    piece = max(round(piece_s * fs), 1)
    # (output index reached, rule setting in force there)
    marks: list[tuple[int, tuple[float, ...]]] = []
    pos = 0
    if first_index - margin > 0:
        sim.advance((first_index - margin) / fs)
        pos = first_index - margin
        marks.append((pos, _rule(sim)))
    if margin > 0:
        sim.advance(margin / fs)
        pos = first_index
        marks.append((pos, _rule(sim)))
    blocks: list[np.ndarray] = []
    start = first_index
    shifts = 0
    frac = period_samples is not None and period_samples != round(period_samples)

    def advance_to(end: int) -> None:
        nonlocal pos
        while pos < end:
            step = min(piece, end - pos)
            blk = sim.advance(step / fs)
            blocks.append(np.asarray(blk.data))
            pos += step
            marks.append((pos, _rule(sim)))

    while True:
        advance_to(start + n)
        # the last change of the setting at or after (start - margin)
        last_change = None
        for (_, r_prev), (i_cur, r_cur) in itertools.pairwise(marks):
            if i_cur > start - margin and r_cur != r_prev:
                last_change = i_cur
        if last_change is None:
            settled = True
            break
        if period_samples is None or shifts >= max_shifts:
            settled = False
            break
        need = last_change + margin - start
        m = max(1, math.ceil(need / period_samples))
        shifts += m
        start = first_index + (round(shifts * period_samples) if frac else shifts * int(period_samples))
    # a fractional period: the moved window stands for the original one delta samples later
    delta = round(shifts * period_samples) - shifts * period_samples if frac and shifts else 0.0
    if delta:
        advance_to(start + n + SINC_HALF_WIDTH + 1)  # the interpolation's neighbours after the window
    data = np.concatenate(blocks, axis=0) if len(blocks) > 1 else blocks[0]
    off = start - first_index
    if delta:
        lo = off - SINC_HALF_WIDTH - 1  # the moved window starts a whole period or more after data[0]
        seg = delay_samples(data[lo : off + n + SINC_HALF_WIDTH + 1], delta)
        return SettledRun(np.ascontiguousarray(seg[off - lo : off - lo + n]), start, shifts, settled)
    return SettledRun(np.ascontiguousarray(data[off : off + n]), start, shifts, settled)
