"""An axial bearing-force sensor's zero offset that no temperature the calibration can claim explains
(issue 11: effects nobody declared; docs/calibration.md Sec. 1, "Sensor conventions and faults nobody
declared"; history Sec. 8.53).

Physics. The axial bearing load of a spur gearbox is purely thermal: the shafts' free expansion held by their
bearings, ``k_s a dT L / (1 + 2 k_s / k_b)`` (Sun et al. 2021, Eqs 9-11; 1846 N per 100 C in the paper's
rig), so its mean is the calibration's thermometer (Sec. 8.2) and at the material table's reference
temperature the model's axial mean is exactly zero. A load cell's zero is the least certain part of a force
measurement (a zero that drifts with the cell's own temperature, a bridge offset, cross-axis sensitivity to
the large radial load), and an offset of a few tens of newtons on the axial channel reads as a temperature:
at the reference temperature its static residual stood 1515 noise deviations out (a 50 N offset), the error
of every record after the fit rose 40-100 fold and no fault row halved it. A temperature offset is only
claimed inside the material table and away from its ends (``Calibrator._bounds``; within 1 % of the range of
an end it is "at bound", ``fit_verify._at_bound``), so what such a mean reads as is either a temperature the
calibration cannot claim, or a sensor's zero.

Rule (:func:`axial_zero_offsets`). For each axial bearing-force channel in the static family, the static
residual at the declared temperature ``z = (d - g m) / sigma`` (``Comparison.score``: noise of the
per-revolution means, the 10 % model-form tolerance of the smaller mean, 5 % of the channel's fluctuation);
where ``|z| > K_SIGMA``, the temperature offset the residual reads, ``dT = (d - g m) / s`` with ``s`` the
model's axial sensitivity from one run at ``+-DT_PROBE_C`` (linear: the thermal load is linear in ``dT``,
E(T), Table 1, changes it by 0.03-0.08 % per C). If ``dT`` lies outside the claimable interval
(``(lo + tol, hi - tol)``, ``tol`` 1 % of the range) the channel's mean is a zero offset: ``d - g m`` is
subtracted from the channel (its mean then reads the declared temperature), and an ``issues`` entry names
the column, the offset and the temperature it would be. A mean that a claimable temperature explains is
left to the static screen (``fit_screens._static_screen``): a zero offset of that size cannot be told from a
temperature.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

#: an axial mean must stand this many static sigmas off the model's at the declared temperature
K_SIGMA = 5.0
#: temperature step of the run that gives the model's axial sensitivity, degC
DT_PROBE_C = 10.0
#: the claimable interval keeps this fraction of the bounds' range from each end (``fit_verify._at_bound``)
AT_BOUND_FRACTION = 0.01


@dataclass(frozen=True)
class AxialZero:
    """One axial channel read as carrying a zero offset."""

    channel: int
    column: str
    offset_n: float  # measured mean minus the model's at the declared temperature, N
    z: float  # the same in static sigmas
    implied_c: float  # the temperature offset it would read, degC
    claimable_c: tuple[float, float]  # the temperature offsets the calibration can claim, degC
    declared_c: float

    def issue(self) -> str:
        """The ``issues`` entry."""
        lo, hi = self.claimable_c
        at = self.declared_c + self.implied_c
        return (
            f"column {self.column!r}: mean {self.offset_n:+.4g} N off the model's at the declared "
            f"{self.declared_c:g} C ({self.z:+.3g} sigma); the axial bearing load is thermal, so this reads "
            f"as {self.implied_c:+.3g} C ({at:.4g} C), outside the temperatures the calibration can claim "
            f"({self.declared_c + lo:.4g} to {self.declared_c + hi:.4g} C): read as the force sensor's zero "
            f"offset and subtracted (check the sensor's zero; cross-talk from a radial axis reads the same)"
        )


def claimable_interval(bounds: tuple[float, float]) -> tuple[float, float]:
    """Temperature offsets (degC) a fit can claim inside ``bounds``: 1 % of the range kept from each end."""
    lo, hi = bounds
    tol = AT_BOUND_FRACTION * (hi - lo)
    return lo + tol, hi - tol


def axial_zero_offsets(
    residual_n: np.ndarray,
    z: np.ndarray,
    sensitivity_n_per_c: np.ndarray,
    axial: Sequence[int],
    columns: Sequence[str],
    claimable_c: tuple[float, float],
    declared_c: float,
) -> list[AxialZero]:
    """The axial channels whose mean is a zero offset (module docstring).

    Parameters
    ----------
    residual_n, z : numpy.ndarray
        ``(nc,)`` measured minus model mean (N) and the same in static sigmas, at the declared temperature.
    sensitivity_n_per_c : numpy.ndarray
        ``(nc,)`` the model's mean change per degC.
    axial : sequence of int
        The axial bearing-force channels with a static feature.
    columns : sequence of str
        Every channel's column name.
    claimable_c : tuple of float
        :func:`claimable_interval` of the temperature offset's bounds.
    declared_c : float
        The declared temperature.

    Returns
    -------
    list of AxialZero
        One per channel standing more than :data:`K_SIGMA` out whose implied temperature offset is not
        claimable (no sensitivity: any offset).
    """
    lo, hi = claimable_c
    out = []
    for k in axial:
        if not abs(z[k]) > K_SIGMA:
            continue
        s = float(sensitivity_n_per_c[k])
        implied = float(residual_n[k]) / s if abs(s) > 0 else float("inf") * np.sign(residual_n[k])
        if lo < implied < hi:
            continue
        out.append(AxialZero(k, columns[k], float(residual_n[k]), float(z[k]), implied, (lo, hi), declared_c))
    return out


@dataclass(frozen=True)
class AxialReadings:
    """What the rule reads on a set-up calibrator (also printed on the benchmark records,
    ``benchmarks/axial_zero_stats.py``)."""

    axial: tuple[int, ...]  # the axial bearing-force channels with a static feature
    columns: tuple[str, ...]  # every channel's column
    residual_n: np.ndarray  # (nc,) measured minus model mean at the declared temperature
    z: np.ndarray  # (nc,) the same in static sigmas
    sensitivity_n_per_c: np.ndarray | None  # (nc,) from the probe run; None where no mean stands out
    claimable_c: tuple[float, float]
    declared_c: float

    def offsets(self) -> list[AxialZero]:
        """:func:`axial_zero_offsets` of these readings."""
        if self.sensitivity_n_per_c is None:
            return []
        return axial_zero_offsets(
            self.residual_n,
            self.z,
            self.sensitivity_n_per_c,
            self.axial,
            self.columns,
            self.claimable_c,
            self.declared_c,
        )


def axial_channels(cal: Any) -> tuple[int, ...]:
    """The axial bearing-force channels of a set-up calibrator that have a static feature (none without the
    static family)."""
    cmp = cal.cmp
    if "static" not in cmp.families:
        return ()
    return tuple(
        k
        for k, c in enumerate(cal.m.channels)
        if c.quantity == "bearing_force" and c.direction == "z" and cmp.static_mask[k]
    )


def static_z(cal: Any, score: Any, channel: int) -> float:
    """The static residual (sigmas) of ``channel``'s mean in ``score`` (``Score.static_r`` holds one entry per
    channel of ``cal.cmp.static_mask``); 0 for a channel without a static feature."""
    idx = [int(i) for i in np.flatnonzero(cal.cmp.static_mask)]
    return float(score.static_r[idx.index(channel)]) if channel in idx else 0.0


def axial_readings(cal: Any) -> AxialReadings | None:
    """The axial channels' static residuals on a set-up calibrator at the declared temperature, and the
    model's axial sensitivity from one run ``DT_PROBE_C`` above it (below it where that leaves the material
    table) only when one of them stands more than :data:`K_SIGMA` out (a record without one costs no run).
    None without an axial channel in the static family."""
    from gear_rotor_sim.faults import TemperatureOffset

    cmp = cal.cmp
    if "static" not in cmp.families:
        return None
    chans = cal.m.channels
    axial = axial_channels(cal)
    if not axial:
        return None
    feats = cal._features(cal.base_raw)
    sc = cmp.score(feats)
    z = np.zeros(len(chans))
    for k in axial:
        z[k] = static_z(cal, sc, k)
    g = np.asarray(sc.gains, float)
    residual = np.asarray(cmp.d_static - g * feats.static, float)
    bounds = cal._bounds(TemperatureOffset())
    sens = None
    if any(abs(z[k]) > K_SIGMA for k in axial):
        dt = DT_PROBE_C if bounds[1] >= DT_PROBE_C else -DT_PROBE_C
        probe = cal._features(cal._raw((TemperatureOffset(offset_c=dt),))).static
        sens = g * (probe - feats.static) / dt
    return AxialReadings(
        axial,
        tuple(c.column for c in chans),
        residual,
        z,
        sens,
        claimable_interval(bounds),
        float(cal.m.operating_point.temperature_c),
    )


def find_axial_zero(cal: Any) -> list[AxialZero]:
    """The axial channels of a set-up calibrator whose mean is a zero offset (:func:`axial_readings`)."""
    readings = axial_readings(cal)
    return [] if readings is None else readings.offsets()
