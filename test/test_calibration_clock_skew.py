"""A sample clock that is not the declared one, a model window moved by a fractional hunting period, and
one channel delayed by the acquisition (issue 11; docs/history/calibration_sessions.md Sec. 8.57).

Checked against injected truths: the fractional delay against analytic sinusoids; the moved window of a
scripted simulator whose hunting period is not a whole number of samples against the signal at the
original instants (before session 21 it was not moved); the speed check's clock reading against the
clock a generator record was made with; each channel's delay read from the order features against the
delay put on one channel, synthetic and on a short ``lumped_gearbox`` record.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from gear_rotor_sim.calibration.channel_skew import ChannelDelay, channel_delays, read_delays, skew_fix
from gear_rotor_sim.calibration.fractional_delay import delay_samples
from gear_rotor_sim.calibration.model_settle import run_settled, window_period_samples
from gear_rotor_sim.calibration.sample_clock import clock_alternative, clock_ratio

FS = 20000.0


@pytest.mark.parametrize("d", [0.37, 2.6, -1.25, 3.0])
def test_delay_samples_moves_lines_by_their_phase(d: float) -> None:
    """``y[i] = x(i - d)``: lines from 50 Hz to 0.45 fs within 3e-4 of the analytic delayed line away
    from the ends (the kernel's half-width); a whole-sample delay moves the samples exactly."""
    t = np.arange(6000) / FS
    for f in (50.0, 1450.0, 4350.0, 9000.0):
        x = np.cos(2 * np.pi * f * t + 0.4)
        y = delay_samples(x, d)
        ref = np.cos(2 * np.pi * f * (t - d / FS) + 0.4)
        assert np.max(np.abs(y - ref)[64:-64]) < 3e-4, (f, d)
    if d == round(d):
        x = np.random.default_rng(1).standard_normal(500)
        assert np.array_equal(delay_samples(x, d)[3:], x[:-3])
        # read 3 samples earlier, the last 3 hold the last sample (mirrored ends put a kink there that the
        # envelope family read as a line 470 times its noise, Sec. 8.57)
        assert np.array_equal(delay_samples(x, -d)[-3:], np.full(3, x[-1]))


class _PeriodicSim:
    """A band-limited signal periodic in ``period`` samples (fractional) at the output indices; the dt
    rule's setting is 1 on output samples [on, off), else 0 (as ``test_calibration_contact_eccentricity``)."""

    def __init__(self, period: float, on: int, off: int) -> None:
        self.period, self.on, self.off, self.n = period, on, off, 0
        self.last_chunk_stats: dict[str, float] = {}

    def signal(self, k: np.ndarray) -> np.ndarray:
        ph = 2 * np.pi * k / self.period
        return np.cos(3 * ph + 0.2) + 0.5 * np.sin(1811 * ph) + 0.2 * np.cos(7000 * ph - 1.0)

    def advance(self, duration: float) -> SimpleNamespace:
        end = int(np.ceil((self.n / FS + duration) * FS - 1e-9))
        data = self.signal(np.arange(self.n, end, dtype=float))[:, None]
        self.n = end
        loss = float(self.on <= end - 1 < self.off)
        self.last_chunk_stats = {"decimation": 3.0 + 13.0 * loss, "contact_loss_rule": loss}
        return SimpleNamespace(data=data)


def test_window_moves_by_a_fractional_period_and_reads_the_original_instants() -> None:
    """Hunting period 0.98 s x 1.003 (a record at 2991 rpm, or a clock 0.3 % fast): 19658.8 samples. A
    start-up switch of the rule from 1600 to 3600 moves the window (3000 + 12000 samples) on by one period,
    19659 whole samples, and the moved window is read 0.2 samples earlier: it equals the signal at the
    original instants 3000.. within 1e-3 (lines up to 0.36 fs). Before session 21 such a period gave
    ``None`` and the window stayed where the switch was."""
    period = window_period_samples(0.98 * 1.003, FS)
    assert period == pytest.approx(19658.8)
    sim = _PeriodicSim(period, 1600, 3600)
    run = run_settled(sim, 3000, 12000, FS, period)
    assert run.settled and run.shifts == 1 and run.first_index == 3000 + 19659
    want = sim.signal(np.arange(3000, 15000, dtype=float))
    assert np.max(np.abs(run.data[:, 0] - want)) < 1e-3
    whole = window_period_samples(0.98, FS)
    assert whole == 19600 and isinstance(whole, int)


def test_clock_alternative_names_the_ratio() -> None:
    """A record at the declared 3000 rpm whose clock runs 0.3 % fast reads 3000 / 1.003 rpm: the clause
    names 0.3 % fast and the true rate 20060 Hz."""
    measured = 3000.0 / 1.003
    assert clock_ratio(3000.0, measured) == pytest.approx(1.003, abs=1e-12)
    text = clock_alternative(3000.0, measured, FS)
    assert "0.3 % fast" in text and "20060 Hz" in text
    assert "0.3 % slow (19940 Hz" in clock_alternative(3000.0, 3000.0 / 0.997, FS)


def test_speed_check_names_the_clock_of_a_generator_record(tmp_path: Path) -> None:
    """``lumped_gearbox`` 3000 rpm, 0.5 s, made at 20060 Hz and written with the declared 20000 Hz time
    column (``benchmarks/undeclared_probe.clock_error``): the speed check reads 3000 / 1.003 rpm (within
    0.01 rpm) and its issue names the clock 0.3 % fast as the other reading."""
    from gear_rotor_sim.calibration.measurement import load_measurement
    from gear_rotor_sim.calibration.speed_check import check_operating_speed
    from gear_rotor_sim.config import load_config
    from lumped_gearbox import make_record, write_record

    rec = make_record(3000.0, 25.0, [], duration_s=0.5, seed=5, sample_rate_hz=FS * 1.003)
    rec.time_s = np.arange(rec.time_s.size) / FS
    m = load_measurement(write_record(tmp_path / "clock.csv", rec))
    out, check = check_operating_speed(m, load_config(m.gearbox))
    assert check is not None and check.corrected
    assert out.operating_point.speed_rpm == pytest.approx(3000.0 / 1.003, abs=0.01)
    issue = out.issues[-1]
    assert "sample clock runs 0.3 % fast" in issue and "20060 Hz" in issue


def _synthetic(delay: float, n_ch: int = 5, seed: int = 3) -> tuple[list, list, list, list]:
    """Order features of ``n_ch`` channels of a 3000 rpm rig (pinion orders 1-93 at 50 Hz): the model's
    random complex lines, the record the model times a per-channel model-form phase error of 0.2 rad rms
    and noise, channel 1 delayed by ``delay`` samples."""
    rng = np.random.default_rng(seed)
    orders = np.arange(1, 94)
    f = orders * 50.0
    mesh = (orders % 29 == 0) | (np.abs(orders - 29 * np.round(orders / 29)) <= 6)
    d_o, v_o, m_o = [], [], []
    for c in range(n_ch):
        amp = np.where(mesh, 30.0, 0.3) * (1 + rng.random(orders.size))
        m = amp * np.exp(2j * np.pi * rng.random(orders.size))
        err = np.exp(1j * 0.2 * rng.standard_normal(orders.size))
        d = m * err * (np.exp(-2j * np.pi * f * delay / FS) if c == 1 else 1.0)
        d = d + (rng.standard_normal(orders.size) + 1j * rng.standard_normal(orders.size)) * 0.5
        d_o.append([d])
        v_o.append([np.full(orders.size, 0.5)])
        m_o.append([m])
    return d_o, v_o, m_o, [f]


@pytest.mark.parametrize("delay", [1.0, 3.0, 2.4, -2.7])
def test_channel_delay_read_against_the_injected_one(delay: float) -> None:
    """Synthetic features: the delayed channel's skew reads the injected delay within 0.1 sample; from 2
    samples on (the lines' phases then turn by 0.9-2.7 rad over the mesh harmonics) it is the one channel
    fixed, one sample gains too little coherence over the model-form scatter (``MIN_GAIN``); without a delay
    no channel is."""
    d_o, v_o, m_o, f = _synthetic(delay)
    ds = channel_delays(d_o, v_o, m_o, f, FS, FS / 1450.0)
    assert ds[1].skew_samples == pytest.approx(delay, abs=0.1)
    fix = skew_fix(ds, [f"c{k}" for k in range(5)], FS)
    if abs(delay) < 2:
        assert ds[1].gain < 1.5 and fix.channels == ()
        return
    assert fix.channels == (1,) and fix.delays[0] == pytest.approx(delay, abs=0.1)
    assert "'c1': delayed by" in fix.issues[0]
    clean = channel_delays(*_synthetic(0.0), FS, FS / 1450.0)
    assert all(abs(c.skew_samples) < 0.2 for c in clean)
    assert skew_fix(clean, [f"c{k}" for k in range(5)], FS).channels == ()


def test_skew_fix_needs_one_channel_alone() -> None:
    """Two channels off the others: the model's, not one acquisition channel's; nothing is fixed; nor where
    the other channels disagree among themselves (no reference)."""
    cd = [ChannelDelay(0.0, 0.9, 0.9, 0.0, 20, 0.5), ChannelDelay(3.0, 0.9, 0.3, 3.0, 20, 0.5)]
    cd += [ChannelDelay(-2.0, 0.9, 0.3, -2.0, 20, 0.5), ChannelDelay(0.0, 0.9, 0.9, 0.0, 20, 0.5)]
    assert skew_fix(cd, ["a", "b", "c", "d"], FS).channels == ()
    assert skew_fix(cd[:2] + cd[3:], ["a", "b", "d"], FS).channels == (1,)
    wild = [cd[0], ChannelDelay(3.0, 0.9, 0.3, 3.0, 20, 5.0), cd[3]]  # the others disagree by 5 samples
    assert skew_fix(wild, ["a", "b", "d"], FS).channels == ()


def test_skew_on_a_generator_record_read_and_undone(tmp_path: Path) -> None:
    """``lumped_gearbox`` pinion tooth at 3000 rpm, 0.6 s: ``bearing2_fx`` delayed by 3 samples reads a skew
    within 0.5 sample of 3 against the healthy model and is the one channel fixed; the record as made has
    none. The fixed channel advanced by the reading lies within 0.5 sample of the undelayed one."""
    from gear_rotor_sim.calibration.fit import Calibrator
    from gear_rotor_sim.calibration.measurement import load_measurement
    from lumped_gearbox import make_record, write_record

    rec = make_record(3000.0, 25.0, ["tooth_damage:wheel=pinion,tooth=7,depth=0.4"], duration_s=0.6, seed=11)
    clean = write_record(tmp_path / "clean.csv", rec)
    x = rec.data["bearing2_fx"].copy()
    rec.data["bearing2_fx"] = np.concatenate([np.full(3, x[0]), x[:-3]])
    skewed = write_record(tmp_path / "skewed.csv", rec)
    readings = {}
    for name, path in (("clean", clean), ("skewed", skewed)):
        cal = Calibrator(load_measurement(path))
        cal._setup()
        cols = [c.column for c in cal.m.channels]
        ds = read_delays(cal)
        readings[name] = (ds, skew_fix(ds, cols, cal.m.sample_rate_hz), cols)
    ds, fix, cols = readings["skewed"]
    k = cols.index("bearing2_fx")
    assert ds[k].skew_samples == pytest.approx(3.0, abs=0.5)
    assert fix.channels == (k,)
    assert readings["clean"][1].channels == ()
    assert not math.isnan(readings["clean"][0][k].skew_samples)
