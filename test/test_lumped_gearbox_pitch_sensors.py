"""The independent generator's pitch errors (lumped_gearbox/pitch.py) and sensor filters (sensors.py)
against their analytic limits."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from lumped_gearbox import Gearbox, build, make_record, run
from lumped_gearbox.__main__ import main as lumped_main
from lumped_gearbox.pitch import PitchErrors
from lumped_gearbox.sensors import SensorFilter, parse_sensor


def _sine(t: np.ndarray, x: np.ndarray, f: float) -> complex:
    """Least-squares complex amplitude of ``x`` at ``f`` (``x ~ c0 + Re(A exp(2 pi i f t))``)."""
    a = np.column_stack([np.ones_like(t), np.cos(2 * math.pi * f * t), -np.sin(2 * math.pi * f * t)])
    _, c, s = np.linalg.lstsq(a, x, rcond=None)[0]
    return complex(c, s)


def test_zero_pitch_errors_are_the_exact_teeth_record_bit_for_bit():
    """All-zero errors leave the kernel on its single deadzone: the same record bit for bit."""
    a = make_record(3000.0, duration_s=0.05, seed=3, sampling="point")
    b = make_record(3000.0, duration_s=0.05, seed=3, sampling="point", pitch_errors=PitchErrors())
    for ch in a.data:
        assert np.array_equal(a.data[ch], b.data[ch]), ch
    assert "pitch_errors" not in a.truth() and b.truth()["pitch_errors"]["f_pt_um"] == 0.0


@pytest.mark.parametrize("speed", [3000.0, 8000.0])
def test_the_per_pair_law_with_zero_errors_is_the_single_deadzone(speed):
    """``sum_n k_n [d]_b = (sum_n k_n) [d]_b``: the per-pair path forced with zero errors gives the exact
    teeth's record to round-off, in contact (3000 rpm) and where the teeth separate (8000 rpm)."""
    gb = Gearbox()
    ref = run(build(gb, speed, 25.0), 0.05, substeps=8, preroll_s=0.05)
    s = build(gb, speed, 25.0)
    s.pitch = np.zeros(gb.z1 + gb.z2)
    got = run(s, 0.05, substeps=8, preroll_s=0.05)
    for ch in ("dte", "bearing2_fx", "bearing2_fy", "node5_ay", "mesh_force"):
        scale = float(np.max(np.abs(ref[ch])))
        np.testing.assert_allclose(got[ch], ref[ch], rtol=0, atol=1e-8 * scale, err_msg=ch)


def test_a_common_flank_offset_moves_the_dte_and_not_the_forces():
    """Every pinion flank ``c`` ahead is a rigid turn of the pinion: the mesh deflection, hence every force,
    is unchanged and the DTE (the wheels' kinematic position) moves by ``-c`` exactly, once the start-up
    from the exact teeth's static state has decayed."""
    gb = Gearbox()
    c = 4e-6
    ref = run(build(gb, 3000.0, 25.0), 0.1, substeps=8, preroll_s=0.3)
    s = build(gb, 3000.0, 25.0)
    s.pitch = np.concatenate([np.full(gb.z1, c), np.zeros(gb.z2)])
    got = run(s, 0.1, substeps=8, preroll_s=0.3)
    np.testing.assert_allclose(got["dte"], ref["dte"] - c, rtol=0, atol=1e-3 * c)
    for ch in ("bearing2_fx", "bearing2_fy", "mesh_force"):
        scale = float(np.max(np.abs(ref[ch])))
        np.testing.assert_allclose(got[ch], ref[ch], rtol=0, atol=1e-4 * scale, err_msg=ch)


def test_pitch_error_draw_has_the_stated_single_pitch_rms_and_runout():
    """Independent flank positions of deviation ``f_pt / sqrt 2``: single pitch deviations of RMS ``f_pt``
    (2000 teeth: within 5 %); the once-per-turn part's amplitude is the runout (a DFT at order 1)."""
    p, g = PitchErrors(f_pt_um=5.0, runout_um=0.0, seed=2).positions_um(2000, 2000)
    for x in (p, g):
        assert np.sqrt(np.mean((x - np.roll(x, 1)) ** 2)) == pytest.approx(5.0, rel=0.05)
    p, _ = PitchErrors(f_pt_um=0.0, runout_um=10.0, seed=2).positions_um(29, 49)
    assert 2.0 * abs(np.fft.rfft(p)[1]) / 29 == pytest.approx(10.0, rel=1e-9)
    only = PitchErrors(f_pt_um=5.0, wheels="gear").positions_um(29, 49)
    assert not np.any(only[0]) and np.any(only[1])
    with pytest.raises(ValueError, match=r"pitch_errors\.f_pt_um"):
        PitchErrors(f_pt_um=-1.0)


