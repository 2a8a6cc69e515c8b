"""Periodic replay at steady state against integration (part (r) of bench_solver.py; docs/solver.md,
"Periodic replay at steady state").

Per speed: a ``Simulator`` with ``periodic_replay=True`` is advanced in ``chunk_s`` chunks from the
static equilibrium until the replay engages (at most ``max_settle_s`` simulated): the simulated time
at which it engaged and the CPU / wall time that took. Then a default ``Simulator`` (integrating,
replay off) is brought to the same time and the two are advanced alternately, ``repeats`` chunks
each: the RTF of each (medians, wall and CPU) and the difference of the last chunks (RMS of the
difference over the integrated stream's fluctuating RMS, per channel; the replay option takes the
angles from the step index modulo the forcing period, which moves the stream by the integrator's own
round-off sensitivity, see docs/solver.md). Paper gearbox, 25 C, 20 kHz output, the default dt rule
and model. One process; run with ``OPENBLAS_NUM_THREADS=1``.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_replay.py [--chunk-s 0.2] [--repeats 5]
[--json PATH]``.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from collections.abc import Sequence

import numpy as np

from gear_rotor_sim.examples import paper_gearbox
from gear_rotor_sim.simulator import Simulator

OUTPUT_RATE_HZ = 20000.0
CASES = (
    ("dte", ["dte"], 3000.0),
    ("dte", ["dte"], 7000.0),
    ("dte", ["dte"], 12000.0),
    ("dte", ["dte"], 20000.0),
    ("default16", None, 3000.0),
    ("default16", None, 20000.0),
)


def replay_case(
    cfg: object, rpm: float, channels: Sequence[str] | None, chunk_s: float, repeats: int, max_settle_s: float
) -> dict:
    """Time to engage, then integrated against replayed RTF, interleaved (see the module docstring)."""
    rep = Simulator(cfg, rpm, 25.0, OUTPUT_RATE_HZ, channels=channels, periodic_replay=True)
    assert rep.replay is not None
    c0, w0 = time.process_time(), time.perf_counter()
    while not rep.replay.active and rep.time_s < max_settle_s:
        rep.advance(chunk_s)
    out: dict = {
        "rpm": rpm,
        "n_channels": len(rep.channels),
        "engaged": rep.replay.active,
        "engaged_at_s": rep.replay.engaged_at_s,
        "settle_cpu_s": time.process_time() - c0,
        "settle_wall_s": time.perf_counter() - w0,
        "period_steps": rep.replay.period_steps,
        "period_s": rep.replay.period_steps * rep.dt,
        "load": [os.getloadavg()[0]],
    }
    integ = Simulator(cfg, rpm, 25.0, OUTPUT_RATE_HZ, channels=channels)
    integ.advance(rep.time_s)
    wall: dict[str, list[float]] = {"integrated": [], "replay": []}
    cpu: dict[str, list[float]] = {"integrated": [], "replay": []}
    last: dict[str, np.ndarray] = {}
    for _ in range(repeats):
        for name, sim in (("integrated", integ), ("replay", rep)):
            c0, w0 = time.process_time(), time.perf_counter()
            last[name] = np.asarray(sim.advance(chunk_s).data)
            wall[name].append(time.perf_counter() - w0)
            cpu[name].append(time.process_time() - c0)
    for name in wall:
        out[f"rtf_{name}"] = chunk_s / float(np.median(wall[name]))
        out[f"rtf_cpu_{name}"] = chunk_s / float(np.median(cpu[name]))
    out["still_active"] = rep.replay.active
    ref = last["integrated"]
    sd = np.std(ref, axis=0)
    diff = np.sqrt(np.mean((last["replay"] - ref) ** 2, axis=0))
    out["rel_diff_max"] = float(np.max(diff / np.where(sd > 0, sd, 1.0)))
    out["load"].append(os.getloadavg()[0])
    return out


def replay_table(chunk_s: float = 0.2, repeats: int = 5, max_settle_s: float = 5.0) -> dict:
    """Part (r): every case of ``CASES``."""
    cfg = paper_gearbox()
    res: dict = {"chunk_s": chunk_s, "repeats": repeats}
    for name, ch, rpm in CASES:
        res[f"{name}_{rpm:.0f}rpm"] = replay_case(cfg, rpm, ch, chunk_s, repeats, max_settle_s)
    return res


def _row(key: str, r: dict) -> str:
    """One line of part (r)."""
    eng = "NOT engaged"
    if r["engaged"]:
        eng = (
            f"engaged at {r['engaged_at_s']:.2f} s simulated ({r['settle_cpu_s']:.2f} s CPU from the "
            f"start; period {r['period_steps']} steps = {r['period_s'] * 1e3:.1f} ms)"
        )
    rtf = {m: f"{r[f'rtf_{m}']:7.2f} | {r[f'rtf_cpu_{m}']:7.2f}" for m in ("integrated", "replay")}
    return (
        f"  {key:18s} {r['n_channels']:2d} ch: integrated RTF {rtf['integrated']}   with replay "
        f"{rtf['replay']}  {eng}; last chunk replay - integrated: {r['rel_diff_max']:.1e} of the "
        f"fluctuating RMS (load {r['load'][0]:.1f}->{r['load'][1]:.1f})"
    )


def report_replay(res: dict) -> None:
    """Print part (r)."""
    print(
        f"\n(r) periodic replay at steady state against integration, paper gearbox 25 C, default model "
        f"and dt rule, {res['chunk_s']} s chunks interleaved x{res['repeats']} (RTF wall | CPU, medians)"
    )
    for key, r in res.items():
        if isinstance(r, dict):
            print(_row(key, r))


def main() -> None:
    ap = argparse.ArgumentParser(description="periodic replay against integration (paper gearbox)")
    ap.add_argument("--chunk-s", type=float, default=0.2, help="simulated s per advance")
    ap.add_argument("--repeats", type=int, default=5, help="timed chunks per simulator")
    ap.add_argument("--json", default="", help="write the figures to this file")
    args = ap.parse_args()
    res = replay_table(args.chunk_s, args.repeats)
    report_replay(res)
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(res, fh, indent=1, default=float)


if __name__ == "__main__":
    main()
