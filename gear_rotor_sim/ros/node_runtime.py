"""What the simulator node's threads share, and small process helpers (no rclpy).

:class:`SharedState` is the one object the stepping thread, the output thread and the executor's
callbacks share (guarded by its lock); :func:`chunk_stat` reads the simulator's chunk statistics;
:func:`achieved_rtf` is the real-time factor over the recent chunks; :func:`process_age_s` and
:func:`name_os_thread` serve the start-up log and ``top -H``. See :mod:`.simulator_node`.
"""

from __future__ import annotations

import collections
import math
import threading
import time
from dataclasses import dataclass, field
from typing import Any

from diagnostic_msgs.msg import DiagnosticStatus

#: Blocks the stepping thread may run ahead of the output thread (publishing and recording).
OUTPUT_QUEUE = 2
#: Interpreter-lock switch interval of the node process (Python's default is 5 ms).
GIL_SWITCH_INTERVAL_S = 2e-4


@dataclass
class SharedState:
    """What the stepping thread and the executor callbacks share; guarded by ``lock``."""

    lock: threading.Lock = field(default_factory=threading.Lock)
    pending_speed: float | None = None
    pending_temperature: float | None = None
    target_speed: float = 0.0
    target_temperature: float = 0.0
    accepted: int = 0
    refused: int = 0
    refused_since_diag: int = 0
    last_refusal: str = ""
    last_warn_wall: float = -math.inf
    warn_suppressed: int = 0
    sim_time: float = 0.0
    speed: float = 0.0
    temperature: float = 0.0
    chunks: int = 0
    samples: int = 0
    late_chunks: int = 0
    contact_loss: float = 0.0
    back_side_contact: float = 0.0
    solver_steps: int = 0
    chunk_wall_s: float = 0.0
    mesh_solve_failures: int = 0
    health_level: bytes = DiagnosticStatus.OK
    health_message: str = "ok"
    achieved_rtf_window: collections.deque = field(default_factory=lambda: collections.deque(maxlen=512))
    start_wall: float = 0.0

    def record_chunk(self, sim: Any, n_samples: int, t_end: float, late: bool) -> None:
        """Count one simulated chunk of ``n_samples`` ending at ``t_end`` (``late``: behind the wall
        clock) and take the simulator's operating point and chunk statistics."""
        stats = getattr(sim, "last_chunk_stats", None)
        with self.lock:
            self.sim_time = t_end
            self.speed = float(sim.speed_rpm)
            self.temperature = float(sim.temperature_c)
            self.chunks += 1
            self.samples += n_samples
            self.late_chunks += int(late)
            self.contact_loss = chunk_stat(stats, "contact_loss_fraction")
            self.back_side_contact = chunk_stat(stats, "back_contact_fraction", "back_side_contact_fraction")
            self.solver_steps = int(chunk_stat(stats, "steps"))
            self.chunk_wall_s = chunk_stat(stats, "wall_s", "wall_time_s")
            self.mesh_solve_failures = int(chunk_stat(stats, "mesh_solve_failures"))
            self.achieved_rtf_window.append((time.monotonic(), t_end))


def chunk_stat(stats: Any, *names: str, default: float = 0.0) -> float:
    """Field of the simulator's chunk statistics, which may be a dataclass or a mapping."""
    if stats is None:
        return default
    for name in names:
        if isinstance(stats, dict) and name in stats:
            return float(stats[name])
        if hasattr(stats, name):
            return float(getattr(stats, name))
    return default


def achieved_rtf(window: list[tuple[float, float]]) -> float:
    """Simulated seconds per wall second over the last 3 s of ``window`` (0 before two chunks).

    Parameters
    ----------
    window : list of (float, float)
        (wall time, simulated time) at the end of each recent chunk, oldest first.
    """
    if len(window) < 2:
        return 0.0
    now = window[-1][0]
    recent = [w for w in window if now - w[0] <= 3.0]
    if len(recent) < 2:
        recent = window[-2:]
    (w0, s0), (w1, s1) = recent[0], recent[-1]
    return (s1 - s0) / (w1 - w0) if w1 > w0 else 0.0


def process_age_s() -> float | None:
    """Seconds since this process started (Linux ``/proc/self/stat``); None where unavailable."""
    try:
        with open("/proc/self/stat", encoding="ascii") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        start_ticks = int(fields[19])  # field 22, starttime, in clock ticks since boot
        import os

        return time.clock_gettime(time.CLOCK_BOOTTIME) - start_ticks / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, AttributeError):
        return None


def name_os_thread(name: str) -> None:
    """Name the calling thread in the operating system (Linux ``prctl(PR_SET_NAME)``, at most 15
    bytes: ``top -H``, ``/proc/<pid>/task/<tid>/comm``, ``benchmarks/bench_node.py``); a no-op where
    that is not available."""
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(15, ctypes.c_char_p(name.encode("ascii")[:15]), 0, 0, 0)  # 15: PR_SET_NAME
    except (OSError, AttributeError, ValueError):
        pass
