"""The rattle point (8000 rpm) diagnosed against a held reference baseline (issue 11, ``--baseline``).

The reference is the one the benchmark fits on the independent machine's healthy 2000 rpm record
(teeth in contact): mesh stiffness x1.3085, mesh damping x1.7, bearing stiffness x0.522, bearing
damping x1.285, carrier tolerance 0.5 (docs/calibration.md Sec. 8.1,
docs/history/calibration_sessions.md Sec. 8.17). Held at 8000 rpm it
shrinks a damaged tooth's model response five times in power per unit depth and triples the
healthy model's node-5 comb; with the bearing channels' path fitted (``fault_path.py``) a small pinion
tooth then read the node accelerations' rattle comb on the healthy record. Checked here:

- the path factor minimises the channel's chi^2 as it is scored (the tolerance depends on the model
  the factor makes), against an exhaustive search of the complex plane;
- the gain of the comb at the channels at the mesh (DTE) against a hand computation, in sum and per
  sideband family, and the family rules applied to it (a tooth must be a broad comb at the mesh too);
- on 1 s records of the independent lumped gearbox with that reference held: the healthy record claims
  no tooth, a damaged pinion tooth is named on its tooth within 25 % with the error halved.
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from gear_rotor_sim.calibration.comb_families import narrow_comb_reason
from gear_rotor_sim.calibration.fault_path import mesh_comb_gain, mesh_comb_gain_by_family, path_factors
from gear_rotor_sim.calibration.fit import Calibrator
from gear_rotor_sim.calibration.measurement import load_measurement
from gear_rotor_sim.calibration.residual import ModelFeatures
from gear_rotor_sim.faults import BearingStiffnessDamping, MeshStiffnessDamping, ToothDamage

#: the benchmark's 2000 rpm reference (``benchmarks/calibration_independent.py --only-baseline``, 2 s
#: record, seed of the benchmark), as ``--save-baseline`` writes it
REFERENCE = {
    "baseline": [
        MeshStiffnessDamping(stiffness_scale=1.3085, damping_scale=1.7),
        BearingStiffnessDamping(stiffness_scale=0.5217, damping_scale=1.2854),
    ],
    "carrier_tolerance": 0.5,
    "baseline_source": "healthy 2000 rpm reference",
}


def _channel(orders: np.ndarray, sig: np.ndarray, data: np.ndarray, noise: float, tol: float):
    """A comparison with a DTE channel (unused) and one radial bearing channel whose uncertainty is
    ``noise + (tol min(|model|, |data|))^2`` (the form of ``Comparison.order_sigma2``)."""
    d = [[sig.copy()], [data]]

    def sigma2(c: int, s: int, m: np.ndarray | None = None) -> np.ndarray:
        if m is None:
            return np.full(orders.size, noise)
        return noise + (tol * np.minimum(np.abs(m), np.abs(d[c][s]))) ** 2

    cmp = SimpleNamespace(
        nc=2,
        names=["dte", "bearing2_fx"],
        shafts=[SimpleNamespace(orders=orders)],
        d_order=d,
        order_gain=lambda g, c, s: g[c],
        order_sigma2=sigma2,
        carriers=lambda s: orders % 29 == 0,
    )
    sigf = ModelFeatures([[sig.copy()], [sig.copy()]], [np.zeros(4, complex), np.zeros(4, complex)])
    return cmp, sigf


def test_path_factor_minimises_the_channel_chi2_as_scored() -> None:
    """The model's signature holds lines the record lacks on a third of the comb (a path of another
    shape) and the rest is the signature times 0.5+0.3j with 5 % scatter. The uncertainty depends on
    the scaled model, so the factor must minimise ``sum |d - a s|^2 / sigma^2(a s)``: it is compared
    with a 0.02-step grid over the complex plane. The least squares with the weights taken once at
    the unscaled signature (the previous rule) is far worse, as is the model's own path a = 1."""
    orders = np.arange(1, 64)
    ok = orders % 29 != 0
    for seed in (0, 1):
        rng = np.random.default_rng(seed)
        s = (1.0 + rng.random(orders.size)) * np.exp(2j * np.pi * rng.random(orders.size))
        data = (0.5 + 0.3j) * s * (1.0 + 0.05 * rng.standard_normal(orders.size))
        data[::3] = 0.02 * s[::3]
        cmp, sig = _channel(orders, s, data, 1e-4, 0.3)
        cur = sig.scaled(0.0)

        def chi2(a: complex, cmp=cmp, s=s, data=data) -> float:
            return float(np.sum((np.abs(data - a * s) ** 2 / cmp.order_sigma2(1, 0, a * s))[ok]))

        a = path_factors(cmp, cur, sig, np.array([False, True]))
        assert a[0] == 1.0
        re, im = np.meshgrid(np.arange(-1.0, 2.0, 0.02), np.arange(-1.5, 1.5, 0.02))
        grid = np.array([chi2(complex(x, y)) for x, y in zip(re.ravel(), im.ravel(), strict=True)])
        # at least as good as every point of the grid (measured: 0.139+0.056j and 0.142+0.057j)
        assert chi2(a[1]) <= grid.min() * (1.0 + 1e-9)
        w = 1.0 / cmp.order_sigma2(1, 0, s)
        once = np.sum((w * np.conj(s) * data)[ok]) / np.sum((w * np.abs(s) ** 2)[ok])
        assert chi2(a[1]) < 0.5 * chi2(once)
        assert chi2(a[1]) < 0.1 * chi2(1.0)


