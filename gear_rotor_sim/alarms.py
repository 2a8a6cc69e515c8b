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
from typing import Any

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
        """Features above their thresholds (empty: no alarm); names absent from ``features`` are skipped."""
        lim = self.limit(c)
        return [n for i, n in enumerate(self.names) if n in features and features[n] > lim[i]]


#: Indicators watched per fault type (on every housing channel): the alarm of a type is raised when
#: any of its indicators exceeds its threshold on any channel.
FAULT_GROUPS: dict[str, tuple[str, ...]] = {
    "tooth_damage": ("fm4", "na4", "kurtosis", "crest_factor", "fm0"),
    "tooth_wear": ("rms", "fm0", "ser"),
    "pinion_eccentricity": ("ser", "order1", "rms"),
    "gear_eccentricity": ("ser", "order1", "rms"),
    "mass_unbalance": ("order1", "rms"),
    "shaft_misalignment": ("order2", "rms"),
    "outer_race_defect": ("env_bpfo", "kurtosis"),
    "inner_race_defect": ("env_bpfi", "kurtosis"),
    "ball_defect": ("env_bsf", "kurtosis"),
}


#: fault types of a gear mesh: not watched on a rig without one (``config/cwru_rig.yaml``)
GEAR_FAULTS = ("tooth_damage", "tooth_wear", "pinion_eccentricity", "gear_eccentricity")


def group_alarms(
    exceeded: Iterable[str], groups: Mapping[str, Sequence[str]] = FAULT_GROUPS
) -> dict[str, list[str]]:
    """Fault types whose indicator group has an exceeded feature (``<channel>.<indicator>`` names)."""
    out: dict[str, list[str]] = {}
    for name in exceeded:
        ind = name.rsplit(".", 1)[1]
        for t, g in groups.items():
            if ind in g:
                out.setdefault(t, []).append(name)
    return out


def save_thresholds(th: Thresholds, path: str, config: str = "paper_sun2021", note: str = "") -> None:
    """Write thresholds as JSON (what the monitor node's ``fault_thresholds_file`` reads)."""
    import json

    data = {
        "rule": "mean + k std per feature and operating class",
        "k": th.k,
        "config": config,
        "note": note,
        "names": list(th.names),
        "classes": [
            {"speed_rpm": c[0], "temperature_c": c[1], "mean": th.mean[c].tolist(), "std": th.std[c].tolist()}
            for c in sorted(th.mean)
        ],
    }
    with open(path, "w", encoding="utf-8") as f:
        json.dump(data, f, indent=1)
        f.write("\n")


class FaultAlarms:
    """The monitor's fault alarms: indicators of a window, thresholds of its operating class, groups.

    Parameters
    ----------
    path : str
        JSON written by :func:`save_thresholds` (``benchmarks/detection.py --save-thresholds``).
    """

    def __init__(self, path: str) -> None:
        import json

        try:
            with open(path, encoding="utf-8") as f:
                data = json.load(f)
            th = Thresholds(float(data["k"]), tuple(data["names"]))
            for c in data["classes"]:
                key = (float(c["speed_rpm"]), float(c["temperature_c"]))
                th.mean[key] = np.asarray(c["mean"], float)
                th.std[key] = np.asarray(c["std"], float)
                if th.mean[key].size != len(th.names) or th.std[key].size != len(th.names):
                    raise ValueError(f"class {key}: {th.mean[key].size} values for {len(th.names)} names")
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise ValueError(f"{path}: not a thresholds file ({exc})") from None
        if not th.mean:
            raise ValueError(f"{path}: no operating class")
        self.thresholds = th
        self.config = str(data.get("config", "paper_sun2021"))
        self.speeds = sorted({c[0] for c in th.mean})
        self.temperatures = sorted({c[1] for c in th.mean})
        from gear_rotor_sim.fault_indicators import has_gear_mesh

        gears = has_gear_mesh(self.config)
        self.groups = {t: g for t, g in FAULT_GROUPS.items() if gears or t not in GEAR_FAULTS}

    def check(self, window: Any) -> tuple[dict[str, list[str]], tuple[float, float]]:
        """``({fault type: exceeded features}, operating class)`` of a window (``channels``, ``data``,
        ``sample_rate_hz``, ``speed_rpm``, ``temperature_c``); features of channels the thresholds
        do not know are ignored; on a rig without a gear mesh the :data:`GEAR_FAULTS` are not watched."""
        from gear_rotor_sim.fault_indicators import window_features

        feats = window_features(window, self.config)
        c = operating_class(window.speed_rpm, window.temperature_c, self.speeds, self.temperatures)
        return group_alarms(self.thresholds.exceeded(feats, c), self.groups), c
