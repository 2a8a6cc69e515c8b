"""The chi^2 of a healthy reference record over the mesh stiffness scale: where the reference fit's minima lie
and why (docs/history/calibration_sessions.md Sec. 8.77).

A reference fit (``calibrate --baseline HEALTHY``, ``calibration/baseline.py``) takes the mesh and bearing
stiffness and damping scales that fit the reference record best and carries them to every other speed. This
script sets a calibrator up on the reference record as that fit does (the reference numerics and steps, the
sensor gains and slopes refitted per run) and scores the model with the mesh stiffness times ``s`` for each
``s`` of ``--scales``: the balanced chi^2, the error, chi^2 / n per family, and the FE model's first mesh mode
against the record's mesh harmonics (``calibration/mesh_mode.py``), so that a minimum placed by a resonance
(the mode on one side of a harmonic or the other) is told from one the static compliance ``F / k`` sets.

Usage::

    python benchmarks/reference_mesh_scan.py REFERENCE.csv --scales 0.36,0.45,0.6,0.8,1,1.2,1.4,1.7,2
"""

from __future__ import annotations

import argparse
import time
from typing import Any


def prepared(record: str) -> Any:
    """A calibrator on ``record`` set up as ``fit_reference_baseline`` does, brought to its first round."""
    from gear_rotor_sim.calibration.channel_conventions import check_conventions
    from gear_rotor_sim.calibration.fit import Calibrator, FitSettings
    from gear_rotor_sim.calibration.line_removal import remove_unlocked_lines
    from gear_rotor_sim.calibration.measurement import load_measurement
    from gear_rotor_sim.calibration.residual import REFERENCE_STEPS_PER_MESH

    cal = Calibrator(
        load_measurement(record),
        fit_settings=FitSettings(max_effects=0),
        steps_per_mesh=REFERENCE_STEPS_PER_MESH,
        reference_numerics=True,
    )
    cal._feat_correction = None
    remove_unlocked_lines(cal)
    check_conventions(cal)
    cal._prepare_comparison()
    cal.n_total = cal.cmp.score(cal._features(cal.base_raw)).n_total
    cal.cmp.set_carrier_tolerance(cal.settings.tolerance)
    return cal


def score_with(cal: Any, effects: tuple) -> tuple[Any, str]:
    """The record's score on the model with ``effects`` (the transfer slopes refitted on it) and its chi^2 / n
    per family as text."""
    feats = cal._features(cal._raw(effects))
    cal._refit_transfer(feats)
    sc = cal.cmp.score(feats)
    return sc, ", ".join(f"{f} {sc.chi2[f] / max(sc.n[f], 1):.4g}" for f in sc.chi2 if sc.n[f])


def main(argv: list[str] | None = None) -> int:
    from gear_rotor_sim.calibration.mesh_mode import mesh_mode_hz
    from gear_rotor_sim.calibration.model_runner import cached_system
    from gear_rotor_sim.faults import BearingStiffnessDamping, MeshStiffnessDamping
    from gear_rotor_sim.solver.newmark import mesh_frequency_hz

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("record", help="a healthy reference record (CSV with its YAML sidecar)")
    ap.add_argument("--scales", default="0.36,0.45,0.6,0.8,1,1.2,1.4,1.7,2", help="mesh stiffness scales")
    ap.add_argument("--bearing", type=float, default=1.0, help="bearing stiffness scale held in every run")
    args = ap.parse_args(argv)
    t0 = time.process_time()
    cal = prepared(args.record)
    op = cal.m.operating_point
    f_mesh = mesh_frequency_hz(cached_system(cal.runner.cfg, op.temperature_c), op.speed_rpm)
    held = (BearingStiffnessDamping(stiffness_scale=args.bearing),) if args.bearing != 1.0 else ()
    print(
        f"{args.record}: {op.speed_rpm:g} rpm, {op.temperature_c:g} C; mesh harmonics "
        + ", ".join(f"{h * f_mesh:.0f}" for h in (1, 2, 3))
        + " Hz"
        + (f"; bearing stiffness x{args.bearing:g} held" if held else "")
    )
    for s in (float(v) for v in args.scales.split(",")):
        mesh = (MeshStiffnessDamping(stiffness_scale=s),) if s != 1.0 else ()
        sc, fam = score_with(cal, (*held, *mesh))
        loss = cal.runner.last_contact_loss
        f_mode = mesh_mode_hz(cal.runner.cfg, op.temperature_c, [*held, *mesh])
        print(
            f"  mesh x{s:g}: FE mesh mode {f_mode:.0f} Hz ({f_mode / f_mesh:.2f} f_mesh); balanced chi2 "
            f"{sc.balanced_chi2:.6g}, error {sc.error:.4g} (chi2/n: {fam}); contact loss {loss:.3f}",
            flush=True,
        )
    print(f"  CPU {time.process_time() - t0:.0f} s, {cal.runner.n_runs} runs")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
