"""A held reference set aside where its machine scores the record worse than the nominal machine
(``calibration/reference_point.py``; docs/history/calibration_sessions.md Sec. 8.77)."""

import math

from gear_rotor_sim.calibration.reference_point import HELD_OVER_NOMINAL, ReferencePoint, reference_point


def _prepared(record, baseline):
    """A calibrator against the held ``baseline`` brought to its first round (as ``Calibrator.run``)."""
    from gear_rotor_sim.calibration.channel_conventions import check_conventions
    from gear_rotor_sim.calibration.fit import Calibrator
    from gear_rotor_sim.calibration.line_removal import remove_unlocked_lines
    from gear_rotor_sim.calibration.measurement import load_measurement

    cal = Calibrator(load_measurement(record), baseline=baseline, carrier_tolerance=0.5)
    cal._feat_correction = None
    remove_unlocked_lines(cal)
    check_conventions(cal)
    cal._prepare_comparison()
    return cal


def test_the_ratio_and_its_limit():
    # blind10 (set 1): the 5851 rpm reference's machine (mesh x0.36) at 2970 rpm, and a machine that describes
    off = ReferencePoint(44.14, 22.36, 2970.0, 5851.0)
    on = ReferencePoint(15.0, 14.0, 3000.0, 2000.0)
    assert math.isclose(off.ratio, 44.14 / 22.36) and not off.describes()
    assert on.describes()
    assert ReferencePoint(HELD_OVER_NOMINAL * 10.0, 10.0, 1.0, 2.0).describes()
    assert "5851 rpm" in off.note() and "2970 rpm" in off.note()
    assert off.as_dict()["limit"] == HELD_OVER_NOMINAL


def test_a_mode_placing_mesh_scale_is_set_aside_at_another_speed(shared_records):
    """The independent generator's healthy 3000 rpm record against the FE machine with the mesh scale a
    5851 rpm reference took (x0.36, its mesh mode moved from 5.2 to 3.4 kHz, between that speed's first two
    mesh harmonics): worse than the nominal machine by more than the limit; the bearing set alone (x0.7, the
    same reference's) is not."""
    from gear_rotor_sim.faults import BearingStiffnessDamping, MeshStiffnessDamping

    bearing = BearingStiffnessDamping(stiffness_scale=0.703)
    cal = _prepared(shared_records["healthy_3000"], [MeshStiffnessDamping(stiffness_scale=0.36), bearing])
    held = cal.cmp.score(cal._features(cal.base_raw))
    off = reference_point(cal, held)
    assert not off.describes(), off
    # the calibrator's state is left as it was: the held machine scores the same afterwards
    again = cal.cmp.score(cal._features(cal.base_raw))
    assert math.isclose(again.error, held.error, rel_tol=1e-12)
    cal = _prepared(shared_records["healthy_3000"], [bearing])
    on = reference_point(cal, cal.cmp.score(cal._features(cal.base_raw)))
    assert on.describes(), on
