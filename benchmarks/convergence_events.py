"""RMS DTE error with and without event location at 32..96 steps per mesh period (docs/solver.md).

Paper gearbox, bearings A#, 25 and 225 C, 1000..14000 rpm (the periodic range of the convergence
study, with and without contact loss). Per point: static equilibrium, a 0.6 s transient, then 400
recorded mesh periods; reference = 1024 steps per mesh period with events located. Printed per run:
the relative error (%) of the RMS of the DTE (mean included, ``e_tot``) and of its standard
deviation (``e_ac``), for steps per mesh 32, 48, 64, 96, located (``L``) and not (``-``).

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
from gear_rotor_sim.solver.newmark import mesh_frequency_hz, simulate_steady
from gear_rotor_sim.system import GearRotorSystem

TEMPERATURES_C = (25.0, 225.0)
SPEEDS_RPM = (1000.0, 3000.0, 5000.0, 7000.0, 9500.0, 12000.0, 14000.0)
STEPS = (32, 48, 64, 96)
REFERENCE = 1024
TRANSIENT_S = 0.6
PERIODS = 400


def rms_pair(system: object, rpm: float, spm: int, locate: bool) -> tuple[float, float, float, str]:
    ntr = int(TRANSIENT_S * mesh_frequency_hz(system, rpm))  # type: ignore[arg-type]
    _, st = simulate_steady(system, rpm, 0, ntr, spm, ("dte",), sample="mesh", locate_events=locate)  # type: ignore[arg-type]
    res, _ = simulate_steady(
        system,  # type: ignore[arg-type]
        rpm,
        0,
        PERIODS,
        spm,
        ("dte",),
        initial_state=st,
        sample="step",
        locate_events=locate,
    )
    x = res.channel("dte")
    motion = classify_motion(x[spm - 1 :: spm], scale=float(np.ptp(x)))  # Poincare section, phase 0
    return math.sqrt(float(np.mean(x * x))), float(np.std(x)), res.contact_loss_fraction, motion.label


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", default="", help="write the results to this JSON file")
    args = ap.parse_args()
    out: dict[str, dict] = {}
    head = " ".join(f"{s:>3d}{m}" for s in STEPS for m in ("L", "-"))
    print(f"{'T':>5} {'rpm':>6} {'loss':>5} {'motion':>14s}  e_tot / e_ac (%) at steps per mesh: {head}")
    worst = {(s, m): 0.0 for s in STEPS for m in (True, False)}
    for temp in TEMPERATURES_C:
        system = GearRotorSystem.from_config(paper_gearbox(), temp)
        for rpm in SPEEDS_RPM:
            ref = rms_pair(system, rpm, REFERENCE, True)
            row: dict[str, object] = {
                "ref_rms": ref[0],
                "ref_std": ref[1],
                "contact_loss": ref[2],
                "motion": ref[3],
            }
            cells = []
            for spm in STEPS:
                for loc in (True, False):
                    r = rms_pair(system, rpm, spm, loc)
                    e_tot, e_ac = (r[0] / ref[0] - 1) * 100, (r[1] / ref[1] - 1) * 100
                    row[f"{spm}{'L' if loc else '-'}"] = (e_tot, e_ac)
                    worst[(spm, loc)] = max(worst[(spm, loc)], abs(e_tot))
                    cells.append(f"{e_tot:+.2f}/{e_ac:+.2f}")
            out[f"{temp:.0f}C_{rpm:.0f}rpm"] = row
            print(f"{temp:5.0f} {rpm:6.0f} {ref[2]:5.2f} {ref[3]:>14s}  " + " ".join(cells), flush=True)
    print("worst |e_tot| (%): " + ", ".join(f"{s}{'L' if m else '-'} {v:.2f}" for (s, m), v in worst.items()))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
