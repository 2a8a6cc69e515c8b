"""Aligned arrays and the per-chunk work buffers of the stepper (``newmark``)."""

from __future__ import annotations

import math

import numpy as np

_ALIGN = 64


def aligned_zeros(shape: int | tuple[int, ...], dtype: type = np.float64) -> np.ndarray:
    """C-contiguous zeros whose data pointer is 64-byte aligned."""
    shape_t = (shape,) if isinstance(shape, int) else tuple(shape)
    n = math.prod(shape_t)
    item = np.dtype(dtype).itemsize
    buf = np.zeros(n * item + _ALIGN, dtype=np.uint8)
    off = (-buf.ctypes.data) % _ALIGN
    return buf[off : off + n * item].view(dtype).reshape(shape_t)


class ChunkBuffers:
    """Work arrays kept from one chunk to the next, grown when a chunk needs more rows.

    :meth:`NewmarkStepper.run` takes its per-chunk arrays (phases, phase rates, the kernel's per-step
    mesh outputs) from here when the stepper holds one (``stepper.chunk_buffers``, set by the
    :class:`~gear_rotor_sim.simulator.Simulator`): then the arrays it returns, other than the
    channels, are views valid until its next call. Without it every chunk allocates them afresh,
    and glibc may map and fault them in anew each time (about 5000 minor page faults and 4-12 ms of
    system CPU per simulated second at 20000 rpm; docs/solver.md, "Session 10").
    """

    def __init__(self) -> None:
        self._arrays: dict[str, np.ndarray] = {}

    def get(self, name: str, shape: tuple[int, ...], dtype: type = np.float64) -> np.ndarray:
        """A C-contiguous array of ``shape`` (contents undefined), the first ``shape[0]`` rows of the
        buffer ``name`` (re-made, with room to spare, when it is too small or of another layout)."""
        a = self._arrays.get(name)
        if a is None or a.shape[1:] != shape[1:] or a.dtype != dtype or a.shape[0] < shape[0]:
            a = np.empty((max(shape[0], 1) + shape[0] // 4 + 64, *shape[1:]), dtype=dtype)
            self._arrays[name] = a
        return a[: shape[0]]


def aligned(a: np.ndarray) -> np.ndarray:
    """64-byte aligned C-contiguous copy of ``a``."""
    out = aligned_zeros(a.shape, a.dtype.type)
    out[...] = a
    return out