def test_mesh_comb_gain_counts_the_dte_comb_only() -> None:
    """chi^2 gain of the comb at the DTE on one shaft, by hand: noise variance 1 (tolerance 0), the
    record's comb 3 on every order; a model at 1 leaves 4 per order, at 2 leaves 1: the gain is
    2 x (4 - 1) per comb order (2 per complex coefficient); the carrier (order 29) and the bearing
    channel do not count. A model at 5 (an overshoot) loses: 2 x (4 - 4) = 0."""
    orders = np.arange(1, 36)
    comb = int(np.count_nonzero(orders % 29 != 0))
    cmp, _ = _channel(orders, np.full(orders.size, 3.0 + 0j), np.full(orders.size, 100.0 + 0j), 1.0, 0.0)

    def model(x: float) -> ModelFeatures:
        return ModelFeatures(
            [[np.full(orders.size, x + 0j)], [np.zeros(orders.size, complex)]],
            [np.zeros(4, complex), np.zeros(4, complex)],
        )

    assert mesh_comb_gain(cmp, model(1.0), model(2.0), 0) == pytest.approx(2.0 * 3.0 * comb, rel=1e-12)
    assert mesh_comb_gain(cmp, model(1.0), model(5.0), 0) == pytest.approx(0.0, abs=1e-9)
    assert mesh_comb_gain(cmp, model(2.0), model(1.0), 0) == pytest.approx(-2.0 * 3.0 * comb, rel=1e-12)


