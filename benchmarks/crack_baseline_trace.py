"""Why a reference baseline moves the shaft crack's loss: the crack's round-0 fit under each baseline update.

For one crack record, the crack candidate (``calibration/candidates_crack.py``) is fitted on the healthy
model as the first round of ``gear-rotor-sim calibrate`` would fit it, in each of its two model forms
(``bearing_tilt_damping`` True / False), with the model's baseline switched one part at a time:

- ``none``: no reference (the record's own nominal model, the settings of a run without ``--baseline``);
- ``numerics``: a held reference with no update (its numerics and carrier tolerance alone);
- ``mesh``, ``bearing_k``, ``bearing_c``, ``bearing``: one update of the reference (the mesh scale, the
  bearings' stiffness scale alone, their damping scale alone, both bearing scales);
- ``all``: every update of the reference (what ``--baseline REFERENCE`` fits against).

Printed per variant and form: the reported loss (``loss_reference="support"``), the phase, the shaft's loss,
the whole chi^2 and the low orders' (``candidates_crack.low_order_chi2``: what the form and the phase are
chosen on), and the node's ``k_s / k_L`` and ``b`` on the nominal and the updated system.
``--no-dynamic`` fits the static share alone; ``--session23`` the phase on the whole chi^2 and every loss term
on the nominal system (session 23's fit; docs/history/calibration_sessions.md Sec. 8.67).

Usage::

    python benchmarks/crack_baseline_trace.py RECORD.csv --reference REF.reference.json \
        [--variants none all ...] [--no-dynamic] [--session23]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import resource
import time
from typing import Any

from gear_rotor_sim.faults import BearingStiffnessDamping, Effect, MeshStiffnessDamping

VARIANTS = ("none", "numerics", "mesh", "bearing_k", "bearing_c", "bearing", "all")


def reference_updates(path: str) -> tuple[list[Effect], float]:
    """The baseline sets and the carrier tolerance of a saved reference (``--save-baseline``)."""
    from gear_rotor_sim.calibration.baseline import load_reference

    ref = load_reference(path)
    return list(ref.effects), float(ref.carrier_tolerance)


def variant_baseline(name: str, updates: list[Effect]) -> list[Effect] | None:
    """The baseline held in variant ``name`` (None: no reference)."""
    mesh = [e for e in updates if isinstance(e, MeshStiffnessDamping)]
    bearing = [e for e in updates if isinstance(e, BearingStiffnessDamping)]
    if name == "none":
        return None
    if name == "numerics":
        return []
    if name == "mesh":
        return mesh
    if name == "bearing":
        return bearing
    if name == "bearing_k":
        return [dataclasses.replace(b, damping_scale=1.0) for b in bearing]
    if name == "bearing_c":
        return [dataclasses.replace(b, stiffness_scale=1.0) for b in bearing]
    if name == "all":
        return list(updates)
    raise ValueError(f"unknown variant {name!r}; one of {VARIANTS}")


def prepared(record: str, baseline: list[Effect] | None, ctol: float | None) -> Any:
    """A calibrator brought to its first round (``Calibrator.run`` up to the candidates' fits)."""
    from gear_rotor_sim.calibration.channel_conventions import check_conventions
    from gear_rotor_sim.calibration.fit import Calibrator
    from gear_rotor_sim.calibration.line_removal import remove_unlocked_lines
    from gear_rotor_sim.calibration.measurement import load_measurement

    cal = Calibrator(
        load_measurement(record), baseline=baseline, carrier_tolerance=ctol if baseline is not None else None
    )
    cal._feat_correction = None
    remove_unlocked_lines(cal)
    check_conventions(cal)
    cal._prepare_comparison()
    cal.n_total = cal.cmp.score(cal._features(cal.base_raw)).n_total
    cal.cmp.set_carrier_tolerance(cal.fixed_carrier_tolerance or cal.settings.tolerance)
    cal._cur_feat = cal._features(cal.base_raw)
    return cal


def crack_forms(cal: Any, node: int = 5) -> list[dict[str, Any]]:
    """The crack's fit in each model form on the prepared calibrator's current model."""
    from gear_rotor_sim.calibration import candidates_crack as cc
    from gear_rotor_sim.calibration.model_runner import cached_system
    from gear_rotor_sim.faults.crack import ShaftCrack

    cur = cal._cur_feat
    e = cc.fitted_crack(cal, ShaftCrack(node=node))
    temp = cal.m.operating_point.temperature_c
    nominal = cached_system(cal.runner.cfg, temp)
    cfg = cal.runner.cfg
    for b in cal.baseline:
        cfg = b.modify_config(cfg)
    updated = cached_system(cfg, temp)
    out = []
    for tilt in cc.TILT_FORMS:
        fit = cc._fit_form(cal, dataclasses.replace(e, bearing_tilt_damping=tilt), cur)
        if fit is None:
            out.append({"tilt_damping": tilt, "fit": None})
            continue
        loss = float(fit.effect.parameters()["stiffness_loss"])
        out.append(
            {
                "tilt_damping": tilt,
                "loss": loss,
                "phase_rad": float(fit.effect.parameters()["phase_rad"]),
                "shaft_loss_nominal": fit.effect.shaft_stiffness_loss(nominal),
                "chi2": float(cal._chi2(fit.feats)),
                "chi2_low": cc.low_order_chi2(cal, fit.feats),
                "error": float(fit.score.error),
                "r_b_nominal": dataclasses.replace(e, support_terms=()).reference_terms(nominal),
                "r_b_updated": dataclasses.replace(e, support_terms=()).reference_terms(updated),
            }
        )
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("record")
    ap.add_argument("--reference", required=True, help="a saved reference baseline (*.reference.json)")
    ap.add_argument("--variants", nargs="*", default=list(VARIANTS))
    ap.add_argument("--json", default=None, help="write the rows here")
    ap.add_argument("--no-dynamic", action="store_true", help="the static share alone (DYNAMIC_SHARE off)")
    ap.add_argument(
        "--session23",
        action="store_true",
        help="the phase and the loss's terms as in session 23 (PHASE_ON_LOW_ORDERS, NOMINAL_SUPPORT off)",
    )
    args = ap.parse_args(argv)
    from gear_rotor_sim.calibration import candidates_crack

    if args.no_dynamic:
        candidates_crack.DYNAMIC_SHARE = False
    if args.session23:
        candidates_crack.NOMINAL_SUPPORT = False
        candidates_crack.PHASE_ON_LOW_ORDERS = False
    updates, ctol = reference_updates(args.reference)
    rows = []
    for name in args.variants:
        t0, r0 = time.perf_counter(), resource.getrusage(resource.RUSAGE_SELF)
        cal = prepared(args.record, variant_baseline(name, updates), ctol)
        base_err = float(cal.cmp.score(cal._cur_feat).error)
        forms = crack_forms(cal)
        r1 = resource.getrusage(resource.RUSAGE_SELF)
        cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
        for f in forms:
            f.update(variant=name, error_before=base_err, cpu_s=cpu, wall_s=time.perf_counter() - t0)
            rows.append(f)
            if f.get("fit", 1) is None:
                print(f"{name:10s} tilt_damping={f['tilt_damping']!s:5s}: no fit")
                continue
            print(
                f"{name:10s} tilt_damping={f['tilt_damping']!s:5s} loss {f['loss']:.4f} phase "
                f"{f['phase_rad']:+.3f} shaft loss {f['shaft_loss_nominal']:.4f} chi2 {f['chi2']:.4g} "
                f"low {f['chi2_low']:.4g} "
                f"E {base_err:.3g} -> {f['error']:.3g}; r, b nominal {f['r_b_nominal'][0]:.3f}, "
                f"{f['r_b_nominal'][1]:.3f} updated {f['r_b_updated'][0]:.3f}, {f['r_b_updated'][1]:.3f}; "
                f"CPU {cpu:.0f} s",
                flush=True,
            )
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1, default=str)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
