"""Alarm thresholds learnt from healthy runs, per operating class.

Rule: for every feature (``<channel>.<indicator>``) the threshold is ``mean + k std`` of that
feature over the healthy training windows of the same operating class (nearest nominal speed and
temperature); a window raises an alarm when any feature exceeds its threshold. With ``F`` features
per window the false-alarm probability grows with ``F``; ``k`` is therefore well above the usual 3
(the detection benchmark reports the false alarms for several ``k``, docs/detection.md).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np


def operating_class(
    speed_rpm: float, temperature_c: float, speeds: Sequence[float], temperatures: Sequence[float]
) -> tuple[float, float]:
    """Nearest nominal (speed on a log scale, temperature)."""
    s = min(speeds, key=lambda v: abs(np.log(speed_rpm / v)))
    t = min(temperatures, key=lambda v: abs(temperature_c - v))
    return float(s), float(t)


@dataclass
class Thresholds:
    """``mean + k std`` per feature and operating class."""

    k: float
    names: tuple[str, ...] = ()
    mean: dict[tuple[float, float], np.ndarray] = field(default_factory=dict)
    std: dict[tuple[float, float], np.ndarray] = field(default_factory=dict)

    @classmethod
    def fit(
        cls, features: Iterable[Mapping[str, float]], classes: Iterable[tuple[float, float]], k: float
    ) -> Thresholds:
        """Learn from healthy windows (feature dicts with the same keys) and their classes."""
        groups: dict[tuple[float, float], list[list[float]]] = {}
        names: tuple[str, ...] = ()
        for f, c in zip(features, classes, strict=True):
            if not names:
                names = tuple(sorted(f))
            groups.setdefault(c, []).append([f[n] for n in names])
        th = cls(float(k), names)
        for c, rows in groups.items():
            a = np.asarray(rows, float)
            if a.shape[0] < 3:
                raise ValueError(f"operating class {c}: {a.shape[0]} healthy windows; need at least 3")
            th.mean[c] = a.mean(axis=0)
            th.std[c] = a.std(axis=0, ddof=1)
        return th

    def limit(self, c: tuple[float, float]) -> np.ndarray:
        return self.mean[c] + self.k * self.std[c]

    def exceeded(self, features: Mapping[str, float], c: tuple[float, float]) -> list[str]:
        """Features above their thresholds (empty: no alarm)."""
        v = np.array([features[n] for n in self.names])
        return [n for n, hit in zip(self.names, v > self.limit(c), strict=True) if hit]
