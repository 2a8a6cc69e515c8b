"""Is tooth wear observable at all on the independent records? (docs/history/calibration_sessions.md
Sec. 8.32)

For each speed (25 C) this script makes ``lumped_gearbox`` records (the generator's default chain,
2 s, noise and gain draws of ``make_record``): healthy ones at several noise seeds and worn ones at
each depth of ``--depths-um``, and scores each against the FE model as the calibration does before any
fit (``Calibrator``: the step count from the model's convergence, the rattle rules where the healthy
model's teeth separate, the sensor gains and transfer slopes fitted on the healthy model and held):

- ``E0``: the error against the healthy FE model (the calibration's ``error_before``);
- ``E(h)``: the error against the FE model with tooth wear ``h`` (each of ``--model-depths-um``; where
  the teeth separate the wear is switched on after whole hunting periods on the healthy branch, as in
  the calibration's runs), the same held nuisances.

The yardstick is the healthy records' own ``E0`` (mean and spread over the seeds): a worn record whose
``E0`` lies within that spread, or whose best ``E(h)`` is not clearly below its ``E0``, carries no wear
signature the features can see, whatever the method. Printed per speed: the lumped gearbox's and the FE
model's contact-loss fractions, the healthy ``E0`` over the seeds, and per worn record ``E0``, ``E(h)``
at every model depth, the best model depth and ``E(best) / E0``.

Usage::

    python benchmarks/wear_observability.py --speeds-rpm 8000 --depths-um 10 20 40 80
    python benchmarks/wear_observability.py --contact-loss-only \
        --speeds-rpm 2000 3000 4500 6000 7000 7500 8000 8500 9000
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from gear_rotor_sim.calibration.features_rattle import apply_rattle_uncertainty
from gear_rotor_sim.calibration.fit import Calibrator
from gear_rotor_sim.calibration.measurement import load_measurement
from gear_rotor_sim.faults import ToothWear
from lumped_gearbox import make_record, write_record


def contact_loss(speed_rpm: float, depth_um: float, duration_s: float = 1.0) -> float:
    """The lumped gearbox's contact-loss fraction (clean run, default chain)."""
    faults = [f"tooth_wear:wear_depth_m={depth_um * 1e-6:g}"] if depth_um > 0 else []
    return float(make_record(speed_rpm, 25.0, faults, duration_s=duration_s, seed=0).contact_loss_fraction)


def _families(sc: Any) -> dict[str, float]:
    """chi^2 / N of each family with features."""
    return {f: float(sc.chi2[f] / sc.n[f]) for f in sc.chi2 if sc.n.get(f, 0) > 0}


