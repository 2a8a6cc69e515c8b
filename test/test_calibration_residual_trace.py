"""The residual trace (``calibration/residual_trace.py``, docs/calibration.md Sec. 5): its shares against the
score's own per-channel errors, its reading of a fault the library does not have, and that it changes
nothing in the calibration."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gear_rotor_sim.calibration import fit as fit_module
from gear_rotor_sim.calibration.fit import Calibrator
from gear_rotor_sim.calibration.measurement import load_measurement
from gear_rotor_sim.calibration.report import result_json, write_report
from gear_rotor_sim.calibration.residual_signatures import profile_patterns
from lumped_gearbox import make_record, write_record


@pytest.fixture(scope="module")
def healthy(healthy_3000_calibration):
    """A healthy 0.6 s record at 3000 rpm / 25 C calibrated without a reference: the session's
    (``conftest.healthy_3000_calibration``, seed 1; this file made its own, seed 41, before session 25:
    docs/history/calibration_sessions.md Sec. 8.72)."""
    return healthy_3000_calibration


@pytest.mark.acceptance
def test_shares_are_the_scores_per_channel_errors(healthy):
    """Each channel's share of ``E^2`` from the score's per-channel normalised errors (``per_channel``:
    ``sqrt(chi2_c / n_c)`` per family) and feature counts: an independent route to the trace's sums."""
    res, tr = healthy, healthy.residual_trace
    assert not res.effects
    assert tr["consistent"]
    assert sum(tr["shares_by_channel"].values()) == pytest.approx(1.0, abs=1e-9)
    assert sum(tr["shares_by_family"].values()) == pytest.approx(1.0, abs=1e-9)
    sc, cmp = res.score_after, res.comparison
    fams = [f for f in sc.chi2 if sc.n[f] > 0]
    assert set(fams) == {"order", "envelope", "static"}
    chi2_c: dict[str, dict[str, float]] = {f: {} for f in fams}
    for c, name in enumerate(cmp.names):
        n_order = 2 * sum(int(np.count_nonzero(np.isfinite(v))) for v in cmp.v_order[c])
        chi2_c["order"][name] = sc.per_channel["order"][name] ** 2 * n_order
        if name in sc.per_channel["envelope"]:
            chi2_c["envelope"][name] = sc.per_channel["envelope"][name] ** 2 * cmp.d_env[c].size
        if name in sc.per_channel["static"]:
            chi2_c["static"][name] = sc.per_channel["static"][name] ** 2
    for f in fams:  # the counts reproduce the score's totals
        assert sum(chi2_c[f].values()) == pytest.approx(sc.chi2[f], rel=1e-9)
    for name in cmp.names:
        want = sum(chi2_c[f].get(name, 0.0) / (len(fams) * sc.n[f]) for f in fams) / sc.error**2
        assert tr["shares_by_channel"].get(name, 0.0) == pytest.approx(want, rel=1e-6, abs=1e-12)
    # where the model predicts more than the record holds nothing is read: no reading on a healthy record
    assert tr["readings"] == []
    # the components' largest features in units of noise: finite, and r / sigma bounded by E * sqrt(N)
    for comp in tr["components"]:
        assert math.isfinite(comp["largest"]["measured_over_noise"])
        assert comp["largest"]["normalised_residual"] <= sc.error * math.sqrt(sc.n_total)


def test_profile_patterns():
    assert profile_patterns(np.array([9.0, 0.5, 0.2, 0, 0, 0])) == ["1x"]
    assert set(profile_patterns(np.array([3.0, 5.0, 2.0, 0, 0, 0]))) == {"2x", "1x-3x"}
    assert set(profile_patterns(np.array([0.2, 6.0, 0.1, 3.0, 0.1, 0.6]))) == {"2x", "even"}
    assert "broad" in profile_patterns(np.ones(6))
    assert profile_patterns(np.zeros(6)) == []


