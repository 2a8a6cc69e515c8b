"""The mesh set read from the DTE mean where the FE model's teeth separate and the record's stay in contact
(``calibration/contact_mesh.py``; docs/history/calibration_sessions.md Sec. 8.77)."""

from gear_rotor_sim.calibration.contact_mesh import Z_TRIGGER, applies, pick_scale


def test_it_applies_only_where_the_model_rattles_and_the_dte_mean_stands_off():
    # blind05 (set 1): the nominal model's teeth separate 28.8 %, the DTE mean 14.6 sigma off
    assert applies(0.288, 14.6)
    # the table's wear records: the model in contact, the DTE mean 9-12 sigma off (read by the wear rules)
    assert not applies(0.0, 12.6)
    # the 8000 rpm rattle records: both models rattle, the DTE mean agrees (0.2-0.4 sigma)
    assert not applies(0.36, 0.37)
    assert not applies(0.3, Z_TRIGGER) and applies(0.3, -1.01 * Z_TRIGGER)


def test_the_scale_of_least_chi2_among_those_that_bring_the_mean_within_three_sigma():
    # (scale, DTE mean z, balanced chi^2): the chi^2 of blind05's healthy twin (reference_mesh_scan.py;
    # static family 54.8 / 58.7 / 0.084 / 0.134 per mean), the z read from it
    trials = [(0.8, 14.8, 2170.7), (1.25, 15.3, 1641.4), (1.6, 0.29, 914.5), (2.0, 0.37, 921.6)]
    assert pick_scale(trials) == (1.6, 914.5)
    # a lower chi^2 whose mean stays off is not taken; none within 3 sigma: nothing
    assert pick_scale([(1.25, 4.0, 10.0), (2.0, 2.9, 20.0)]) == (2.0, 20.0)
    assert pick_scale([(1.25, 4.0, 10.0)]) is None
