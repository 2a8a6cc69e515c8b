"""A misaligned wheel's angle read from the axial force's line below the mesh band, not from the sidebands
``m z +- 1`` (``candidates_misalignment.axial_low_orders``; docs/history/calibration_sessions.md Sec. 8.80).

The axial force ``F(t) angle cos(theta + phi)`` puts ``F0 angle`` at the tilted wheel's order 1
(``F0 = T / r_b``: the same in any model of the gearbox) and the dynamic mesh force's harmonics times the
angle at ``m z +- 1`` (model form). Constructed here: a record whose sidebands are 3.5 times the model's per
radian (blind2_02's 0.248 N against 0.071 N per mrad) and whose order-1 line is exact. The least squares on
the low orders must return the record's angle exactly; on every feature they must not (else the selection
would not matter).
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from gear_rotor_sim.calibration.candidates_misalignment import axial_chi2, axial_low_orders
from gear_rotor_sim.calibration.fit_candidates import CandidateFitting
from gear_rotor_sim.calibration.residual_types import ModelFeatures
from gear_rotor_sim.faults import GearMisalignment

Z_P, Z_G = 29, 49
SPEED_HZ = 2067.0 / 60.0
NAMES = ["dte", "bearing2_fz"]
SHAFTS = [
    SimpleNamespace(orders=np.arange(1, 2 * Z_P + 1), ratio=1.0),
    SimpleNamespace(orders=np.arange(1, 2 * Z_G + 1), ratio=Z_P / Z_G),
]
F0 = 1000.0  # N, the static mesh force
SIDEBAND = 71.0  # N per rad of the model at orders z_g +- 1 of the gear (blind2_02: 0.071 N per mrad)
ANGLE, PHASE = 0.687e-3, 0.78


def _axial(order1: complex, sideband: complex) -> ModelFeatures:
    """Features with the axial channel's gear order 1 and sidebands ``z_g +- 1`` set, the rest zero."""
    order = [[np.zeros(sh.orders.size, complex) for sh in SHAFTS] for _ in NAMES]
    g = order[1][1]
    g[0] = order1
    g[Z_G - 2] = g[Z_G] = sideband  # orders 48 and 50
    return ModelFeatures(order, [np.zeros(4) for _ in NAMES], np.zeros(len(NAMES)))


NOISE = 0.012  # N, the axial channel's noise per order (blind2_02)
TOLERANCE = 0.05  # the model-form tolerance on the common amplitude (``ResidualSettings.tolerance``)


def _cmp(record: ModelFeatures) -> SimpleNamespace:
    def sigma2(c: int, s: int, m: np.ndarray | None = None) -> np.ndarray:
        d = record.order[c][s]
        common = np.zeros(d.size) if m is None else np.minimum(np.abs(m), np.abs(d))
        return NOISE**2 + (TOLERANCE * common) ** 2

    return SimpleNamespace(
        names=NAMES,
        nc=len(NAMES),
        shafts=SHAFTS,
        speed_hz=SPEED_HZ,
        mesh_hz=Z_P * SPEED_HZ,
        families=["order"],
        d_order=record.order,
        best_shift=lambda cur: 0.0,
        apply_shift=lambda x, tau: x,
        fit_gains=lambda f: np.ones(len(NAMES)),
        order_gain=lambda g, c, s: 1.0,
        order_sigma2=sigma2,
        score=lambda f, tau=None: SimpleNamespace(balanced_chi2=0.0),
    )


def _calibrator(sideband_ratio: float) -> SimpleNamespace:
    rot = complex(math.cos(PHASE), math.sin(PHASE))
    record = _axial(F0 * ANGLE * rot, sideband_ratio * SIDEBAND * ANGLE * rot)

    def signature(e: GearMisalignment) -> ModelFeatures:
        r = e.angle_rad * complex(math.cos(e.phase_rad), math.sin(e.phase_rad))
        return _axial(F0 * r, SIDEBAND * r)

    return SimpleNamespace(
        cmp=_cmp(record),
        _signature=signature,
        _is_zero=CandidateFitting._is_zero,
        n_total=1000,
    )


def _fit(cal: SimpleNamespace, select: list | None) -> GearMisalignment:
    fit = CandidateFitting._fit_phase_amplitude(
        cal, GearMisalignment(member="gear"), _axial(0, 0), 1e-5, select
    )
    assert fit is not None
    return fit.effect


def test_low_orders_are_the_axial_channel_below_half_the_mesh_frequency() -> None:
    sel = axial_low_orders(_cmp(_axial(0, 0)))
    assert sel is not None
    assert not any(m.any() for m in sel[0])  # the DTE: nothing
    # pinion orders below 14.5, gear orders below 24.5 (half the mesh frequency)
    assert np.flatnonzero(sel[1][0]).max() + 1 == 14
    assert np.flatnonzero(sel[1][1]).max() + 1 == 24
    no_axial = _cmp(_axial(0, 0))
    no_axial.names = ["dte", "bearing2_fx"]
    assert axial_low_orders(no_axial) is None


def test_angle_from_the_line_whatever_the_sidebands() -> None:
    """Sidebands 3.5 x the model's: the line gives the angle and phase exactly; every feature +20 %
    (the line's weight is cut by the tolerance on its own amplitude, the sidebands' is the noise's)."""
    cal = _calibrator(3.5)
    e = _fit(cal, axial_low_orders(cal.cmp))
    assert e.angle_rad == pytest.approx(ANGLE, rel=1e-9)
    assert e.phase_rad == pytest.approx(PHASE, abs=1e-9)
    off = _fit(cal, None).angle_rad / ANGLE - 1.0
    assert off > 0.1, off  # the sidebands' model form pulls the all-feature fit up


def test_all_features_agree_where_the_model_holds() -> None:
    """With the record's sidebands the model's own (ratio 1) both fits read the truth."""
    cal = _calibrator(1.0)
    assert _fit(cal, None).angle_rad == pytest.approx(ANGLE, rel=1e-9)
    assert _fit(cal, axial_low_orders(cal.cmp)).angle_rad == pytest.approx(ANGLE, rel=1e-9)


def test_axial_chi2_ignores_the_sidebands() -> None:
    """The refinement's objective: zero at the right line whatever the sidebands; the line off by 10 %
    counts ``2 |0.1 F0 angle|^2 / sigma^2`` (noise and the tolerance on the record's line)."""
    cal = _calibrator(3.5)
    rot = complex(math.cos(PHASE), math.sin(PHASE))
    good = _axial(F0 * ANGLE * rot, SIDEBAND * ANGLE * rot)
    assert axial_chi2(cal, good) == pytest.approx(0.0, abs=1e-12)
    bad = _axial(1.1 * F0 * ANGLE * rot, SIDEBAND * ANGLE * rot)
    line = F0 * ANGLE
    expected = 2.0 * (0.1 * line) ** 2 / (NOISE**2 + (TOLERANCE * line) ** 2)
    assert axial_chi2(cal, bad) == pytest.approx(expected, rel=1e-9)
