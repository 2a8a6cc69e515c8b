"""Force sensors that hold no mean (AC-coupled piezoelectric sensors; calibration/force_coupling.py)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from gear_rotor_sim.calibration.force_coupling import means_not_measured

CH = [
    SimpleNamespace(quantity="dynamic_transmission_error", direction=None),
    SimpleNamespace(quantity="bearing_force", direction="x"),
    SimpleNamespace(quantity="bearing_force", direction="y"),
    SimpleNamespace(quantity="bearing_force", direction="z"),
    SimpleNamespace(quantity="acceleration", direction="x"),
]
#: the healthy model's means at 3000 rpm, 125 C (DTE in m, forces in N) and each mean's noise variance
MODEL = np.array([4.2e-5, -497.0, -1365.0, 1846.0, 0.0])
VAR = np.array([1e-16, 0.8, 1.1, 0.5, np.inf])


@pytest.mark.parametrize(
    ("measured", "expect"),
    [
        # every force mean gone (a 0.5 Hz high-pass on all three): every force channel's mean left out
        ([4.1e-5, 0.31, -0.22, 0.05, 0.0], [1, 2, 3]),
        # only the radials read zero while the axial holds its thermal load: the sensors are still one kind
        ([4.1e-5, 0.31, -0.22, 1850.0, 0.0], [1, 2, 3]),
        # DC-coupled, gains 0.97-1.02: nothing
        ([4.1e-5, -485.0, -1391.0, 1840.0, 0.0], []),
        # one radial channel without its load, the other with it: a sensor fault of one channel, not this rule
        ([4.1e-5, 0.31, -1391.0, 1840.0, 0.0], []),
        # a radial mean at 1.5 % of the load but 8 noise deviations out: no mean (2 % of the model's)
        ([4.1e-5, -7.4, 8.2, 0.0, 0.0], [1, 2, 3]),
        # at 3 % of the load: a mean (a sensor at gain 0.03 is still read by the radial-mean issue, not here)
        ([4.1e-5, -15.0, -41.0, 0.0, 0.0], []),
    ],
)
def test_force_channels_without_a_mean_are_read_as_ac_coupled(measured, expect):
    assert means_not_measured(np.array(measured), VAR, MODEL, CH) == expect


def test_no_loaded_radial_channel_no_reading():
    """Without a radial load the model says the record must show, a zero mean says nothing (an unloaded
    gearbox, a rig without radial force channels)."""
    model = MODEL.copy()
    model[1:3] = [2.0, -3.0]  # within 30 noise deviations of zero
    assert means_not_measured(np.array([4.1e-5, 0.3, -0.2, 0.0, 0.0]), VAR, model, CH) == []
    keep = [0, 3, 4]  # no radial channel at all: the axial mean alone is never read as AC coupling
    got = means_not_measured(np.array([4.1e-5, 0.0, 0.0]), VAR[keep], MODEL[keep], [CH[k] for k in keep])
    assert got == []


@pytest.mark.acceptance
def test_an_ac_coupled_record_is_named_and_its_force_means_left_out(tmp_path):
    """A 0.6 s healthy 3000 rpm record at 125 C whose three force sensors are high-passed at 0.5 Hz (the
    generator's ``sensors``): the radial reactions and the 1.8 kN thermal axial load are gone. The issue names
    the three columns, the static family keeps the DTE's mean alone, and nothing is claimed (read as DC the
    axial zero was taken for a -100 C temperature and subtracted as a zero; history Sec. 8.62)."""
    from gear_rotor_sim.calibration.fit import Calibrator
    from gear_rotor_sim.calibration.measurement import load_measurement
    from lumped_gearbox import make_record, write_record
    from lumped_gearbox.sensors import SensorFilter

    hp = SensorFilter("highpass", 0.5)
    sensors = {c: hp for c in ("bearing2_fx", "bearing2_fy", "bearing2_fz")}
    rec = make_record(3000.0, 125.0, [], duration_s=0.6, seed=36, sensors=sensors)
    res = Calibrator(load_measurement(write_record(tmp_path / "ac.csv", rec))).run()
    found = [i for i in res.measurement.issues if i.startswith("bearing-force channels hold no mean")]
    assert len(found) == 1 and all(c in found[0] for c in sensors)
    assert set(res.score_after.per_channel["static"]) == {"dte"}
    assert not res.effects
