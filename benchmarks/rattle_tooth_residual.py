"""Where a diagnosis's order residual sits: chi^2 per channel, shaft and order group
(docs/history/calibration_sessions.md Sec. 8.37).

Runs the calibration of each record as the CLI does (``gear-rotor-sim calibrate RECORD --json``, with
``--baseline REF.json`` when given: the reference written by ``--save-baseline`` or by
``benchmarks/calibration_independent.py``), then splits the order family's chi^2 of the healthy
(baseline-updated) model and of the final model (with the effects found) into groups per channel and
shaft: the low orders 1-6, the mesh carriers ``m z`` and the sideband families ``m z +- j`` (``j`` =
1..6, with the low order ``j``: ``comb_families.sideband_family``). Each cell is printed as
``chi^2 / N`` (N real features; 1 = the noise level), the chi^2 with the gains and time shift held as
the rattle rules hold them (``fault_path.order_terms``). Also the envelope chi^2 per channel.

Usage::

    python benchmarks/rattle_tooth_residual.py RECORD.csv [RECORD.csv ...] [--baseline REF.json]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from gear_rotor_sim.calibration.baseline import load_reference
from gear_rotor_sim.calibration.calibrate_cli import skip_start_transient
from gear_rotor_sim.calibration.comb_families import sideband_family
from gear_rotor_sim.calibration.fault_path import order_terms
from gear_rotor_sim.calibration.fit import Calibrator
from gear_rotor_sim.calibration.measurement import load_measurement
from gear_rotor_sim.calibration.residual import ModelFeatures, ResidualSettings


def order_groups(cmp: Any, feats: ModelFeatures) -> dict[str, dict[str, tuple[float, int]]]:
    """``{channel: {"shaft/group": (chi2, n)}}`` of the order features of ``feats`` (gains 1, no shift)."""
    out: dict[str, dict[str, tuple[float, int]]] = {}
    for c, name in enumerate(cmp.names):
        row: dict[str, tuple[float, int]] = {}
        for s, sh in enumerate(cmp.shafts):
            v = order_terms(cmp, feats, c, s)
            ok = np.isfinite(v)
            fam = sideband_family(sh.orders, sh.teeth) if sh.teeth else np.zeros(sh.orders.size, int)
            groups = {"low": (sh.orders <= 6) & ~cmp.carriers(s), "carrier": cmp.carriers(s)}
            for j in range(1, 7):
                groups[f"j{j}"] = (fam == j) & (sh.orders > 6) & ~cmp.carriers(s)
            for g, mask in groups.items():
                m = mask & ok
                row[f"s{s}/{g}"] = (2.0 * float(np.sum(v[m])), 2 * int(np.count_nonzero(m)))
        out[name] = row
    return out


def run(path: Path, reference: Path | None) -> dict[str, Any]:
    m = load_measurement(path)
    start = skip_start_transient(m)
    if start:
        m = m.segment(start, None)
    kw = load_reference(reference).calibrator_kwargs() if reference else {}
    t0 = time.process_time()
    cal = Calibrator(m, settings=ResidualSettings(), **kw)
    res = cal.run()
    cpu = time.process_time() - t0
    # the final model as scored: its full run plus the correction an accepted effect's fitted path left
    final = cal.cmp.features(res.model_after)
    if getattr(cal, "_feat_correction", None) is not None:
        final = final.combo(cal._feat_correction, 1.0)
    base = cal._features(cal.base_raw)
    out = {
        "record": path.name,
        "reference": str(reference) if reference else None,
        "error": [res.error_before, res.error_after],
        "effects": [(f.label, f.parameters) for f in res.effects],
        "baseline": [(b.label, b.parameters) for b in res.baseline_updates if b.label != "sensor_transfer"],
        "cpu_s": cpu,
        "healthy": order_groups(cal.cmp, base),
        "final": order_groups(cal.cmp, final),
        "envelope_final": {
            n: float(np.sum(r)) for n, r in zip(cal.cmp.names, cal.cmp.score(final).envelope_r2, strict=False)
        },
        "order_chi2_check": [res.score_after.chi2.get("order"), cal.cmp.score(final).chi2.get("order")],
        "notes": cal.notes,
    }
    return out


def show(r: dict[str, Any]) -> None:
    e0, e1 = r["error"]
    print(f"\n## {r['record']} (reference {r['reference']}): error {e0:.3g} -> {e1:.3g}")
    print(f"effects {r['effects']}; baseline {r['baseline']}; CPU {r['cpu_s']:.0f} s")
    keys = list(next(iter(r["final"].values())).keys())
    print("| channel | model | " + " | ".join(keys) + " |")
    print("|---|---|" + "---|" * len(keys))
    for ch in r["final"]:
        for tag in ("healthy", "final"):
            cells = []
            for k in keys:
                chi, n = r[tag][ch][k]
                cells.append(f"{chi / n:.2g}" if n else "-")
            print(f"| {ch} | {tag} | " + " | ".join(cells) + " |")
    print("order chi2 reported / recomputed:", r["order_chi2_check"])
    print("envelope chi2 (final):", {k: round(v) for k, v in r["envelope_final"].items()})


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("records", nargs="+", type=Path)
    ap.add_argument("--baseline", type=Path, default=None, help="reference baseline JSON")
    ap.add_argument("--json", type=Path, default=None, help="write the groups to this file")
    a = ap.parse_args()
    results = [run(p, a.baseline) for p in a.records]
    for r in results:
        show(r)
    if a.json:
        a.json.write_text(json.dumps(results, default=str, indent=1))


if __name__ == "__main__":
    main()
