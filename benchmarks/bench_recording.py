"""Recording throughput: CDR serialisation, MCAP write rate and overhead on the simulation.

Run from the repository root::

    .venv/bin/python benchmarks/bench_recording.py [--seconds 2] [--out-dir /tmp]

Prints (1) the time to serialise one 20,000-float64 ``VibrationChunk``, (2) the recorder's write
rate in samples/s and MB/s for the standard streams of the paper's gearbox at 20 kHz, using
synthetic blocks (recording alone, fsync policy on), and (3) the real streaming simulator with
and without recording over the same simulated time: recording wall time relative to simulation
wall time.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gear_rotor_sim.blocks import SampleBlock
from gear_rotor_sim.recording.cdr import serialize_vibration_chunk
from gear_rotor_sim.recording.writer import McapRecorder
from gear_rotor_sim.streams import StreamSpec, chunk_fields, default_streams

RATE = 20000.0


def bench_cdr() -> float:
    """Median seconds to serialise one 20,000-sample single-channel chunk."""
    b = SampleBlock(0.0, RATE, ("dte",), ("m",), np.random.default_rng(0).normal(size=(20000, 1)))
    f = chunk_fields(b, StreamSpec("dte", ("dte",), "gear_mesh"), 0)
    times = []
    for _ in range(200):
        t0 = time.perf_counter()
        serialize_vibration_chunk(f)
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def bench_writer(out: Path, seconds: float, block_s: float) -> tuple[float, float, float, int]:
    """Synthetic 20 kHz data for the paper's streams: (samples/s, MB/s, wall s, channels)."""
    specs = default_streams(4, displacement_nodes=(5, 6), acceleration_nodes=(5,))
    chans = tuple(dict.fromkeys(c for s in specs for c in s.channels))
    n = int(block_s * RATE)
    rng = np.random.default_rng(1)
    units = tuple("m" for _ in chans)
    speed, temp = np.full(n, 3000.0), np.full(n, 25.0)
    blocks = [
        SampleBlock(k * block_s, RATE, chans, units, rng.normal(size=(n, len(chans))), k * n, speed, temp)
        for k in range(round(seconds / block_s))
    ]
    t0 = time.perf_counter()
    with McapRecorder(out, specs) as rec:
        for k, b in enumerate(blocks):
            for s in specs:
                rec.write_block(b, s, k)
    wall = time.perf_counter() - t0
    values = sum(b.n_samples for b in blocks) * len(chans)
    return values / wall, out.stat().st_size / wall / 1e6, wall, len(chans)


def bench_with_simulator(out: Path, seconds: float, block_s: float) -> dict:
    """Real simulator at 3000 rpm, 20 kHz, standard streams: wall time with and without recording."""
    from gear_rotor_sim.config import load_config
    from gear_rotor_sim.simulator import Simulator

    cfg = load_config("paper_sun2021")
    specs = default_streams(len(cfg.bearings))
    chans = [c for s in specs for c in s.channels]

    def make() -> Simulator:
        sim = Simulator(cfg, speed_rpm=3000.0, temperature_c=25.0, output_rate_hz=RATE, channels=chans)
        sim.advance(block_s)  # compile and warm up outside the timing
        return sim

    sim = make()
    t0 = time.perf_counter()
    for _ in range(round(seconds / block_s)):
        sim.advance(block_s)
    bare = time.perf_counter() - t0

    sim = make()
    t_sim = t_rec = 0.0
    t0 = time.perf_counter()
    with McapRecorder(out, specs) as rec:
        for k in range(round(seconds / block_s)):
            a = time.perf_counter()
            b = sim.advance(block_s)
            c = time.perf_counter()
            for s in specs:
                rec.write_block(b, s, k)
            t_sim += c - a
            t_rec += time.perf_counter() - c
        c = time.perf_counter()
    t_rec += time.perf_counter() - c
    total = time.perf_counter() - t0
    return {"bare_s": bare, "sim_s": t_sim, "rec_s": t_rec, "total_s": total, "bytes": out.stat().st_size}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="simulated seconds per measurement")
    parser.add_argument("--block-s", type=float, default=0.1, help="simulated seconds per message")
    parser.add_argument("--out-dir", default=None, help="where to write the files (default: a temp folder)")
    parser.add_argument("--no-simulator", action="store_true", help="skip the real-simulator measurement")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(dir=args.out_dir) as tmp:
        folder = Path(tmp)
        print(f"CDR serialisation, 20,000 float64: {bench_cdr() * 1e6:.1f} us (median of 200)")
        sps, mbs, wall, nch = bench_writer(folder / "synthetic.mcap", args.seconds, args.block_s)
        print(
            f"recorder alone ({nch} channels at 20 kHz, {args.block_s:g} s per message, fsync each flush): "
            f"{sps / 1e6:.1f} M samples/s, {mbs:.0f} MB/s "
            f"({wall * 1e3:.0f} ms for {args.seconds:g} s simulated)"
        )
        if not args.no_simulator:
            r = bench_with_simulator(folder / "sim.mcap", args.seconds, args.block_s)
            print(
                f"simulator 3000 rpm, 20 kHz, {args.seconds:g} s simulated: alone {r['bare_s']:.2f} s wall; "
                f"recording run: simulate {r['sim_s']:.2f} s + record {r['rec_s'] * 1e3:.0f} ms "
                f"({100 * r['rec_s'] / r['sim_s']:.1f} % overhead, {r['bytes'] / 1e6:.1f} MB, "
                f"real-time factor {args.seconds / r['total_s']:.2f} with recording)"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
