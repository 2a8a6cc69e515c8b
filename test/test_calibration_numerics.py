"""Numerics of the calibration's features and model runs (issue 11, docs/history/calibration_sessions.md
Sec. 8.18).

Each check is against an independent truth: analytic Fourier coefficients and derivatives of
constructed signals, a brute-force quadrature of a step mean, and the simulator itself at 1024 steps
per mesh period (the converged solution) for the step-grid lines of the model runs.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from gear_rotor_sim.calibration.model_accel import MARGIN, differentiate, velocity_of
from gear_rotor_sim.calibration.order_dft import revolution_coefficients
from gear_rotor_sim.calibration.residual import order_coefficients
from gear_rotor_sim.faults.gear import step_average_periodic

FS = 20000.0


def _mesh_signal(n: int, shaft_hz: float, teeth: int, line_order: int, line_amp: float) -> np.ndarray:
    """Mesh harmonics 1-6 of amplitude 100 (1450 Hz: up to 0.44 fs) plus a weak shaft-order line."""
    t = np.arange(n) / FS
    x = sum(100.0 * np.cos(2 * np.pi * teeth * k * shaft_hz * t + k) for k in range(1, 7))
    return x + line_amp * np.cos(2 * np.pi * line_order * shaft_hz * t + 0.3)


@pytest.mark.parametrize("shaft_hz", [50.0, 50.0 * 29 / 49])  # 400 and 675.9 samples per revolution
def test_order_coefficients_are_exact_with_no_images_of_the_mesh_harmonics(shaft_hz: float) -> None:
    teeth = 29 if shaft_hz == 50.0 else 49  # the mesh harmonics are orders k z of either shaft
    orders = np.array([1, 2, 3, 4, 5, 6, 25, 29, 33, 58, 62, 87, 91])
    x = _mesh_signal(40000, shaft_hz, teeth, 5, 0.2)
    coef, var, n_rev = order_coefficients(x, FS, shaft_hz, orders, 0.0)
    truth = np.zeros(orders.size, dtype=complex)
    truth[orders == 5] = 0.1 * np.exp(0.3j)  # |c_k| is half the peak amplitude
    for k in range(1, 4):
        truth[orders == teeth * k] = 50.0 * np.exp(1j * k)
    # every coefficient within 1e-5 of the largest line (50): the linear-interpolation order
    # tracking put 1.9 at order 4 and 2.3 at order 33 (images of the 4th and 5th mesh harmonics) and
    # read the 3rd harmonic 15 % low
    assert np.max(np.abs(coef - truth)) < 1e-5 * 50.0
    assert n_rev == int((40000 - 2) // (FS / shaft_hz))
    # no noise: the between-revolution scatter of the coefficients is a tiny part of the lines
    assert np.sqrt(var.max()) < 1e-4 * 50.0


def test_revolution_coefficients_noise_variance_is_that_of_white_noise() -> None:
    rng = np.random.default_rng(3)
    shaft_hz = 50.0 * 29 / 49
    orders = np.arange(1, 60)
    per = revolution_coefficients(rng.standard_normal(40000), FS, shaft_hz, orders)
    r = per.shape[0]
    var = np.sum(np.abs(per - per.mean(axis=0)) ** 2, axis=0) / (r - 1) / r
    expected = 1.0 / ((FS / shaft_hz) * r)  # unit white noise: E|c_k|^2 = 1 / N per revolution
    assert abs(var.mean() / expected - 1.0) < 0.1


def test_differentiator_matches_the_analytic_derivative_up_to_0_4_fs() -> None:
    n = 6000
    t = np.arange(n) / FS
    freqs = np.array([37.0, 1450.0, 4350.0, 7900.0])  # 0.4 fs is the decimator's passband edge
    x = np.sum(np.sin(2 * np.pi * freqs[:, None] * t + 0.7), axis=0)
    dx = np.sum(2 * np.pi * freqs[:, None] * np.cos(2 * np.pi * freqs[:, None] * t + 0.7), axis=0)
    d = differentiate(x, FS)[MARGIN:-MARGIN]
    err = np.max(np.abs(d - dx[MARGIN:-MARGIN])) / np.max(np.abs(dx))
    assert err < 1e-3
    assert velocity_of("node5_ax") == "node5_vx" and velocity_of("bearing2_fx") is None


def test_step_average_of_a_periodic_table_with_a_jump() -> None:
    n = 64
    table = np.where(np.arange(n) < 40, 1.0, 3.0)  # jumps within the cell [39/64, 40/64)
    rng = np.random.default_rng(5)
    x = rng.uniform(-1.0, 2.0, 300)
    w = rng.uniform(0.0, 0.2, 300)
    got = step_average_periodic(table, x, w)
    grid = np.arange(n) / n
    fine = np.array(
        [
            np.interp(np.linspace(a - b / 2, a + b / 2, 20001), grid, table, period=1.0).mean()
            for a, b in zip(x, w, strict=True)
        ]
    )
    assert np.max(np.abs(got - fine)) < 1e-3  # trapezoid-free reference: 20001-point mean
    assert np.array_equal(step_average_periodic(table, x, 0.0 * w), np.interp(x, grid, table, period=1.0))


def test_model_runs_in_contact_carry_no_step_grid_lines() -> None:
    """The calibration's model runs (64 steps per mesh period, located, accelerations from the
    velocities) against the converged simulator at 1024 steps: the RMS error of the non-carrier
    pinion orders, as a fraction of the RMS of the reference's mesh-order lines (the carriers they
    sit between), below 1e-3 for the bearing force and 3e-3 for the pinion-node acceleration
    (measured 1.8e-4 and 1.2e-3, i.e. 0.013 N and 0.155 m/s^2; at 32 steps with direct
    accelerations 9.7e-3 and 2.8e-2)."""
    from gear_rotor_sim.calibration.measurement import OperatingPoint
    from gear_rotor_sim.calibration.residual import REFERENCE_STEPS_PER_MESH, ModelRunner
    from gear_rotor_sim.config import load_config
    from gear_rotor_sim.simulator import Simulator

    cfg = load_config("paper_sun2021")
    cfg = cfg.replace(load=dataclasses.replace(cfg.load, torque_nm=200.0))
    n = 8000  # 0.4 s: 20 pinion revolutions at 3000 rpm
    chans = ["bearing2_fx", "node5_ay"]
    runner = ModelRunner(
        cfg, OperatingPoint(3000.0, 25.0, 200.0), FS, n, 0.0, chans, 0.15, REFERENCE_STEPS_PER_MESH
    )
    model = runner.signals(())
    sim = Simulator(
        cfg, speed_rpm=3000.0, temperature_c=25.0, output_rate_hz=FS, channels=chans, steps_per_mesh=1024
    )
    ref = np.asarray(sim.advance(0.15 + n / FS + 1e-3).data)[3000 : 3000 + n]
    orders = np.arange(1, 100)
    off = orders % 29 != 0
    rel = []
    for c in range(2):
        a = order_coefficients(model[:, c], FS, 50.0, orders, 0.0)[0]
        b = order_coefficients(ref[:, c], FS, 50.0, orders, 0.0)[0]
        err = np.sqrt(np.mean(np.abs(a - b)[off] ** 2))
        carriers = np.sqrt(np.mean(np.abs(b[~off]) ** 2))
        rel.append(float(err / carriers))
    assert rel[0] < 1e-3, rel  # bearing force
    assert rel[1] < 3e-3, rel  # pinion-node acceleration
