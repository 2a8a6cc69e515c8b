"""The breathing shaft crack in the calibration (``calibration/candidates_crack.py``, docs/calibration.md
Secs. 3, 4): named on a record of the independent generator's crack, and the phase grid it is fitted on (the
claim check's patterns of a crack: ``test_calibration_claim_check.py``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gear_rotor_sim.calibration.fit import Calibrator
from gear_rotor_sim.calibration.measurement import load_measurement
from gear_rotor_sim.config import load_config
from gear_rotor_sim.faults.crack import ShaftCrack
from gear_rotor_sim.simulator import Simulator
from lumped_gearbox import make_record, write_record

LOSS, PHASE = 0.3, 0.7
CRACK = f"shaft_crack:shaft=pinion,stiffness_loss={LOSS},phase_rad={PHASE}"


def _crack_named_with_its_loss_and_phase(r):
    """The first effect of the result ``r``: the crack at the pinion seat, its loss within 25 % and its phase
    within 0.35 rad of the generator's, the error at least halved, and the form kept the one without the
    bearings' tilt damping (the generator's shaft has pinned ends, history Sec. 8.64), reported as such."""
    assert r.effects, r.conclusion
    first = r.effects[0]
    assert first.label == "shaft_crack@node5", [(e.label, e.confidence) for e in r.effects]
    assert abs(first.parameters["stiffness_loss"] / LOSS - 1.0) < 0.25, first.parameters
    assert abs(math.remainder(first.parameters["phase_rad"] - PHASE, 2.0 * math.pi)) < 0.35, first.parameters
    assert r.error_after <= 0.5 * r.error_before, (r.error_before, r.error_after)
    assert first.as_dict()["model_form"]["bearing_tilt_damping"] is False
    return first


@pytest.mark.acceptance
def test_crack_of_the_independent_generator_is_named_with_its_loss_and_phase(tmp_path) -> None:
    """A breathing crack on the pinion shaft of the independent lumped gearbox (its own model: the crack on
    the lumped lateral spring, breathing on the instantaneous deflection; 3000 rpm, 0.6 s): the library's
    crack is named first, its loss within 25 % of the generator's (the loss reported as a fraction of the
    node's shaft-and-bearing spring, the generator's convention; the crack fitted with and without the
    bearings' tilt damping in its response, history Sec. 8.64: 0.305 measured; 0.354 with the free dynamic
    gain alone, Sec. 8.61), its phase within 0.35 rad (two grid steps of pi / 29), the error at least
    halved, and the claim check leaves it confident."""
    rec = make_record(3000.0, 25.0, [CRACK], duration_s=0.6, seed=44)
    r = Calibrator(load_measurement(write_record(tmp_path / "crack.csv", rec))).run()
    first = _crack_named_with_its_loss_and_phase(r)
    assert first.status == "found" and first.confidence > 0.5
    assert not any(e.label.startswith("tooth_damage") for e in r.effects)


@pytest.mark.acceptance
def test_crack_loss_against_a_reference_baseline(tmp_path, reference_2000) -> None:
    """The same crack record diagnosed against the machine's baseline fitted on a healthy 2000 rpm record of
    the generator (``--baseline``, the shared 0.6 s reference of conftest.py: its bearing scale lowers the
    node's support spring, its carrier tolerance reweights the features): the loss, reported on the nominal
    machine's support spring, within 25 % of the generator's, its phase within 0.35 rad, the error at least
    halved (history Sec. 8.67: session 23's code read the table's 2 s record 0.457, +52 %, keeping the
    tilt-damped form on the whole chi^2; with its three switches off this test reads 0.457 and fails). The
    crack is the only candidate offered: what is tested is its fit
    against the updated model, not the ranking (the table benchmark's row)."""
    rec = make_record(3000.0, 25.0, [CRACK], duration_s=0.6, seed=44)
    m = load_measurement(write_record(tmp_path / "crack.csv", rec))
    r = Calibrator(m, candidates=[ShaftCrack(node=5)], **reference_2000.calibrator_kwargs()).run()
    _crack_named_with_its_loss_and_phase(r)


def test_a_crack_phase_one_mesh_period_on_is_the_response_one_mesh_period_later() -> None:
    """The fit's phase grid (``candidates_crack.py``): the healthy model is periodic over a mesh period, so
    the crack's response at ``phase - 2 pi / z`` is its response at ``phase`` delayed by one mesh period
    (static and dynamic share alike). Checked on the simulator after the start-up transient, relative to the
    crack's own response."""
    cfg = load_config("paper_sun2021")
    fs, speed, z = 20000.0, 3000.0, 29
    channels = ["bearing2_fx", "bearing2_fy", "node5_ay", "dte"]
    dyn = (1e-6 + 0.5e-6j, 2e-8j, 0.0, 0.0, 0.0, 0.5e-6 - 1e-6j, 1e-8, 0.0, 0.0, 0.0)

    def run(effects: list) -> np.ndarray:
        sim = Simulator(cfg, speed, 25.0, fs, channels=channels, effects=effects)
        return sim.advance(0.5).data

    healthy = run([])
    a = run([ShaftCrack(stiffness_loss=0.3, phase_rad=0.7, mesh_deflection=dyn)]) - healthy
    later = 0.7 - 2.0 * math.pi / z
    b = run([ShaftCrack(stiffness_loss=0.3, phase_rad=later, mesh_deflection=dyn)]) - healthy
    period = fs / (z * speed / 60.0)  # samples per mesh period (13.79: not whole, so compare in the spectrum)
    n0 = int(0.25 * fs)
    sa = np.fft.rfft(a[n0:], axis=0)
    sb = np.fft.rfft(b[n0:], axis=0)
    f = np.fft.rfftfreq(a.shape[0] - n0, 1.0 / fs)
    want = sa * np.exp(-2j * np.pi * f * period / fs)[:, None]
    lines = np.abs(sa) > 0.05 * np.abs(sa).max(axis=0)
    err = np.abs(sb - want)[lines].max() / np.abs(sa).max()
    assert err < 0.05, err