@pytest.mark.acceptance
def test_cardan_joint_traced_to_the_input_shafts_even_orders(tmp_path):
    """A Cardan joint at the input (a fault the library does not have), 8000 rpm: the largest share of the
    final error is in the input shaft's low orders at a pinion-side channel, where the record holds more than
    the model; its profile is even (2x), and the reading names the Cardan joint among the effects outside the
    library (the library's shaft_misalignment, a lateral 2x force at the coupling, takes part of it)."""
    rec = make_record(
        8000.0, 25.0, ["cardan_misalignment:angle_rad=0.06,phase_rad=0.4"], duration_s=0.6, seed=43
    )
    res = Calibrator(load_measurement(write_record(tmp_path / "cardan.csv", rec))).run()
    tr = res.residual_trace
    assert tr["consistent"]
    top = tr["components"][0]
    assert (top["channel"], top["family"]) == ("bearing2_fy", "shaft orders (input)")
    assert top["largest"]["at"] == "order 2"
    assert top["model_lacks_share"] > 0.5 * top["share"]
    rd = tr["readings"][0]
    md = write_report(res, tmp_path / "report", figures=False)["markdown"].read_text()
    assert "## Where the remaining residual is (residual trace)" in md
    assert "| bearing2_fy | shaft orders (input) |" in md and "Cardan" in md
    assert rd["component"] == "bearing2_fy: shaft orders (input)"
    assert "even" in rd["patterns"] and rd["profile"]["2x"] > 0.8
    assert any("Cardan" in x for x in rd["outside_the_library"])


@pytest.mark.acceptance
def test_trace_changes_nothing_in_the_calibration(shared_records, pinion_tooth_calibration, monkeypatch):
    """The shared pinion-tooth calibration with and without the trace: the same JSON but for the field (and
    the count of model runs, which the second calibration takes from the runner's cache)."""
    monkeypatch.setattr(fit_module, "trace_residual", lambda *a, **k: {})
    plain = result_json(Calibrator(load_measurement(shared_records["pinion_tooth"])).run())
    traced = result_json(pinion_tooth_calibration)
    assert traced.pop("residual_trace")["components"]
    assert "residual_trace" not in plain
    # the claim check reads the trace (claim_check.py): without it nothing is checked; the claim here is true
    assert [c["suspect"] for c in traced.pop("claim_checks")] == [False]
    assert "claim_checks" not in plain
    # the second calibration in this process takes its model runs from the runner's cache
    plain.pop("n_simulations"), traced.pop("n_simulations")
    # the same JSON but for round-off: a model run from the cache and one computed in this process may
    # differ in the last digits (~1e-10 relative), which a fit's conditioning amplifies (a candidate's
    # phase 1e-7 relative apart, seen under load); a trace that changed the calibration changes decisions
    # (names, keys, counts) or values far above 1e-5
    _assert_same(traced, plain, "")


#: relative tolerance of the calibrations' floats; absolute for angles (rad) that may sit near zero
REL_TOL, ANGLE_TOL_RAD = 1e-5, 1e-5


def _assert_same(a: object, b: object, where: str) -> None:
    """``a`` and ``b`` equal, floats within ``REL_TOL`` (angles ``ANGLE_TOL_RAD``); names the field."""
    if isinstance(a, float) and isinstance(b, float):
        abs_tol = ANGLE_TOL_RAD if where.endswith("_rad") else 0.0
        assert math.isclose(a, b, rel_tol=REL_TOL, abs_tol=abs_tol) or a == b, f"{where}: {a!r} != {b!r}"
    elif isinstance(a, dict) and isinstance(b, dict):
        assert sorted(a) == sorted(b), f"{where}: keys {sorted(a)} != {sorted(b)}"
        for k in a:
            _assert_same(a[k], b[k], f"{where}/{k}")
    elif isinstance(a, list) and isinstance(b, list):
        assert len(a) == len(b), f"{where}: length {len(a)} != {len(b)}"
        for n, (u, v) in enumerate(zip(a, b, strict=True)):
            _assert_same(u, v, f"{where}/{n}")
    else:
        assert a == b, f"{where}: {a!r} != {b!r}"
