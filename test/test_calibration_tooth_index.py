"""A damaged tooth's index from the transmission error's low orders where the whole record names another
tooth (``calibration/candidates_tooth_index.py``; docs/history/calibration_sessions.md Sec. 8.80).

The truth here is analytic: a tooth's pulse in the DTE, ``a`` over the mesh cycles ``[j - 1, j - 1 + eps)``
of a wheel of ``z`` teeth, has the order-``k`` Fourier coefficient ``a (1 - exp(-2 pi i k eps / z)) /
(2 pi i k) exp(-2 pi i k (j - 1) / z)``: shifting it by one tooth turns order ``k`` by ``2 pi k / z``. A
model whose pulse is off in amplitude and length (model form) must still be least off at the true tooth on
orders 1-6.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from gear_rotor_sim.calibration.candidates_tooth_index import (
    DECISIVE_RATIO,
    LowOrderIndex,
    decisive,
    rank_low_orders,
    teeth_to_compare,
)
from gear_rotor_sim.calibration.candidates_tooth_path import low_order_mesh_chi2

Z = 29
ORDERS = np.arange(1, 2 * Z + 1)


def _pulse(tooth: int, amp: float, eps: float) -> np.ndarray:
    """Order coefficients 1..2z of the pulse of ``tooth`` (1-based) over ``eps`` mesh cycles."""
    k = ORDERS.astype(float)
    shape = (1 - np.exp(-2j * np.pi * k * eps / Z)) / (2j * np.pi * k)
    return amp * shape * np.exp(-2j * np.pi * k * (tooth - 1) / Z)


def _cmp(record: np.ndarray, sigma: float) -> SimpleNamespace:
    """A comparison with one DTE channel on one shaft (the damaged wheel's), noise ``sigma`` per order."""
    shaft = SimpleNamespace(orders=ORDERS)
    return SimpleNamespace(
        names=["dte"],
        nc=1,
        shafts=[shaft],
        d_order=[[record]],
        carriers=lambda s: ORDERS % Z == 0,
        order_gain=lambda g, c, s: 1.0,
        order_sigma2=lambda c, s, m: np.full(ORDERS.size, sigma**2),
    )


def _feats(coef: np.ndarray) -> SimpleNamespace:
    return SimpleNamespace(order=[[coef]])


def test_low_orders_name_the_true_tooth_under_model_form() -> None:
    """Record: tooth 13, pulse 1.0 over 1.6 mesh cycles. Model: 0.7 over 1.3 cycles (another depth and
    contact ratio). The low-order chi^2 is least at tooth 13 and its neighbours read at least twice it."""
    noise = 1e-4
    cal = SimpleNamespace(cmp=_cmp(_pulse(13, 1.0, 1.6), noise))
    low = np.array([low_order_mesh_chi2(cal, _feats(_pulse(t, 0.7, 1.3)), 0) for t in range(1, Z + 1)])
    assert int(np.argmin(low)) + 1 == 13
    assert min(low[11], low[13]) >= DECISIVE_RATIO * low[12]
    healthy = low_order_mesh_chi2(cal, _feats(np.zeros(ORDERS.size, complex)), 0)
    # the whole record (other channels' path misfit) named tooth 15 in the constructed ranking
    whole = np.ones(Z)
    whole[14] = 0.5
    r = rank_low_orders(low, whole, healthy)
    assert (r.whole_tooth, r.low_tooth) == (15, 13)
    assert decisive(r, 10.0)
    assert teeth_to_compare(r, Z) == (15, 13, 12, 14)


def test_low_order_chi2_ignores_orders_above_six() -> None:
    """Orders above 6 (the carriers' and higher harmonics' model form) do not enter."""
    rec = _pulse(13, 1.0, 1.6)
    cal = SimpleNamespace(cmp=_cmp(rec, 1e-3))
    model = rec.copy()
    model[6:] = 0.0  # orders 7.. wrong
    assert low_order_mesh_chi2(cal, _feats(model), 0) == pytest.approx(0.0, abs=1e-12)
    model = rec.copy()
    model[5] *= 1.1  # order 6 wrong by 10 %
    expected = 2.0 * abs(0.1 * rec[5]) ** 2 / 1e-6
    assert low_order_mesh_chi2(cal, _feats(model), 0) == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize(
    ("r", "expected"),
    [
        (LowOrderIndex(15, 13, 15272.0, 1300.4, 6.81e5), True),  # blind2_16 on full runs (module docstring)
        (LowOrderIndex(15, 13, 1.9 * 1300.0, 1300.0, 6.81e5), False),  # below the ratio
        (LowOrderIndex(13, 13, 1300.0, 1300.0, 6.81e5), False),  # the rankings agree: nothing changes
        (LowOrderIndex(15, 13, 40.0, 5.0, 12.0), False),  # the low orders do not hold the pulse (gain 7)
        (LowOrderIndex(15, 13, np.inf, 5.0, 1e4), False),  # not ranked
    ],
)
def test_decisive(r: LowOrderIndex, expected: bool) -> None:
    assert decisive(r, 10.0) is expected


def test_teeth_to_compare_wraps_round_the_wheel() -> None:
    r = LowOrderIndex(3, 1, 10.0, 1.0, 100.0)
    assert teeth_to_compare(r, Z) == (3, 1, 29, 2)
    r = LowOrderIndex(28, 29, 10.0, 1.0, 100.0)
    assert teeth_to_compare(r, Z) == (28, 29, 1)
