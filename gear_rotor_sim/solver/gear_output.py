"""Output emission of the gear kernel (numba): the buffered steps' outputs by one matrix product.

Part of the gear kernel (:mod:`.gear_kernel`; docs/solver.md, "Module layout").
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, error_model="numpy", _nrt=True)
def _emit_block(
    hbuf: np.ndarray, hb: int, cstack: np.ndarray, dfeed_static: np.ndarray, out: np.ndarray, o0: int
) -> None:
    """Outputs of ``hb`` buffered steps ``[z_r, z_i, beta]`` by one matrix product (BLAS) into
    ``out[o0 : o0 + hb]``, plus the static feed-through (a call every ``hbuf.shape[0]`` steps)."""
    blk = out[o0 : o0 + hb]
    np.dot(hbuf[:hb], cstack, blk)
    no = cstack.shape[1]
    for r in range(hb):
        for c in range(no):
            blk[r, c] += dfeed_static[c]


@njit(cache=True, error_model="numpy", inline="always")
def _copy_int(src: np.ndarray, dst: np.ndarray) -> None:
    for i in range(src.shape[0]):
        dst[i] = src[i]
