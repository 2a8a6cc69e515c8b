"""Step convergence of the independent generator's data-acquisition chain (docs/independent_data.md).

``lumped_gearbox.daq.acquire`` integrates at ``substeps`` RK4 steps per 20 kHz sample, low-passes and
samples. This script makes the clean 8000 rpm records (healthy and 20 um worn: the teeth rattle, the
impacts set the step) at each substep count of ``--substeps`` and prints, per channel, the RMS about
the mean and the pinion comb of the synchronous average (``sqrt(2 sum |c|^2)`` over the orders 1-93
of each sideband family ``m z +- f``, f = 1..6) with their change against the next finer step, and the
generation time of each record.

Usage::

    python benchmarks/lumped_daq_convergence.py [--substeps 16 32 64] [--duration-s 2]
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from lumped_gearbox import Gearbox
from lumped_gearbox.daq import acquire
from lumped_gearbox.faults import parse_fault
from lumped_gearbox.simulate import CHANNELS, build

SPEED_RPM, FS, TEETH = 8000.0, 20000.0, 29


def families(x: np.ndarray) -> np.ndarray:
    """Pinion comb per sideband family 1..6 (orders 1-93 of the synchronous average)."""
    spr = round(FS * 60.0 / SPEED_RPM)
    n_rev = x.size // spr
    c = np.fft.rfft(x[: n_rev * spr].reshape(n_rev, spr).mean(axis=0)) / spr
    o = np.arange(c.size)
    fam = np.minimum(o % TEETH, TEETH - o % TEETH)
    ok = (o >= 1) & (o <= 3 * TEETH + 6)
    return np.array([np.sqrt(2.0 * np.sum(np.abs(c[ok & (fam == f)]) ** 2)) for f in range(1, 7)])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--substeps", type=int, nargs="+", default=[16, 32, 64])
    ap.add_argument("--duration-s", type=float, default=2.0)
    args = ap.parse_args(argv)
    acquire(build(Gearbox(), SPEED_RPM, 25.0), 0.05, substeps=2)  # numba compilation outside the timing
    skip = round(0.1 * FS)
    for label, faults in (("healthy", []), ("wear 20 um", ["tooth_wear:wear_depth_m=20e-6"])):
        setup = build(Gearbox(), SPEED_RPM, 25.0, [parse_fault(f) for f in faults])
        res = {}
        for n in args.substeps:
            t0 = time.perf_counter()
            r = acquire(setup, args.duration_s, FS, n)
            res[n] = (r, time.perf_counter() - t0)
        for i, n in enumerate(args.substeps):
            r, cost = res[n]
            print(f"{label}, {n} substeps ({cost:.2f} s for {args.duration_s:g} s of record):")
            for ch in CHANNELS:
                x = r[ch][skip:]
                rms = float(np.std(x))
                fam = families(x)
                line = f"  {ch:12s} rms {rms:.5g}  families 1-6 " + " ".join(f"{v:.3g}" for v in fam)
                if i + 1 < len(args.substeps):
                    y = res[args.substeps[i + 1]][0][ch][skip:]
                    rms_f, fam_f = float(np.std(y)), families(y)
                    d_rms = abs(rms - rms_f) / rms_f if rms_f > 0 else 0.0
                    d_fam = np.abs(fam - fam_f) / np.maximum(fam_f, 1e-300)
                    comb = np.sqrt(np.sum(fam**2))
                    comb_f = np.sqrt(np.sum(fam_f**2))
                    print(
                        line + f" | vs {args.substeps[i + 1]}: rms {100 * d_rms:.2f} %, comb "
                        f"{100 * abs(comb - comb_f) / max(comb_f, 1e-300):.2f} %, largest family "
                        f"{100 * float(np.max(d_fam)):.1f} %"
                    )
                else:
                    print(line)
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
