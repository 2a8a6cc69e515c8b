"""Is the independent lumped gearbox's pinion-order comb at 8000 rpm physics or numerics? (Sec. 8.26)

``lumped_gearbox``'s point-sampled chain (``make_record(..., sampling="point")``, the records of
sessions 1-12; the default since session 13 is the data-acquisition chain of ``lumped_gearbox/daq.py``)
integrates with classical RK4 at 8 steps per output sample and stores every 8th state as the 20 kHz
record, without an anti-aliasing filter. At 8000 rpm a pinion revolution
is exactly 150 output samples and 1200 steps, so (a) content above 10 kHz aliases onto pinion orders
(mesh harmonic ``m`` in Nyquist zone ``k`` lands at order ``|29 m - 150 k|``, sideband family
``5 k mod 29``: zone 1 gives family 5) and (b) the step grid's position relative to the impacts repeats
every revolution, so the integration error of the impacts is pinion-locked. This script runs the
generator's own model (read only) at the record's step and at ``--fine`` substeps, stores every step,
and prints each channel's pinion comb (``sqrt(2 sum |c|^2)`` over the sideband families 1-6 of orders
1-93 of the synchronous average; family 5 apart) point-sampled as the record and after a zero-phase
9 kHz low-pass; healthy and worn. With ``--records DIR`` it also writes the benchmark's two 8000 rpm
records (``rattle_tooth_wear`` seed 28, ``healthy_8000rpm_25C`` seed 35) with the generator's
data-acquisition chain (``make_record``'s default since session 13, at ``--fine`` substeps), for
``gear-rotor-sim calibrate``.

Usage::

    python benchmarks/lumped_rattle_numerics.py [--fine 32] [--duration-s 1.5] [--records DIR]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy import signal

from lumped_gearbox import Gearbox
from lumped_gearbox.faults import parse_fault
from lumped_gearbox.simulate import build, run

SPEED_RPM, FS, TEETH = 8000.0, 20000.0, 29
CHANNELS = ("dte", "bearing2_fx", "bearing2_fy", "node5_ax", "node5_ay")
WEAR = "tooth_wear:wear_depth_m=20e-6"


def comb(x: np.ndarray) -> tuple[float, float]:
    """Pinion comb over the sideband families 1-6 without family 5, and family 5 alone."""
    spr = round(FS * 60.0 / SPEED_RPM)
    n_rev = x.size // spr
    c = np.fft.rfft(x[: n_rev * spr].reshape(n_rev, spr).mean(axis=0)) / spr
    o = np.arange(c.size)
    fam = np.minimum(o % TEETH, TEETH - o % TEETH)
    ok = (o >= 1) & (o <= 3 * TEETH + 6) & (fam > 0) & (fam <= 6)
    return (
        float(np.sqrt(2.0 * np.sum(np.abs(c[ok & (fam != 5)]) ** 2))),
        float(np.sqrt(2.0 * np.sum(np.abs(c[ok & (fam == 5)]) ** 2))),
    )


def signals(faults: list[str], substeps: int, duration_s: float) -> dict[str, np.ndarray]:
    """Every integration step of the generator's model at ``substeps`` per 20 kHz sample."""
    setup = build(Gearbox(), SPEED_RPM, 25.0, [parse_fault(f) for f in faults])
    return run(setup, duration_s, sample_rate_hz=FS * substeps, substeps=1)


def lowpass(x: np.ndarray, substeps: int) -> np.ndarray:
    b = signal.firwin(101 * substeps + 1, 9000.0, fs=FS * substeps)
    return signal.filtfilt(b, [1.0], x)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--fine", type=int, default=32, help="substeps of the converged run (record: 8)")
    ap.add_argument("--duration-s", type=float, default=1.5)
    ap.add_argument("--records", type=Path, default=None)
    args = ap.parse_args(argv)
    skip = round(0.5 * FS)
    print("pinion comb without family 5 / family 5 alone: point-sampled (as the record) | low-passed")
    for label, faults in (("healthy", []), ("wear 20 um", [WEAR])):
        for sub in (8, args.fine):
            s = signals(faults, sub, args.duration_s)
            cells = []
            for ch in CHANNELS:
                p = comb(s[ch][::sub][skip:])
                f = comb(lowpass(s[ch], sub)[::sub][skip:])
                cells.append(f"{ch} {p[0]:.3g} / {p[1]:.3g} | {f[0]:.3g} / {f[1]:.3g}")
            print(f"{label}, {sub} substeps: " + "; ".join(cells), flush=True)
    if args.records is not None:
        # since session 13 this is the generator's default chain (lumped_gearbox.daq: RK4 at --fine
        # substeps, the anti-aliasing FIR, then the 20 kHz sampling); the scratch wrapper of session
        # 12 (a 9 kHz firwin in this process) is gone
        import lumped_gearbox.record as rec

        for tag, faults, seed in (("rattle_tooth_wear", [WEAR], 28), ("healthy_8000rpm_25C", [], 35)):
            r = rec.make_record(SPEED_RPM, 25.0, faults, duration_s=2.0, seed=seed, substeps=args.fine)
            print(rec.write_record(args.records / f"{tag}.csv", r), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
