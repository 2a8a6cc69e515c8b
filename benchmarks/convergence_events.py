"""Accuracy of the default dt rule and of fixed resolutions against a converged run (docs/solver.md).

Paper gearbox, bearings A#, 25/125/225 C, 1000..20000 rpm (1272 rpm: the 615 Hz mode at the mesh
frequency; 7800-8100 rpm: the 11.0-11.8 kHz modes at the 3rd mesh harmonic). Per point:

* reference: 1024 steps per mesh period, events located, fixed; a 0.6 s transient from the static
  equilibrium gives the state ``st0`` on the converged attractor, then 400 recorded mesh periods;
* each rule runs from ``st0`` (100 mesh periods to settle on its own discrete attractor, then 400
  recorded): the error of its RMS DTE (mean included) against the reference (``matched``). This is
  the integration error proper. Several points have coexisting attractors (7000 rpm at 25 C: RMS
  6.28e-5 and 4.75e-5 m, both stable at 1024 steps), so a run from rest may settle on another one
  than the reference; that is a change of basin, not an integration error, and is counted apart;
* the default rule and the old fixed default (32 steps, not located) also run from rest like the
  reference (``rest``).

Rules: ``rule`` = the default (``gear_rotor_sim.solver.dt_rule.rule_steps_per_mesh``: 32 steps per
mesh period in contact, at least 320 kHz with the events located while the teeth separate, and the
resonance part near a light mode driven by a low mesh harmonic) and fixed 32 / 48 / 64 / 96 steps,
located (``L``) or not (``-``). The worst errors are taken over the periodic and quasi-periodic
points; chaotic points are printed but not counted (the RMS of a chaotic window of 400 periods is a
statistic, not a converged number).

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/convergence_events.py [--json PATH]``
(about 10 minutes on one core).
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from gear_rotor_sim.analysis.classify import classify_motion
from gear_rotor_sim.examples import paper_gearbox
from gear_rotor_sim.solver.newmark import SolverState, mesh_frequency_hz
from gear_rotor_sim.solver.steady import simulate_steady
from gear_rotor_sim.system import GearRotorSystem

TEMPERATURES_C = (25.0, 125.0, 225.0)
SPEEDS_RPM = (1000.0, 1272.0, 3000.0, 5000.0, 6000.0, 7000.0, 7800.0, 7900.0, 8000.0, 8100.0, 9500.0, 11000.0,
              12000.0, 13000.0, 14000.0, 15000.0, 17000.0, 20000.0)  # fmt: skip
FIXED = ((32, False), (32, True), (48, True), (64, True), (96, True))
REFERENCE = 1024
TRANSIENT_S = 0.6
SETTLE = 100
PERIODS = 400
BASIN_CHANGE = 0.05  # a from-rest error above 5 % is counted as another attractor


def _rms(
    system: GearRotorSystem, rpm: float, spm: int, state: SolverState | None, n_tr: int, **kw: object
) -> tuple[float, object, np.ndarray]:
    res, _ = simulate_steady(
        system, rpm, n_tr, PERIODS, spm, ("dte",), initial_state=state, sample="step", **kw
    )  # type: ignore[arg-type]
    x = res.channel("dte")
    return math.sqrt(float(np.mean(x * x))), res, x


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", default="", help="write the results to this JSON file")
    args = ap.parse_args()
    fixed_kw = {"contact_loss_rate_hz": None}
    names = ["rule"] + [f"{s}{'L' if loc else '-'}" for s, loc in FIXED]
    head = " ".join(f"{n:>7s}" for n in names)
    print(
        f"{'T':>5} {'rpm':>6} {'loss':>5} {'motion':>14s} {'N':>4}  matched error (%): {head}"
        "   rest: rule, 32-"
    )
    out: dict[str, dict] = {}
    worst = dict.fromkeys(names, 0.0)
    worst_rest = {"rule": 0.0, "32-": 0.0}
    basin = {"rule": 0, "32-": 0}
    for temp in TEMPERATURES_C:
        system = GearRotorSystem.from_config(paper_gearbox(), temp)
        for rpm in SPEEDS_RPM:
            ntr = int(TRANSIENT_S * mesh_frequency_hz(system, rpm))
            _, st0 = simulate_steady(system, rpm, 0, ntr, REFERENCE, ("dte",), locate_events=True, **fixed_kw)  # type: ignore[arg-type]
            ref, res_ref, x = _rms(system, rpm, REFERENCE, st0, 0, locate_events=True, **fixed_kw)
            motion = classify_motion(x[REFERENCE - 1 :: REFERENCE], scale=float(np.ptp(x))).label
            row: dict[str, object] = {
                "ref_rms": ref,
                "motion": motion,
                "contact_loss": res_ref.contact_loss_fraction,
            }  # type: ignore[attr-defined]
            rule, res_rule, _ = _rms(system, rpm, 32, st0, SETTLE)
            row["rule_steps_per_mesh"] = res_rule.steps_per_mesh  # type: ignore[attr-defined]
            row["rule_located"] = res_rule.located  # type: ignore[attr-defined]
            err = {"rule": (rule / ref - 1) * 100}
            for spm, loc in FIXED:
                e = _rms(system, rpm, spm, st0, SETTLE, locate_events=loc, **fixed_kw)[0]
                err[f"{spm}{'L' if loc else '-'}"] = (e / ref - 1) * 100
            rest = {
                "rule": (_rms(system, rpm, 32, None, ntr)[0] / ref - 1) * 100,
                "32-": (_rms(system, rpm, 32, None, ntr, locate_events=False, **fixed_kw)[0] / ref - 1) * 100,
            }
            row["matched_pct"] = err
            row["rest_pct"] = rest
            out[f"{temp:.0f}C_{rpm:.0f}rpm"] = row
            if motion != "chaotic":
                for n in names:
                    worst[n] = max(worst[n], abs(err[n]))
                for n, v in rest.items():
                    if abs(v) > 100 * BASIN_CHANGE:
                        basin[n] += 1
                    else:
                        worst_rest[n] = max(worst_rest[n], abs(v))
            n_rule = f"{row['rule_steps_per_mesh']:>3d}{'L' if row['rule_located'] else '-'}"
            cells = " ".join(f"{err[n]:+7.3f}" for n in names)
            print(
                f"{temp:5.0f} {rpm:6.0f} {row['contact_loss']:5.2f} {motion:>14s} {n_rule}  {' ' * 19}{cells}"
                f"   {rest['rule']:+7.3f} {rest['32-']:+7.3f}",
                flush=True,
            )
    summary = {
        "worst_matched_pct": worst,
        "worst_rest_pct_same_basin": worst_rest,
        "basin_changes_from_rest": basin,
    }
    print("worst |matched error| over periodic and quasi-periodic points (%): "
          + ", ".join(f"{n} {v:.2f}" for n, v in worst.items()))  # fmt: skip
    print("from rest, same attractor (%): " + ", ".join(f"{n} {v:.2f}" for n, v in worst_rest.items())
          + "; other attractor: " + ", ".join(f"{n} {v}" for n, v in basin.items()))  # fmt: skip
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"points": out, "summary": summary}, fh, indent=1)


if __name__ == "__main__":
    main()
