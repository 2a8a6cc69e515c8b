"""``gear-rotor-sim serve``: watch the simulator live in Foxglove, without ROS.

Example::

    gear-rotor-sim serve --speed-rpm 3000 --temperature-c 25        # ws://localhost:8765, until Ctrl-C
    gear-rotor-sim serve --port 0 --duration-s 10                   # any free port, 10 simulated s

One streaming :class:`~gear_rotor_sim.simulator.Simulator` is advanced chunk by chunk and paced
against the wall clock (:class:`ChunkPacer`, the node's rule: when the model is late by more than
one chunk, simulated time slows down; no sample is dropped or repeated). Each chunk goes to a
:class:`~gear_rotor_sim.live.server.LiveServer`. Setpoints published by a client are validated with
:func:`gear_rotor_sim.setpoints.check_setpoint` (the node's validation) when they arrive and handed
to the simulator between two chunks; the simulator's own range checks may still refuse them there.

Exit status: 0 after ``--duration-s`` or on Ctrl-C/SIGTERM; 2 for invalid arguments (named) or a
port that cannot be opened; 1 when the simulation stops on an error.
"""

from __future__ import annotations

import argparse
import collections
import logging
import math
import signal
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

from gear_rotor_sim.setpoints import DEFAULT_LIMITS, check_setpoint

EXIT_INVALID = 2
#: Chunks over which /gear_rotor/status reports the achieved real-time factor (3 s of 0.1 s chunks).
RTF_WINDOW_CHUNKS = 30
EXIT_FAILED = 1


class ChunkPacer:
    """Releases chunk ``k`` when the wall clock reaches its simulated end time / ``real_time_factor``.

    Parameters
    ----------
    real_time_factor : float
        Simulated seconds per wall-clock second (> 0).
    clock, sleep : callables
        ``time.monotonic`` and an interruptible sleep (default ``time.sleep``).
    """

    def __init__(
        self,
        real_time_factor: float,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], Any] = time.sleep,
    ) -> None:
        if not (math.isfinite(real_time_factor) and real_time_factor > 0):
            raise ValueError(f"real_time_factor: {real_time_factor} must be finite and > 0")
        self.rtf = float(real_time_factor)
        self._clock = clock
        self._sleep = sleep
        self._anchor: tuple[float, float] | None = None
        self.late_chunks = 0

    def start(self, t_sim: float) -> None:
        """Anchor simulated time ``t_sim`` to now."""
        self._anchor = (self._clock(), float(t_sim))

    def wait(self, t_start: float, t_end: float) -> bool:
        """Wait until the chunk ``[t_start, t_end)`` is due; True when it was late (re-anchored)."""
        if self._anchor is None:
            self.start(t_start)
        assert self._anchor is not None
        wall0, sim0 = self._anchor
        due = wall0 + (t_end - sim0) / self.rtf
        now = self._clock()
        if due > now:
            self._sleep(due - now)
            return False
        if now - due > (t_end - t_start) / self.rtf:
            self._anchor = (now, float(t_end))  # cannot keep up: simulated time slows down
            self.late_chunks += 1
            return True
        return False


