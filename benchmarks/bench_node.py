"""End-to-end benchmark of the simulator node: simulate, publish the default streams, record MCAP.

Starts the installed ``simulator`` executable (as ``ros2 run`` resolves it) with
``config/simulator_node.yaml``, recording on, a requested real-time factor far above what the model
can do (so it runs flat out), and measures the achieved real-time factor from ``/diagnostics``
(simulated time advanced / wall time between two reports, after a warm-up), and the CPU time of the
node's stepping and output threads per simulated second (from ``/proc``: on a loaded machine the
wall figure shows the load, the CPU figures what the node needs). Prints the median of ``--runs``
runs per speed. Goals: >= 10 at 3000 rpm (issue 4), >= 6 at 20000 rpm (issue 13); the two-stage
example >= 3 at 3000 rpm (issue 15).

``--burst`` instead runs the setpoint-flood check of issue 4: 1000 setpoints/s for 10 s (valid and
invalid mixed) at real time factor 1, and prints the largest gap between stream messages and the
node's memory before and after.

``--faults FILE`` adds runs with that fault list (the node's ``faults_file``), interleaved with the
runs without it, and prints both medians and their ratio (e.g. the cost of a misaligned gear, whose
axial force the simulator takes from a running average of its own mesh force).

    . scripts/env.sh && python benchmarks/bench_node.py [--speeds 3000 20000] [--runs 3] [--burst]
        [--model NAME] [--faults FILE] [--replay on|off|both|faults|all]

``--replay``: the node's ``periodic_replay`` (default on, as the node's default; docs/solver.md,
"Periodic replay at steady state"); ``both`` runs with and without it, interleaved; ``faults`` with it and
``periodic_replay_faults`` (faults replayed where the plain integration does not repeat), ``all`` the
three interleaved.
"""

from __future__ import annotations

import argparse
import itertools
import math
import os
import signal
import statistics
import sys
import tempfile
import time
from pathlib import Path

from gear_rotor_sim.ros.demo import (
    Probe,
    ros_environment,
    rss_bytes,
    share_file,
    start_process,
    stop_process,
    wait_for,
)

#: (model, speed_rpm) -> goal: issue 4 (paper gearbox, 3000 rpm), issue 13 (20000 rpm), issue 15
#: (the two-stage example at 3000 rpm); None is the node's default model.
GOALS = {(None, 3000.0): 10.0, (None, 20000.0): 6.0, ("two_stage_example", 3000.0): 3.0}


def _sim_args(
    env: dict[str, str],
    speed: float,
    rtf: float,
    mcap: Path,
    model: str | None = None,
    faults: Path | None = None,
    replay: str = "on",
) -> list[str]:
    return [
        "--ros-args",
        "--params-file",
        str(share_file("config/simulator_node.yaml", env)),
        *(["-p", f"model:={model}"] if model else []),
        *(["-p", f"faults_file:={faults}"] if faults else []),
        "-p",
        f"speed_rpm:={speed}",
        "-p",
        f"real_time_factor:={rtf}",
        "-p",
        "recording.enabled:=true",
        "-p",
        f"recording.path:={mcap}",
        "-p",
        "diagnostics_period_s:=0.5",
        "-p",
        f"periodic_replay:={'false' if replay == 'off' else 'true'}",
        "-p",
        f"periodic_replay_faults:={'true' if replay == 'faults' else 'false'}",
    ]


def _diag_points(probe: Probe) -> list[tuple[float, float]]:
    """(wall, sim_time_s) of every received simulation status."""
    out = []
    with probe.lock:
        diags = list(probe.diagnostics)
    for wall, arr in diags:
        for st in arr.status:
            if st.name.endswith(": simulation"):
                kv = {k.key: k.value for k in st.values}
                out.append((wall, float(kv["sim_time_s"])))
    return out


#: OS names of the node's threads (simulator_node names them) whose CPU the benchmark reports.
THREADS = {"gear_rotor_step": "stepping", "gear_rotor_out": "output"}


