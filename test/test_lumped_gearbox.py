"""The independent lumped-parameter simulator (lumped_gearbox) against analytic truth and the paper."""

from __future__ import annotations

import ast
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from lumped_gearbox import (
    CONTACT_RPM,
    RATTLE_RPM,
    Gearbox,
    build,
    make_record,
    parse_fault,
    run,
    write_record,
)
from lumped_gearbox import model as mdl

PKG = Path(__file__).resolve().parents[1] / "lumped_gearbox"
T2 = 200.0  # Table 3, N m
RB1 = 0.5 * 3e-3 * 29 * math.cos(math.radians(20.0))  # base radii from Table 3, m
RB2 = 0.5 * 3e-3 * 49 * math.cos(math.radians(20.0))


def test_shares_no_code_with_gear_rotor_sim():
    imported = set()
    for f in PKG.glob("*.py"):
        for node in ast.walk(ast.parse(f.read_text())):
            if isinstance(node, ast.Import):
                imported |= {a.name.split(".")[0] for a in node.names}
            elif isinstance(node, ast.ImportFrom) and node.module:
                imported.add(node.module.split(".")[0])
            elif isinstance(node, ast.Call) and getattr(node.func, "id", "") == "__import__":
                imported.add("__import__")
    assert "gear_rotor_sim" not in imported and "__import__" not in imported, imported
    code = (
        "import sys, lumped_gearbox.record; print(any(m.startswith('gear_rotor_sim') for m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_static_load_sharing_and_torque_balance():
    setup = build(Gearbox(), 3000.0, 25.0, ste=False)
    r = run(setup, 0.5)
    f_static = T2 / RB2  # mesh force that holds the output torque
    assert abs(np.mean(r["mesh_force"]) - f_static) < 0.01 * f_static
    # input torque through the drive shaft = T2 z1/z2 (torque balance of the pair)
    t_in = -setup.kk[mdl.K_T1] * np.mean(r["q"][:, 3])
    assert abs(t_in - T2 * 29 / 49) < 0.01 * T2 * 29 / 49
    # bearing 2 carries half the pinion's mesh reaction, along -(sin a, cos a)
    a = math.radians(20.0)
    for ch, c in (("bearing2_fx", math.sin(a)), ("bearing2_fy", math.cos(a))):
        assert abs(np.mean(r[ch]) + 0.5 * f_static * c) < 0.01 * 0.5 * f_static * c


def test_mesh_mode_frequency_matches_two_dof_torsional_formula():
    """Pinion and gear free in torsion, translations blocked: w^2 = k (rb1^2/J1 + rb2^2/J2)."""
    setup = build(Gearbox(), 1e-6, 25.0, ste=False)
    setup.mass[[mdl.M_M1, mdl.M_M2]] = 1e12  # translations do not move
    setup.cc[:] = 0.0
    setup.load[mdl.L_B] = 0.0
    q0 = setup.static_state()  # static deflection under T2 with the mean stiffness
    setup.kk[mdl.K_T1] = 0.0  # pinion free in torsion
    setup.load[mdl.L_T2] = 0.0  # released: free oscillation about delta = 0
    setup.static_state = lambda: q0  # type: ignore[method-assign]
    fs = 200_000.0
    r = run(setup, 0.05, fs, substeps=4, preroll_s=0.0)
    k = float(np.mean(r["mesh_stiffness"]))
    j1, j2 = setup.mass[mdl.M_J1], setup.mass[mdl.M_J2]
    f_exact = math.sqrt(k * (RB1**2 / j1 + RB2**2 / j2)) / (2 * math.pi)
    x = r["dte"] - np.mean(r["dte"])
    i = np.flatnonzero((x[:-1] < 0) & (x[1:] >= 0))
    ti = (i - x[i] / (x[i + 1] - x[i])) / fs  # interpolated upward zero crossings
    f_sim = (len(ti) - 1) / (ti[-1] - ti[0])
    assert abs(f_sim - f_exact) < 2e-3 * f_exact, (f_sim, f_exact)


def test_thermal_axial_load_formula_and_paper_value():
    gb = Gearbox()
    r = run(build(gb, 3000.0, 125.0), 0.3)
    ks = 200e9 * math.pi * 0.015**2 / 0.14  # E(125 C) from Table 1, shaft of Table 4
    expected = ks * 1.17e-5 * 100.0 * 0.14 / (1 + 2 * ks / 2.28e7)
    mean_fz = float(np.mean(r["bearing2_fz"]))
    assert abs(mean_fz - expected) < 2e-3 * expected
    # the independent figure for this gearbox: 1846 N per 100 C
    assert abs(mean_fz - 1846.0) < 0.01 * 1846.0


def test_zero_temperature_rise_gives_zero_axial_load():
    r = run(build(Gearbox(), 3000.0, 25.0), 0.3)
    assert abs(np.mean(r["bearing2_fz"])) < 1e-6 * 1846.0


def test_zero_backlash_limit_while_in_contact():
    """In contact the dead zone only shifts the deflection by b: forces equal, DTE shifted by b."""
    gb = Gearbox()
    r35 = run(build(gb, 3000.0, 25.0), 0.2)
    r0 = run(build(gb.replace(half_backlash_m=0.0), 3000.0, 25.0), 0.2)
    assert np.min(np.abs(r35["mesh_force"])) > 0  # never separated
    scale = np.std(r35["mesh_force"])
    assert np.max(np.abs(r35["mesh_force"] - r0["mesh_force"])) < 1e-6 * scale
    assert np.max(np.abs(r35["dte"] - r0["dte"] - 35e-6)) < 1e-6 * 35e-6


def test_mesh_frequency_line_in_dte_spectrum():
    r = run(build(Gearbox(), 3000.0, 25.0), 1.0)
    x = r["dte"] - np.mean(r["dte"])
    spec = np.abs(np.fft.rfft(x * np.hanning(x.size)))
    f = np.fft.rfftfreq(x.size, 1 / 20000.0)
    assert abs(f[np.argmax(spec)] - 29 * 3000 / 60) <= f[1]


def test_rattle_operating_point_loses_contact_and_contact_point_does_not():
    assert make_record(CONTACT_RPM, 25.0, duration_s=0.3).contact_loss_fraction == 0.0
    for fault in ([], ["pinion_eccentricity:eccentricity_m=15e-6"], ["temperature_offset:offset_c=100"]):
        assert make_record(RATTLE_RPM, 25.0, fault, duration_s=0.3).contact_loss_fraction > 0.2


def test_gear_tooth_damage_gives_gear_order_comb():
    """Damage on gear tooth 5 repeats once per gear revolution: gear orders rise, pinion orders not."""
    healthy = run(build(Gearbox(), 3000.0, 25.0), 2.0)
    damaged = run(
        build(Gearbox(), 3000.0, 25.0, [parse_fault("tooth_damage:wheel=gear,tooth=5,depth=0.5")]), 2.0
    )
    f_gear = 3000 / 60 * 29 / 49
    f = np.fft.rfftfreq(healthy["dte"].size, 1 / 20000.0)

    def line(x, freq):
        s = np.abs(np.fft.rfft(x - x.mean())) / x.size
        return s[np.argmin(np.abs(f - freq))]

    for order in (1, 2, 3):
        assert line(damaged["dte"], order * f_gear) > 10 * line(healthy["dte"], order * f_gear)


def test_records_are_readable_by_the_calibration_loaders(tmp_path):
    from gear_rotor_sim.calibration.measurement import load_measurement

    rec = make_record(3000.0, 125.0, ["temperature_offset:offset_c=50"], duration_s=0.2, seed=3)
    path = write_record(tmp_path / "hot.csv", rec)
    m = load_measurement(path)
    assert m.sample_rate_hz == pytest.approx(20000.0, rel=1e-9)
    assert m.operating_point.temperature_c == 125.0 and m.operating_point.speed_rpm == 3000.0
    assert m.model_channels == ["dte", "bearing2_fx", "bearing2_fy", "bearing2_fz", "node5_ax", "node5_ay"]
    fz = m.channel("bearing2_fz")
    assert np.allclose(fz, rec.data["bearing2_fz"], rtol=1e-7, atol=1e-7 * np.abs(fz).max())
    truth = (tmp_path / "hot.truth.json").read_text()
    assert '"offset_c": 50.0' in truth and rec.actual_temperature_c == 175.0


def test_bad_fault_names_field_and_range():
    with pytest.raises(ValueError, match=r"tooth_damage.depth: 1.5 outside the allowed range \[0, 1\]"):
        parse_fault("tooth_damage:wheel=gear,tooth=5,depth=1.5")
    with pytest.raises(ValueError, match="unknown name 'crack'"):
        parse_fault("crack:depth=0.1")
    with pytest.raises(ValueError, match="temperature_c"):
        build(Gearbox(), 3000.0, 400.0)


def test_outer_race_defect_envelope_line_at_bpfo():
    """6206 (9 balls, d = 9.525 mm, D = 46 mm): BPFO = n/2 (1 - d/D) f_shaft = 3.568 x 50 Hz."""
    healthy = run(build(Gearbox(), 3000.0, 25.0), 1.0)
    faulty = run(build(Gearbox(), 3000.0, 25.0, [parse_fault("outer_race_defect:force_n=300")]), 1.0)
    pulses = faulty["bearing2_fy"] - healthy["bearing2_fy"]
    assert np.allclose(faulty["dte"], healthy["dte"], rtol=0, atol=1e-9 * np.abs(healthy["dte"]).max())
    env = np.abs(pulses)
    spec = np.abs(np.fft.rfft(env - env.mean()))
    f = np.fft.rfftfreq(env.size, 1 / 20000.0)
    band = (f > 20) & (f < 1000)
    bpfo = 9 / 2 * (1 - 9.525 / 46.0) * 50.0
    assert abs(f[band][np.argmax(spec[band])] - bpfo) <= 2 * f[1]
    # peak close to force_n times the Hertz load factor at the defect (90 deg vs load at 110 deg)
    assert 0.5 * 300 < np.max(np.abs(pulses)) <= 300 * math.cos(math.radians(20)) ** 1.5 * (1 + 1e-9)


def test_cli_record_and_bad_fault(tmp_path, capsys):
    from lumped_gearbox.__main__ import main

    out = tmp_path / "out" / "gear_tooth5.csv"
    args = [
        "record",
        "--speed-rpm",
        "3000",
        "--temperature-c",
        "25",
        "--duration-s",
        "0.1",
        "--out",
        str(out),
    ]
    assert main([*args, "--fault", "tooth_damage:wheel=gear,tooth=5,depth=0.3"]) == 0
    assert out.exists() and out.with_suffix(".yaml").exists() and out.with_suffix(".truth.json").exists()
    assert main([*args, "--fault", "tooth_damage:wheel=gear,tooth=50,depth=0.3"]) == 2
    assert "tooth_damage.tooth: 50 outside 1..49 for the gear" in capsys.readouterr().err


def test_housing_path_matches_sdof_frequency_response(tmp_path):
    """Steady sine force: |a/F| = w^2 / |k - m w^2 + i c w| of the housing mode (analytic)."""
    from gear_rotor_sim.calibration.measurement import load_measurement
    from lumped_gearbox import housing as hs

    fs = 20000.0
    t = np.arange(40000) / fs
    m, fn, zeta = hs.HOUSING_MASS_KG, hs.HOUSING_FREQUENCY_HZ, hs.HOUSING_DAMPING_RATIO
    k = m * (2 * math.pi * fn) ** 2
    c = 2 * zeta * math.sqrt(k * m)
    for f in (500.0, 2600.0, 6000.0):
        w = 2 * math.pi * f
        acc = hs.housing_acceleration(100.0 * np.sin(w * t), fs)[20000:]  # transient decayed
        expected = 100.0 * w**2 / abs(k - m * w**2 + 1j * c * w)
        amp = math.sqrt(2.0) * np.std(acc)
        assert abs(amp - expected) < 0.01 * expected, (f, amp, expected)
    rec = make_record(3000.0, 25.0, duration_s=0.1, housing=True)
    meas = load_measurement(write_record(tmp_path / "h.csv", rec))
    assert "bearing2_housing_ay" in meas.model_channels


def test_eccentricity_is_followed_kinematically_at_shaft_rate():
    """Far below every resonance the train follows a run-out rigidly: DTE 1x line = e (quasi-static)."""
    e = 15e-6
    r = run(
        build(Gearbox(), 600.0, 25.0, [parse_fault(f"pinion_eccentricity:eccentricity_m={e}")], ste=False),
        2.0,
    )
    x = r["dte"] - np.mean(r["dte"])
    n = x.size
    t = np.arange(n) / 20000.0
    amp = 2.0 * abs(np.sum(x * np.exp(-2j * np.pi * 10.0 * t))) / n  # 600 rpm = 10 Hz, 20 whole periods
    assert abs(amp - e) < 0.03 * e, amp


def test_thermal_backlash_unchanged_when_housing_expands_like_the_gears():
    """Uniform expansion of gears and housing is a similarity: the backlash just scales by 1 + a dT."""
    from lumped_gearbox import thermal_half_backlash

    gb = Gearbox(housing_expansion_per_c=1.17e-5)
    assert thermal_half_backlash(gb, 225.0) == pytest.approx(35e-6 * (1 + 1.17e-5 * 200), rel=1e-12)
    assert thermal_half_backlash(Gearbox(), 25.0) == pytest.approx(35e-6, rel=1e-12)
    assert thermal_half_backlash(Gearbox(), 225.0) < 35e-6  # steel gears in a cast-iron housing close up


# --- the data-acquisition chain (daq.py, session 13): converged step, anti-aliasing, sampling ---


def _tone_through_chain(freq_hz: float, substeps: int = 32, fs: float = 20000.0, n_out: int = 4000):
    """A unit sine at ``freq_hz`` on the fine grid, through the chain; and its exact samples."""
    from lumped_gearbox.daq import anti_alias_fir, low_pass_sample

    h = anti_alias_fir(substeps)
    half = (h.size - 1) // 2
    n_fine = (n_out - 1) * substeps + 2 * half + 1
    t_fine = (np.arange(n_fine) - half) / (fs * substeps)
    y = low_pass_sample(np.sin(2 * math.pi * freq_hz * t_fine), substeps, n_out, h)
    return y, np.sin(2 * math.pi * freq_hz * np.arange(n_out) / fs)


def test_daq_tone_above_nyquist_does_not_fold_into_the_record():
    """Content above fs/2 is attenuated by the filter's stopband spec (>= 80 dB from 0.5 fs)."""
    from lumped_gearbox.daq import STOPBAND_DB

    limit = 10 ** (-STOPBAND_DB / 20)
    # 10.2 kHz folds to 9.8, 11.6 kHz (the 3rd mesh harmonic at 8000 rpm) to 8.4, 15.47 kHz (the 4th) to
    # 4.53 kHz = pinion order 34, 33 kHz far out; the point-sampled chain keeps each at full amplitude
    for f in (10200.0, 11601.0, 15467.0, 33000.0):
        y, _ = _tone_through_chain(f)
        assert np.max(np.abs(y)) <= limit, (f, np.max(np.abs(y)))


def test_daq_passband_is_flat_and_zero_phase():
    """Below 0.4 fs a tone comes through at the sample instants within the passband spec (1e-3)."""
    for f in (50.0, 1450.0, 3867.0, 7734.0, 8000.0):
        y, exact = _tone_through_chain(f)
        assert np.max(np.abs(y - exact)) < 1e-3, (f, np.max(np.abs(y - exact)))
    # unit gain at 0 Hz: the static content (bearing forces, DTE mean) is kept exactly
    y, _ = _tone_through_chain(0.0)
    assert np.max(np.abs(y)) == 0.0
    from lumped_gearbox.daq import anti_alias_fir

    assert abs(np.sum(anti_alias_fir(32)) - 1.0) < 1e-12


def test_daq_step_is_converged_where_the_teeth_rattle():
    """At 8000 rpm (impacts) a record at 32 and at 64 substeps differ by < 1 % of each channel's RMS."""
    from lumped_gearbox.daq import DAQ_SUBSTEPS, acquire

    setup = build(Gearbox(), RATTLE_RPM, 25.0, [parse_fault("tooth_wear:wear_depth_m=20e-6")])
    r1 = acquire(setup, 0.3, substeps=DAQ_SUBSTEPS)
    r2 = acquire(setup, 0.3, substeps=2 * DAQ_SUBSTEPS)
    assert np.mean(np.abs(r2["mesh_force"]) <= 1e-9 * np.max(np.abs(r2["mesh_force"]))) > 0.2  # rattles
    for ch in ("dte", "bearing2_fx", "bearing2_fy", "node5_ax", "node5_ay"):
        scale = float(np.std(r2[ch]))
        assert np.std(r1[ch] - r2[ch]) < 0.01 * scale, (ch, np.std(r1[ch] - r2[ch]) / scale)


def test_daq_record_keeps_static_content_and_point_sampling_stays_reachable():
    """The default chain keeps the thermal axial load; ``sampling="point"`` is the old chain exactly."""
    daq = make_record(3000.0, 125.0, duration_s=0.2, seed=2)
    point = make_record(3000.0, 125.0, duration_s=0.2, seed=2, sampling="point")
    assert daq.sampling == "daq" and daq.truth()["substeps"] == 32 and point.truth()["sampling"] == "point"
    old = run(build(Gearbox(), 3000.0, 125.0), 0.2)
    for ch in ("dte", "bearing2_fx", "bearing2_fz", "node5_ax"):
        assert np.array_equal(point.clean[ch], old[ch])
    for ch in ("dte", "bearing2_fx", "bearing2_fz"):
        # in contact at 3000 rpm the displacements and forces hold little above 8 kHz: both chains
        # agree to 2 % of the RMS (the accelerations differ by 4 %: their content above 8 kHz)
        scale = float(np.std(old[ch])) or abs(float(np.mean(old[ch])))
        assert np.std(daq.clean[ch] - old[ch]) < 0.02 * scale, ch
    fz = float(np.mean(daq.clean["bearing2_fz"]))
    assert abs(fz - float(np.mean(old["bearing2_fz"]))) < 1e-6 * abs(fz)
    with pytest.raises(ValueError, match="sampling: 'sharp' not one of daq, point"):
        make_record(3000.0, 25.0, duration_s=0.1, sampling="sharp")
    with pytest.raises(ValueError, match="substeps: 0 must be an integer >= 1"):
        make_record(3000.0, 25.0, duration_s=0.1, substeps=0)


def test_daq_record_keeps_the_bearing_defect_impulses():
    """The pulses of an outer-race defect reach the record through the chain with their impulse: per
    impact ``2 F q tau / pi`` (half-sine of peak ``F q``, q the Hertz factor at 90 deg from a load at
    110 deg), at BPFO (3.568 x 50 Hz) over the record; the FIR's unit DC gain keeps the area."""
    from lumped_gearbox.bearing import SPALL_WIDTH, kinematics

    dur, force = 0.5, 300.0
    healthy = make_record(3000.0, 25.0, duration_s=dur, seed=1, noise=(0.0, 0.0), gain_error=0.0)
    faulty = make_record(
        3000.0,
        25.0,
        [f"outer_race_defect:force_n={force}"],
        duration_s=dur,
        seed=1,
        noise=(0.0, 0.0),
        gain_error=0.0,
    )
    kin = kinematics(3000.0)
    tau = SPALL_WIDTH / kin["outer_speed"]
    q = math.cos(math.radians(20.0)) ** 1.5
    per_impact = 2.0 * force * q * tau / math.pi
    pulses = faulty.clean["bearing2_fy"] - healthy.clean["bearing2_fy"]  # the pulses act on the housing only
    impulse = -float(np.sum(pulses)) / 20000.0  # the defect at -90 deg pushes the housing along -y
    n_impacts = impulse / per_impact
    assert abs(n_impacts - kin["outer_rate"] * dur) <= 1.5, (n_impacts, kin["outer_rate"] * dur)
    # the same pulse train point-sampled (sessions 1-12): the same impulse within 2 % of one impact
    point = make_record(
        3000.0,
        25.0,
        [f"outer_race_defect:force_n={force}"],
        duration_s=dur,
        seed=1,
        noise=(0.0, 0.0),
        gain_error=0.0,
        sampling="point",
    )
    ref = make_record(
        3000.0, 25.0, duration_s=dur, seed=1, noise=(0.0, 0.0), gain_error=0.0, sampling="point"
    )
    impulse_point = -float(np.sum(point.clean["bearing2_fy"] - ref.clean["bearing2_fy"])) / 20000.0
    assert abs(impulse - impulse_point) < 0.02 * per_impact + 1e-3 * abs(impulse_point)
