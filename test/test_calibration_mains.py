"""Mains interference nobody declared (issue 11; calibration/mains_check.py, docs/calibration.md Sec. 1,
history Sec. 8.51): a line at 50/60 Hz or a harmonic that is no shaft's order is named; one on a shaft order
is named when the fitted model leaves it unexplained. Each rule on a short generator record with and without
the line."""

from __future__ import annotations

import copy
import math
from types import SimpleNamespace

import numpy as np
import pytest

from gear_rotor_sim.calibration import mains_check as mc


def _with_line(x: np.ndarray, fs: float, f_hz: float, amp: float, phase: float = 0.3) -> np.ndarray:
    return x + amp * np.sin(2.0 * math.pi * f_hz * np.arange(x.size) / fs + phase)


def test_a_mains_line_off_every_order_is_found_on_its_channel_only(shared_records):
    """The shared healthy 2000 rpm record (0.6 s): 50 Hz is no order of either shaft (33.3 Hz input,
    19.7 Hz output). A 50 Hz line at 0.3 RMS on node5_ay, absent from the model, is named on that channel
    and nowhere else; the record without it, or with the same line in the model, names nothing."""
    from gear_rotor_sim.calibration.measurement import load_measurement

    m = load_measurement(shared_records["healthy_2000"])
    fs, y = m.sample_rate_hz, m.data
    names = [c.column for c in m.channels]
    sp = m.operating_point.speed_rpm / 60.0
    shafts = [("input", sp), ("output", sp * 29.0 / 49.0)]
    k = names.index("node5_ay")
    hum = y.copy()
    hum[:, k] = _with_line(y[:, k], fs, 50.0, math.sqrt(2) * 0.3 * float(np.std(y[:, k])))
    found = mc.off_order_lines(hum, y, fs, names, shafts)
    assert [(x["channel"], x["mains_hz"], x["harmonic"]) for x in found] == [("node5_ay", 50.0, 1)]
    assert abs(found[0]["frequency_hz"] - 50.0) <= mc.EXACT_HZ
    assert found[0]["over_local"] > mc.LINE_SNR
    assert mc.off_order_lines(y, y, fs, names, shafts) == []
    assert mc.off_order_lines(hum, hum, fs, names, shafts) == []  # the model holds the line: the machine's


def test_a_line_beside_the_mains_frequency_is_not_mains(shared_records):
    """A line 1 Hz off 50 Hz (a machine's component, not the supply) is not named."""
    from gear_rotor_sim.calibration.measurement import load_measurement

    m = load_measurement(shared_records["healthy_2000"])
    fs, y = m.sample_rate_hz, m.data
    names = [c.column for c in m.channels]
    sp = m.operating_point.speed_rpm / 60.0
    k = names.index("node5_ay")
    off = y.copy()
    off[:, k] = _with_line(y[:, k], fs, 51.0, math.sqrt(2) * 0.3 * float(np.std(y[:, k])))
    assert mc.off_order_lines(off, y, fs, names, [("input", sp), ("output", sp * 29.0 / 49.0)]) == []


@pytest.mark.acceptance
def test_a_line_on_a_shaft_order_is_named_only_when_the_model_leaves_it_unexplained(
    pinion_tooth_calibration,
):
    """The shared pinion-tooth calibration (3000 rpm: every input-shaft order is a 50 Hz harmonic): its
    own trace names nothing; the same trace with an input-shaft order 1 component that the model lacks and
    that holds most of the final error is named as a line on the 50 Hz mains frequency."""
    res = pinion_tooth_calibration
    cal = SimpleNamespace(cmp=res.comparison)
    assert mc.mains_issues(cal, res.residual_trace, res.model_after) == []
    trace = copy.deepcopy(res.residual_trace)
    hum = {
        "channel": "node5_ay",
        "family": "shaft orders (input)",
        "share": 0.8,
        "model_lacks_share": 0.8,
        "largest_lacking_residual": 90.0,
        "n_features": 6,
        "largest": {
            "at": "order 1",
            "measured_over_noise": 95.0,
            "model_over_noise": 4.0,
            "normalised_residual": 90.0,
        },
    }
    trace["components"] = [hum, *trace.get("components", [])]
    issues = mc.mains_issues(cal, trace, res.model_after)
    assert len(issues) == 1 and "'node5_ay'" in issues[0] and "50 Hz mains" in issues[0]
    for change in ({"model_lacks_share": 0.2}, {"largest": {**hum["largest"], "model_over_noise": 40.0}}):
        trace["components"][0] = {**hum, **change}
        assert mc.mains_issues(cal, trace, res.model_after) == []
    # order 3 of the output shaft (88.8 Hz) is no mains harmonic
    out3 = {**hum["largest"], "at": "order 3"}
    trace["components"][0] = {**hum, "family": "shaft orders (output)", "largest": out3}
    assert mc.mains_issues(cal, trace, res.model_after) == []


def test_no_mains_check_without_the_order_family():
    """Without orders (no mesh: the CWRU rig) the speed is nominal: nothing is examined."""
    cmp = SimpleNamespace(families=("envelope",), shafts=())
    assert mc.mains_issues(SimpleNamespace(cmp=cmp), {}, np.zeros((0, 1))) == []
