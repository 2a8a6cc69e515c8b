"""The static screen's trigger: the channel means as a whole, or the axial bearing force alone
(``calibration/temperature_trigger.py``; docs/history/calibration_sessions.md Sec. 8.77)."""

import numpy as np

from gear_rotor_sim.calibration.temperature_trigger import AXIAL_SIGMA, axial_off, screen_fires

# channels: 0 dte, 1 bearing2_fx, 2 bearing2_fy, 3 bearing2_fz (axial), 4 node5_ax (no static feature)
STATIC = [0, 1, 2, 3]
AXIAL = [3]


def _chi2(r: list[float]) -> float:
    return float(np.sum(np.square(r)))


def test_an_axial_mean_off_fires_where_the_whole_means_do_not():
    # blind16 (set 1): dte 0.80, radial 2.17 / 2.79, axial 4.91 sigma: chi^2 37.3 < 9 * 4 + 25 = 61
    r = [0.80, 2.17, 2.79, 4.91]
    assert _chi2(r) < 9 * 4 + 25
    assert axial_off(np.array(r), STATIC, AXIAL)
    assert screen_fires(_chi2(r), np.array(r), STATIC, AXIAL)


def test_radial_means_off_alone_do_not_fire():
    # every record without a temperature offset: radial means 2.0-2.9 sigma, the axial 0.0-0.3
    r = [1.3, 2.9, 2.9, 0.3]
    assert not screen_fires(_chi2(r), np.array(r), STATIC, AXIAL)
    # the same means with the axial one just inside the trigger, and just outside it
    inside = [1.3, 2.9, 2.9, AXIAL_SIGMA * 0.99]
    outside = [1.3, 2.9, 2.9, AXIAL_SIGMA * 1.01]
    assert not screen_fires(_chi2(inside), np.array(inside), STATIC, AXIAL)
    assert screen_fires(_chi2(outside), np.array(outside), STATIC, AXIAL)


def test_the_whole_means_still_fire_without_an_axial_channel():
    r = [9.0, 2.0, 2.0]
    assert screen_fires(_chi2(r), np.array(r), [0, 1, 2], [])
    assert not screen_fires(_chi2(r[1:]), np.array(r[1:]), [1, 2], [])


def test_an_axial_channel_without_a_static_feature_is_ignored():
    # the axial channel is not among the static features (e.g. a record whose axial mean is left out)
    r = [0.5, 2.0, 2.0]
    assert not axial_off(np.array(r), [0, 1, 2], [3])