def _rate(recent: collections.deque) -> float:
    """Simulated seconds per wall second over the recent (wall, simulated end) pairs; 0 before two."""
    if len(recent) < 2:
        return 0.0
    (w0, s0), (w1, s1) = recent[0], recent[-1]
    return (s1 - s0) / (w1 - w0) if w1 > w0 else 0.0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--speed-rpm", type=float, default=3000.0, help="initial speed (default 3000)")
    parser.add_argument("--temperature-c", type=float, default=25.0, help="initial temperature (default 25)")
    parser.add_argument("--port", type=int, default=8765, help="WebSocket port (default 8765; 0: any free)")
    parser.add_argument("--host", default="127.0.0.1", help="address to bind (default 127.0.0.1)")
    parser.add_argument(
        "--duration-s", type=float, default=None, help="stop after this simulated time (default: Ctrl-C)"
    )
    parser.add_argument("--real-time-factor", type=float, default=1.0, help="sim s per wall s (default 1)")
    parser.add_argument("--chunk-s", type=float, default=0.1, help="simulated time per message (default 0.1)")
    parser.add_argument("--sample-rate-hz", type=float, default=20000.0, help="output rate (default 20000)")
    parser.add_argument("--config", default="paper_sun2021", help="rig config name or YAML path")
    parser.add_argument("--bearing-type", choices=("A#", "B#", "C#"), help="bearing type of every bearing")
    parser.add_argument(
        "--displacement-nodes",
        default="5,14",
        help="nodes (1-based) on /gear_rotor/displacements, e.g. 5,14 (default, as the node); '' for none",
    )
    parser.add_argument("--speed-ramp-rpm-per-s", type=float, default=2000.0, help="ramp rate (default 2000)")
    parser.add_argument("--temperature-ramp-c-per-s", type=float, default=20.0, help="ramp rate (default 20)")
    parser.add_argument(
        "--speed-rpm-max",
        type=float,
        default=DEFAULT_LIMITS["limits.speed_rpm_max"],
        help="largest accepted speed setpoint (default 30000, as the node's limits.speed_rpm_max)",
    )
    parser.add_argument("--temperature-c-min", type=float, default=DEFAULT_LIMITS["limits.temperature_c_min"])
    parser.add_argument("--temperature-c-max", type=float, default=DEFAULT_LIMITS["limits.temperature_c_max"])


def _nodes(text: str) -> tuple[int, ...]:
    parts = [p.strip() for p in text.split(",") if p.strip()]
    try:
        nodes = tuple(int(p) for p in parts)
    except ValueError:
        raise ValueError(f"--displacement-nodes: {text!r} is not a comma-separated list of nodes") from None
    if any(n < 1 for n in nodes):
        raise ValueError(f"--displacement-nodes: {text!r}: nodes are numbered from 1")
    return nodes


class _Targets:
    """Setpoints accepted by the server thread, waiting for the stepping loop (guarded by a lock)."""

    def __init__(self, limits: dict[str, float]) -> None:
        self.limits = limits
        self.lock = threading.Lock()
        self.pending: dict[str, float] = {}

    def offer(self, kind: str, value: float) -> str | None:
        reason = check_setpoint(kind, value, self.limits)
        if reason is None:
            with self.lock:
                self.pending[kind] = value
        return reason

    def take(self) -> dict[str, float]:
        with self.lock:
            out, self.pending = self.pending, {}
        return out