def test_a_high_pass_gives_no_output_for_a_constant_and_minus_3_db_at_its_cutoff():
    """First-order high-pass (AC coupling): a constant gives zero; a sine at ``f_c`` leaves with gain
    ``1/sqrt 2`` and leads by 45 degrees; a sine at ``30 f_c`` with ``30 / sqrt(901)``."""
    fs = 2000.0
    hp = SensorFilter("highpass", 1.0)
    assert np.max(np.abs(hp.apply(np.full(4000, 1234.5), fs))) < 1e-9 * 1234.5
    t = np.arange(int(40 * fs)) / fs
    for f, gain in ((1.0, 1.0 / math.sqrt(2.0)), (30.0, 30.0 / math.sqrt(901.0))):
        y = hp.apply(1000.0 + np.cos(2 * math.pi * f * t), fs)
        late = t > 20.0  # the start-up (tau = 0.16 s) long gone
        a = _sine(t[late], y[late], f)
        assert abs(a) == pytest.approx(gain, rel=1e-3)
        assert math.degrees(np.angle(a)) == pytest.approx(math.degrees(math.atan(1.0 / f)), abs=0.1)


def test_a_second_order_low_pass_is_minus_3_db_at_its_cutoff():
    """Butterworth low-pass at 3 kHz on the chain's 640 kHz fine rate: gain ``1/sqrt 2`` at 3 kHz (phase -90
    degrees), the analog ``1/sqrt(1 + 2^4)`` one octave above within 0.5 %, a constant passed unchanged."""
    fs = 640000.0
    lp = SensorFilter("lowpass", 3000.0, 2)
    t = np.arange(64000) / fs
    for f, gain in ((3000.0, 1.0 / math.sqrt(2.0)), (6000.0, 1.0 / math.sqrt(17.0))):
        y = lp.apply(np.cos(2 * math.pi * f * t), fs)
        late = t > 0.02
        a = _sine(t[late], y[late], f)
        assert abs(a) == pytest.approx(gain, rel=5e-3)
    y = lp.apply(np.cos(2 * math.pi * 3000.0 * t), fs)
    assert math.degrees(np.angle(_sine(t[t > 0.02], y[t > 0.02], 3000.0))) == pytest.approx(-90.0, abs=0.5)
    assert np.allclose(lp.apply(np.full(1000, 7.0), fs), 7.0, rtol=1e-12)


@pytest.mark.parametrize("sampling", ["point", "daq"])
def test_an_ac_coupled_force_channel_loses_its_mean_and_keeps_its_dynamics(sampling):
    """The high-passed column has no mean left and its fluctuation within 1 % of the flat sensor's; every
    other column bit for bit."""
    kw = {"duration_s": 0.3, "seed": 3, "sampling": sampling, "noise": (0.0, 0.0), "gain_error": 0.0}
    a = make_record(3000.0, **kw)
    b = make_record(3000.0, sensors={"bearing2_fy": SensorFilter("highpass", 0.5)}, **kw)
    assert abs(np.mean(a.data["bearing2_fy"])) > 500.0  # the static radial load
    assert abs(np.mean(b.data["bearing2_fy"])) < 1e-3 * abs(np.mean(a.data["bearing2_fy"]))
    assert np.std(b.data["bearing2_fy"]) == pytest.approx(np.std(a.data["bearing2_fy"]), rel=0.01)
    for ch in a.data:
        if ch != "bearing2_fy":
            assert np.array_equal(a.data[ch], b.data[ch]), ch
    assert b.truth()["sensors"] == {"bearing2_fy": [{"kind": "highpass", "cutoff_hz": 0.5, "order": 1}]}


def test_command_line_writes_pitch_errors_and_sensors_into_the_truth(tmp_path):
    out = tmp_path / "r.csv"
    argv = ["record", "--duration-s", "0.05", "--sampling", "point", "--pitch-fpt-um", "5"]
    argv += ["--sensor", "node5_ax:lowpass:3000", "--out", str(out)]
    assert lumped_main(argv) == 0
    truth = json.loads(out.with_suffix(".truth.json").read_text())
    assert truth["pitch_errors"]["f_pt_um"] == 5.0 and len(truth["pitch_errors"]["gear"]["position_um"]) == 49
    assert truth["sensors"]["node5_ax"][0] == {"kind": "lowpass", "cutoff_hz": 3000.0, "order": 2}
    assert parse_sensor("bearing2_fz:highpass:0.2") == ("bearing2_fz", SensorFilter("highpass", 0.2, 1))
    assert lumped_main(["record", "--sensor", "nope:lowpass:3000", "--out", str(out)]) == 2
