"""Rules of the ``--baseline`` path that are checked on constructed cases (issue 11, session 8).

- Where the teeth separate, the per-channel model-form tolerance of ``features_rattle.py`` (rule 3)
  is lifted at the shaft orders 1 and 2 where the healthy model has nothing: a fault's content
  there is kinematic or quasi-static (the order-1 bearing forces of an unbalance: a lever rule) and
  keeps the contact tolerance (docs/history/calibration_sessions.md Sec. 8.12).
- The DTE channel of a mesh is found by its contract name.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from gear_rotor_sim.calibration.candidates_wear_reference import dte_channel
from gear_rotor_sim.calibration.features_rattle import rattle_orders
from gear_rotor_sim.calibration.residual import Comparison


def test_rule_3_is_lifted_only_at_quiet_low_shaft_orders() -> None:
    orders = [np.array([0, 1, 2, 3, 28, 29])]
    noise = [[np.array([1.0, 1.0, 4.0, 1.0, 1.0, np.inf])]]
    # order 1: power 100 (the healthy rattle is there); order 2: 4 against 36 = 9 noise variances
    # (quiet: a quasi-static fault's own); order 3 and the sideband 28 quiet but not low orders
    # (a damaged tooth's comb); order 29 left out (infinite variance)
    nominal = [[np.array([5.0, 10.0, 2.0j, 0.1, 0.1, 50.0])]]
    where = rattle_orders(nominal, noise, orders)
    assert where[0][0].tolist() == [True, True, False, True, True, True]
    # with max_order 3 the quiet order 3 is lifted too
    assert rattle_orders(nominal, noise, orders, max_order=3)[0][0].tolist() == [
        True,
        True,
        False,
        False,
        True,
        True,
    ]


def _stub(where: list[list[np.ndarray]] | None) -> SimpleNamespace:
    """The attributes of a ``Comparison`` that ``order_sigma2`` reads: one channel, one shaft, three
    orders, the last a mesh carrier."""
    return SimpleNamespace(
        v_order=[[np.full(3, 0.5)]],
        v_model_form=[[np.array([0.25, 0.0, 0.0])]],
        d_order=[[np.array([100.0, 40.0, 200.0])]],
        s=SimpleNamespace(tolerance=0.05),
        carrier_tolerance=0.5,
        channel_tolerance=np.array([0.3]),
        channel_tolerance_where=where,
        carriers=lambda s: np.array([False, False, True]),
    )


def test_channel_tolerance_only_where_the_healthy_model_rattles() -> None:
    model = np.array([80.0, 50.0, 150.0])
    common = np.array([80.0, 40.0, 150.0])  # the smaller of model and data
    v = np.array([0.75, 0.5, 0.5])  # noise + ensemble variance
    # order 0: rattle (channel tolerance 0.3); order 1: the fault's own (contact tolerance 0.05);
    # the carrier: the larger of the carrier tolerance (0.5) and the channel's
    got = Comparison.order_sigma2(_stub([[np.array([True, False, True])]]), 0, 0, model)
    want = v + (np.array([0.3, 0.05, 0.5]) * common) ** 2
    np.testing.assert_allclose(got, want, rtol=1e-12)
    # without the mask (as before): the channel tolerance on every non-carrier order
    got_all = Comparison.order_sigma2(_stub(None), 0, 0, model)
    np.testing.assert_allclose(got_all, v + (np.array([0.3, 0.3, 0.5]) * common) ** 2, rtol=1e-12)
    # noise alone without a model
    np.testing.assert_allclose(Comparison.order_sigma2(_stub(None), 0, 0), v, rtol=1e-12)


def test_dte_channel_by_contract_name() -> None:
    names = ["dte", "bearing2_fx", "bearing2_fy"]
    assert dte_channel(names, 1, 1) == 0
    assert dte_channel(names, 2, 2) is None
    two = ["mesh1_dte", "mesh1_force", "mesh2_dte", "mesh2_force"]
    assert dte_channel(two, 2, 2) == 2
    assert dte_channel(two, 1, 2) == 0
