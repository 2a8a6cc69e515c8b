"""Fault-alarm thresholds learnt from healthy recordings of one's own machine, and records checked with them.

The monitor's alarm rule (:mod:`gear_rotor_sim.alarms`: ``mean + k std`` per feature and operating
class, indicator groups per fault type) needs thresholds learnt on the machine it watches: the
shipped ``config/fault_thresholds.json`` was learnt on the FE model's own healthy runs and does not
transfer to another machine (docs/detection.md, "On data the model did not make"). This module cuts
measurement files (``.csv`` + sidecar, ``.mcap``, ``.mat`` with a mapping; docs/calibration.md,
Sec. 1) into the monitor's windows, learns thresholds from healthy ones and checks other records;
``gear-rotor-sim thresholds learn|check`` (:mod:`gear_rotor_sim.alarms_cli`) is its command line.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from gear_rotor_sim.alarms import Thresholds, operating_class
from gear_rotor_sim.fault_indicators import window_features

#: the detection benchmark's windows (docs/detection.md, "Method")
WINDOW_S = 0.25
SKIP_S = 0.5


@dataclass(frozen=True)
class RecordWindow:
    """One window of housing accelerations, as the monitor node hands it to
    :meth:`gear_rotor_sim.alarms.FaultAlarms.check`."""

    data: np.ndarray
    channels: tuple[str, ...]
    sample_rate_hz: float
    speed_rpm: float
    temperature_c: float
    t0: float


def array_windows(
    channels: Mapping[str, np.ndarray],
    sample_rate_hz: float,
    speed_rpm: float,
    temperature_c: float,
    window_s: float = WINDOW_S,
    skip_s: float = SKIP_S,
    duration_s: float | None = None,
) -> list[RecordWindow]:
    """Consecutive, non-overlapping windows of the housing channels (``bearing<k>_housing_a<x|y|z>``).

    Parameters
    ----------
    channels : mapping of str to ndarray
        Model channel name -> samples (m/s^2); channels that are not housing accelerations are dropped.
    sample_rate_hz, speed_rpm, temperature_c : float
        Sample rate and declared operating point of the record.
    window_s, skip_s : float
        Window length and start of the first window (the record's start is skipped), s.
    duration_s : float, optional
        Only windows that end within ``skip_s + duration_s`` (default: to the record's end).

    Raises
    ------
    ValueError
        No housing-acceleration channel, or a window shorter than 2 samples.
    """
    names = tuple(c for c in channels if "_housing_a" in c)
    if not names:
        raise ValueError(f"no housing-acceleration channel (bearing<k>_housing_a*) among {list(channels)}")
    n = round(window_s * sample_rate_hz)
    if n < 2:
        raise ValueError(f"window_s: {window_s!r} gives fewer than 2 samples at {sample_rate_hz:g} Hz")
    data = np.column_stack([np.asarray(channels[c], float) for c in names])
    start = round(skip_s * sample_rate_hz)
    stop = (
        data.shape[0]
        if duration_s is None
        else min(data.shape[0], start + round(duration_s * sample_rate_hz))
    )
    return [
        RecordWindow(data[i : i + n], names, sample_rate_hz, speed_rpm, temperature_c, i / sample_rate_hz)
        for i in range(start, stop - n + 1, n)
    ]


def load_record(path: str) -> Any:
    """A measurement file (:func:`gear_rotor_sim.calibration.measurement.load_measurement`); a CWRU
    ``.mat`` file without a ``.yaml`` of its own goes through the built-in CWRU mapping (12 kHz,
    :func:`gear_rotor_sim.calibration.cwru.load_cwru`), as in ``gear-rotor-sim calibrate``."""
    from pathlib import Path

    from gear_rotor_sim.calibration import cwru
    from gear_rotor_sim.calibration.measurement import load_measurement

    p = Path(path)
    if p.suffix.lower() == ".mat" and cwru.is_cwru_file(p) and not p.with_suffix(".yaml").exists():
        return cwru.load_cwru(p, duration_s=None)
    return load_measurement(p)


def measurement_windows(
    path: str, window_s: float = WINDOW_S, skip_s: float = SKIP_S, duration_s: float | None = None
) -> tuple[list[RecordWindow], str]:
    """:func:`array_windows` of a measurement file (:func:`load_record`) and its declared gearbox."""
    m = load_record(path)
    cols = {name: m.data[:, i] for i, name in enumerate(m.model_channels)}
    op = m.operating_point
    wins = array_windows(cols, m.sample_rate_hz, op.speed_rpm, op.temperature_c, window_s, skip_s, duration_s)
    return wins, m.gearbox


def learn(
    features: Sequence[Mapping[str, float]],
    points: Sequence[tuple[float, float]],
    k: float,
    speeds: Sequence[float] | None = None,
    temperatures: Sequence[float] | None = None,
) -> Thresholds:
    """Thresholds ``mean + k std`` per feature and operating class from healthy windows.

    Parameters
    ----------
    features : sequence of mapping
        :func:`gear_rotor_sim.fault_indicators.window_features` of each healthy window.
    points : sequence of (float, float)
        Declared (speed rpm, temperature C) of each window.
    k : float
        Threshold multiplier (docs/detection.md recommends 6 with 96 features).
    speeds, temperatures : sequence of float, optional
        Nominal values of the operating classes; each window goes to the nearest
        (:func:`gear_rotor_sim.alarms.operating_class`). Default: the distinct declared values.
    """
    sp = sorted(set(speeds)) if speeds else sorted({round(p[0], 6) for p in points})
    tc = sorted(set(temperatures)) if temperatures else sorted({round(p[1], 6) for p in points})
    return Thresholds.fit(features, [operating_class(s, t, sp, tc) for s, t in points], k)


def features_of(windows: Iterable[RecordWindow], config: str = "paper_sun2021") -> list[dict[str, float]]:
    """The monitor's features of each window (:func:`gear_rotor_sim.fault_indicators.window_features`)."""
    return [window_features(w, config) for w in windows]