def thread_cpu_s(pid: int) -> dict[str, float]:
    """CPU seconds (user + system) of the node's named threads, from ``/proc/<pid>/task``, and of the
    whole process (``process``), from ``/proc/<pid>/stat`` (Linux)."""
    out: dict[str, float] = {}
    tick = os.sysconf("SC_CLK_TCK")
    try:
        tids = os.listdir(f"/proc/{pid}/task")
        with open(f"/proc/{pid}/stat", encoding="ascii") as f:  # the whole process, every thread
            fields = f.read().rsplit(")", 1)[1].split()
        out["process"] = (int(fields[11]) + int(fields[12])) / tick
    except OSError:
        return out
    for tid in tids:
        try:
            with open(f"/proc/{pid}/task/{tid}/stat", encoding="ascii") as f:
                stat = f.read()
        except OSError:
            continue
        name = stat[stat.index("(") + 1 : stat.rindex(")")]
        fields = stat.rsplit(")", 1)[1].split()
        if name in THREADS:
            out[THREADS[name]] = (int(fields[11]) + int(fields[12])) / tick
    return out


def run_once(
    speed: float,
    warmup_s: float,
    measure_s: float,
    workdir: Path,
    model: str | None = None,
    faults: Path | None = None,
    replay: str = "on",
) -> float:
    """Achieved real-time factor of one node run at ``speed`` rpm (``model``: the node's default;
    ``faults``: a fault list file; ``replay``: ``on`` / ``off`` the node's ``periodic_replay``, ``faults``
    on with ``periodic_replay_faults``)."""
    env = ros_environment()
    os.environ.update({k: env[k] for k in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE")})
    mcap = workdir / f"bench_{int(speed)}.mcap"
    sim = start_process(
        "simulator", _sim_args(env, speed, 1.0e4, mcap, model, faults, replay), env, workdir / "simulator.log"
    )
    probe = Probe(topics=("/gear_rotor/dte",), reliable=False, keep_data=False)
    try:
        wait_for(
            lambda: len(_diag_points(probe)) > 0 and _diag_points(probe)[-1][1] > 0, 300.0, "first chunks"
        )
        time.sleep(warmup_s)
        p0, cpu0 = _diag_points(probe)[-1], thread_cpu_s(sim.pid)
        time.sleep(measure_s)
        p1, cpu1 = _diag_points(probe)[-1], thread_cpu_s(sim.pid)
    finally:
        rc = stop_process(sim, signal.SIGINT)
        probe.close()
    if rc != 0:
        raise RuntimeError(f"simulator exited with {rc}; see {workdir / 'simulator.log'}")
    size = mcap.stat().st_size / 1e6
    rtf = (p1[1] - p0[1]) / (p1[0] - p0[0])
    sim_s = p1[1] - p0[1]
    threads = "".join(
        f", {name} thread {(cpu1[name] - cpu0[name]) / sim_s * 1e3:.0f}"
        for name in (*THREADS.values(), "process")
        if name in cpu0 and name in cpu1 and sim_s > 0
    )
    print(
        f"  {speed:7.0f} rpm{' (faults)' if faults else ''} replay {replay}: achieved RTF {rtf:6.2f} "
        f"({sim_s:.2f} s simulated in "
        f"{p1[0] - p0[0]:.2f} s wall; MCAP {size:.1f} MB"
        + (f"; ms CPU per simulated s{threads}" if threads else "")
        + f"; load average {os.getloadavg()[0]:.1f})",
        flush=True,
    )
    return rtf


def run_burst(workdir: Path, duration_s: float = 10.0, rate_hz: float = 1000.0) -> int:
    """Setpoint flood at real time: stream gaps and node memory."""
    env = ros_environment()
    os.environ.update({k: env[k] for k in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE")})
    sim = start_process(
        "simulator", _sim_args(env, 3000.0, 1.0, workdir / "burst.mcap"), env, workdir / "simulator.log"
    )
    probe = Probe(topics=("/gear_rotor/dte",), reliable=False, keep_data=False)
    try:
        probe.wait_subscribers(300.0)
        probe.wait_sim_time(2.0, 300.0)
        rss0 = rss_bytes(sim.pid)
        bad = [math.nan, math.inf, -1.0, 1.0e9]
        t0 = time.monotonic()
        sent = 0
        while time.monotonic() - t0 < duration_s:
            if sent % 2:
                probe.set_speed(bad[sent % len(bad)])
            else:
                probe.set_speed(3000.0)
            sent += 1
            delay = t0 + sent / rate_hz - time.monotonic()
            if delay > 0:
                time.sleep(delay)
        t1 = time.monotonic()
        time.sleep(1.5)
        rss1 = rss_bytes(sim.pid)
        recs = [r for r in probe.records("/gear_rotor/dte") if t0 <= r.wall <= t1]
        status = probe.latest_status(": setpoints") or {}
    finally:
        stop_process(sim, signal.SIGINT)
        probe.close()
    gaps = [b.wall - a.wall for a, b in itertools.pairwise(recs)]
    seq_ok = all(b.sequence == a.sequence + 1 for a, b in itertools.pairwise(recs))
    print(f"burst: {sent} setpoints in {t1 - t0:.1f} s ({sent / (t1 - t0):.0f}/s, half invalid)")
    print(
        f"  stream: {len(recs)} chunks during the burst, largest gap {max(gaps):.3f} s "
        f"(nominal 0.100 s), sequence continuous: {seq_ok}"
    )
    print(
        f"  node RSS {rss0 / 1e6:.1f} MB -> {rss1 / 1e6:.1f} MB; refused total {status.get('refused_total')}"
    )
    return 0 if seq_ok and max(gaps) < 1.0 and rss1 - rss0 < 20e6 else 1


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--speeds", type=float, nargs="+", default=[3000.0, 20000.0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--warmup-s", type=float, default=3.0)
    parser.add_argument("--measure-s", type=float, default=8.0)
    parser.add_argument("--burst", action="store_true", help="run the setpoint-flood check instead")
    parser.add_argument(
        "--model", default=None, help="rig config of the node (e.g. two_stage_example; default: the node's)"
    )
    parser.add_argument(
        "--faults",
        type=Path,
        default=None,
        help="YAML fault list (docs/faults.md): runs with it, interleaved with runs without",
    )
    parser.add_argument(
        "--replay",
        choices=("on", "off", "both", "faults", "all"),
        default="on",
        help="the node's periodic_replay (docs/solver.md); both: runs with and without, interleaved; "
        "faults: with periodic_replay_faults; all: on, faults and off, interleaved",
    )
    args = parser.parse_args(argv)
    faults = args.faults.resolve() if args.faults else None
    if faults is not None and not faults.is_file():
        parser.error(f"--faults: {args.faults} is not a file")
    with tempfile.TemporaryDirectory(prefix="bench_node_") as tmp:
        workdir = Path(tmp)
        if args.burst:
            return run_burst(workdir)
        print(
            f"node end to end (simulate, publish default streams, record MCAP); median of {args.runs} runs"
            + (f"; model {args.model}" if args.model else "")
        )
        replays = {"both": ["on", "off"], "all": ["on", "faults", "off"]}.get(args.replay, [args.replay])
        variants = [(f, r) for f in ([None, faults] if faults else [None]) for r in replays]
        results: dict[tuple[float, Path | None, str], float] = {}
        for speed in args.speeds:
            runs: dict[tuple[Path | None, str], list[float]] = {v: [] for v in variants}
            for _ in range(args.runs):  # interleaved: the machine's load falls on both alike
                for v in variants:
                    runs[v].append(run_once(speed, args.warmup_s, args.measure_s, workdir, args.model, *v))
            for v in variants:
                results[(speed, *v)] = statistics.median(runs[v])
        print("\nspeed_rpm  achieved_RTF  goal")
        for speed in args.speeds:
            for r in replays:
                rtf = results[(speed, None, r)]
                goal = GOALS.get((args.model, speed))
                verdict = "" if goal is None else f">= {goal:g}  {'met' if rtf >= goal else 'NOT met'}"
                print(f"{speed:9.0f}  {rtf:12.2f}  {verdict}  (periodic_replay {r})")
                if faults:
                    rf = results[(speed, faults, r)]
                    ratio = f"x{rf / rtf:.3f} of the run without"
                    print(f"{speed:9.0f}  {rf:12.2f}  with {faults.name} ({ratio})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
