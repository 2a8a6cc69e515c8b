"""Cost of the anti-aliasing decimation and the Python glue of ``Simulator.advance`` (prints; not a test).

Run with OPENBLAS_NUM_THREADS=1. All figures are CPU time (``time.process_time``) per simulated second
at 20 kHz output, median of ``--repeats`` (>= 5) runs of 1 simulated second each (ten 0.1 s chunks,
the node's default ``chunk_period_s``), after a warm-up; the machine is shared, so the 1-min load
average is printed with each line.

(a) ``StreamDecimator.push`` alone, 22 columns (the node's 20 channels + speed + temperature, passed
    as three parts as ``Simulator`` does), decimation k = 3 and 16 (3000 / 20000 rpm on the paper
    gearbox at 32 steps per mesh period): whole push and the FIR kernel
    (``fir_decimate_polyphase``) inside it.
(b) ``Simulator.advance(0.1)`` on ``config/paper_sun2021.yaml`` at 3000 and 20000 rpm with the node's
    20 channels, split into ``NewmarkStepper.run`` (the step kernel and its Python wrapper),
    ``StreamDecimator.push`` (FIR + store) and the rest of ``advance`` (simulator glue).

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_decimate.py [--repeats 7] [--part a|b]``.
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from gear_rotor_sim.solver import decimate

OUTPUT_RATE_HZ = 20000.0
CHUNK_S = 0.1
CHUNKS = 10  # one simulated second
CHUNK_OUT = 2000  # output samples per chunk
CHANNELS = (
    ["dte", "mesh_force"]
    + [f"bearing{b}_f{d}" for b in (1, 2, 3, 4) for d in "xyz"]
    + [f"node{n}_{d}" for n in (5, 14) for d in "xyz"]
)
_ROOT = Path(__file__).resolve().parents[1]


class _Timers:
    """Accumulated process time of wrapped callables, by key."""

    def __init__(self) -> None:
        self.acc: dict[str, float] = {}

    def wrap(self, owner: object, name: str, key: str) -> None:
        fn = getattr(owner, name)
        self.acc[key] = 0.0

        def timed(*a: object, **kw: object) -> object:
            t0 = time.process_time()
            try:
                return fn(*a, **kw)
            finally:
                self.acc[key] += time.process_time() - t0

        setattr(owner, name, timed)

    def reset(self) -> None:
        for key in self.acc:
            self.acc[key] = 0.0


def _median_rows(run: Callable[[], dict[str, float]], repeats: int) -> tuple[dict[str, float], float]:
    la = os.getloadavg()[0]
    rows = [run() for _ in range(repeats)]
    return {key: float(np.median([r[key] for r in rows])) for key in rows[0]}, la


def part_a(repeats: int, timers: _Timers) -> None:
    print("(a) StreamDecimator.push alone, 22 columns, ms CPU per simulated second")
    rng = np.random.default_rng(0)
    for k in (3, 16):
        n = CHUNK_OUT * k
        t = np.arange(n)[:, None] / (k * OUTPUT_RATE_HZ)
        ch = np.sin(2 * np.pi * (137.0 + 59.0 * np.arange(20)) * t) + 1e-3 * rng.standard_normal((n, 20))
        speed = np.full(n, 1000.0 * k)
        temp = np.full(n, 25.0)
        dec = decimate.StreamDecimator(k, np.zeros(22))
        push: Callable[..., np.ndarray] = dec.push
        try:
            push(ch, speed, temp)  # warm-up: store sized, kernels loaded
        except TypeError:  # a version whose push takes one (n, ncol) array: the caller stacks
            push = lambda *p, _f=dec.push: _f(np.column_stack(p))  # noqa: E731
            push(ch, speed, temp)

        def run(
            push: Callable[..., np.ndarray] = push,
            parts: tuple[np.ndarray, ...] = (ch, speed, temp),
        ) -> dict[str, float]:
            timers.reset()
            t0 = time.process_time()
            for _ in range(CHUNKS):
                push(*parts)
            return {"push": time.process_time() - t0, "fir": timers.acc["fir"]}

        med, la = _median_rows(run, repeats)
        print(
            f"  k={k:2d} ({decimate.design_taps(k).size} taps): push {1e3 * med['push']:6.1f}  "
            f"of which FIR {1e3 * med['fir']:6.1f}   (load {la:.1f})"
        )


def part_b(repeats: int, timers: _Timers) -> None:
    from gear_rotor_sim.config import load_config
    from gear_rotor_sim.simulator import Simulator
    from gear_rotor_sim.solver.newmark import NewmarkStepper

    timers.wrap(NewmarkStepper, "run", "run")
    timers.wrap(decimate.StreamDecimator, "push", "push")
    cfg = load_config(str(_ROOT / "config" / "paper_sun2021.yaml"))
    print("(b) Simulator.advance(0.1), 20 channels, ms CPU per simulated second")
    for rpm in (3000.0, 20000.0):
        sim = Simulator(cfg, speed_rpm=rpm, output_rate_hz=OUTPUT_RATE_HZ, channels=CHANNELS)
        sim.advance(0.2)  # warm-up

        def run(sim: Simulator = sim) -> dict[str, float]:
            timers.reset()
            t0 = time.process_time()
            for _ in range(CHUNKS):
                sim.advance(CHUNK_S)
            total = time.process_time() - t0
            acc = timers.acc
            return {
                "total": total,
                "run": acc["run"],
                "push": acc["push"],
                "fir": acc["fir"],
                "glue": total - acc["run"] - acc["push"],
            }

        med, la = _median_rows(run, repeats)
        k = sim.last_chunk_stats["decimation"]
        print(
            f"  {rpm:5.0f} rpm (k={k:2.0f}): total {1e3 * med['total']:6.1f}  stepper.run "
            f"{1e3 * med['run']:6.1f}  push {1e3 * med['push']:5.1f} (FIR {1e3 * med['fir']:5.1f})  "
            f"simulator glue {1e3 * med['glue']:5.1f}   (load {la:.1f})"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--part", choices=("a", "b", "ab"), default="ab")
    args = ap.parse_args()
    timers = _Timers()
    # the FIR kernel the decimator calls (fir_decimate in versions before the polyphase store)
    fir = "fir_decimate_polyphase" if hasattr(decimate, "fir_decimate_polyphase") else "fir_decimate"
    timers.wrap(decimate, fir, "fir")
    if "a" in args.part:
        part_a(max(args.repeats, 5), timers)
    if "b" in args.part:
        part_b(max(args.repeats, 5), timers)


if __name__ == "__main__":
    main()
