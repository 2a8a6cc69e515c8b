"""Chaotic-window algebra of the reproduction: joining, condensing and comparing speed windows.

Pure functions on lists of ``(low_rpm, high_rpm)`` windows (or ``(label, low, high)`` motion windows)
of a bifurcation sweep (:class:`~gear_rotor_sim.analysis.bifurcation.BifurcationResult`); used by
``gear-rotor-sim reproduce``, its report and the readings study. No simulation here.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from gear_rotor_sim.analysis.bifurcation import BifurcationResult


def main_band(windows: list[tuple[float, float]], above_rpm: float = 11000.0) -> tuple[float, float]:
    """The widest chaotic window ending above ``above_rpm`` (the primary-resonance band)."""
    cand = [(a, b) for a, b in windows if b >= above_rpm]
    if not cand:
        return float("nan"), float("nan")
    return max(cand, key=lambda w: w[1] - w[0])


def merge_windows(windows: list[tuple[float, float]], gap_rpm: float) -> list[tuple[float, float]]:
    """Chaotic windows joined where the gap between them is below ``gap_rpm`` (sorted by start)."""
    out: list[list[float]] = []
    for a, b in sorted(windows):
        if out and a - out[-1][1] < gap_rpm:
            out[-1][1] = max(out[-1][1], b)
        else:
            out.append([a, b])
    return [(float(a), float(b)) for a, b in out]


def condense_windows(
    windows: list[tuple[str, float, float]], min_points: int, speeds: np.ndarray
) -> list[tuple[str, float, float]]:
    """Motion windows with runs shorter than ``min_points`` grid speeds absorbed by neighbours."""
    ds = float(np.mean(np.diff(speeds))) if speeds.size > 1 else 1.0
    out: list[tuple[str, float, float]] = []
    for lab, lo, hi in windows:
        n = round((hi - lo) / ds) + 1
        if out and (n < min_points or out[-1][0] == lab):
            out[-1] = (out[-1][0], out[-1][1], hi)
        else:
            out.append((lab, lo, hi))
    merged: list[tuple[str, float, float]] = []
    for w in out:
        if merged and merged[-1][0] == w[0]:
            merged[-1] = (w[0], merged[-1][1], w[2])
        else:
            merged.append(w)
    return merged


def overlap_near(model: list[tuple[float, float]], paper: tuple[float, float]) -> tuple[float, float, float]:
    """Model chaotic extent within +-1500 rpm of a paper window: (lo, hi, Jaccard index)."""
    lo_p, hi_p = paper
    near = [(a, b) for a, b in model if b >= lo_p - 1500 and a <= hi_p + 1500]
    if not near:
        return float("nan"), float("nan"), 0.0
    lo, hi = min(a for a, _ in near), max(b for _, b in near)
    inter = max(0.0, min(hi, hi_p) - max(lo, lo_p))
    union = max(hi, hi_p) - min(lo, lo_p)
    return lo, hi, inter / union if union > 0 else 0.0


def label_at(res: BifurcationResult, speed: float) -> str:
    """Motion label of ``res`` at the grid speed nearest ``speed``, with that speed."""
    i = int(np.argmin(np.abs(res.speeds_rpm - speed)))
    return f"{res.labels()[i]} ({res.speeds_rpm[i]:.0f} rpm)"
