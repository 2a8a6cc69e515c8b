"""Compiled binning of a running synchronous average (faults/misalignment_stream.py).

One pass over a chunk's integration steps: the wheel angle ``ratio * input_angle`` in bins of one
revolution, each step's value shared linearly between the two neighbouring bin centres (the
kernel-weighted average of the bins is then second-order accurate in the bin width, where a plain
histogram has a first-order bias from the steps' positions inside a bin). The steps are added in
their order, one at a time, so a chunk split into pieces gives the same sums bit for bit.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, error_model="numpy")
def bin_linear(
    input_angle: np.ndarray,
    values: np.ndarray,
    column: int,
    bins_per_rad: float,
    sums: np.ndarray,
    weights: np.ndarray,
) -> None:
    """Add ``values[:, column]`` at the angles ``input_angle * bins_per_rad`` (in bins; any sign,
    taken modulo ``sums.size``, a power of two) to ``sums`` and their weights to ``weights``.

    Parameters
    ----------
    input_angle : numpy.ndarray
        Input-shaft angles of the steps, rad (n,).
    values : numpy.ndarray
        Per-step values (n, m); column ``column`` is binned.
    column : int
        Column of ``values``.
    bins_per_rad : float
        Signed factor from the input angle to the wheel angle in bins (``ratio * bins / (2 pi)``).
    sums, weights : numpy.ndarray
        Accumulators (bins,), updated in place.
    """
    mask = sums.size - 1
    for i in range(input_angle.size):
        x = input_angle[i] * bins_per_rad
        fl = np.floor(x)
        f = x - fl
        b0 = np.int64(fl) & mask
        b1 = (b0 + 1) & mask
        v = values[i, column]
        sums[b0] += (1.0 - f) * v
        sums[b1] += f * v
        weights[b0] += 1.0 - f
        weights[b1] += f
