"""Served real-time factor and client-side latency of ``gear-rotor-sim serve`` (docs/live.md).

Starts ``gear-rotor-sim serve --port 0 --duration-s D`` (defaults: 3000 rpm, 25 C, the node's
streams), connects the Foxglove-protocol test client (test/foxglove_ws_client.py), subscribes to
``/gear_rotor/dte`` and ``/gear_rotor/status`` and, after a warm-up, measures:

- served real-time factor: simulated seconds received per wall second at the client (from the
  first to the last DTE chunk after the warm-up);
- latency: client receive time minus the server's send time (``wall_time_s`` of each status, logged
  right after the chunk of the same instant; one clock, one machine), median and 95th percentile;
- sample continuity: gaps/overlaps of ``first_sample_index``.

Usage: ``python benchmarks/bench_live.py [--duration-s 20] [--warmup-s 3] [--speed-rpm 3000]``.
"""

from __future__ import annotations

import argparse
import itertools
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "test"))

from foxglove_ws_client import FoxgloveClient  # noqa: E402


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--duration-s", type=float, default=20.0)
    p.add_argument("--warmup-s", type=float, default=3.0)
    p.add_argument("--speed-rpm", type=float, default=3000.0)
    p.add_argument("--temperature-c", type=float, default=25.0)
    a = p.parse_args()
    cmd = [sys.executable, "-m", "gear_rotor_sim.cli", "serve", "--port", "0"]
    cmd += ["--duration-s", str(a.duration_s), "--speed-rpm", str(a.speed_rpm)]
    cmd += ["--temperature-c", str(a.temperature_c)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, cwd=ROOT)
    line = proc.stdout.readline()
    if not line.startswith("serving ws://"):
        print(f"serve did not start: {line!r}", file=sys.stderr)
        proc.kill()
        return 1
    client = FoxgloveClient(line.split()[1])
    chunks: list[tuple[float, float, int, int]] = []  # (recv wall, sim end, first index, n)
    latencies: list[float] = []
    try:
        client.wait_for(lambda c: "/gear_rotor/status" in c.topics(), 30.0)
        client.subscribe(["/gear_rotor/dte", "/gear_rotor/status"])
        while True:
            got = client.poll(60.0)
            if got is None:
                break
            now = time.time()
            if got.topic == "/gear_rotor/status":
                if got.message["sim_time_s"] > a.warmup_s:
                    latencies.append(now - got.message["wall_time_s"])
                continue
            m = got.message
            t_end = (m.first_sample_index + m.sample_count) / m.sample_rate_hz
            if t_end > a.warmup_s:
                chunks.append((time.monotonic(), t_end, m.first_sample_index, m.sample_count))
    except Exception as exc:  # the server closes the connection after --duration-s
        if "ConnectionClosed" not in type(exc).__name__:
            raise
    finally:
        client.close()
        proc.wait(timeout=60)
    if len(chunks) < 2:
        print("too few chunks received", file=sys.stderr)
        return 1
    gaps = sum(1 for x, y in itertools.pairwise(chunks) if y[2] != x[2] + x[3])
    rtf = (chunks[-1][1] - chunks[0][1]) / (chunks[-1][0] - chunks[0][0])
    lat = np.asarray(latencies) * 1e3
    print(
        f"serve {a.speed_rpm:g} rpm, {a.temperature_c:g} C: {len(chunks)} DTE chunks after {a.warmup_s:g} s; "
        f"served real-time factor {rtf:.3f}; sample gaps/overlaps {gaps}; "
        f"latency median {np.median(lat):.2f} ms, p95 {np.percentile(lat, 95):.2f} ms, "
        f"max {lat.max():.2f} ms ({lat.size} status messages)"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
