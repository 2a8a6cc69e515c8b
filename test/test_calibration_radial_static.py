"""A radial force sensor's zero and the baseline updates; a DTE zero against wear read from the DTE mean
(issue 11, effects nobody declared; calibration/radial_static.py, calibration/dte_zero.py; docs/calibration.md
Sec. 1, history Sec. 8.58).

Constructed scores (no model runs): the rule that keeps a baseline scale from moving a wrong channel mean
further away judges the DTE's mean as before and no longer a radial bearing reaction's (an equilibrium load no
stiffness moves); the wear's two readings of the DTE mean are stated with the numbers they rest on.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from gear_rotor_sim.calibration.dte_zero import (
    WearMeanReading,
    dte_zero_issues,
    dynamic_dbic,
    wear_zero_issue,
)
from gear_rotor_sim.calibration.measurement_contract import ChannelSpec
from gear_rotor_sim.calibration.radial_static import baseline_judged_means, moved_judged_mean
from gear_rotor_sim.calibration.residual import Score
from gear_rotor_sim.calibration.search_rounds import mean_moved_further

CHANNELS = [
    ChannelSpec("dte", "dynamic_transmission_error", "m"),
    ChannelSpec("bearing2_fx", "bearing_force", "N", bearing=2, direction="x"),
    ChannelSpec("bearing2_fy", "bearing_force", "N", bearing=2, direction="y"),
    ChannelSpec("bearing2_fz", "bearing_force", "N", bearing=2, direction="z"),
    ChannelSpec("node5_ay", "acceleration", "m/s^2", node=5, direction="y"),
]


def _cal() -> SimpleNamespace:
    # the accelerometer has no static feature
    return SimpleNamespace(
        cmp=SimpleNamespace(static_mask=np.array([True, True, True, True, False])),
        m=SimpleNamespace(channels=CHANNELS),
        notes=[],
    )


def _static(*r: float) -> Score:
    return Score(
        {"static": float(np.sum(np.square(r)))}, {"static": len(r)}, np.ones(1), {}, {}, static_r=np.array(r)
    )


def test_radial_reactions_are_left_out_of_the_moved_mean_rule():
    judged = baseline_judged_means(_cal())
    assert judged.tolist() == [True, False, False, True]
    # the fy-zero record in miniature: bearing2_fy at 3.24 sigma, moved to 3.30 by a bearing update
    before, after = _static(1.0, 2.6, 3.24, 0.1), _static(0.9, 2.6, 3.30, 0.1)
    assert mean_moved_further(before, after) == 3.24
    assert mean_moved_further(before, after, judged) is None
    # the worn record: the DTE mean 8.74 sigma off, moved further: still not taken
    before, after = _static(8.74, 2.46, 2.61, 0.13), _static(8.9, 2.46, 2.61, 0.13)
    assert mean_moved_further(before, after, judged) == 8.74
    # a scripted calibrator without channels judges every mean (as before)
    assert baseline_judged_means(SimpleNamespace()) is None


def test_the_radial_channel_that_would_have_held_the_update_back_is_named():
    cal = _cal()
    before, after = _static(1.0, 2.6, 3.24, 0.1), _static(0.9, 2.6, 3.30, 0.1)
    assert moved_judged_mean(cal, before, after, "bearing_stiffness_damping") is None
    assert moved_judged_mean(cal, before, after, "bearing_stiffness_damping") is None
    assert len(cal.notes) == 1 and "'bearing2_fy'" in cal.notes[0] and "3.24 -> 3.3 sigma" in cal.notes[0]
    # the DTE mean still holds it back, and then nothing is noted
    cal = _cal()
    assert moved_judged_mean(cal, _static(8.74, 2.6, 3.24, 0.1), _static(8.9, 2.6, 3.3, 0.1), "m") == 8.74
    assert cal.notes == []


def _score(order: float, envelope: float, static: float) -> Score:
    chi2 = {"order": order, "envelope": envelope, "static": static}
    return Score(chi2, {"order": 400, "envelope": 100, "static": 4}, np.ones(1), {}, {})


def test_the_dynamic_gain_leaves_the_channel_means_out():
    before, after = _score(2000.0, 300.0, 120.0), _score(1990.0, 300.0, 2.0)
    # balanced: each spectral family weighted to 250 of the 500 features; the static family drops out
    dyn = 2000.0 * 250 / 400 + 300.0 - (1990.0 * 250 / 400 + 300.0)
    assert math.isclose(dynamic_dbic(before, after), dyn - 2 * math.log(504))
    assert dynamic_dbic(before, after) < 10.0


def test_both_readings_of_a_wear_from_the_dte_mean():
    reading = WearMeanReading(16.5e-6, 23.1e-6, 4.5e-6, -3.0, 0.0, "dte")
    text = wear_zero_issue(reading)
    assert "'dte'" in text and "16.5 um" in text and "+23.1 um" in text
    assert "do not tell them apart" in text and "no wear and a zero offset" in text
    supported = wear_zero_issue(WearMeanReading(16.5e-6, 23.1e-6, 4.5e-6, 250.0, 1.0, "dte"))
    assert "support a wear" in supported and "1.4 h + z = +23.1 um" in supported
    cal = SimpleNamespace(wear_mean_reading=reading)
    wear = SimpleNamespace(name="tooth_wear", parameters={"wear_depth_m": 16.6e-6, "mesh": 1})
    other = SimpleNamespace(name="tooth_wear", parameters={"wear_depth_m": 30e-6, "mesh": 1})
    assert dte_zero_issues(cal, [wear]) == [text]
    assert dte_zero_issues(cal, [other]) == []
    assert dte_zero_issues(SimpleNamespace(), [wear]) == []
