"""Eccentricity at the contact point (3000 rpm, 25 C) on data the model did not make (issue 11).

A 15 um pinion eccentricity passed in session 5 (-3 %) and was then no longer claimed: the model
run's start-up from static equilibrium separated the teeth for two steps, the simulator's dt rule ran
its contact-loss setting into the analysed window, and the envelope of the non-synchronous part read
that switch as a misfit that does not scale with the eccentricity (``calibration/model_settle.py``,
docs/history/calibration_sessions.md Sec. 8.7). Checked here: the switch and its removal on the FE model
against the same run with the rule off, the window logic against a scripted simulator, and the diagnosis of a
``lumped_gearbox`` record.
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from gear_rotor_sim.calibration.features_orders import remove_synchronous
from gear_rotor_sim.calibration.fit import Calibrator
from gear_rotor_sim.calibration.measurement import load_measurement
from gear_rotor_sim.calibration.model_settle import run_settled, whole_period_samples
from gear_rotor_sim.calibration.model_window import hunting_period_s

FS = 20000.0
SPEED = 3000.0


class _ScriptedSim:
    """Emits its output index as the signal; the dt rule's setting is 1 on [on, off) samples, else 0."""

    def __init__(self, on: int, off: int) -> None:
        self.on, self.off, self.n = on, off, 0
        self.last_chunk_stats: dict[str, float] = {}

    def advance(self, duration: float) -> SimpleNamespace:
        end = int(np.ceil((self.n / FS + duration) * FS - 1e-9))
        data = np.arange(self.n, end, dtype=float)[:, None]
        self.n = end
        loss = float(self.on <= end - 1 < self.off)
        self.last_chunk_stats = {"decimation": 3.0 + 13.0 * loss, "contact_loss_rule": loss}
        return SimpleNamespace(data=data)


def test_window_moves_by_whole_periods_past_a_rule_switch() -> None:
    """The window starts at sample 3000 (0.15 s) and lasts 12000; the scripted rule is in its
    contact-loss setting from 1600 to 3600 (a start-up separation). The window moves on by one period
    (19600 samples: 0.98 s at 3000 rpm) and holds the samples of that later time; a switch ending
    before the settling margin (50 ms = 1000 samples) leaves it in place, and without a whole-sample
    period it is returned unmoved and marked unsettled."""
    period = whole_period_samples(0.98, FS)
    assert period == 19600
    run = run_settled(_ScriptedSim(1600, 3600), 3000, 12000, FS, period)
    assert run.settled and run.shifts == 1 and run.first_index == 3000 + 19600
    assert run.data[0, 0] == 3000 + 19600 and run.data.shape == (12000, 1)
    early = run_settled(_ScriptedSim(600, 1900), 3000, 12000, FS, period)
    assert early.settled and early.shifts == 0 and early.data[0, 0] == 3000
    assert whole_period_samples(0.98 + 0.3 / FS, FS) is None
    stuck = run_settled(_ScriptedSim(1600, 3600), 3000, 12000, FS, None)
    assert not stuck.settled and stuck.shifts == 0 and stuck.data[0, 0] == 3000


@pytest.mark.slow
def test_settled_window_of_an_eccentric_pinion_matches_the_run_without_rule_switches() -> None:
    """FE paper gearbox, 15 um pinion eccentricity: the start-up separates the teeth and the dt rule's
    contact-loss setting reaches into the window after the 0.15 s warm-up. The non-synchronous RMS
    of ``bearing2_fy`` in the window's first 50 ms is several times that of the same run with the rule
    off (``contact_loss_rate_hz=None``: no switch; independent of the window logic); the settled window
    equals the rule-off level within 20 %. At -2 rad: with the eccentricity's profile error and whirl
    from one centre offset (docs/history/calibration_sessions.md Sec. 8.33) the start-up at 0.5 rad stays in
    contact (measured 19.8 N against 0.51 N rule-off at -2 rad, 38 times; at 0.5 rad 1.0 times)."""
    from gear_rotor_sim.calibration.residual import cached_system
    from gear_rotor_sim.config import load_config
    from gear_rotor_sim.faults import GearEccentricity
    from gear_rotor_sim.simulator import Simulator

    cfg = load_config("paper_sun2021")
    ecc = (GearEccentricity(member="pinion", eccentricity_m=15e-6, phase_rad=-2.0),)
    shafts = [SPEED / 60.0, SPEED / 60.0 * 29 / 49]
    i0, n = 3000, 12000

    def sim(**kw) -> Simulator:
        return Simulator(
            cfg, SPEED, 25.0, FS, ["bearing2_fy"], effects=ecc, system_builder=cached_system, **kw
        )

    def head_rms(x: np.ndarray) -> float:
        return float(np.std(remove_synchronous(x, FS, shafts)[:1000]))

    plain = sim().advance((i0 + n) / FS).data[i0 : i0 + n, 0]
    off = sim(contact_loss_rate_hz=None).advance((i0 + n) / FS).data[i0 : i0 + n, 0]
    period = whole_period_samples(hunting_period_s(cfg, SPEED), FS)
    run = run_settled(sim(), i0, n, FS, period)
    ref = head_rms(off)
    assert head_rms(plain) > 5.0 * ref, (head_rms(plain), ref)
    assert run.shifts >= 1 and run.settled
    assert abs(head_rms(run.data[:, 0]) - ref) <= 0.2 * ref, (head_rms(run.data[:, 0]), ref)


@pytest.mark.acceptance
@pytest.mark.slow
def test_pinion_eccentricity_named_first_within_25_percent(tmp_path: Path) -> None:
    """``lumped_gearbox`` record (0.6 s, 3000 rpm, 25 C, 15 um pinion eccentricity at 0.5 rad, seed
    of the benchmark row): named first, within 25 %, error at least halved (issue 11 acceptance)."""
    from lumped_gearbox import make_record, write_record

    rec = make_record(
        SPEED, 25.0, ["pinion_eccentricity:eccentricity_m=15e-6,phase_rad=0.5"], duration_s=0.6, seed=13
    )
    path = write_record(tmp_path / "pinion_ecc.csv", rec)
    r = Calibrator(load_measurement(path)).run()
    assert r.effects, r.conclusion
    first = r.effects[0]
    assert first.name == "pinion_eccentricity", [(e.label, e.parameters) for e in r.effects]
    assert abs(first.parameters["eccentricity_m"] - 15e-6) <= 0.25 * 15e-6, first.parameters
    assert r.error_after <= 0.5 * r.error_before, (r.error_before, r.error_after)
