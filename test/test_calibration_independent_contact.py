"""Bearing defects on data the model did not make (issue 11, contact point 3000 rpm / 25 C).

The record comes from ``lumped_gearbox`` (docs/independent_data.md): its defect pulses act between
race and housing and reach only the bearing-2 force channels, its mesh and shafts differ from the
finite-element model (mesh carriers off by tens of percent). Criteria of the issue: the defect is
named first, its impact force within 25 % of the injected one, the error at least halved. What
makes it hold (docs/history/calibration_sessions.md Sec. 8.5): the envelope of the non-synchronous part (every
shaft's synchronous average removed), analysed on the channels at a bearing, and the direct path of
the impact into the housing.

Also the synchronous-part removal itself against signals of known content.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gear_rotor_sim.calibration.features_orders import (
    leading_transient_s,
    remove_synchronous,
    sideband_ratios,
    synchronous_part,
)
from gear_rotor_sim.calibration.fit import Calibrator
from gear_rotor_sim.calibration.measurement import load_measurement

DURATION_S = 0.6  # 30 input revolutions at 3000 rpm: 17 envelope segments of 0.1 s


@pytest.mark.acceptance
@pytest.mark.slow
def test_outer_race_defect_named_first_with_its_force(tmp_path: Path) -> None:
    from lumped_gearbox import make_record, write_record

    rec = make_record(3000.0, 25.0, ["outer_race_defect:force_n=300"], duration_s=DURATION_S, seed=21)
    path = write_record(tmp_path / "outer.csv", rec)
    truth = json.loads(path.with_suffix(".truth.json").read_text())
    r = Calibrator(load_measurement(path)).run()
    assert r.effects, r.conclusion
    first = r.effects[0]
    assert first.label == "outer_race_defect@bearing2", [(e.label, e.parameters) for e in r.effects]
    force = first.parameters["force_n"]
    assert abs(force - 300.0) <= 0.25 * 300.0, (force, truth)
    assert r.error_after <= 0.5 * r.error_before, (r.error_before, r.error_after)


def test_synchronous_removal_keeps_what_is_not_periodic_with_a_shaft() -> None:
    """Shaft harmonics of both shafts (29/49 teeth, mesh at 1450 Hz) vanish to 0.2 % of their
    amplitude up to the third mesh harmonic; a tone at a non-synchronous rate passes; white noise
    keeps its power (the plain averages would take ``1/R`` of it per shaft of ``R`` revolutions)
    (independent truth: the construction)."""
    fs, n = 20000.0, 40000
    t = np.arange(n) / fs
    f1 = 50.0
    f2 = f1 * 29 / 49
    sync = sum(np.cos(2 * np.pi * k * f1 * t + 0.3 * k) for k in (1, 2, 29, 58, 87, 28, 30))
    sync = sync + sum(np.cos(2 * np.pi * k * f2 * t - 0.2 * k) for k in (1, 3, 48, 50, 97))
    tone = np.cos(2 * np.pi * 191.3 * t)
    left = remove_synchronous(sync + tone, fs, [f1, f2]) - tone
    assert np.std(left) <= 2e-3 * np.std(sync) + 0.03 * np.std(tone), (np.std(left), np.std(sync))
    noise = np.random.default_rng(1).standard_normal(n)
    # the plain synchronous averages (significance 0) take 1/R of the noise power per shaft; with the
    # 3-standard-error rule almost no noise order qualifies and the noise keeps its power
    plain = noise - sum(synchronous_part(noise, fs, f, significance=0.0) for f in (f1, f2))
    expected = 1.0 - 1.0 / int(n / fs * f1) - 1.0 / int(n / fs * f2)
    assert abs(np.var(plain) / np.var(noise) - expected) <= 0.01, (np.var(plain), expected)
    kept = np.var(remove_synchronous(noise, fs, [f1, f2])) / np.var(noise)
    assert abs(kept - 1.0) <= 0.005, kept


def test_leading_transient_found_and_steady_record_untouched() -> None:
    """Gear content of both shafts plus 2 % noise: no transient; with a free vibration at 1234 Hz
    (periodic with no shaft) decaying over the first 60 ms on one of two channels, the skipped head
    covers it (independent truth: the construction)."""
    fs, n = 20000.0, 40000
    t = np.arange(n) / fs
    f1, f2 = 50.0, 50.0 * 29 / 49
    gear = sum(np.cos(2 * np.pi * k * f1 * t + 0.3 * k) for k in (1, 29, 58)) + np.cos(
        2 * np.pi * 48 * f2 * t
    )
    rng = np.random.default_rng(3)
    x = np.column_stack([gear + 0.02 * np.std(gear) * rng.standard_normal(n) for _ in range(2)])
    assert leading_transient_s(x, fs, [f1, f2]) == 0.0
    x[:, 1] += 0.5 * np.exp(-t / 0.012) * np.sin(2 * np.pi * 1234.0 * t)
    head = leading_transient_s(x, fs, [f1, f2])
    assert 0.05 <= head <= 0.15, head


def test_leading_transient_takes_its_decaying_tail() -> None:
    """A free vibration (1234 Hz, tau 15 ms) whose first 50 ms window stands at about 48 x the noise RMS
    and whose second at about 2 x (from the construction: the window means of exp(-2 t / tau) over the
    noise variance): the skip covers both windows (before session 27 only the first, the second being
    below 3 x), and the third (1.002 x) is kept (history Sec. 8.76)."""
    fs, n = 20000.0, 40000
    t = np.arange(n) / fs
    f1, f2 = 50.0, 50.0 * 29 / 49
    rng = np.random.default_rng(5)
    sigma = 0.1
    x = sigma * rng.standard_normal((n, 1)) + np.cos(2 * np.pi * 29 * f1 * t)[:, None]
    tau = 0.015
    # second window: A^2 / 2 * mean(exp(-2 t / tau)) = 3 sigma^2 (RMS ratio 2)
    mean2 = tau / 2 * (np.exp(-2 * 0.05 / tau) - np.exp(-2 * 0.1 / tau)) / 0.05
    amp = np.sqrt(6.0 * sigma**2 / mean2)
    x[:, 0] += amp * np.exp(-t / tau) * np.sin(2 * np.pi * 1234.0 * t)
    assert leading_transient_s(x, fs, [f1, f2]) == pytest.approx(0.1)
    assert leading_transient_s(x, fs, [f1, f2], tail_ratio=3.0) == pytest.approx(0.05)


def test_sideband_ratios_of_an_amplitude_modulated_carrier() -> None:
    """A carrier at order 29 modulated by (1 + m cos(theta + phi)) has sidebands of ratio m/2 e^{+-i phi}
    at orders 28 and 30, whatever the carrier's amplitude or a common gain (the ratio cancels both)."""
    orders = np.arange(20, 40)
    m, phi = 0.3, 0.7
    for amp in (1.0, 250.0):
        coef = np.zeros(orders.size, dtype=complex)
        coef[orders == 29] = amp
        coef[orders == 30] = amp * m / 2 * np.exp(1j * phi)
        coef[orders == 28] = amp * m / 2 * np.exp(-1j * phi)
        r, idx = sideband_ratios(1.1 * coef, orders, 29, 1, 1)
        assert idx.tolist() == [[1, -1], [1, 1]]
        assert np.allclose(r, [m / 2 * np.exp(-1j * phi), m / 2 * np.exp(1j * phi)], rtol=1e-12)
