"""Table-jump steps taken whole with the step's average tables (``Simulator(average_table_jumps=True)``)
against located sub-steps (the default): speed and accuracy (docs/solver.md, "Session 11").

Speed: DTE only, the two simulators advanced alternately in one process (0.5 s each, ``--reps``
times after 0.3 s), CPU real-time factor medians and their ratio, and the sub-steps per simulated
second. Accuracy: the 16 default channels against 1024 located steps per mesh period from the same
static equilibrium, statistics of the 20 kHz stream over 0.3-0.5 s (the metrics of
``benchmarks/convergence_highspeed.py``: RMS DTE, its fluctuating RMS, the worst channel's RMS and
fluctuating RMS, the worst bearing spectrum distance, the DTE sample by sample; errors in %).

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/average_jumps.py [--speeds 15000,20000]
[--temperature 25] [--reps 7] [--no-accuracy]`` (about 2 minutes per speed with the accuracy part).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from convergence_highspeed import DURATION_S, OUTPUT_RATE_HZ, WINDOW_S, compare

from gear_rotor_sim.examples import paper_gearbox
from gear_rotor_sim.simulator import Simulator

VARIANTS = {"located": False, "averaged": True}


def speed_table(rpm: float, temp: float, reps: int) -> None:
    sims = {k: Simulator(paper_gearbox(), rpm, temp, OUTPUT_RATE_HZ, channels=["dte"], average_table_jumps=v)
            for k, v in VARIANTS.items()}  # fmt: skip
    for s in sims.values():
        s.advance(0.3)
    rtf: dict[str, list[float]] = {k: [] for k in sims}
    sub = dict.fromkeys(sims, 0)
    for _ in range(reps):
        for k, s in sims.items():
            n0 = s._stepper.n_substeps
            c0 = time.process_time()
            s.advance(0.5)
            rtf[k].append(0.5 / (time.process_time() - c0))
            sub[k] += s._stepper.n_substeps - n0
    med = {k: statistics.median(v) for k, v in rtf.items()}
    print(
        f"{rpm:6.0f} rpm {temp:4.0f} C, DTE only, CPU RTF medians of {reps}: "
        + ", ".join(f"{k} {med[k]:.2f} ({min(rtf[k]):.2f}-{max(rtf[k]):.2f})" for k in sims)
        + f"; ratio {med['averaged'] / med['located']:.3f}; sub-steps per simulated s "
        + " / ".join(f"{sub[k] / (0.5 * reps):.0f}" for k in sims),
        flush=True,
    )


def _run(rpm: float, temp: float, **kw: object) -> tuple[np.ndarray, tuple[str, ...]]:
    sim = Simulator(paper_gearbox(), rpm, temp, OUTPUT_RATE_HZ, **kw)  # type: ignore[arg-type]
    data = np.concatenate([np.asarray(sim.advance(0.1).data) for _ in range(round(DURATION_S / 0.1))])
    i0, i1 = (round(w * OUTPUT_RATE_HZ) for w in WINDOW_S)
    return data[i0:i1], sim.channels


def accuracy_table(rpm: float, temp: float) -> None:
    ref, names = _run(rpm, temp, steps_per_mesh=1024, contact_loss_rate_hz=None, locate_events=True)
    for k, v in VARIANTS.items():
        y, _ = _run(rpm, temp, average_table_jumps=v)
        e = compare(y, ref, names)
        print(
            f"{rpm:6.0f} rpm {temp:4.0f} C {k:9s} rms {e['rms']:+.3f} fluct {e['fluct']:+.2f} "
            f"ch rms {e['ch_rms']:+.3f} ({e['ch_rms_name']}) ch fluct {e['ch_fluct']:+.2f} "
            f"({e['ch_fluct_name']}) spec {e['spec']:.1f} ({e['spec_name']}) wave {e['wave']:.1f}",
            flush=True,
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--speeds", default="15000,20000")
    ap.add_argument("--temperature", type=float, default=25.0)
    ap.add_argument("--reps", type=int, default=7)
    ap.add_argument("--no-accuracy", action="store_true")
    args = ap.parse_args()
    for rpm in (float(s) for s in args.speeds.split(",")):
        speed_table(rpm, args.temperature, args.reps)
        if not args.no_accuracy:
            accuracy_table(rpm, args.temperature)


if __name__ == "__main__":
    main()
