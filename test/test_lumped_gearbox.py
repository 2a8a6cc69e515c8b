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
