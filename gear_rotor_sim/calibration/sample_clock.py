"""A sample clock that is not the declared one, named beside a declared speed that is not the true one
(issue 11; docs/calibration.md Sec. 2 "Speed check", docs/history/calibration_sessions.md Sec. 8.57).

A record whose clock runs at ``fs (1 + eps)`` while its file says ``fs`` puts every line at
``f / (1 + eps)`` of the file's time: the machine's orders and mesh lines, but also its fixed resonances,
the acquisition's anti-aliasing edge and mains pickup. A speed off by ``eps`` moves only the orders. The
speed check reads the mesh lines, so it reads either as the speed ``declared / (1 + eps)``, and the two
differ only in where the fixed frequencies sit relative to the orders:

- the machine's resonances: compared with the model's, whose own resonances are the FE model's, not the
  machine's (on the independent records the two models' mesh modes differ by 18 % at 4500 rpm,
  Sec. 8.35, and the structural path's peaks are not resolved in a healthy record's non-synchronous
  part, which holds only the sensors' white noise: Sec. 8.57); a clock off by 0.1-0.5 % is far below that;
- the anti-aliasing edge: a DAQ's filter is derived from its own clock and moves with it;
- mains pickup at 50 or 60 Hz: a reference where present (a line within 0.05 Hz of a harmonic is removed
  as mains, ``line_removal.py``); the benchmark's records hold none.

So where the speed check corrects the speed, :func:`clock_alternative` names the clock off by the same
ratio as the other reading in ``issues``: the calibration then runs at the speed that the file's time
gives, which is the right model for the record's orders either way (the model's fixed resonances are
then ``eps`` off the record's, as they are off the machine's by the model's own error).
"""

from __future__ import annotations

import math


def clock_ratio(declared_rpm: float, measured_rpm: float) -> float:
    """The true sample rate over the declared one that would explain the measured speed with the
    declared speed right: ``declared / measured`` (a fast clock compresses the file's time)."""
    if not (declared_rpm > 0 and measured_rpm > 0):
        return math.nan
    return float(declared_rpm) / float(measured_rpm)


def clock_alternative(declared_rpm: float, measured_rpm: float, sample_rate_hz: float) -> str:
    """The ``issues`` clause naming a sample clock off by the ratio the speed check read.

    Parameters
    ----------
    declared_rpm, measured_rpm : float
        The declared speed and the speed the record's mesh lines give.
    sample_rate_hz : float
        The record's declared sample rate.

    Returns
    -------
    str
        E.g. ``"or the speed is the declared one and the sample clock runs 0.3 % fast (20060 Hz for the
        declared 20000 Hz): every line moves alike, and the record holds no fixed-frequency reference
        (mains, a resolved resonance) to tell the two apart"``.
    """
    r = clock_ratio(declared_rpm, measured_rpm)
    rel = 100.0 * (r - 1.0)
    way = "fast" if rel > 0 else "slow"
    return (
        f"or the speed is the declared one and the sample clock runs {abs(rel):.3g} % {way} "
        f"({sample_rate_hz * r:.6g} Hz for the declared {sample_rate_hz:.6g} Hz): every line of the record "
        "moves alike, and it holds no fixed-frequency reference (mains, a resolved resonance) to tell the "
        "two apart; the model runs at the speed of the file's time either way"
    )
