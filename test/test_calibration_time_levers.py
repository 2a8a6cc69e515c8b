"""The CPU levers of session 26 (docs/history/calibration_sessions.md Sec. 8.73) against the exact
computations they replace.

Truths used: ``numpy.linalg.lstsq`` (SVD) on the wheel's orders (what ``misalignment_force.wheel_orders``
solved before, here in the complex basis), the direct DTFT sum, and the three-operand
``numpy.einsum`` of the crack's tilt moments. The signals are the independent generator's
(``lumped_gearbox``, the shared 0.6 s pinion-tooth record of test/conftest.py) and random lines.
"""

from __future__ import annotations

import numpy as np
import pytest

from gear_rotor_sim.faults import misalignment_force as mf
from gear_rotor_sim.faults.crack import line_sum

RATE_HZ = 20000.0


def _lstsq_orders(t: np.ndarray, x: np.ndarray, shaft_hz: float, kmax: int) -> np.ndarray:
    """The order coefficients by ``numpy.linalg.lstsq`` (SVD) on the complex basis ``e^{i k theta}``,
    ``|k| <= K``: for real samples the same least squares as the real basis ``[1, cos, -sin]``."""
    theta = 2.0 * np.pi * shaft_hz * t
    e = np.exp(1j * np.outer(theta, np.arange(-kmax, kmax + 1)))
    return np.linalg.lstsq(e, x.astype(complex), rcond=None)[0][kmax:]


@pytest.fixture(scope="module")
def generator_force(shared_records: dict) -> np.ndarray:
    """A radial bearing force of the generator's 3000 rpm pinion-tooth record (the mesh orders of both
    wheels, their sidebands and sensor noise)."""
    data = np.genfromtxt(shared_records["pinion_tooth"], delimiter=",", names=True)
    return np.asarray(data["bearing2_fy"], dtype=float)


@pytest.mark.parametrize(("shaft_hz", "first"), [(50.0, 0), (-50.0 * 23 / 37, 1234)])
def test_normal_equations_equal_lstsq_on_a_generator_force(generator_force, shaft_hz, first):
    # whole revolutions of the wheel but for the window's rounding to a sample
    n = round(np.floor(generator_force.size / RATE_HZ * abs(shaft_hz)) / abs(shaft_hz) * RATE_HZ)
    x = generator_force[:n]
    t = (first + np.arange(n)) / RATE_HZ
    kmax = mf.max_wheel_order(shaft_hz, RATE_HZ)
    fast = mf._orders_by_normal_equations(t, x, shaft_hz, kmax)
    assert fast is not None  # the basis is orthogonal to rounding: the fast path is taken
    ref = _lstsq_orders(t, x, shaft_hz, kmax)
    assert np.linalg.norm(fast - ref) <= 1e-12 * np.linalg.norm(ref)
    # and wheel_orders returns it (not its memo of another call)
    mf._ORDERS.clear()
    got = mf.wheel_orders(t, x, shaft_hz, kmax)
    assert np.linalg.norm(got - ref) <= 1e-12 * np.linalg.norm(ref)


def test_ill_conditioned_or_non_uniform_windows_fall_back_to_lstsq():
    rng = np.random.default_rng(3)
    # a quarter revolution: the orders are far from orthogonal
    t = np.arange(250) / RATE_HZ
    x = rng.normal(size=t.size)
    assert mf._orders_by_normal_equations(t, x, 20.0, 6) is None
    mf._ORDERS.clear()
    np.testing.assert_array_equal(mf.wheel_orders(t, x, 20.0, 6), mf._orders_by_least_squares(t, x, 20.0, 6))
    # times off the uniform grid
    t = np.sort(rng.uniform(0.0, 0.5, 2000))
    x = np.cos(2 * np.pi * 40.0 * t)
    assert mf._orders_by_normal_equations(t, x, 40.0, 5) is None


def test_block_order_sums_equal_the_direct_dtft():
    rng = np.random.default_rng(5)
    for n in (1, 7, 1000, 4099):
        x = rng.normal(size=n)
        k = np.arange(0, 41)
        theta0, step = 0.37, 2 * np.pi * 33.3 / RATE_HZ
        direct = np.exp(-1j * np.outer(k, theta0 + step * np.arange(n))) @ x
        got = mf.order_sums(x, theta0, step, k)
        # rounding of the phases (up to |theta| = theta0 + K n step rad) and of the n-term sums, relative to
        # the sum's bound sum |x|
        scale = abs(theta0) + k.max() * step * n + n
        tol = 16 * np.finfo(float).eps * scale * np.sum(np.abs(x))
        assert np.max(np.abs(got - direct)) <= tol


@pytest.mark.parametrize("nh", [0, 3])
def test_tilt_line_sum_equals_the_three_operand_einsum(nh):
    rng = np.random.default_rng(nh)
    n, nk, nt = 700, 17, 4
    ek = np.exp(1j * rng.uniform(0, 2 * np.pi, (n, nk)))
    eh = np.exp(1j * rng.uniform(0, 2 * np.pi, (n, 2 * nh + 1)))
    lines = rng.normal(size=(nk, 2 * nh + 1, nt)) + 1j * rng.normal(size=(nk, 2 * nh + 1, nt))
    ref = np.real(np.einsum("nk,nh,kht->nt", ek, eh, lines))
    got = line_sum(ek, eh, lines)
    assert got.shape == ref.shape
    assert np.max(np.abs(got - ref)) <= 1e-13 * np.max(np.abs(ref))


def test_crack_phase_search_on_the_order_features_alone_gives_the_same_floats(shared_records: dict):
    """``candidates_crack._fit_form`` searches the mouth's phase on the order features alone
    (``order_part``): the linear fit, its low-order loss, the low orders' chi^2, the gains and the time
    shift are the floats the full features (with analytic signals) give. Features of the generator's
    healthy 2000 rpm record, scaled and with noise as model columns."""
    from gear_rotor_sim.calibration import candidates_crack as cc
    from gear_rotor_sim.calibration.fit import Calibrator
    from gear_rotor_sim.calibration.measurement import load_measurement
    from gear_rotor_sim.calibration.residual_types import ModelFeatures

    cal = Calibrator(load_measurement(shared_records["healthy_2000"]))
    cmp, n = cal.cmp, cal.runner.n_model
    data = np.asarray(cal.m.data[:n], dtype=float)
    rng = np.random.default_rng(8)

    def feats(scale: float) -> ModelFeatures:
        model = scale * data + 0.1 * np.std(data, axis=0) * rng.normal(size=data.shape)
        analytic = [rng.normal(size=n) + 1j * rng.normal(size=n) for _ in range(cmp.nc)]
        return ModelFeatures(cmp._order(model), analytic, model.mean(axis=0))

    cur, cols = feats(0.9), [feats(0.05), feats(0.02), feats(0.01)]
    bare_cur, bare_cols = cc.order_part(cur), [cc.order_part(x) for x in cols]
    assert bare_cur.analytic == [] and len(cur.analytic) == cmp.nc
    c = cc.linear_coefficients(cal, cur, cols)
    assert c is not None and np.all(c != 0.0)
    assert np.array_equal(cc.linear_coefficients(cal, bare_cur, bare_cols), c)
    low = cc.low_order_coefficient(cal, cur, cols, c)
    assert low is not None and cc.low_order_coefficient(cal, bare_cur, bare_cols, c) == low
    assert cc.low_order_chi2(cal, bare_cur) == cc.low_order_chi2(cal, cur)
    assert np.array_equal(cmp.fit_gains(bare_cur), cmp.fit_gains(cur))
    assert cmp.best_shift(bare_cur) == cmp.best_shift(cur)