def score_record(csv: Path, model_depths_um: list[float]) -> dict[str, Any]:
    """``E0`` and ``E(h)`` of one record (module docstring), the FE model's contact loss."""
    m = load_measurement(csv)
    cal = Calibrator(m)
    cal._feat_correction = None
    cal._setup()
    base = cal._features(cal.base_raw)
    at_rattle = apply_rattle_uncertainty(
        cal.cmp, base, lambda e: cal._features(cal._raw((e,))), cal.base_contact_loss, m.issues
    )
    if at_rattle:
        cal.runner.grown_effects = (ToothWear,)
    cal._refit_transfer(base)
    s0 = cal.cmp.score(base)
    errs, fams = {}, {"0": _families(s0)}
    for h in model_depths_um:
        if h <= 0:
            continue
        raw = cal._raw((ToothWear(wear_depth_m=1e-6 * h),))
        sc = cal.cmp.score(cal._features(raw))
        errs[h] = float(sc.error)
        fams[f"{h:g}"] = _families(sc) | {"fe_contact_loss": float(cal.runner.last_contact_loss)}
    return {
        "E0": float(s0.error),
        "E": errs,
        "families": fams,
        "fe_contact_loss": float(cal.base_contact_loss),
        "rattle_rules": bool(at_rattle),
        "steps_per_mesh": int(cal.runner.steps_per_mesh),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--speeds-rpm", type=float, nargs="+", default=[8000.0])
    ap.add_argument("--depths-um", type=float, nargs="+", default=[10.0, 20.0, 40.0, 80.0])
    ap.add_argument("--model-depths-um", type=float, nargs="+", default=None, help="default: --depths-um")
    ap.add_argument("--healthy-seeds", type=int, nargs="+", default=[501, 502, 503, 504])
    ap.add_argument("--worn-seeds", type=int, nargs="+", default=[601])
    ap.add_argument("--contact-loss-only", action="store_true", help="only the lumped contact-loss table")
    ap.add_argument("--json", type=Path, default=None, help="write every number to this file")
    args = ap.parse_args(argv)
    model_depths = args.model_depths_um or args.depths_um
    out: dict[str, Any] = {}
    for speed in args.speeds_rpm:
        cl = {d: contact_loss(speed, d) for d in [0.0, *args.depths_um]}
        print(
            f"{speed:.0f} rpm: lumped contact loss "
            + ", ".join(f"{d:.0f} um {v:.3f}" for d, v in cl.items()),
            flush=True,
        )
        out[f"{speed:.0f}"] = {"lumped_contact_loss": cl}
        if args.contact_loss_only:
            continue
        with tempfile.TemporaryDirectory() as tmp:
            rows = []
            for depth in [0.0, *args.depths_um]:
                seeds = args.healthy_seeds if depth == 0 else args.worn_seeds
                for seed in seeds:
                    faults = [f"tooth_wear:wear_depth_m={depth * 1e-6:g}"] if depth > 0 else []
                    t = time.process_time()
                    csv = write_record(
                        Path(tmp) / f"r{speed:.0f}_{depth:.0f}_{seed}",
                        make_record(speed, 25.0, faults, duration_s=2.0, seed=seed),
                    )
                    r = score_record(csv, model_depths)
                    r.update(depth_um=depth, seed=seed, cpu_s=time.process_time() - t)
                    rows.append(r)
                    best = min(r["E"], key=r["E"].get) if r["E"] else None
                    line = ", ".join(f"E({h:.0f}) {v:.3g}" for h, v in r["E"].items())
                    print(
                        f"  wear {depth:.0f} um seed {seed}: E0 {r['E0']:.3g}; {line}; best model depth "
                        f"{best} (E/E0 {r['E'][best] / r['E0']:.3f}); FE contact loss "
                        f"{r['fe_contact_loss']:.3f}, rattle rules {r['rattle_rules']}, "
                        f"{r['steps_per_mesh']} steps/mesh; CPU {r['cpu_s']:.0f} s",
                        flush=True,
                    )
                    print(
                        "    chi2/N per family: "
                        + "; ".join(
                            f"{k} um: " + ", ".join(f"{f} {v:.3g}" for f, v in d.items())
                            for k, d in r["families"].items()
                        ),
                        flush=True,
                    )
        healthy = np.array([r["E0"] for r in rows if r["depth_um"] == 0])
        mu, sd = float(healthy.mean()), float(healthy.std(ddof=1)) if healthy.size > 1 else math.nan
        print(
            f"  healthy E0 over {healthy.size} seeds: mean {mu:.3g}, sd {sd:.3g}, range "
            f"{healthy.min():.3g}-{healthy.max():.3g}",
            flush=True,
        )
        for r in rows:
            if r["depth_um"] > 0:
                print(
                    f"  wear {r['depth_um']:.0f} um: E0 {r['E0']:.3g} = {r['E0'] / mu:.2f} x the healthy "
                    "mean, "
                    f"{(r['E0'] - mu) / sd:+.2f} sd",
                    flush=True,
                )
        out[f"{speed:.0f}"].update(rows=rows, healthy_mean=mu, healthy_sd=sd)
    if args.json is not None:
        args.json.write_text(json.dumps(out, indent=1, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
