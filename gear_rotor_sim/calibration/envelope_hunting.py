"""Content periodic in the hunting period kept out of the envelope family (issue 11; history Sec. 8.65).

The envelope family reads the non-synchronous part of a bearing channel (every shaft's synchronous
average removed, ``features_orders.remove_synchronous``): what a rolling-bearing defect makes, impacts
at a rate no integer multiple of a shaft rate, jittered by the rolling elements' slip (Randall & Antoni
2011, Sec. 3.3). A measured gearbox holds another kind of content that no shaft's average removes:
content periodic in the *hunting period* ``T_h = lcm(z_p, z_g) / f_mesh`` (``model_window``), the time
after which the same pinion tooth meets the same gear tooth again. Every wheel has manufacturing pitch
errors (ISO 1328-1: a single pitch deviation of 3-12 um at quality 5-7 for the paper's wheels); each
tooth pair then meets at its own flank position, and a pair whose flank lags more than the load
deflection leaves contact alone (Inalpolat, Handschuh & Kahraman 2015). That non-linearity mixes the
pinion's and the gear's error sequences: its products repeat with the tooth pairs, every ``T_h``, not
with either shaft. Measured on the independent gearbox at 3000 rpm (``lumped_gearbox/pitch.py``, history
Sec. 8.62/8.65): at an RMS single pitch deviation of 6 um they are 57 % of the power of
``bearing2_fx``'s non-synchronous part and made the envelope family's error 7.5 on a healthy record (1.0
without pitch errors).

A bearing defect's impacts are not periodic in ``T_h`` (their rate is incommensurate with the tooth
pairs and slips), so the part of the measured non-synchronous signal that repeats from one hunting
period to the next is gear content the model lacks, not a bearing's. It is estimated as the
synchronous average over the hunting period (:func:`hunting_part`), and subtracted from the measured
envelope input where it is large enough to matter (:func:`hunting_share` at least
:data:`MIN_SHARE` at a bearing channel). The model's envelope input is not changed: the non-synchronous
envelope is used only where the healthy model's non-synchronous part stays below 1 % of its RMS
(``ResidualSettings.envelope_periodic_limit``), so in the model it holds no such content, and the model
window covers one hunting period, too short to average over.

Assumes a constant speed known to the order resolution (as the non-synchronous envelope itself) and a
record of at least two hunting periods (2 s at 3000 rpm for the paper's 29 / 49 teeth: 2.04 periods).
With two periods each coefficient's between-period scatter has a single degree of freedom, so it is
floored by its running median over :data:`FLOOR_BINS` neighbouring bins on either side (the local noise
level): random content (noise, a bearing's slipping impacts) then passes the 3-standard-error test with a
probability of about ``exp(-9)`` per bin, content repeated in both periods passes where it stands above
the local noise.
"""

from __future__ import annotations

import math

import numpy as np

from gear_rotor_sim.calibration.features_orders import synchronous_part

#: smallest share of the non-synchronous power at a bearing channel periodic in the hunting period for
#: it to leave the envelope input. A choice after measuring at most 0.064 on 39 table and held-out records
#: at 2000-4500 rpm (the outer races 0.037-0.064 at ``bearing2_fy``, the inner races and balls 0.013-0.039;
#: ``benchmarks/pitch_error_trace.py --hunting-stats``), 0.09 on the quality-5 tooth record and 0.42-0.80
#: at quality 7: a separating value, not a derived one.
MIN_SHARE = 0.10
#: running-median half width (bins of the hunting period's order spectrum) of the coefficients' noise floor
FLOOR_BINS = 64
#: fewest whole hunting periods the average needs
MIN_PERIODS = 2


def hunting_part(x: np.ndarray, fs: float, hunting_hz: float, significance: float = 3.0) -> np.ndarray:
    """The part of ``x`` periodic in the hunting period: ``features_orders.synchronous_part`` over the
    hunting period, each coefficient's between-period scatter floored by its running median over
    ``+- FLOOR_BINS`` bins (module docstring); zeros when the record holds fewer than
    :data:`MIN_PERIODS` periods.

    Parameters
    ----------
    x : numpy.ndarray
        Signal (n,), constant speed (usually already without every shaft's synchronous part).
    fs : float
        Sample rate, Hz.
    hunting_hz : float
        ``1 / T_h``, Hz.
    significance : float
        Standard errors a coefficient must stand above its noise.
    """
    x = np.asarray(x, dtype=float)
    if not (hunting_hz > 0 and math.isfinite(hunting_hz)):
        raise ValueError(f"hunting_hz: must be positive and finite, got {hunting_hz!r}")
    if x.size / fs * hunting_hz < MIN_PERIODS:
        return np.zeros_like(x)
    return synchronous_part(x, fs, hunting_hz, significance=significance, floor_bins=FLOOR_BINS)


def hunting_share(x: np.ndarray, part: np.ndarray) -> float:
    """Share of the power of ``x`` (zero mean) that ``part`` (its hunting-periodic part) carries."""
    p = float(np.mean((x - np.mean(x)) ** 2))
    return float(1.0 - np.mean((x - np.mean(x) - part) ** 2) / p) if p > 0 else 0.0
