"""Keep freed chunk-sized arrays in the process heap (glibc ``mallopt``), so that a chunk's arrays are
not mapped and faulted in afresh each time (docs/solver.md, "Session 10").

A chunk at 20000 rpm holds about 32000 integration steps: its time, phase and output arrays are
0.25-1 MB each. glibc serves allocations above ``M_MMAP_THRESHOLD`` (128 KiB at first, raised
dynamically up to 32 MiB as mapped blocks are freed) by ``mmap`` and returns them by ``munmap``, and
trims the heap top above ``M_TRIM_THRESHOLD``; which arrays land on fresh pages (one minor fault per
page, zeroed by the kernel) then depends on the order of the allocations. Measured on the paper
gearbox (CPU per simulated second): the 16 default channels at 7000-20000 rpm, 400-700 faults and
2-3.4 ms system CPU; DTE only at 20000 rpm, none before session 10's decimator change and 5058
faults (4-12 ms system CPU, about 6 % of the run) after it, from one 256 KiB array less per chunk
(docs/solver.md, "Session 10"). With the thresholds fixed above the chunk sizes the freed pages are
reused: 0-122 faults per simulated second in all these cases, and the same peak memory (274 MB).

The setting is process-wide and lasts for the process: freed memory up to ``TRIM_THRESHOLD_BYTES``
stays in the heap instead of going back to the system. Set ``GEAR_ROTOR_SIM_MALLOPT=off`` to leave
the allocator alone. Without glibc (musl, macOS, Windows) nothing is done.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os

__all__ = ["MMAP_THRESHOLD_BYTES", "TRIM_THRESHOLD_BYTES", "retain_chunk_memory"]

#: Allocations up to this size come from the heap (glibc's largest accepted value on 64-bit is 32 MiB).
MMAP_THRESHOLD_BYTES = 16 * 1024 * 1024
#: The heap top is returned to the system only when this much of it is free.
TRIM_THRESHOLD_BYTES = 64 * 1024 * 1024
_M_TRIM_THRESHOLD = -1  # glibc malloc.h
_M_MMAP_THRESHOLD = -3

_done: bool | None = None


def retain_chunk_memory() -> bool:
    """Fix glibc's mmap and trim thresholds (once per process); True if they are set.

    Idempotent; does nothing (False) with ``GEAR_ROTOR_SIM_MALLOPT=off`` or without glibc.
    """
    global _done
    if _done is not None:
        return _done
    _done = False
    if os.environ.get("GEAR_ROTOR_SIM_MALLOPT", "").strip().lower() in ("off", "0", "no", "false"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    ok = mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES) == 1
    ok = mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES) == 1 and ok
    _done = ok
    return ok
