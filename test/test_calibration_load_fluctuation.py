"""The fluctuating-load check (calibration/load_fluctuation.py) on short independent records with and without
a fluctuating output torque (lumped_gearbox load_profile)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from gear_rotor_sim.calibration.load_fluctuation import (
    MIN_RELATIVE,
    find_load_fluctuation,
    first_firing,
)
from gear_rotor_sim.calibration.measurement import load_measurement
from lumped_gearbox import make_record, write_record

RPM = 3000.0
#: shaft rates of the paper gearbox at 3000 rpm (29 / 49 teeth)
SHAFTS = [RPM / 60.0, RPM / 60.0 * 29.0 / 49.0]


def _record(tmp_path, name, faults=(), load_profile=None):
    rec = make_record(
        RPM, 25.0, list(faults), duration_s=0.8, seed=5, sampling="point", load_profile=load_profile
    )
    return load_measurement(write_record(tmp_path / f"{name}.csv", rec))


def _find(m):
    return find_load_fluctuation(m.data, m.sample_rate_hz, m.channels, SHAFTS)


def test_slow_load_fluctuation_is_read_with_its_frequency_and_depth(tmp_path):
    m = _record(tmp_path, "f10", load_profile={"amplitude_pct": 8.0, "frequency_hz": 10.0})
    found = first_firing(_find(m))
    assert found is not None and found.order is None
    assert abs(found.frequency_hz - 10.0) < 0.2
    # the radial means are modulated by the torque's 8 % (sensor gains cancel in x / mean)
    assert abs(abs(found.amplitude) - 0.08) < 0.1 * 0.08
    assert found.spread < 0.05
    text = found.describe(200.0)
    assert "operating_point.output_torque_nm" in text and "10 Hz" in text and "not a library fault" in text


def test_gear_order_load_fluctuation_is_read_and_its_dte_ratio_is_a_loads(tmp_path):
    m = _record(tmp_path, "g1", load_profile={"amplitude_pct": 10.0, "gear_order": 1.0})
    found = first_firing(_find(m))
    assert found is not None and (found.shaft, found.order) == (1, 1)
    assert abs(abs(found.amplitude) - 0.10) < 0.1 * 0.10
    # the DTE moves by its elastic part only (F / k of a mean that also holds the backlash offset)
    assert 0.05 < abs(found.dte_ratio) < 0.5
    # without the DTE an order-locked modulation is not read (an eccentric gear could not be told apart)
    keep = [k for k, c in enumerate(m.channels) if c.quantity != "dynamic_transmission_error"]
    no_dte = dataclasses.replace(m, data=m.data[:, keep], channels=tuple(m.channels[k] for k in keep))
    assert first_firing(_find(no_dte)) is None


@pytest.mark.parametrize(
    "faults",
    [
        (),
        ("gear_eccentricity:eccentricity_m=20e-6,phase_rad=-1.0",),
        ("mass_unbalance:node=5,unbalance_kg_m=3e-4,phase_rad=1.0",),
        ("tooth_damage:wheel=pinion,tooth=7,depth=0.4",),
    ],
)
def test_constant_load_records_do_not_fire(tmp_path, faults):
    """A healthy record, an eccentric gear (its DTE moves by the centre offset: rho >> 1), an unbalance (a
    rotating force: x and y not modulated alike) and a damaged tooth claim no fluctuating load."""
    cands = _find(_record(tmp_path, "const", faults))
    assert cands and first_firing(cands) is None
    non = next(c for c in cands if c.order is None)
    assert abs(non.amplitude) < 0.1 * MIN_RELATIVE


def test_one_radial_channel_reads_nothing(tmp_path):
    m = _record(tmp_path, "one", load_profile={"amplitude_pct": 8.0, "frequency_hz": 10.0})
    keep = [k for k, c in enumerate(m.channels) if c.column != "bearing2_fy"]
    one = dataclasses.replace(m, data=m.data[:, keep], channels=tuple(m.channels[k] for k in keep))
    assert _find(one) == []
    assert np.isfinite(m.data).all()


def test_demodulation_leaves_the_record_of_the_mean_load(tmp_path):
    """The load's sidebands removed: the modulation at f* drops below 5 % of itself and the mesh harmonic of
    the radial force equals the constant-load record's (same seed) within 3 %."""
    from gear_rotor_sim.calibration.load_demodulation import demodulate

    mod = _record(tmp_path, "f10", load_profile={"amplitude_pct": 8.0, "frequency_hz": 10.0})
    const = _record(tmp_path, "c", ())
    found = first_firing(_find(mod))
    mesh = [29.0 * RPM / 60.0]
    data, rms = demodulate(mod.data, mod.sample_rate_hz, found.frequency_hz, SHAFTS, mesh, found.shaft)
    left = next(
        c for c in find_load_fluctuation(data, mod.sample_rate_hz, mod.channels, SHAFTS) if c.order is None
    )
    assert abs(left.amplitude) < 0.05 * abs(found.amplitude)
    assert first_firing(find_load_fluctuation(data, mod.sample_rate_hz, mod.channels, SHAFTS)) is None
    k = [c.column for c in mod.channels].index("bearing2_fy")
    t = np.arange(data.shape[0]) / mod.sample_rate_hz

    def h1(x):
        return abs(np.mean((x - x.mean()) * np.exp(-2j * np.pi * mesh[0] * t)))

    assert abs(h1(data[:, k]) - h1(const.data[:, k])) < 0.03 * h1(const.data[:, k])
    assert abs(np.mean(data[:, k]) - np.mean(const.data[:, k])) < 0.01 * abs(np.mean(const.data[:, k]))
    assert rms[k] > 0.0


def test_the_calibrator_removes_a_fluctuating_load_and_says_so(tmp_path):
    """The hook (load_check.check_load): the setup is redone on the demodulated record, ``issues`` names
    ``operating_point.output_torque_nm`` and the modulation; a record at a constant load is left untouched."""
    from gear_rotor_sim.calibration.channel_conventions import check_conventions
    from gear_rotor_sim.calibration.fit import Calibrator

    def set_up(load_profile):
        rec = make_record(RPM, 25.0, [], duration_s=0.6, seed=23, load_profile=load_profile)
        cal = Calibrator(load_measurement(write_record(tmp_path / "r.csv", rec)))
        return cal, check_conventions(cal)

    cal, _ = set_up({"amplitude_pct": 8.0, "frequency_hz": 10.0})
    found = cal.load_fluctuation
    assert found is not None and abs(found.frequency_hz - 10.0) < 0.3
    (issue,) = [i for i in cal.m.issues if "output_torque_nm" in i]
    assert "the load fluctuates" in issue and "removed from every channel" in issue
    assert sum(n.startswith("load_fluctuation:") for n in cal.notes) == 1
    assert sum("model steps per mesh period" in n for n in cal.notes) == 1
    left = _find(cal.m)
    assert first_firing(left) is None
    # the comparison holds the corrected record: its radial means are the record's
    k = cal.cmp.names.index("bearing2_fy")
    assert cal.cmp.d_static[k] == pytest.approx(np.mean(cal.m.data[:, k]), rel=0.01)

    cal0, _ = set_up(None)
    assert cal0.load_fluctuation is None
    assert not [i for i in cal0.m.issues if "output_torque_nm" in i]
