"""Each wheel's pitch deviations read from the DTE's synchronous averages (``pitch_pattern.py``) and added
to the machine's baseline after the search (``pitch_baseline.py``; docs/history/calibration_sessions.md
Sec. 8.68).

Truth is the independent generator's flank positions (``lumped_gearbox/pitch.py``, which shares no code with
the FE model) and the analytic Fourier series of one pair's share.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gear_rotor_sim.calibration import pitch_pattern as pp
from gear_rotor_sim.calibration.pitch_baseline import MIN_SIGNIFICANCE, MIN_SPREAD
from lumped_gearbox import make_record, write_record
from lumped_gearbox.pitch import PitchErrors

FS = 20000.0
RPM = 3000.0
Z1, Z2 = 29, 49
EPS = 1.6985  # the FE pair's contact ratio at 25 C
COS = math.cos(math.radians(20.0))
TOOTH = "tooth_damage:wheel=pinion,tooth=7,depth=0.4"


def _truth(f_pt_um: float) -> tuple[np.ndarray, np.ndarray]:
    """The generator's flank positions on the line of action (m) without what the reading leaves out."""
    out = []
    for p, z in zip(PitchErrors(f_pt_um=f_pt_um, seed=7).positions_um(Z1, Z2), (Z1, Z2), strict=True):
        b = pp.pattern_basis(z, long_wave=True)
        out.append(b @ np.linalg.lstsq(b, p * COS * 1e-6, rcond=None)[0])
    return out[0], out[1]


def _read(dte: np.ndarray, long_wave: bool = True, fixed: tuple[int, ...] = ()) -> list[pp.WheelPattern]:
    out = []
    for z, f in ((Z1, RPM / 60.0), (Z2, RPM / 60.0 * Z1 / Z2)):
        orders = pp.pattern_orders(z)
        coef, var = pp.wheel_orders(dte, FS, f, 0.0, orders)
        out.append(pp.fit_wheel_pattern(coef, var, z, EPS, fixed if z == Z1 else (), long_wave))
    return out


@pytest.fixture(scope="module")
def records() -> dict[str, np.ndarray]:
    """1 s (50 pinion, 30 gear revolutions) at 3000 rpm: healthy with exact teeth and at quality 7 (6 um),
    the pinion tooth 7 at depth 0.4 with exact teeth."""

    def dte(faults: list[str], f_pt: float, seed: int) -> np.ndarray:
        pe = PitchErrors(f_pt_um=f_pt, seed=7) if f_pt else None
        return make_record(RPM, 25.0, faults, duration_s=1.0, seed=seed, pitch_errors=pe).data["dte"]

    return {"q7": dte([], 6.0, 34), "exact": dte([], 0.0, 34), "tooth": dte([TOOTH], 0.0, 11)}


def test_share_spectrum_is_the_fourier_series_of_one_pairs_share() -> None:
    n = 200000
    s = (np.arange(n) + 0.5) / n * Z1  # mesh cycles over one revolution
    share = np.where(s < EPS, np.where((s < EPS - 1.0) | (s >= 1.0), 0.5, 1.0), 0.0)
    k = np.array([1, 5, 17, 28, 30, 57])
    num = np.array([np.mean(share * np.exp(-2j * math.pi * kk * s / Z1)) for kk in k])
    # the midpoint rule misplaces each jump by up to half a grid step (Z1 / n cycles): 6.5e-5 of the largest
    # coefficient measured; a share of the wrong shape (all 1 over eps) is 0.2 and more off
    assert np.allclose(pp.share_spectrum(k, Z1, EPS), num, rtol=0, atol=2e-4 * np.max(np.abs(num)))


def test_flank_positions_of_the_independent_gearbox_are_read(records) -> None:
    """Quality 7: each wheel's flank positions within 35 % RMS of the generator's (measured 0.25-0.28 on a
    2 s record), the pattern significant and spread; with exact teeth nothing significant."""
    for w, truth in zip(_read(records["q7"]), _truth(6.0), strict=True):
        rel = math.sqrt(np.mean((w.positions_m - truth) ** 2) / np.mean(truth**2))
        scale = float(np.dot(w.positions_m, truth) / np.dot(truth, truth))
        assert rel <= 0.35 and 0.9 <= scale <= 1.3, (rel, scale)
    for w in _read(records["q7"], long_wave=False):
        assert w.significance >= 5 * MIN_SIGNIFICANCE and pp.spread(w.positions_m) >= MIN_SPREAD
    for w in _read(records["exact"], long_wave=False):
        assert w.significance < 3.0, w.significance


def test_one_damaged_tooth_is_not_a_pattern(records) -> None:
    """A single damaged tooth reads as one lagging flank (and its pulse's shape on its neighbours):
    significant but not spread round the wheel; held at the mean, its slot is left to the fault."""
    pin, gear = _read(records["tooth"], long_wave=False)
    assert pin.significance >= MIN_SIGNIFICANCE and pp.spread(pin.positions_m) < 0.5 * MIN_SPREAD
    assert int(np.argmin(pin.positions_m)) == 6 and pin.positions_m[6] < -3e-6  # tooth 7 lags, about 4.7 um
    assert gear.significance < 3.0
    held = _read(records["tooth"], long_wave=False, fixed=(6,))[0]
    assert abs(held.positions_m[6]) < 1e-12


@pytest.mark.acceptance
def test_calibration_adds_the_pattern_after_the_search(tmp_path) -> None:
    """A quality-7 healthy record (0.6 s): nothing claimed, the pattern reported as a baseline update with the
    generator's flanks, lowering the error; without it (the step removed) the test fails."""
    from gear_rotor_sim.calibration.fit import Calibrator
    from gear_rotor_sim.calibration.measurement import load_measurement

    rec = make_record(RPM, 25.0, [], duration_s=0.6, seed=34, pitch_errors=PitchErrors(f_pt_um=6.0, seed=7))
    res = Calibrator(load_measurement(write_record(tmp_path / "q7.csv", rec))).run()
    assert not res.effects
    found = [b for b in res.baseline_updates if b.name == "pitch_deviation"]
    assert found and found[0].error_after < found[0].error_before
    pin = np.asarray(found[0].effect.pinion_m)
    truth = _truth(6.0)[0]
    assert math.sqrt(np.mean((pin - truth) ** 2) / np.mean(truth**2)) <= 0.4


def test_a_smooth_wave_round_the_wheel_is_not_a_pattern() -> None:
    """A misaligned wheel's even orders (4 and 6 per turn) read as flank positions spread round the wheel
    but hold their energy in the low per-tooth harmonics; random deviations hold about 0.6 of it above a
    quarter of the teeth (the generator's quality-7 draws: 0.54-0.64 measured)."""
    from gear_rotor_sim.calibration.pitch_baseline import MIN_HIGH_SHARE

    j = np.arange(Z2)
    wave = np.cos(2 * math.pi * 4 * j / Z2) + 0.5 * np.cos(2 * math.pi * 6 * j / Z2 + 1.0)
    assert pp.spread(wave) >= MIN_SPREAD and pp.high_harmonic_share(wave) == pytest.approx(0.0, abs=1e-12)
    for p in _truth(6.0):
        assert pp.high_harmonic_share(p) >= 1.5 * MIN_HIGH_SHARE
