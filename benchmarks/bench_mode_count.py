"""The gear kernel's cost per step against the number of modes it carries, on a captured chunk (figures).

Issue 13 (docs/history/solver_sessions.md, "Session 23"). ``run_chunk_gear`` on the chunk captured by
``profile_event_steps.py capture`` (paper gearbox, 20000 rpm, 25 C, DTE only, default model: 48
modes, the 39 forced first) with its modal arrays cut to the first ``k`` modes (``min(k, 39)``
forced), events located as the dt rule has it and not located, alternated, CPU medians per step.

The cut at 39 drops the 9 unforced modes only. In a run from the static equilibrium at a fixed set
point their amplitudes and static increments are exactly zero (printed) and nothing forces them, so
the cut changes no number there (the sub-steps, the status and the last delta are printed to show
it): 48 against 39 is the most that skipping the unforced modes could save. Below 39 the cut drops
forced modes and the motion changes (another trajectory, other events): those rows say how the cost
scales with the modes, not what any model would cost.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/profile_event_steps.py capture /tmp/c20k.pkl``
then ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_mode_count.py /tmp/c20k.pkl``.
"""

from __future__ import annotations

import argparse
import copy
import os
import pickle
import time

import numpy as np


def cut_modes(args: tuple, k: int, locate: bool) -> tuple:
    """The captured call's arguments with every modal array (last axis the modes) cut to ``k`` modes."""
    out = list(copy.deepcopy(args))
    nmode = args[0][0].shape[0]
    out[0] = tuple(np.ascontiguousarray(x[..., :k]) if x.shape[-1] == nmode else x for x in args[0])
    out[1] = min(k, int(args[1]))
    out[8] = locate
    return tuple(out)


def main() -> None:
    from gear_rotor_sim.solver import gear_kernel

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("path", help="a chunk from profile_event_steps.py capture")
    ap.add_argument("--modes", type=int, nargs="+", default=[48, 39, 24, 1])
    ap.add_argument("--runs", type=int, default=9)
    args = ap.parse_args()
    with open(args.path, "rb") as fh:
        cap = pickle.load(fh)
    modal, nf = cap[0], int(cap[1])
    n = cap[4][0].shape[0] - 1
    un = slice(nf, modal[0].shape[0])
    print(
        f"{modal[0].shape[0]} modes, {nf} forced, {n} steps; the unforced modes' largest |z|, |c0|: "
        f"{np.max(np.abs(modal[0][un] + 1j * modal[1][un]), initial=0.0):.1e}, "
        f"{np.max(np.abs(modal[4][un] + 1j * modal[5][un]), initial=0.0):.1e}; load {os.getloadavg()[0]:.1f}"
    )
    for locate in (bool(cap[8]), False):
        calls = {k: cut_modes(cap, k, locate) for k in args.modes}
        ends = {}
        for k, a in calls.items():  # compile or load, and what each run ends with
            b = copy.deepcopy(a)
            st = gear_kernel.run_chunk_gear(*b)
            ends[k] = (st[0], st[3], float(b[6][4][-1, 0]))
        cpu: dict[int, list[float]] = {k: [] for k in calls}
        for _ in range(args.runs):
            for k, a in calls.items():
                b = copy.deepcopy(a)
                c0 = time.process_time()
                gear_kernel.run_chunk_gear(*b)
                cpu[k].append(time.process_time() - c0)
        ref = float(np.median(cpu[args.modes[0]]))
        print(f"events {'located' if locate else 'not located'} (CPU medians of {args.runs}):")
        for k in args.modes:
            med = float(np.median(cpu[k]))
            status, nsub, d_last = ends[k]
            print(
                f"  {k:3d} modes ({min(k, nf)} forced): {1e6 * med / n:.3f} us per step (x{ref / med:.2f}); "
                f"status {status}, {nsub / n:.3f} sub-steps per step, last delta {d_last:.6e} m"
            )


if __name__ == "__main__":
    main()