def run(args: argparse.Namespace) -> int:
    from gear_rotor_sim.config import load_config
    from gear_rotor_sim.live.server import LiveServer
    from gear_rotor_sim.simulator import Simulator
    from gear_rotor_sim.streams import default_streams

    logging.basicConfig(level=logging.INFO, format="[serve] %(levelname)s: %(message)s", stream=sys.stderr)

    def fail(msg: str) -> int:
        print(f"gear-rotor-sim serve: {msg}", file=sys.stderr)
        return EXIT_INVALID

    limits = {
        "limits.speed_rpm_max": args.speed_rpm_max,
        "limits.temperature_c_min": args.temperature_c_min,
        "limits.temperature_c_max": args.temperature_c_max,
    }
    for kind, value in (("speed_rpm", args.speed_rpm), ("temperature_c", args.temperature_c)):
        reason = check_setpoint(kind, value, limits)
        if reason is not None:
            return fail(f"--{kind.replace('_', '-')}: {reason}")
    if args.duration_s is not None and not (math.isfinite(args.duration_s) and args.duration_s > 0):
        return fail(f"--duration-s: {args.duration_s} must be finite and > 0")
    if not (math.isfinite(args.chunk_s) and 1e-3 <= args.chunk_s <= 2.0):
        return fail(f"--chunk-s: {args.chunk_s} is outside [0.001, 2] s")
    stop = threading.Event()
    try:
        if not (math.isfinite(args.real_time_factor) and args.real_time_factor > 0):
            return fail(f"--real-time-factor: {args.real_time_factor} must be finite and > 0")
        pacer = ChunkPacer(args.real_time_factor, sleep=stop.wait)
        nodes = _nodes(args.displacement_nodes)
        cfg = load_config(args.config)
        if args.bearing_type:
            cfg = cfg.with_bearing_type(args.bearing_type)
        streams = default_streams(
            len(cfg.bearings), displacement_nodes=nodes, has_mesh=bool(cfg.meshes), n_meshes=len(cfg.meshes)
        )
        channels = list(dict.fromkeys(c for s in streams for c in s.channels))
        sim = Simulator(
            cfg,
            speed_rpm=args.speed_rpm,
            temperature_c=args.temperature_c,
            output_rate_hz=args.sample_rate_hz,
            channels=channels,
            speed_ramp_rpm_per_s=args.speed_ramp_rpm_per_s,
            temperature_ramp_c_per_s=args.temperature_ramp_c_per_s,
        )
    except (ValueError, KeyError, OSError) as exc:
        return fail(str(exc))
    targets = _Targets(limits)
    pinion_teeth = cfg.gears[0].teeth if cfg.gears else 1
    try:
        server = LiveServer(streams, targets.offer, port=args.port, host=args.host, pinion_teeth=pinion_teeth)
    except (ValueError, RuntimeError, OSError) as exc:
        return fail(f"--port {args.port}: cannot serve: {exc}")

    def on_signal(signum: int, _frame: Any) -> None:
        stop.set()

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    print(
        f"serving ws://{args.host}:{server.port} (Foxglove: Open connection -> Foxglove WebSocket -> "
        f"ws://localhost:{server.port}); topics {[s.topic for s in streams]}, /gear_rotor/indicators, "
        "/gear_rotor/dte_spectrum, /gear_rotor/status; setpoints on /gear_rotor/setpoint/speed_rpm and "
        "/gear_rotor/setpoint/temperature_c",
        flush=True,
    )
    wall0 = time.monotonic()
    recent: collections.deque[tuple[float, float]] = collections.deque(maxlen=RTF_WINDOW_CHUNKS)
    chunks = 0
    status = 0
    try:
        while not stop.is_set():
            for kind, value in targets.take().items():
                try:
                    sim.set_targets(**{kind: value})
                except ValueError as exc:  # the simulator's own range checks
                    server.refuse(f"{kind} setpoint {value} refused by the simulator: {exc}")
            t_start = float(sim.time_s)
            step = args.chunk_s
            if args.duration_s is not None:
                step = min(step, args.duration_s - t_start)
                if step <= 0.5 / args.sample_rate_hz:
                    break
            block = sim.advance(step)
            t_end = float(sim.time_s)
            pacer.wait(t_start, t_end)
            server.publish(block)
            chunks += 1
            recent.append((time.monotonic(), t_end))
            server.publish_status(
                {
                    "sim_time_s": t_end,
                    "speed_rpm": sim.speed_rpm,
                    "target_speed_rpm": sim.target_speed_rpm,
                    "temperature_c": sim.temperature_c,
                    "target_temperature_c": sim.target_temperature_c,
                    "achieved_real_time_factor": _rate(recent),
                    "requested_real_time_factor": args.real_time_factor,
                },
                t_end,
            )
    except Exception as exc:  # reported; the server is stopped cleanly below
        logging.getLogger("gear_rotor_sim.live").error("simulation stopped: %s: %s", type(exc).__name__, exc)
        status = EXIT_FAILED
    finally:
        server.stop()
    wall = time.monotonic() - wall0
    t = float(sim.time_s)
    print(
        f"served {t:.3f} s simulated in {wall:.3f} s wall (real-time factor {t / wall if wall else 0:.3f}), "
        f"{chunks} chunks, {pacer.late_chunks} late; "
        f"setpoints accepted {server.accepted}, refused {server.refused}",
        flush=True,
    )
    return status
