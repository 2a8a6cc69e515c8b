"""An axial bearing-force sensor's zero offset (issue 11, an effect nobody declared;
calibration/axial_zero.py, hooked in channel_conventions.check_conventions; docs/calibration.md Sec. 1).

The rule on analytic residuals, and the calibrator's setup on a short ``lumped_gearbox`` record at 25 C (the
reference temperature: the model's axial load is zero): the record as made is left untouched; +50 N on
``bearing2_fz`` is named and subtracted, its implied temperature the analytic ``50 N / 18.46 N per C``
(1846 N per 100 C, calibration.md Sec. 8.2); a real temperature offset of 60 C is left to the static screen.
"""

from __future__ import annotations

import numpy as np
import pytest

from gear_rotor_sim.calibration.axial_zero import (
    K_SIGMA,
    axial_zero_offsets,
    claimable_interval,
    find_axial_zero,
)

#: the paper rig's axial thermal load per degC near 25 C (calibration.md Sec. 8.2)
SENS_N_PER_C = 18.46


def _offsets(residual: float, z: float, bounds: tuple[float, float] = (0.0, 300.0)) -> list:
    return axial_zero_offsets(
        np.array([0.0, residual]),
        np.array([0.0, z]),
        np.array([0.0, SENS_N_PER_C]),
        [1],
        ["dte", "bearing2_fz"],
        claimable_interval(bounds),
        25.0,
    )


def test_the_rule_on_analytic_residuals():
    assert claimable_interval((0.0, 300.0)) == pytest.approx((3.0, 297.0))
    # within the noise: nothing, whatever it would read as
    assert _offsets(-50.0, K_SIGMA * 0.9) == []
    # a temperature the calibration can claim (+60 C at 25 C): left to the static screen
    assert _offsets(60.0 * SENS_N_PER_C, 1e4) == []
    # below the declared temperature at the table's lower end, and +2.7 C (within 3 C of that end): a zero
    for r in (-67.0, 50.0):
        (z,) = _offsets(r, np.sign(r) * 1e3)
        assert z.column == "bearing2_fz" and z.offset_n == r
        assert z.implied_c == pytest.approx(r / SENS_N_PER_C)
        assert "'bearing2_fz'" in z.issue() and "zero offset" in z.issue()
    # at 125 C the same +50 N is a claimable +2.7 C
    assert _offsets(50.0, 1e3, (-100.0, 200.0)) == []
    # no sensitivity (a rig whose axial load does not follow the temperature): any offset is a zero
    none = axial_zero_offsets(
        np.array([40.0]), np.array([80.0]), np.zeros(1), [0], ["fz"], (3.0, 297.0), 25.0
    )
    assert len(none) == 1 and np.isinf(none[0].implied_c)


def _set_up(m):
    from gear_rotor_sim.calibration.channel_conventions import check_conventions
    from gear_rotor_sim.calibration.fit import Calibrator

    cal = Calibrator(m)
    return cal, check_conventions(cal)


@pytest.fixture(scope="module")
def record(shared_records):
    from gear_rotor_sim.calibration.measurement import load_measurement

    return shared_records["pinion_tooth"], load_measurement


def test_the_record_as_made_is_left_untouched(record):
    path, load = record
    m = load(path)
    data = m.data.copy()
    cal, _ = _set_up(m)
    assert find_axial_zero(cal) == []
    assert np.array_equal(cal.m.data, data)
    assert not any("zero offset" in i for i in cal.m.issues)


def test_an_axial_zero_offset_is_named_and_subtracted(record):
    path, load = record
    m = load(path)
    k = [c.column for c in m.channels].index("bearing2_fz")
    clean_mean = float(np.mean(m.data[:, k]))
    m.data[:, k] += 50.0
    cal, _ = _set_up(m)
    (issue,) = [i for i in cal.m.issues if "zero offset" in i]
    assert "'bearing2_fz'" in issue and "reads as +2.7" in issue
    # subtracted: the channel's mean is the record's own again (to the model's axial mean, 0 at 25 C)
    assert abs(float(np.mean(cal.m.data[:, k])) - clean_mean) < 0.5
    assert abs(float(cal.cmp.d_static[k])) < 0.5
    assert find_axial_zero(cal) == []


def test_a_real_temperature_offset_is_left_to_the_static_screen(tmp_path):
    from gear_rotor_sim.calibration.measurement import load_measurement
    from lumped_gearbox import make_record, write_record

    rec = make_record(3000.0, 25.0, ["temperature_offset:offset_c=60"], duration_s=0.6, seed=7)
    m = load_measurement(write_record(tmp_path / "t60.csv", rec))
    data = m.data.copy()
    cal, _ = _set_up(m)
    assert find_axial_zero(cal) == [] and np.array_equal(cal.m.data, data)