def test_mesh_comb_gain_by_family_and_the_narrow_comb_rule() -> None:
    """Per sideband family at the DTE, by hand: orders 1-6, 23-35 and 52-64 of a 29-tooth shaft (five
    orders in each family j = 1..6: j, 29 -+ j, 58 -+ j), noise variance 1. A tooth's model puts 1.5 on
    every comb order. Against a record with 3 on the families 3 and 4 only (two rattle components) it
    gains 2 x (9 - 2.25) = 13.5 per order there and loses 2 x 2.25 = 4.5 per order elsewhere: +67.5 and
    -22.5 per family, significant in two families (threshold 17): refused. Against a record with 3 on
    every comb order it gains 67.5 in each family: a tooth. Against one with 3 on the families 2-6 only,
    its fundamental family loses: refused where the teeth separate (the fundamental rule), accepted
    where they do not (five families)."""
    orders = np.array([*range(1, 7), *range(23, 36), *range(52, 65)])
    fam = np.minimum(orders % 29, 29 - orders % 29)

    def case(record_families: set[int]) -> dict[int, float]:
        data = np.where(np.isin(fam, sorted(record_families)), 3.0, 0.0).astype(complex)
        cmp, _ = _channel(orders, data, np.zeros(orders.size, complex), 1.0, 0.0)
        cmp.shafts[0].teeth = 29

        def model(x: float) -> ModelFeatures:
            m = np.where(fam > 0, x, 0.0).astype(complex)
            return ModelFeatures(
                [[m], [np.zeros(orders.size, complex)]], [np.zeros(4, complex), np.zeros(4, complex)]
            )

        by_family = mesh_comb_gain_by_family(cmp, model(0.0), model(1.5), 0)
        assert sum(by_family.values()) == pytest.approx(
            mesh_comb_gain(cmp, model(0.0), model(1.5), 0), rel=1e-12
        )
        return by_family

    two = case({3, 4})
    assert two == pytest.approx({1: -22.5, 2: -22.5, 3: 67.5, 4: 67.5, 5: -22.5, 6: -22.5}, rel=1e-12)
    assert "2 sideband families only" in narrow_comb_reason(two, 17.0, 0.02, 3, True)
    broad = case({1, 2, 3, 4, 5, 6})
    assert broad == pytest.approx(dict.fromkeys(range(1, 7), 67.5), rel=1e-12)
    assert narrow_comb_reason(broad, 17.0, 0.02, 3, True) == ""
    no_fundamental = case({2, 3, 4, 5, 6})
    assert "first family" in narrow_comb_reason(no_fundamental, 17.0, 0.02, 3, True)
    assert narrow_comb_reason(no_fundamental, 17.0, 0.02, 3, False) == ""


@pytest.fixture(scope="module")
def records(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    from lumped_gearbox import make_record, write_record

    root = tmp_path_factory.mktemp("rattle_reference")
    out = {}
    for tag, faults, seed in (
        ("healthy", [], 21),
        ("pinion_tooth", ["tooth_damage:wheel=pinion,tooth=7,depth=0.4"], 22),
    ):
        rec = make_record(8000.0, 25.0, faults, duration_s=1.0, seed=seed)
        assert rec.contact_loss_fraction > 0.3  # the teeth do separate
        out[tag] = write_record(root / f"{tag}.csv", rec)
    return out


@pytest.mark.acceptance
def test_pinion_tooth_against_a_held_reference_where_the_teeth_separate(records) -> None:
    """Healthy 8000 rpm record against the 2000 rpm reference: no tooth. Damaged pinion tooth 7 (depth
    0.4): named on its tooth within 25 %, error at least halved. Numbers measured on the point-sampled
    records of sessions 1-12: on the 2 s benchmark record a pinion tooth 28 at depth 0.08 had taken 20 %
    of the excess from the node-5 accelerations while the DTE's comb got worse; on this 1 s record the
    best pinion tooth gained 685 in chi^2 on its shaft's comb but -127 at the DTE, refused by the
    mesh-channel rule; the damaged tooth 0.365, 8.48 -> 2.48 (2 s benchmark record 0.360, 11.2 -> 2.84;
    before, with the path rule off against a reference, 0.239)."""
    cands = [ToothDamage(wheel="pinion"), ToothDamage(wheel="gear")]
    res = Calibrator(load_measurement(records["healthy"]), candidates=cands[:1], **REFERENCE).run()
    assert res.effects == [], [(e.label, e.parameters) for e in res.effects]
    # (on the point-sampled records of sessions 1-12 the pinion tooth was refused by the mesh-channel
    # rule here, note "at the channels at the mesh (DTE) gains -"; on the anti-aliased, converged record
    # of lumped_gearbox/daq.py no pinion tooth explains anything beyond the noise:
    # docs/history/calibration_sessions.md Sec. 8.29)
    res = Calibrator(load_measurement(records["pinion_tooth"]), candidates=cands, **REFERENCE).run()
    assert res.effects, res.notes
    first = res.effects[0]
    assert first.label == "tooth_damage@pinion"
    assert first.parameters["tooth"] == 7
    assert first.parameters["depth"] == pytest.approx(0.4, rel=0.25)
    assert any("fitted transfer factor" in n for n in res.notes), res.notes
    assert res.error_after <= 0.5 * res.error_before
