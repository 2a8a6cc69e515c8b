"""The independent generator's fluctuating output torque (lumped_gearbox/load_profile.py) against statics."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lumped_gearbox import Gearbox, build, make_record, run
from lumped_gearbox import model as mdl
from lumped_gearbox.__main__ import main as lumped_main
from lumped_gearbox.load_profile import LoadProfile, relative_torque

T0 = 200.0  # N m, the gearbox's output torque (Table 3)
RB2 = 0.5 * 3e-3 * 49 * math.cos(math.radians(20.0))  # gear base radius, m
SA = math.sin(math.radians(20.0))


def _sine_fit(t: np.ndarray, x: np.ndarray, arg: np.ndarray) -> tuple[float, float, float]:
    """Least-squares ``x ~ c0 + s sin(arg) + c cos(arg)``: (c0, s, c)."""
    a = np.column_stack([np.ones_like(t), np.sin(arg), np.cos(arg)])
    c0, s, c = np.linalg.lstsq(a, x, rcond=None)[0]
    return float(c0), float(s), float(c)


@pytest.mark.parametrize(
    ("profile", "gear_order"),
    [(LoadProfile(10.0, frequency_hz=3.7, phase_rad=0.3), 0.0), (LoadProfile(10.0, gear_order=1.0), 1.0)],
)
def test_mean_mesh_force_follows_the_torque_quasi_statically(profile, gear_order):
    """Below the drivetrain's torsional mode the gear's acceleration is negligible: the mesh force's
    component at the modulation is ``A T0 / rb2`` in phase with ``T2(t)``, its mean ``T0 / rb2``, and the
    input bearing's radial force follows by the lever rule (half the pinion's reaction along -sin a)."""
    setup = build(Gearbox(), 3000.0, 25.0, ste=False)
    setup.load[mdl.L_TA :] = profile.vector()
    r = run(setup, 0.6, preroll_s=0.3)
    t = r["time_s"]
    w2 = setup.geo[mdl.G_W2]
    arg = 2.0 * math.pi * profile.frequency_hz * t + gear_order * w2 * t + profile.phase_rad
    f0 = T0 / RB2
    c0, s, c = _sine_fit(t, r["mesh_force"], arg)
    assert abs(c0 - f0) < 0.01 * f0
    # the modulation's amplitude within 3 % of A F0, its quadrature part (a lag) below 3 % of it
    assert abs(s - 0.1 * f0) < 0.03 * 0.1 * f0
    assert abs(c) < 0.03 * 0.1 * f0
    _, sb, _ = _sine_fit(t, r["bearing2_fx"], arg)
    assert abs(sb + 0.5 * SA * 0.1 * f0) < 0.05 * 0.5 * SA * 0.1 * f0
    # the profile's own torque function
    assert np.allclose(relative_torque(profile.vector(), t, w2 * t), 1.0 + 0.1 * np.sin(arg))


def test_constant_profile_leaves_the_kernel_inputs_and_record_unchanged():
    """A zero amplitude writes zeros into the kernel's load-profile entries: the same record bit for bit."""
    a = make_record(3000.0, duration_s=0.05, seed=3, sampling="point")
    b = make_record(3000.0, duration_s=0.05, seed=3, sampling="point", load_profile=LoadProfile())
    for ch in a.data:
        assert np.array_equal(a.data[ch], b.data[ch]), ch
    assert "load_profile" not in a.truth() and b.truth()["load_profile"]["amplitude_pct"] == 0.0


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"amplitude_pct": 60.0, "frequency_hz": 4.0}, "load_profile.amplitude_pct"),
        ({"amplitude_pct": 10.0, "frequency_hz": 500.0}, "load_profile.frequency_hz"),
        ({"amplitude_pct": 10.0, "gear_order": 12.0}, "load_profile.gear_order"),
        ({"amplitude_pct": 10.0}, "load_profile.frequency_hz / load_profile.gear_order"),
        ({"amplitude_pct": 10.0, "frequency_hz": 4.0, "gear_order": 1.0}, "exactly one"),
    ],
)
def test_bad_load_profile_names_the_field(kwargs, field):
    with pytest.raises(ValueError, match=field):
        LoadProfile(**kwargs)


def test_cli_load_fluctuation_options(tmp_path, capsys):
    out = tmp_path / "rec.csv"
    assert (
        lumped_main(
            [
                "record",
                "--duration-s",
                "0.05",
                "--sampling",
                "point",
                "--load-fluctuation-pct",
                "10",
                "--load-fluctuation-gear-order",
                "2",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    assert '"gear_order": 2.0' in out.with_suffix(".truth.json").read_text()
    assert (
        lumped_main(
            ["record", "--load-fluctuation-pct", "80", "--load-fluctuation-hz", "3", "--out", str(out)]
        )
        == 2
    )
    assert "load_profile.amplitude_pct" in capsys.readouterr().err
